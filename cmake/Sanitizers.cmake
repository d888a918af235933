# Global sanitizer flags, selected with -DTC_SANITIZER=asan-ubsan|tsan. TC_BUILD_FUZZ
# (clang, with asan-ubsan; the asan-ubsan preset) adds libFuzzer's coverage
# instrumentation so one ASan+UBSan tree holds both the tests and the fuzz programs.
if(TC_BUILD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "TC_BUILD_FUZZ needs clang (cmake --preset asan-ubsan)")
  endif()
  if(NOT TC_SANITIZER STREQUAL "asan-ubsan")
    message(FATAL_ERROR "TC_BUILD_FUZZ goes with TC_SANITIZER=asan-ubsan, got '${TC_SANITIZER}'")
  endif()
  # libFuzzer's coverage instrumentation in every target (the code under test); only the
  # fuzz_<target> programs link libFuzzer itself. The tests in the same tree run as usual.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()
if(TC_SANITIZER STREQUAL "asan-ubsan")
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
elseif(TC_SANITIZER STREQUAL "tsan")
  add_compile_options(-fsanitize=thread -fno-omit-frame-pointer)
  add_link_options(-fsanitize=thread)
elseif(NOT TC_SANITIZER STREQUAL "")
  message(FATAL_ERROR "TC_SANITIZER must be '', 'asan-ubsan' or 'tsan', got '${TC_SANITIZER}'")
endif()
