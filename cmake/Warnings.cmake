# Warnings for the project's own targets: tc_set_warnings(<target>).
function(tc_set_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wimplicit-fallthrough)
  if(TC_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
