# Debian packages, built by CPack's DEB generator from the Release tree: `make package`
# (docs/DEPLOYMENT.md). One package per install component:
#   tetcollided               daemon, /etc/tetcollide (conffiles), systemd unit, docs
#   libtetcollide-client      libtetcollide_client.so.0 (with a shlibs file)
#   libtetcollide-client-dev  header, .so link, CMake package, tetcollide-client.pc
#   tetcollide-tools          the tetcollide CLI, the demo scenes and their meshes
# Depends: from dpkg-shlibdeps (the Debian 12 runtime libraries the ELF files need) and,
# between these packages, "= version". tests/package checks the result with dpkg-deb and,
# as root, installs, runs and purges it.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME tetcollide)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_VENDOR tetcollide)
set(TC_DEB_MAINTAINER "tetcollide <dev@tetcollide.invalid>" CACHE STRING
    "Maintainer field of the Debian packages")
set(CPACK_PACKAGE_CONTACT "${TC_DEB_MAINTAINER}")
# Left at CPack's default so that the DEB generator does not prepend one shared synopsis
# to every package: each has its own below.
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${CMAKE_PROJECT_NAME} built using CMake")

# Staged with DESTDIR and the prefix /usr, so the rules that run at install time
# (tc_install_for_prefix) see /usr: conffiles in /etc/tetcollide, the unit's and the .pc
# file's paths those of the installed system, not of the staging directory.
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)

set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL daemon client dev tools)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# The CLI needs libtetcollide_client.so.0, which is in no installed package yet: found
# here, and covered by the component dependency on libtetcollide-client instead.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS ${CMAKE_LIBRARY_OUTPUT_DIRECTORY})
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS ON)
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS_POLICY ">=")
set(CPACK_DEBIAN_ENABLE_COMPONENT_DEPENDS ON)

set(CPACK_DEBIAN_DAEMON_PACKAGE_NAME tetcollided)
set(CPACK_DEBIAN_DAEMON_PACKAGE_SECTION net)
set(CPACK_DEBIAN_DAEMON_DESCRIPTION
    "collision service for deformable tetrahedral meshes (DDS)
tetcollided is a long-running service that simulators talk to over DDS (Eclipse Cyclone
DDS): they register tetrahedral objects and stream their deformed node positions; it
finds the overlapping tetrahedra, computes depth maps by grid-free fast marching and
answers with per-node penalty forces.
This package holds the daemon, its configuration in /etc/tetcollide and a systemd unit
(Type=notify, DynamicUser) that is enabled and started on installation.")
set(TC_DEB_SCRIPTS ${CMAKE_CURRENT_LIST_DIR}/deb/tetcollided)
set(CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_EXTRA
    ${TC_DEB_SCRIPTS}/conffiles ${TC_DEB_SCRIPTS}/postinst ${TC_DEB_SCRIPTS}/prerm
    ${TC_DEB_SCRIPTS}/postrm)
set(CPACK_DEBIAN_DAEMON_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_CLIENT_PACKAGE_NAME libtetcollide-client)
set(CPACK_DEBIAN_CLIENT_PACKAGE_SECTION libs)
set(CPACK_DEBIAN_CLIENT_DESCRIPTION
    "client library of the tetcollided collision service
libtetcollide_client is the C++ API a simulator uses to register its deformable
tetrahedral objects with tetcollided over DDS, stream their positions and receive the
contact forces.")

set(CPACK_DEBIAN_DEV_PACKAGE_NAME libtetcollide-client-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_DEV_DEPENDS client)
set(CPACK_DEBIAN_DEV_PACKAGE_SHLIBDEPS OFF)  # no ELF file, the .so link only
set(CPACK_DEBIAN_DEV_DESCRIPTION
    "client library of the tetcollided collision service (development files)
The headers tetcollide/client.hpp, mesh.hpp and integration.hpp, the CMake package
(find_package(tetcollide) gives the target tetcollide::client) and the pkg-config file
tetcollide-client.pc.")

set(CPACK_DEBIAN_TOOLS_PACKAGE_NAME tetcollide-tools)
set(CPACK_DEBIAN_TOOLS_PACKAGE_SECTION science)
set(CPACK_COMPONENT_TOOLS_DEPENDS client)
set(CPACK_DEBIAN_TOOLS_PACKAGE_SUGGESTS tetcollided)
set(CPACK_DEBIAN_TOOLS_DESCRIPTION
    "command-line tools of the tetcollide collision service
The tetcollide command: mesh inspection and conversion, depth maps, detection and
response on mesh files, recording and replay of service sessions, the demo scenes.")

include(CPack)
