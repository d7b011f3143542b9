# numen as an installed component (docs/package.md):
#   cmake --install build --prefix P
# installs the four libraries (static unless BUILD_SHARED_LIBS=ON), the public headers (the
# curated lists below), the `numen` executable, the shipped scenes, data and viewer page under
# share/numen, the docs under share/doc/numen, and the CMake package numen (targets numen::core,
# numen::hal, numen::platform, numen::sim; lib/cmake/numen). Layout from GNUInstallDirs.
# The system files of the Debian package (/etc/numen, the systemd unit, the limits file) are
# the component `system`, left out of a plain install: cmake/package.cmake.
include(CMakePackageConfigHelpers)

set(NUMEN_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/numen CACHE STRING
    "Where the CMake package numen (numenConfig.cmake) is installed, relative to the prefix")
set(NUMEN_INSTALL_DATADIR ${CMAKE_INSTALL_DATADIR}/numen)  # scenes/, data/, viewer/

# Shared libraries: versioned by MAJOR.MINOR (the API compatibility of 0.x, below), and the
# installed `numen` finds them relative to itself.
foreach(_lib numen_core numen_hal numen_platform numen_sim)
  set_target_properties(${_lib} PROPERTIES
    VERSION ${PROJECT_VERSION} SOVERSION ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
endforeach()
if(BUILD_SHARED_LIBS)
  file(RELATIVE_PATH _lib_from_bin ${CMAKE_INSTALL_FULL_BINDIR} ${CMAKE_INSTALL_FULL_LIBDIR})
  set_target_properties(numen PROPERTIES INSTALL_RPATH "$ORIGIN/${_lib_from_bin}")
  # RUNPATH is not transitive: each layer finds the one below next to itself.
  set_target_properties(numen_core numen_hal numen_platform numen_sim PROPERTIES INSTALL_RPATH "$ORIGIN")
endif()

install(TARGETS numen_core numen_hal numen_platform numen_sim
        EXPORT numenTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS numen RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

# --- Public headers: what a program built on numen calls. Each layer's list is curated; a
# header of include/ that is not listed is an internal of that layer (used by its .cpp files,
# its tests and the `numen` command) and is not installed. tests/install/ compiles every
# installed header on its own against the installed prefix.
# Each listed header is also recorded (NUMEN_INSTALLED_HEADERS, base_dir|header) for the closure
# check at the end of this file.
function(numen_install_headers base_dir)
  foreach(_h IN LISTS ARGN)
    get_filename_component(_d ${_h} DIRECTORY)
    install(FILES ${base_dir}/${_h} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/${_d})
    set_property(GLOBAL APPEND PROPERTY NUMEN_INSTALLED_HEADERS "${base_dir}|${_h}")
  endforeach()
endfunction()

# The lists must be closed under #include "numen/...": an installed header that includes one
# left off the list compiles here and breaks every program built on the installed prefix.
# Checked when CMake configures (seconds), so a forgotten entry fails the build's first step
# rather than tests/install at the end of CI. Generated headers are read from the binary dir
# and so need configure_file to have run first: the check runs after all layers are listed.
function(numen_check_installed_headers_closed)
  get_property(_entries GLOBAL PROPERTY NUMEN_INSTALLED_HEADERS)
  set(_installed "")
  foreach(_e IN LISTS _entries)
    string(REPLACE "|" ";" _parts "${_e}")
    list(GET _parts 1 _h)
    list(APPEND _installed ${_h})
  endforeach()
  set(_missing "")
  foreach(_e IN LISTS _entries)
    string(REPLACE "|" ";" _parts "${_e}")
    list(GET _parts 0 _base)
    list(GET _parts 1 _h)
    if(NOT EXISTS ${_base}/${_h})
      list(APPEND _missing "${_h} (listed, but ${_base}/${_h} does not exist)")
      continue()
    endif()
    file(STRINGS ${_base}/${_h} _lines REGEX "^[ \t]*#[ \t]*include[ \t]+\"numen/")
    foreach(_line IN LISTS _lines)
      string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]+\"([^\"]+)\".*$" "\\1" _inc "${_line}")
      if(NOT _inc IN_LIST _installed)
        list(APPEND _missing "${_inc} (included by ${_h})")
      endif()
    endforeach()
  endforeach()
  if(_missing)
    list(JOIN _missing "\n  " _text)
    message(FATAL_ERROR "cmake/install.cmake: installed headers include headers that are not "
                        "installed; add them to the layer's list (or stop including them):\n  ${_text}")
  endif()
