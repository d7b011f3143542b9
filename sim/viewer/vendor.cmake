# Puts the viewer page's libraries into VENDOR_DIR (cmake -P, run by sim/CMakeLists.txt at build
# time): `npm ci` of package-lock.json in WORK_DIR, then three.js (ES module and OrbitControls)
# and uPlot copied out with their licences. When npm is missing or fails (no registry), the
# build goes on, says so, and writes VENDOR_DIR/MISSING: the page then shows what to install
# instead of a blank canvas (docs/viewer.md "Page").
file(REMOVE_RECURSE ${VENDOR_DIR})
file(MAKE_DIRECTORY ${VENDOR_DIR})
set(_why "")
if(NOT NPM OR NOT EXISTS "${NPM}")
  set(_why "npm not found (Debian: apt-get install nodejs npm; or bash .ci/deps nodejs npm)")
else()
  file(COPY ${SOURCE_DIR}/package.json ${SOURCE_DIR}/package-lock.json DESTINATION ${WORK_DIR})
  execute_process(COMMAND ${NPM} ci --no-audit --no-fund --ignore-scripts --loglevel=error
                  WORKING_DIRECTORY ${WORK_DIR} RESULT_VARIABLE _rc OUTPUT_VARIABLE _out
                  ERROR_VARIABLE _out)
  if(NOT _rc EQUAL 0)
    set(_why "npm ci failed (${_rc}): ${_out}")
  endif()
endif()
if(_why)
  message(WARNING "numen viewer: three.js and uPlot not installed: ${_why}. `numen view` and "
                  "`numen run --view` serve a page that says so.")
  file(WRITE ${VENDOR_DIR}/MISSING "${_why}\n")
  return()
endif()
set(_nm ${WORK_DIR}/node_modules)
file(COPY ${_nm}/three/build/three.module.min.js ${_nm}/three/LICENSE DESTINATION ${VENDOR_DIR}/three)
file(COPY ${_nm}/three/examples/jsm/controls/OrbitControls.js DESTINATION ${VENDOR_DIR}/three/addons/controls)
file(COPY ${_nm}/uplot/dist/uPlot.iife.min.js ${_nm}/uplot/dist/uPlot.min.css ${_nm}/uplot/LICENSE
     DESTINATION ${VENDOR_DIR}/uplot)
