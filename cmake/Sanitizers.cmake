# Global sanitizer flags, selected with -DTC_SANITIZER=asan-ubsan|tsan, and the fuzzing
# build (TC_BUILD_FUZZ, clang only): every target gets libFuzzer's coverage
# instrumentation and ASan+UBSan; the fuzz_<target> programs link libFuzzer itself.
if(TC_BUILD_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "TC_BUILD_FUZZ needs clang (cmake --preset fuzz)")
  endif()
  if(NOT TC_SANITIZER STREQUAL "")
    message(FATAL_ERROR "TC_BUILD_FUZZ brings its own sanitizers; leave TC_SANITIZER empty")
  endif()
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
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
