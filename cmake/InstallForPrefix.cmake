# tc_install_for_prefix(FILES <file>... [CONFIGURE] DESTINATION <dir> COMPONENT <component>)
#
# Installs files whose destination or content depends on the prefix of the actual
# install, which is not the CMAKE_INSTALL_PREFIX of the configure step: the prefix of
# `cmake --install build --prefix P`, or /usr when CPack builds the Debian packages from
# the same tree. The code runs at install time, after cmake/install_dirs.cmake has set
#   TC_PREFIX, TC_INSTALL_BINDIR, TC_INSTALL_LIBDIR, TC_INSTALL_INCLUDEDIR,
#   TC_INSTALL_DOCDIR (the daemon's documents), TC_INSTALL_CONFDIR (/etc/tetcollide for
#   the prefix /usr, <prefix>/etc/tetcollide for most others), TC_INSTALL_UNITDIR,
#   TC_PC_LIBDIR and TC_PC_INCLUDEDIR (${prefix}-relative, for a .pc file)
# from that prefix. <dir> may use them: pass it in brackets, DESTINATION [[${TC_INSTALL_CONFDIR}]],
# so that they are expanded at install time. CONFIGURE: the files are templates
# (configure_file @ONLY with those variables and PROJECT_VERSION); a trailing ".in" is
# dropped from the installed name. DESTDIR is honoured and the files are in the manifest.
set(TC_INSTALL_DIRS_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/install_dirs.cmake)

function(tc_install_for_prefix)
  cmake_parse_arguments(ARG "CONFIGURE" "DESTINATION;COMPONENT" "FILES" ${ARGN})
  if(NOT ARG_FILES OR NOT ARG_DESTINATION OR NOT ARG_COMPONENT)
    message(FATAL_ERROR "tc_install_for_prefix: FILES, DESTINATION and COMPONENT are required")
  endif()
  set(code "set(TC_REL_BINDIR \"${CMAKE_INSTALL_BINDIR}\")
set(TC_REL_LIBDIR \"${CMAKE_INSTALL_LIBDIR}\")
set(TC_REL_INCLUDEDIR \"${CMAKE_INSTALL_INCLUDEDIR}\")
set(TC_REL_SYSCONFDIR \"${CMAKE_INSTALL_SYSCONFDIR}\")
set(TC_REL_DOCDIR \"${TC_DAEMON_DOCDIR}\")
set(TC_REL_UNITDIR \"${TC_SYSTEMD_UNIT_DIR}\")
set(PROJECT_VERSION \"${PROJECT_VERSION}\")
include(\"${TC_INSTALL_DIRS_SCRIPT}\")
")
  set(files "")
  foreach(f IN LISTS ARG_FILES)
    get_filename_component(f "${f}" ABSOLUTE)
    if(ARG_CONFIGURE)
      get_filename_component(name "${f}" NAME)
      string(REGEX REPLACE "\\.in$" "" name "${name}")
      # One directory per destination: concurrent installs into other prefixes (the
      # tests, CPack) never write the same file.
      string(APPEND code "string(MD5 _tc_key \"\$ENV{DESTDIR}|\${CMAKE_INSTALL_PREFIX}\")
configure_file(\"${f}\" \"${CMAKE_CURRENT_BINARY_DIR}/install-for-prefix/\${_tc_key}/${name}\" @ONLY)
")
      string(APPEND files " \"${CMAKE_CURRENT_BINARY_DIR}/install-for-prefix/\${_tc_key}/${name}\"")
    else()
      string(APPEND files " \"${f}\"")
    endif()
  endforeach()
  string(APPEND code "file(INSTALL DESTINATION \"${ARG_DESTINATION}\" TYPE FILE FILES${files})\n")
  if(ARG_CONFIGURE)
    string(APPEND code "file(REMOVE_RECURSE \"${CMAKE_CURRENT_BINARY_DIR}/install-for-prefix/\${_tc_key}\")\n")
  endif()
  install(CODE "${code}" COMPONENT ${ARG_COMPONENT})
endfunction()
