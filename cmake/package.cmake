# The Debian package of numen (docs/deploy.md): from a configured and built tree,
#   cpack --config build/CPackConfig.cmake -G DEB     → numen_<version>_amd64.deb
# One package, not a runtime + -dev split: numen's libraries are static by default, so a -dev
# package would hold nearly everything (headers, the .a files, the CMake package) and the
# runtime package only the `numen` executable, its scenes and the system files; the box that
# runs the loop is also where integrators build against it. The libraries' and headers'
# build dependencies (Eigen, Boost, ...) are Recommends, not Depends: the control loop does not
# need them. tests/install/debian_package.sh checks the package (CTest debian_package).
#
# Contents: the default install (cmake/install.cmake, prefix /usr) and the component `system`
# (absolute paths, left out of a plain `cmake --install`):
#   /etc/numen/scene.toml                  the scene the service runs (conffile): the default
#                                          scene, its recording read from /usr/share/numen/data
#   /etc/security/limits.d/numen.conf      real-time priority and locked memory for group numen
#                                          (conffile; docs/deploy.md §3)
#   /lib/systemd/system/numen.service      platform/systemd/numen.service, ExecStart /usr/bin/numen
# postinst creates the system user and group numen and /var/log/numen (the unit's User=,
# Group= and ReadWritePaths=); it neither enables nor starts the service.
set(NUMEN_DEB_PREFIX /usr)
set(_pkg ${PROJECT_BINARY_DIR}/packaging)

# The unit: the installed executable instead of /usr/local/bin/numen (manual install).
file(READ ${PROJECT_SOURCE_DIR}/platform/systemd/numen.service _unit)
string(REPLACE "/usr/local/bin/numen" "${NUMEN_DEB_PREFIX}/${CMAKE_INSTALL_BINDIR}/numen" _unit "${_unit}")
string(REPLACE "# Install: cp platform/systemd/numen.service /etc/systemd/system/ && systemctl daemon-reload\n"
               "# Installed by the Debian package numen; the scene is /etc/numen/scene.toml.\n" _unit "${_unit}")
file(CONFIGURE OUTPUT ${_pkg}/numen.service CONTENT "${_unit}" @ONLY)

# /etc/numen/scene.toml: the default scene, its recording and DCF paths made absolute.
file(READ ${PROJECT_SOURCE_DIR}/sim/scenes/default.toml _scene)
string(REPLACE "file = \"../data/" "file = \"${NUMEN_DEB_PREFIX}/${NUMEN_INSTALL_DATADIR}/data/" _scene "${_scene}")
string(REPLACE "dcf = \"devices/" "dcf = \"${NUMEN_DEB_PREFIX}/${NUMEN_INSTALL_DATADIR}/scenes/devices/" _scene "${_scene}")
file(CONFIGURE OUTPUT ${_pkg}/scene.toml CONTENT
  "# The scene run by the numen service (numen.service); a copy of\n# ${NUMEN_DEB_PREFIX}/${NUMEN_INSTALL_DATADIR}/scenes/default.toml (docs/scenes.md).\n${_scene}" @ONLY)
