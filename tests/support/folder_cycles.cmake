# Shared by tests/hal/folder_graph.cmake and tests/core/folder_graph.cmake: prints one line per
# edge between folders, "from -> to  (N files)", and appends to the list named by `out` each
# pair of folders that reach each other through the edges (a cycle), as "a <-> b".
# Reads, in the caller's scope (and sorts, without repeats): _folders, _edges ("from>to"),
# _edge_files_<from>_<to> (the files behind each edge). hal's "top" is printed "(top)". A
# macro, so the caller's lists are its own.
macro(folder_cycles out)
  set(${out})
  list(REMOVE_DUPLICATES _folders)
  list(SORT _folders)
  list(REMOVE_DUPLICATES _edges)
  list(SORT _edges)
  foreach(_e IN LISTS _edges)
    string(REPLACE ">" ";" _pair "${_e}")
    list(GET _pair 0 _a)
    list(GET _pair 1 _b)
    list(REMOVE_DUPLICATES _edge_files_${_a}_${_b})
    list(LENGTH _edge_files_${_a}_${_b} _n)
    string(REGEX REPLACE "^top$" "(top)" _sa "${_a}")
    string(REGEX REPLACE "^top$" "(top)" _sb "${_b}")
    message("${_sa} -> ${_sb}  (${_n} files)")
    set(_reach_${_a}_${_b} TRUE)
  endforeach()
  # Which folder reaches which (Warshall): a pair reaching each other is on a cycle (an include
  # within a folder is no edge).
  foreach(_k IN LISTS _folders)
    foreach(_i IN LISTS _folders)
      if(_reach_${_i}_${_k})
        foreach(_j IN LISTS _folders)
          if(_reach_${_k}_${_j})
            set(_reach_${_i}_${_j} TRUE)
          endif()
        endforeach()
      endif()
    endforeach()
  endforeach()
  foreach(_i IN LISTS _folders)
    foreach(_j IN LISTS _folders)
      if(_i STRLESS _j AND _reach_${_i}_${_j} AND _reach_${_j}_${_i})
        list(APPEND ${out} "${_i} <-> ${_j}")
      endif()
    endforeach()
  endforeach()
endmacro()
