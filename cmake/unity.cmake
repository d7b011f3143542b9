# Unity builds (docs/testing.md "Test build time"): numen_unity(TARGET) compiles TARGET's
# sources NUMEN_UNITY_BATCH at a time, one translation unit per batch, so that each batch
# parses the heavy header-only libraries it shares (GoogleTest, Eigen, CLI11, toml++,
# nlohmann/json, pybind11) once instead of once per file. Applied to the test programs and
# benchmarks, the `numen` command, numen::sim, the Python module and the MuJoCo peer's library;
# core, hal and platform compile file by file (their files are light to parse, and heavy to
# optimise at -O3), but in sanitizer builds (numen_unity_when_sanitized): there everything is at
# -O1, and parsing Eigen and the standard library once per batch is the larger share.
#
# File-local names (anonymous namespaces, static functions) of the files of one batch share a
# translation unit: two of one name are a redefinition error. Give one a distinct name, or
# move a shared helper to a header. NUMEN_UNITY_BATCH=1 turns unity builds off (a change to
# one file then recompiles that file alone: the setting for editing one file often).
set(NUMEN_UNITY_BATCH 8 CACHE STRING "Source files per unity translation unit (1: no unity build)")
if(NOT NUMEN_UNITY_BATCH MATCHES "^[1-9][0-9]*$")
  message(FATAL_ERROR "NUMEN_UNITY_BATCH must be a positive integer, not '${NUMEN_UNITY_BATCH}'")
endif()
# The test programs take larger batches: their compile is mostly the instantiation of Eigen and
# GoogleTest templates, which a batch does once for all its files (two batches of 8 core test
# files compiled as one: 23 % less compiler time). File-local names clash as above, within a
# batch of 16 (a test file added, or left out by a NUMEN_WITH_* option, shifts the batches).
set(NUMEN_UNITY_TEST_BATCH 16 CACHE STRING "Test files per unity translation unit of a test program")
if(NOT NUMEN_UNITY_TEST_BATCH MATCHES "^[1-9][0-9]*$")
  message(FATAL_ERROR "NUMEN_UNITY_TEST_BATCH must be a positive integer, not '${NUMEN_UNITY_TEST_BATCH}'")
endif()
# numen_unity(TARGET [BATCH]): BATCH files per unity translation unit, NUMEN_UNITY_BATCH when
# not given; nothing when NUMEN_UNITY_BATCH is 1 (no unity build anywhere).
function(numen_unity target)
  set(batch ${NUMEN_UNITY_BATCH})
  if(ARGC GREATER 1)
    set(batch ${ARGV1})
  endif()
  if(NUMEN_UNITY_BATCH GREATER 1 AND batch GREATER 1)
    set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE ${batch})
  endif()
endfunction()
# core, hal and platform: unity batches in sanitizer builds only (NUMEN_SANITIZE, .ci/sanitize).
function(numen_unity_when_sanitized target)
  if(NUMEN_SANITIZE)
    numen_unity(${target})
  endif()
endfunction()
