# Unity builds (docs/testing.md "Test build time"): numen_unity(TARGET) compiles TARGET's
# sources NUMEN_UNITY_BATCH at a time, one translation unit per batch, so that each batch
# parses the heavy header-only libraries it shares (GoogleTest, Eigen, CLI11, toml++,
# nlohmann/json, pybind11) once instead of once per file. Applied to the test programs and
# benchmarks, the `numen` command and every library (core, hal, platform, sim), the Python
# module and the MuJoCo peer's library. Even the libraries' compile at -O3 is mostly parsing:
# `-fsyntax-only` of each file one by one takes 63 % of its whole compile in core, hal and
# platform alike; core's step costs the same instructions either way (callgrind, docs/testing.md
# "Test build time").
#
# File-local names (anonymous namespaces, static functions) of the files of one batch share a
# translation unit: two of one name are a redefinition error. Give one a distinct name, or
# move a shared helper to a header. Every configure checks this for every pair of files of a
# target, whatever batches this build makes (numen_check_unity_names() below).
# NUMEN_UNITY_BATCH=1 turns unity builds off (a change to one file then recompiles that file
# alone: the setting for editing one file often).
set(NUMEN_UNITY_BATCH 8 CACHE STRING "Source files per unity translation unit (1: no unity build)")
if(NOT NUMEN_UNITY_BATCH MATCHES "^[1-9][0-9]*$")
  message(FATAL_ERROR "NUMEN_UNITY_BATCH must be a positive integer, not '${NUMEN_UNITY_BATCH}'")
endif()
# The test programs take larger batches: their compile is mostly the instantiation of Eigen and
# GoogleTest templates, which a batch does once for all its files (two batches of 8 core test
# files compiled as one: 23 % less compiler time; the core and sim test programs at 32 a batch
# against 16: 270 s of CPU against 355, docs/testing.md "Test build time"). File-local names
# must differ across all of a program's files (numen_check_unity_names() below).
set(NUMEN_UNITY_TEST_BATCH 32 CACHE STRING "Test files per unity translation unit of a test program")
if(NOT NUMEN_UNITY_TEST_BATCH MATCHES "^[1-9][0-9]*$")
  message(FATAL_ERROR "NUMEN_UNITY_TEST_BATCH must be a positive integer, not '${NUMEN_UNITY_TEST_BATCH}'")