endfunction()

# core: the model, the state, one step and its stages, the laws a study calls on its own.
# Internals live beside their sources in core/src/<folder>/ (solver scratch, PCG, the nets' and
# joints' solves, the 6×6 block Cholesky).
numen_install_headers(${PROJECT_SOURCE_DIR}/core/include
  numen/core/articulation.hpp numen/core/broadphase.hpp numen/core/capacity.hpp
  numen/core/collision.hpp numen/core/contact.hpp numen/core/contact_force.hpp
  numen/core/coupling.hpp numen/core/data.hpp numen/core/data_size.hpp numen/core/feedback.hpp
  numen/core/grasp.hpp
  numen/core/needle.hpp numen/core/needle_puncture.hpp
  numen/core/integrator.hpp numen/core/joint.hpp numen/core/mesh.hpp numen/core/mesh_shape.hpp numen/core/model.hpp
  numen/core/multirate.hpp numen/core/multirate/device_loop.hpp numen/core/multirate/exchange.hpp
  numen/core/multirate/god_object.hpp numen/core/multirate/planes.hpp numen/core/net_collision.hpp numen/core/net_forces.hpp numen/core/net_model.hpp
  numen/core/net_material.hpp numen/core/net_tissue_contact.hpp numen/core/net_surface_map.hpp
  numen/core/net_state.hpp numen/core/rigid_body.hpp numen/core/sliding_tie.hpp numen/core/step.hpp
  numen/core/step_outputs.hpp numen/core/step_stages.hpp numen/core/thread.hpp numen/core/types.hpp)
numen_install_headers(${PROJECT_BINARY_DIR}/core/include  # generated
  numen/core/features.hpp numen/version.hpp)

# hal: buses and frames, CANopen, devices and kinematics, inputs, emulators. Not installed:
# cobs.hpp and crc16.hpp (the serial frame's byte stuffing and checksum, reached through
# serial_frame.hpp), and the backends this build leaves out (NUMEN_WITH_*).
set(_hal_headers
  numen/hal/canopen/canopen.hpp numen/hal/canopen/cia402.hpp
  numen/hal/canopen/cia402_settings.hpp
  numen/hal/canopen/dcf.hpp numen/hal/canopen/dcf_configuration.hpp
  numen/hal/canopen/emcy.hpp
  numen/hal/canopen/heartbeat.hpp numen/hal/canopen/nmt.hpp
  numen/hal/canopen/pdo_mapping.hpp
  numen/hal/canopen/sdo.hpp numen/hal/canopen/sdo_poller.hpp
  numen/hal/device/canopen_master.hpp numen/hal/device/device_lifecycle.hpp
  numen/hal/device/nmt_master.hpp
  numen/hal/device/admittance_device.hpp numen/hal/device/axis.hpp
  numen/hal/device/device.hpp numen/hal/device/device_config.hpp
  numen/hal/device/force_sensor.hpp numen/hal/device/impedance_device.hpp
  numen/hal/device/instrument_device.hpp
  numen/hal/device/foaw_estimator.hpp numen/hal/device/passivity_controller.hpp
  numen/hal/device/rate_estimator.hpp
  numen/hal/device/kinematics.hpp numen/hal/device/kinematics_factory.hpp
  numen/hal/device/managed_device.hpp numen/hal/device/minimal_device.hpp
  numen/hal/device/phantom_kinematics.hpp numen/hal/device/pose_tracker_kinematics.hpp
  numen/hal/device/bus_filters.hpp numen/hal/device/device_sample.hpp
  numen/hal/device/device_state.hpp
  numen/hal/device/device_status.hpp
  numen/hal/device/safety_supervisor.hpp numen/hal/device/sample_check.hpp
  numen/hal/device/trocar_kinematics.hpp
  numen/hal/emulation/admittance_emulator.hpp numen/hal/emulation/device_emulator.hpp
  numen/hal/emulation/device_motion.hpp numen/hal/emulation/emulated_device.hpp
  numen/hal/emulation/object_dictionary.hpp numen/hal/emulation/sdo_server.hpp
  numen/hal/input/event_code_name.hpp numen/hal/input/evemu_log.hpp
  numen/hal/input/evemu_replay.hpp numen/hal/input/input_event.hpp
  numen/hal/input/relative_pose_integrator.hpp
  numen/hal/transport/async_record_writer.hpp numen/hal/transport/bus.hpp
  numen/hal/transport/bus_recorder.hpp numen/hal/transport/bus_share.hpp
  numen/hal/transport/can_filter.hpp
  numen/hal/transport/can_frame.hpp numen/hal/transport/candump_log.hpp
  numen/hal/transport/line_file.hpp numen/hal/transport/line_reader.hpp
  numen/hal/transport/log_bus.hpp
  numen/hal/transport/serial_frame.hpp numen/hal/transport/sim_bus.hpp
  numen/hal/transport/splitmix64.hpp)
