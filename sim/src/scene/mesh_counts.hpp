#pragma once
/// @file mesh_counts.hpp
/// The counts a mesh file's header promises, checked against what the file holds before Assimp
/// reads it (docs/meshes.md, "Reading a mesh file"). Assimp trusts them: a PLY whose header says
/// `element vertex 2` over a body of 4 vertices and 4 faces aborts the process inside Assimp (an
/// ai_assert, SIGABRT), a face list of 0 vertices too, a negative vertex index crashes it
/// (SIGSEGV), and a header that promises 10^8 vertices in a 221-byte file has it allocate and parse
/// for a minute. Private to numen::sim; load time only (allocates, throws InputError).

#include <string>

namespace numen::sim {

/// Checks a PLY file (first line `ply`) against its header: the header itself (`format`,
/// `element NAME COUNT`, `property TYPE NAME`, `property list COUNT_TYPE ITEM_TYPE NAME`,
/// `comment`, `obj_info`, `end_header`; PLY's scalar types), then the body.
/// - ASCII: one element a line, as the format writes it. The body's non-blank lines must number
///   the header's counts together; then each line from the first after end_header holds exactly
///   its element's properties, every token a number (a list's count and a face's indices whole
///   numbers); no blank line before the last element's (Assimp reads a blank line, or one of
///   spaces, as an element: the counts shift and it aborts); blank lines after it are ignored.
/// - Binary (either byte order): the body's bytes must be at least the counts times each
///   element's smallest size (its scalars and its lists' counts), then exactly what the elements
///   take, walked list by list. Its first byte is not a line feed (0x0A: Assimp skips it as part of
///   end_header's line and reads every value a byte off).
/// - In both, a `face` element's `vertex_indices` (or `vertex_index`) list has at least 3
///   vertices, each an integer in [0, the `vertex` count); a `tristrips` element's in [−1, it).
/// Throws InputError naming `path` (and the line, for a header or ASCII body line), with both
/// numbers when the counts and the body disagree.
void check_ply_counts(const std::string& path);

/// Checks a `.stl` file: it is ASCII (starts with `solid`, after spaces) or binary with exactly
/// 84 + 50 N bytes for the N triangles its header counts (the count at byte 80, little-endian).
/// Throws InputError naming `path`, the count, the size it implies and the file's size.
void check_stl_counts(const std::string& path);

}  // namespace numen::sim
