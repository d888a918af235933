# service_load: several client processes against the daemon; load figures and the soak
# (docs/RELIABILITY.md, "Load and soak"). Its --worker mode is also the client process
# the reliability tests kill and stop.
add_executable(service_load ${CMAKE_SOURCE_DIR}/bench/service_load.cpp)
target_link_libraries(service_load PRIVATE tetcollide::core tc_test_support tetcollide_client
                                           tetcollide_process CLI11::CLI11
                                           nlohmann_json::nlohmann_json)
target_compile_definitions(service_load PRIVATE TC_SOURCE_DIR="${CMAKE_SOURCE_DIR}")
add_dependencies(service_load tetcollided)
tc_set_warnings(service_load)