file(CONFIGURE OUTPUT ${_pkg}/limits.conf CONTENT
"# numen: SCHED_FIFO up to priority 80 and mlockall() for the members of group numen
# (docs/deploy.md, \"Limits\"); the systemd unit sets LimitRTPRIO= and LimitMEMLOCK= itself.
@numen  -  rtprio   80
@numen  -  memlock  unlimited
" @ONLY)
file(CONFIGURE OUTPUT ${_pkg}/conffiles CONTENT
"/etc/numen/scene.toml
/etc/security/limits.d/numen.conf
" @ONLY)
file(CONFIGURE OUTPUT ${_pkg}/postinst CONTENT
"#!/bin/sh
# numen: the service's system user and its log directory (numen.service).
set -e
if [ \"$1\" = configure ]; then
  if ! getent passwd numen >/dev/null; then
    adduser --system --group --no-create-home --home /nonexistent numen
  fi
  install -d -o numen -g numen -m 0750 /var/log/numen
fi
" @ONLY)
file(CHMOD ${_pkg}/postinst PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ
           GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
file(CONFIGURE OUTPUT ${_pkg}/copyright CONTENT
"Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/
Upstream-Name: numen

Files: *
Copyright: 2026 the numen authors
License: none-granted
 No license has been granted for numen yet; all rights reserved.

Files: usr/share/numen/data/jigsaws_suturing_b002_excerpt.txt
Copyright: Johns Hopkins University and Intuitive Surgical Inc.
License: JIGSAWS
 An excerpt of the JHU-ISI Gesture and Skill Assessment Working Set (JIGSAWS),
 Gao et al., M2CAI 2014; see /usr/share/numen/data/README.md for the source and
 the citation.

Files: usr/share/numen/viewer/vendor/*
Copyright: the three.js authors; Leon Sorokin (uPlot)
License: Expat
 See the LICENSE file next to each library.
" @ONLY)
set(NUMEN_DEB_MAINTAINER "numen maintainers <numen-maintainers@example.org>" CACHE STRING
    "Maintainer field of the Debian package")
# The changelog of a native package (no Debian revision): changelog.gz (lintian).
file(CONFIGURE OUTPUT ${_pkg}/changelog.Debian CONTENT
"numen (${PROJECT_VERSION}) unstable; urgency=medium

  * Package built by CPack from the numen source tree (cmake/package.cmake).

 -- ${NUMEN_DEB_MAINTAINER}  Mon, 23 Nov 2026 12:00:00 +0000
" @ONLY)
execute_process(COMMAND gzip -9nc ${_pkg}/changelog.Debian OUTPUT_FILE ${_pkg}/changelog.gz)

install(FILES ${_pkg}/scene.toml DESTINATION /etc/numen COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${_pkg}/limits.conf DESTINATION /etc/security/limits.d RENAME numen.conf
        COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${_pkg}/numen.service DESTINATION /lib/systemd/system COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${_pkg}/copyright DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT system EXCLUDE_FROM_ALL)
install(FILES ${_pkg}/changelog.gz DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT system EXCLUDE_FROM_ALL)

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME numen)
set(CPACK_PACKAGE_VENDOR "numen")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "real-time control core for generalized dynamic god-objects")
# The extended description (CPack puts CPACK_PACKAGE_DESCRIPTION_SUMMARY first, indents each
# line and turns an empty line into " .").
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "numen pulls a simulated tool (the god-object) toward the pose of a tracked
haptic instrument with damped springs, keeps it out of obstacles with penalty
contacts and sends the spring stretch back to the instrument's motors over
CANopen, at a fixed time step on a real-time Linux box.

This package holds the numen command, its systemd service and configuration,
the shipped scenes, the viewer page, and the static libraries, headers and
CMake package (find_package(numen)) for programs built on numen.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # numen_<version>_<arch>.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${NUMEN_DEB_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)  # Depends of the executable from dpkg-shlibdeps
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser")  # postinst; the shlibdeps are appended
# The Python module (sim/python) is built for one interpreter's ABI and imports NumPy: the
# package then depends on that python3 minor version and on python3-numpy (Debian policy;
# lintian's python-package-missing-depends-on-python).
if(TARGET numen_python AND NUMEN_PYTHON_VERSION MATCHES "^([0-9]+)\\.([0-9]+)$")
  math(EXPR _py_next "${CMAKE_MATCH_2} + 1")
  string(APPEND CPACK_DEBIAN_PACKAGE_DEPENDS ", python3 (>= ${NUMEN_PYTHON_VERSION}),"
         " python3 (<< ${CMAKE_MATCH_1}.${_py_next}), python3-numpy")
endif()
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "cmake, g++, libeigen3-dev, libboost-dev, libassimp-dev, libinih-dev, libevdev-dev, libopenigtlink-dev, pkg-config")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA "${_pkg}/conffiles;${_pkg}/postinst")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_PACKAGING_INSTALL_PREFIX ${NUMEN_DEB_PREFIX})
set(CPACK_STRIP_FILES ON)
# Every file of the default install (Unspecified: the libraries, headers, executable, shared
# files, the CMake package, and the Python module's rule once it exists) and the system files.
set(CPACK_INSTALL_CMAKE_PROJECTS
    "${PROJECT_BINARY_DIR};numen;Unspecified;/;${PROJECT_BINARY_DIR};numen;system;/")
include(CPack)