endif()
# numen_unity(TARGET [BATCH n] [OPTIONAL file...]): n files per unity translation unit
# (NUMEN_UNITY_BATCH when not given); nothing when NUMEN_UNITY_BATCH is 1 (no unity build
# anywhere). The batches are named groups (UNITY_BUILD_MODE GROUP) that keep apart the files a
# NUMEN_WITH_* option touches, so that reconfiguring with other options (the options matrix in
# one build directory: .ci/options-matrix --in) recompiles those batches only, not every batch
# after a left-out file. Touched: the files OPTIONAL names (the target's files that an option
# leaves out, every one whether this build leaves it out or not; relative to the target's folder
# or absolute) and those that include a features.hpp (the options' #if, directly or through
# tests/support's build_features.hpp or lean_scenes.hpp). They are batched among themselves
# (groups features_<i>), the others in their sorted order (groups <i>); without OPTIONAL files
# and with fewer than BATCH / 2 of either kind, all together. n files make round(n / BATCH)
# groups of sizes within one. A file marked SKIP_UNITY_BUILD_INCLUSION before the call is
# compiled alone.
function(numen_unity target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "BATCH" "OPTIONAL")
  set(batch ${NUMEN_UNITY_BATCH})
  if(arg_BATCH)
    set(batch ${arg_BATCH})
  endif()
  get_target_property(_dir ${target} SOURCE_DIR)
  get_target_property(_sources ${target} SOURCES)
  # Every unity-built target's files, for numen_check_unity_names() (also when this build is not
  # a unity one: the names are checked for the builds that are).
  foreach(_s IN LISTS _sources)
    get_filename_component(_a "${_s}" ABSOLUTE BASE_DIR "${_dir}")
    get_source_file_property(_skip "${_a}" TARGET_DIRECTORY ${target} SKIP_UNITY_BUILD_INCLUSION)
    if(_a MATCHES "\\.(cpp|cc|cxx)$" AND NOT _skip)
      set_property(GLOBAL APPEND PROPERTY NUMEN_UNITY_FILES "${target}\t${_a}")
    endif()
  endforeach()
  if(NOT (NUMEN_UNITY_BATCH GREATER 1 AND batch GREATER 1))
    return()
  endif()
  set(_optional)
  foreach(_s IN LISTS arg_OPTIONAL)
    get_filename_component(_a "${_s}" ABSOLUTE BASE_DIR "${_dir}")
    list(APPEND _optional "${_a}")
  endforeach()
  list(REMOVE_DUPLICATES _optional)
  set(_files)
  foreach(_s IN LISTS _sources)
    get_filename_component(_a "${_s}" ABSOLUTE BASE_DIR "${_dir}")
    get_source_file_property(_skip "${_a}" TARGET_DIRECTORY ${target} SKIP_UNITY_BUILD_INCLUSION)
    if(_a MATCHES "\\.(cpp|cc|cxx)$" AND NOT _skip)
      list(APPEND _files "${_a}")
    endif()
  endforeach()
  list(SORT _files)
  set(_plain)
  set(_touched)
  foreach(_a IN LISTS _files)
    set(_features)
    if(NOT _a IN_LIST _optional)
      file(STRINGS "${_a}" _features LIMIT_COUNT 1
           REGEX "^#include \"(numen/(core|hal)/features|build_features|lean_scenes)\\.hpp\"")
    endif()
    if(_a IN_LIST _optional OR _features)
      list(APPEND _touched "${_a}")
    else()
      list(APPEND _plain "${_a}")
    endif()
  endforeach()
  # Without OPTIONAL files and with fewer than half a batch of either kind: one list (a batch of
  # its own would cost every build its parse of the shared headers, to spare the reconfigure a
  # few files; nothing left out, the other batches stay the same anyway).
  list(LENGTH _plain _n_plain)
  list(LENGTH _touched _n_touched)
  list(LENGTH _optional _n_optional)
  math(EXPR _half "${batch} / 2")
  if(_n_optional EQUAL 0 AND (_n_plain LESS _half OR _n_touched LESS _half))
    set(_plain ${_files})
    set(_touched)
  endif()
  # Each list in round(n / batch) groups (at least one) of sizes within one of each other.
  foreach(_kind plain touched)
    list(LENGTH _${_kind} _n)
    if(_n EQUAL 0)
      continue()
    endif()
    math(EXPR _groups "(${_n} + ${batch} / 2) / ${batch}")
    if(_groups LESS 1)
      set(_groups 1)
    endif()
    set(_i 0)
    foreach(_a IN LISTS _${_kind})
      math(EXPR _group "${_i} * ${_groups} / ${_n}")
      if(_kind STREQUAL touched)
        set(_group "features_${_group}")
      endif()
      set_source_files_properties("${_a}" TARGET_DIRECTORY ${target} PROPERTIES UNITY_GROUP ${_group})
      math(EXPR _i "${_i} + 1")
    endforeach()
  endforeach()
  set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_MODE GROUP)
endfunction()

# numen_check_unity_names(): fails the configure when two files of one unity-built target each
# define a file-local name (an anonymous namespace's or a file-level static's) that some build's
# batching would put in one translation unit as a redefinition (cmake/unity_names.py). Which files
# share a batch depends on the NUMEN_WITH_* options, so a clash the default build never compiles
# together breaks another combination's build; this finds it in every configure, whatever the
# options (~2 s). Called once, after every target is defined. Skipped, saying so, without Python.
function(numen_check_unity_names)
  get_property(_lines GLOBAL PROPERTY NUMEN_UNITY_FILES)
  if(NOT _lines)
    return()
  endif()
  find_package(Python3 COMPONENTS Interpreter QUIET)
  if(NOT Python3_Interpreter_FOUND)
    message(STATUS "unity names: not checked (no Python 3 interpreter)")
    return()
  endif()
  list(JOIN _lines "\n" _text)
  set(_list "${CMAKE_BINARY_DIR}/unity_files.txt")
  file(WRITE "${_list}" "${_text}\n")
  execute_process(COMMAND ${Python3_EXECUTABLE} "${PROJECT_SOURCE_DIR}/cmake/unity_names.py" "${_list}"
                  RESULT_VARIABLE _rc OUTPUT_VARIABLE _out ERROR_VARIABLE _err)
  if(NOT _rc EQUAL 0)
    message(FATAL_ERROR "unity names: ${_out}${_err}")
  endif()
  string(STRIP "${_out}" _out)
  message(STATUS "${_out}")
endfunction()
