# cmake -DBUILD_DIR=... -DPREFIX=... -DLIBDIR=... [-DPYTHON=... -DPYTHON_DIR=...] -P check_install.cmake
# Installs the build into PREFIX and checks the background-service layout: daemon,
# default config, Cyclone config, systemd unit (Type=notify) with the prefix's paths, the
# client library with its CMake package and .pc file (tests/package builds programs
# against them); then starts the installed daemon on the installed config and waits for
# its readiness line.
file(REMOVE_RECURSE ${PREFIX})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${PREFIX}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}): ${out}${err}")
endif()
foreach(f bin/tetcollided bin/tetcollide etc/tetcollide/tetcollided.yaml
          etc/tetcollide/cyclonedds.xml etc/tetcollide/cyclonedds-network.xml
          lib/systemd/system/tetcollided.service
          include/tetcollide/client.hpp ${LIBDIR}/libtetcollide_client.so.0
          ${LIBDIR}/cmake/tetcollide/tetcollideConfig.cmake
          ${LIBDIR}/pkgconfig/tetcollide-client.pc share/doc/tetcollided/PROTOCOL.md)
  if(NOT EXISTS ${PREFIX}/${f})
    message(FATAL_ERROR "not installed: ${PREFIX}/${f}")
  endif()
endforeach()
file(READ ${PREFIX}/lib/systemd/system/tetcollided.service unit)
foreach(line
    "ExecStart=${PREFIX}/bin/tetcollided --config ${PREFIX}/etc/tetcollide/tetcollided.yaml"
    "Environment=CYCLONEDDS_URI=file://${PREFIX}/etc/tetcollide/cyclonedds.xml"
    "Documentation=file://${PREFIX}/share/doc/tetcollided/PROTOCOL.md"
    "Type=notify" "KillSignal=SIGTERM")
  string(FIND "${unit}" "${line}" at)
  if(at LESS 0)
    message(FATAL_ERROR "the unit lacks '${line}':\n${unit}")
  endif()
endforeach()
if(unit MATCHES "@[A-Z_]+@")
  message(FATAL_ERROR "unconfigured placeholder in the unit:\n${unit}")
endif()
find_program(SYSTEMD_ANALYZE systemd-analyze)
if(SYSTEMD_ANALYZE)
  execute_process(COMMAND ${SYSTEMD_ANALYZE} verify ${PREFIX}/lib/systemd/system/tetcollided.service
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "systemd-analyze verify: ${out}${err}")
  endif()
endif()
# The installed CLI finds the installed client library.
execute_process(COMMAND ${PREFIX}/bin/tetcollide --version RESULT_VARIABLE rc
                OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "installed tetcollide does not run: ${out}${err}")
endif()
# The installed Python module (TC_PYTHON) imports from the prefix with nothing but
# PYTHONPATH and uses the installed client library (its RUNPATH is relative), not the
# build tree's.
if(PYTHON)
  file(GLOB module ${PREFIX}/${PYTHON_DIR}/tetcollide.*.so)
  if(NOT module)
    message(FATAL_ERROR "not installed: ${PREFIX}/${PYTHON_DIR}/tetcollide.*.so")
  endif()
  execute_process(COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${PREFIX}/${PYTHON_DIR}
                          ${PYTHON} -c "import tetcollide, sys
n, t = tetcollide.read_mesh(sys.argv[1])
assert n.shape == (907, 3) and t.shape == (3276, 4), (n.shape, t.shape)
maps = [l.split()[-1] for l in open('/proc/self/maps') if 'libtetcollide_client' in l]
assert maps and all(m.startswith(sys.argv[2]) for m in maps), maps
assert tetcollide.__file__.startswith(sys.argv[2]), tetcollide.__file__
" ${PREFIX}/share/tetcollide/data/meshes/box.msh ${PREFIX}/
                  WORKING_DIRECTORY ${PREFIX}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the installed Python module does not work: ${out}${err}")
  endif()
endif()
# The installed daemon starts on the installed files (killed after 3 s).
execute_process(COMMAND ${CMAKE_COMMAND} -E env
                        CYCLONEDDS_URI=file://${PREFIX}/etc/tetcollide/cyclonedds.xml
                        ${PREFIX}/bin/tetcollided --config ${PREFIX}/etc/tetcollide/tetcollided.yaml
                        --domain 231
                TIMEOUT 3 OUTPUT_VARIABLE out ERROR_VARIABLE err)
string(FIND "${err}" "tetcollided ready" at)
if(at LESS 0)
  message(FATAL_ERROR "the installed daemon did not become ready:\n${out}${err}")
endif()
file(REMOVE_RECURSE ${PREFIX})
message(STATUS "install layout ok")