if(NUMEN_WITH_SOCKETCAN)
  list(APPEND _hal_headers numen/hal/transport/socketcan_bus.hpp)
endif()
if(NUMEN_WITH_SERIAL)
  list(APPEND _hal_headers numen/hal/transport/serial_bus.hpp)
endif()
if(NUMEN_WITH_EVDEV)
  list(APPEND _hal_headers numen/hal/input/evdev_pointer.hpp)
endif()
if(NUMEN_WITH_OPENIGTLINK)
  list(APPEND _hal_headers numen/hal/igtl/igtl_message.hpp numen/hal/igtl/igtl_tracker_bus.hpp
                           numen/hal/igtl/igtl_tracker_client.hpp)
endif()
numen_install_headers(${PROJECT_SOURCE_DIR}/hal/include ${_hal_headers})
numen_install_headers(${PROJECT_BINARY_DIR}/hal/include numen/hal/features.hpp)  # generated

# platform: the control loops, real-time setup, clocks, timers, statistics, the state stream,
# the multirate scene thread and its triple buffers.
numen_install_headers(${PROJECT_SOURCE_DIR}/platform/include
  numen/platform/control_loop.hpp
  numen/platform/device_binding.hpp numen/platform/device_rig.hpp
  numen/platform/latency_histogram.hpp
  numen/platform/loop_statistics.hpp numen/platform/monotonic_clock.hpp
  numen/platform/multirate_threads.hpp numen/platform/periodic_timer.hpp
  numen/platform/realtime_setup.hpp numen/platform/state_frame.hpp
  numen/platform/period_data.hpp numen/platform/period_stages.hpp
  numen/platform/state_stream.hpp numen/platform/stepper.hpp numen/platform/trace_queue.hpp
  numen/platform/triple_buffer.hpp)

