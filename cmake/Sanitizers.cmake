# Global sanitizer flags, selected with -DTC_SANITIZER=asan-ubsan|tsan.
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
