# cmake -DCPACK=<cpack> -DBUILD_DIR=<Release tree> -DOUT=<dir> -P build_debs.cmake
# Builds the Debian packages of BUILD_DIR into OUT (a directory of its own, emptied
# first: `make package` output in BUILD_DIR/packages is left alone) and checks that the
# four packages are there. Fixture of package.deb_contents and package.deb_install.
file(REMOVE_RECURSE ${OUT})
file(MAKE_DIRECTORY ${OUT})
execute_process(COMMAND ${CPACK} --config ${BUILD_DIR}/CPackConfig.cmake -G DEB -B ${OUT}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cpack failed (${rc}):\n${out}${err}")
endif()
message(STATUS "${out}")
foreach(package tetcollided libtetcollide-client libtetcollide-client-dev tetcollide-tools)
  file(GLOB deb ${OUT}/${package}_*.deb)
  list(LENGTH deb n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "expected one ${package}_*.deb in ${OUT}, found ${n}:\n${out}${err}")
  endif()
endforeach()