# sim: scenes (load_scene, run_scene), trajectories, simulated instruments, traces, studies,
# view recordings and server. Not installed: the `numen` command's helpers (cli_values.hpp,
# view_address.hpp, progress_bar.hpp, run_summary_text.hpp, trace_columns.hpp) and the studies'
# building blocks (study_common.hpp, study_stability_cases.hpp). One folder per concept, as in the
# source tree (docs/architecture.md "sim").
numen_install_headers(${PROJECT_SOURCE_DIR}/sim/include
  numen/sim/scene/mesh_file.hpp numen/sim/scene/passivity_lint.hpp numen/sim/scene/scene.hpp
  numen/sim/scene/scene_info.hpp
  numen/sim/scene/trocar_placement.hpp
  numen/sim/input/bus_spec.hpp numen/sim/input/computed_motion.hpp numen/sim/input/input_error.hpp
  numen/sim/input/jigsaws.hpp numen/sim/input/pointer_path.hpp numen/sim/input/scripted_path.hpp
  numen/sim/input/shipped_files.hpp numen/sim/input/trajectory.hpp
  numen/sim/device/admittance_hand.hpp numen/sim/device/axis_plant.hpp
  numen/sim/device/hand_servo.hpp
  numen/sim/device/device_process.hpp numen/sim/device/hand.hpp
  numen/sim/device/igtl_replay.hpp numen/sim/device/plant_motion.hpp
  numen/sim/device/sdo_session.hpp numen/sim/device/simulated_instrument.hpp
  numen/sim/device/trajectory_motion.hpp numen/sim/device/instrument_targets.hpp
  numen/sim/run/admittance_run.hpp numen/sim/run/divergence.hpp numen/sim/run/igtl_run.hpp
  numen/sim/run/energy.hpp
  numen/sim/run/multirate_run.hpp numen/sim/run/run.hpp numen/sim/run/run_figures.hpp
  numen/sim/run/run_harness.hpp
  numen/sim/run/run_options.hpp numen/sim/run/run_summary.hpp numen/sim/run/run_verdict.hpp
  numen/sim/run/target_measurement.hpp numen/sim/run/trace.hpp
  numen/sim/study/study_accuracy.hpp numen/sim/study/study_shard.hpp
  numen/sim/study/study_stability.hpp
  numen/sim/view/igtl_world_server.hpp
  numen/sim/view/view_output.hpp numen/sim/view/view_recording.hpp numen/sim/view/view_scene.hpp
  numen/sim/view/view_server.hpp)

numen_check_installed_headers_closed()

# --- Shipped files: scenes and data side by side (a scene's "../data/..." resolves), the
# viewer page; found by an installed `numen` relative to itself (sim/src/input/shipped_files.cpp).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/sim/scenes ${PROJECT_SOURCE_DIR}/sim/data
        DESTINATION ${NUMEN_INSTALL_DATADIR})
install(DIRECTORY ${PROJECT_BINARY_DIR}/viewer/ DESTINATION ${NUMEN_INSTALL_DATADIR}/viewer)  # sim/CMakeLists.txt
# docs/ as share/doc/numen/docs, beside the top-level README.md: the README's links (docs/...)
# resolve, and docs/README.md (the docs' index) no longer overwrites it (or is overwritten).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/docs/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/docs)
install(FILES ${PROJECT_SOURCE_DIR}/README.md DESTINATION ${CMAKE_INSTALL_DOCDIR})

# --- Python module (sim/python, pybind11): installed by sim/python/CMakeLists.txt into
# NUMEN_PYTHON_INSTALL_DIR (lib/python3/dist-packages, where Debian's python3 looks under /usr).
# The Debian package (cmake/package.cmake) takes every file of the default install, the module
# included.

# --- The CMake package: find_package(numen 0.1 CONFIG REQUIRED).
install(EXPORT numenTargets NAMESPACE numen:: FILE numenTargets.cmake
        DESTINATION ${NUMEN_INSTALL_CMAKEDIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/numenConfig.cmake.in
  ${PROJECT_BINARY_DIR}/numenConfig.cmake INSTALL_DESTINATION ${NUMEN_INSTALL_CMAKEDIR}
  PATH_VARS NUMEN_INSTALL_DATADIR)
# While MAJOR is 0, a MINOR release may change the API: a request for 0.1 accepts 0.1.x only
# (semantic versioning; docs/package.md). From 1.0 on: SameMajorVersion.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/numenConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/numenConfig.cmake ${PROJECT_BINARY_DIR}/numenConfigVersion.cmake
        DESTINATION ${NUMEN_INSTALL_CMAKEDIR})
