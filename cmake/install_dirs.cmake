# Install-time part of tc_install_for_prefix() (cmake/InstallForPrefix.cmake): the
# directories of this install. In: CMAKE_INSTALL_PREFIX as the install runs, TC_REL_*
# (the configure step's GNUInstallDirs values, relative to the prefix or absolute).
# Out: TC_PREFIX and TC_INSTALL_* (absolute, without DESTDIR), TC_PC_LIBDIR and
# TC_PC_INCLUDEDIR (relative to ${prefix} in a .pc file when they are under it).
set(TC_PREFIX "${CMAKE_INSTALL_PREFIX}")
if(NOT TC_PREFIX STREQUAL "/")
  string(REGEX REPLACE "/+$" "" TC_PREFIX "${TC_PREFIX}")
endif()

macro(_tc_full out rel)
  if(IS_ABSOLUTE "${rel}")
    set(${out} "${rel}")
  elseif(TC_PREFIX STREQUAL "/")
    set(${out} "/${rel}")
  else()
    set(${out} "${TC_PREFIX}/${rel}")
  endif()
endmacro()

_tc_full(TC_INSTALL_BINDIR "${TC_REL_BINDIR}")
_tc_full(TC_INSTALL_LIBDIR "${TC_REL_LIBDIR}")
_tc_full(TC_INSTALL_INCLUDEDIR "${TC_REL_INCLUDEDIR}")
_tc_full(TC_INSTALL_DOCDIR "${TC_REL_DOCDIR}")
_tc_full(TC_INSTALL_UNITDIR "${TC_REL_UNITDIR}")

# The configuration directory follows GNUInstallDirs' rule for SYSCONFDIR (GNU coding
# standards, FHS): the prefixes / and /usr use /etc, /opt/<x> uses /etc/opt/<x>, any
# other prefix <prefix>/etc. So the Debian package (prefix /usr) puts its conffiles in
# /etc/tetcollide and `cmake --install --prefix P` keeps everything under P.
if(IS_ABSOLUTE "${TC_REL_SYSCONFDIR}")
  set(TC_INSTALL_CONFDIR "${TC_REL_SYSCONFDIR}/tetcollide")
elseif(TC_PREFIX MATCHES "^/(usr)?$")
  set(TC_INSTALL_CONFDIR "/${TC_REL_SYSCONFDIR}/tetcollide")
elseif(TC_PREFIX MATCHES "^/opt/" AND NOT TC_PREFIX MATCHES "^/opt/homebrew")
  set(TC_INSTALL_CONFDIR "/${TC_REL_SYSCONFDIR}${TC_PREFIX}/tetcollide")
else()
  set(TC_INSTALL_CONFDIR "${TC_PREFIX}/${TC_REL_SYSCONFDIR}/tetcollide")
endif()

foreach(_tc_dir LIBDIR INCLUDEDIR)
  if(IS_ABSOLUTE "${TC_REL_${_tc_dir}}")
    set(TC_PC_${_tc_dir} "${TC_REL_${_tc_dir}}")
  else()
    set(TC_PC_${_tc_dir} "\${prefix}/${TC_REL_${_tc_dir}}")
  endif()
endforeach()
