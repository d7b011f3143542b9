# hal's folders and the includes between them (docs/architecture.md, "hal: what the controller
# sees"): prints one line per edge, "from -> to (N files)", over hal/include/numen/hal and
# hal/src, and fails if the folders include each other in a cycle (a -> b -> ... -> a).
# (top) is hal's files outside a folder (features.hpp, src/hex_text.hpp, src/text_chars.hpp).
#
#   cmake -DROOT=<source tree> -P tests/hal/folder_graph.cmake
#
# The test hal_folder_graph runs it on the source tree (under a second).
if(NOT ROOT)
  get_filename_component(ROOT "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
endif()
set(_include_base "${ROOT}/hal/include/numen/hal")
set(_src_base "${ROOT}/hal/src")

# The folder of a path relative to a base: its first component, "top" for a file at the base.
function(_folder_of rel out)
  string(FIND "${rel}" "/" _slash)
  if(_slash LESS 0)
    set(${out} top PARENT_SCOPE)
  else()
    string(SUBSTRING "${rel}" 0 ${_slash} _f)
    set(${out} ${_f} PARENT_SCOPE)
  endif()
endfunction()

set(_folders)
set(_edges)
foreach(_base IN ITEMS "${_include_base}" "${_src_base}")
  file(GLOB_RECURSE _files RELATIVE "${_base}" "${_base}/*.hpp" "${_base}/*.cpp" "${_base}/*.h")
  foreach(_rel IN LISTS _files)
    _folder_of("${_rel}" _from)
    list(APPEND _folders ${_from})
    get_filename_component(_dir "${_base}/${_rel}" DIRECTORY)
    file(STRINGS "${_base}/${_rel}" _lines REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"]")
    foreach(_line IN LISTS _lines)
      string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*[<\"]([^>\"]+)[>\"].*$" "\\1" _target "${_line}")
      set(_to)
      if(_target MATCHES "^numen/hal/(.+)$")
        _folder_of("${CMAKE_MATCH_1}" _to)
      elseif(_line MATCHES "\"" AND EXISTS "${_dir}/${_target}")
        # A private header by its relative path (src/device/geometry_check.hpp, ../hex_text.hpp).
        get_filename_component(_abs "${_dir}/${_target}" ABSOLUTE)
        file(RELATIVE_PATH _trel "${_src_base}" "${_abs}")
        if(NOT _trel MATCHES "^\\.\\.")
          _folder_of("${_trel}" _to)
        endif()
      endif()
      if(_to AND NOT _to STREQUAL _from)
        list(APPEND _edges "${_from}>${_to}")
        list(APPEND _edge_files_${_from}_${_to} "${_rel}")
      endif()
    endforeach()
  endforeach()
endforeach()
include("${CMAKE_CURRENT_LIST_DIR}/../support/folder_cycles.cmake")
folder_cycles(_cycles)
if(_cycles)
  list(JOIN _cycles ", " _text)
  message(FATAL_ERROR "hal's folders include each other in a cycle: ${_text} (each folder's "
                      "includes must point one way; docs/architecture.md)")
endif()
list(LENGTH _folders _nf)
message("hal: ${_nf} folders, no cycle")
