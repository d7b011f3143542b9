# core/src's folders and the includes between them (docs/architecture.md, "core's sources by
# concept"): prints one line per edge, "from -> to (N files)", and fails if
#   - a source or private header includes a private header by a path that climbs ("../"),
#   - a folder includes a private header of a folder on its own layer or a higher one (the
#     layers below, as the docs' picture draws them), or of a folder the layers do not name,
#   - the folders include each other in a cycle (implied by the layers; checked apart so that
#     the message names it).
# A folder's edge to another is any include of one of the other's private headers
# ("<folder>/<header>.hpp", core/src being their include root); core's public headers
# (numen/core/...) are one layer above core/src and are no edge.
#
#   cmake -DROOT=<source tree> -P tests/core/folder_graph.cmake
#
# The test core_folder_graph runs it on the source tree (under a second).
if(NOT ROOT)
  get_filename_component(ROOT "${CMAKE_CURRENT_LIST_DIR}/../.." ABSOLUTE)
endif()
set(_src_base "${ROOT}/core/src")

# The layers, lowest first (docs/architecture.md's picture): a folder may include private
# headers of its own folder and of lower layers only.
set(_layer_linalg 0)
set(_layer_mesh 0)
set(_layer_body 0)
set(_layer_scratch 1)
set(_layer_articulation 2)
set(_layer_contact 2)
set(_layer_coupling 2)
set(_layer_model 2)
set(_layer_solver 2)
set(_layer_net 3)
set(_layer_step 3)
set(_layer_grasp 4)
set(_layer_needle 4)
set(_layer_thread 4)
set(_layer_integrator 5)
set(_layer_multirate 5)

set(_errors)
set(_folders)
set(_edges)
file(GLOB_RECURSE _files RELATIVE "${_src_base}" "${_src_base}/*.hpp" "${_src_base}/*.cpp")
foreach(_rel IN LISTS _files)
  string(FIND "${_rel}" "/" _slash)
  if(_slash LESS 0)
    list(APPEND _errors "core/src/${_rel}: a file outside a folder")
    continue()
  endif()
  string(SUBSTRING "${_rel}" 0 ${_slash} _from)
  list(APPEND _folders ${_from})
  if(NOT DEFINED _layer_${_from})
    list(APPEND _errors "core/src/${_from}/: a folder the layers do not name (tests/core/folder_graph.cmake, docs/architecture.md)")
  endif()
  file(STRINGS "${_src_base}/${_rel}" _lines REGEX "^[ \t]*#[ \t]*include[ \t]*\"")
  foreach(_line IN LISTS _lines)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]*\"([^\"]+)\".*$" "\\1" _target "${_line}")
    if(_target MATCHES "^\\.\\./|/\\.\\./")
      list(APPEND _errors "core/src/${_rel}: includes \"${_target}\" by a climbing path")
      continue()
    endif()
    if(NOT EXISTS "${_src_base}/${_target}" OR NOT _target MATCHES "^([^/]+)/")
      continue()  # a public header (numen/core/...) or a library's
    endif()
    set(_to "${CMAKE_MATCH_1}")
    if(_to STREQUAL _from)
      continue()
    endif()
    list(APPEND _edges "${_from}>${_to}")
    list(APPEND _edge_files_${_from}_${_to} "${_rel}")
    if(DEFINED _layer_${_from} AND DEFINED _layer_${_to}
       AND NOT _layer_${_to} LESS _layer_${_from})
      list(APPEND _errors "core/src/${_rel}: includes \"${_target}\", ${_to}/ (layer ${_layer_${_to}}) from ${_from}/ (layer ${_layer_${_from}}): not a lower layer")
    endif()
  endforeach()
endforeach()
include("${CMAKE_CURRENT_LIST_DIR}/../support/folder_cycles.cmake")
folder_cycles(_cycles)
foreach(_c IN LISTS _cycles)
  list(APPEND _errors "core/src's folders include each other in a cycle: ${_c}")
endforeach()
if(_errors)
  list(JOIN _errors "\n  " _text)
  message(FATAL_ERROR "core's folder graph breaks its layers (docs/architecture.md, \"core's sources by concept\"):\n  ${_text}")
endif()
list(LENGTH _folders _nf)
list(LENGTH _edges _ne)
message("core/src: ${_nf} folders, ${_ne} edges, all to lower layers, no cycle")
