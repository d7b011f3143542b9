// Tests of sim/scene/mesh_counts: a PLY's header counts against its body (ASCII lines and
// numbers, binary bytes and lists), its faces' vertex indices, and a binary STL's triangle count
// against the file's size, each refused through load_mesh_file() with its exact message before
// Assimp reads the file (before the checks, the first aborted the process in an Assimp assert,
// a negative index crashed it, a count of 10^8 parsed for a minute).
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <cstring>
#include <string>

#include "mesh_text.hpp"
#include "numen/sim/scene/mesh_file.hpp"
#include "temp_dir.hpp"

namespace {

using numen::sim::load_mesh_file;
using numen::test::ascii_ply;
using numen::test::kTetPlyBody;
using numen::test::mesh_load_message;
using numen::test::TempDir;

/// `v` as `bytes` little- or big-endian bytes.
std::string bytes_of(std::uint64_t v, int bytes, bool big) {
  std::string out(static_cast<std::size_t>(bytes), '\0');
  for (int k = 0; k < bytes; ++k)
    out[static_cast<std::size_t>(big ? bytes - 1 - k : k)] =
        static_cast<char>((v >> (8 * k)) & 0xFF);
  return out;
}

/// The tetrahedron as a binary PLY (float x y z, uchar-counted int lists) in either byte order,
/// with `vertices` in its header.
std::string binary_ply(bool big, int vertices = 4) {
  std::string out = std::string("ply\nformat ") +
                    (big ? "binary_big_endian" : "binary_little_endian") + " 1.0\nelement vertex " +
                    std::to_string(vertices) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face 4\n"
                    "property list uchar int vertex_indices\nend_header\n";
  const float one = 1.0f;
  std::uint32_t one_bits = 0;
  std::memcpy(&one_bits, &one, 4);
  for (const auto& v : {std::array<int, 3>{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}})
    for (const int c : v) out += bytes_of(c == 0 ? 0 : one_bits, 4, big);
  for (const auto& f : {std::array<int, 3>{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}) {
    out += '\3';
    for (const int i : f) out += bytes_of(static_cast<std::uint64_t>(i), 4, big);
  }
  return out;
}

// Defect 1: the header says 2 vertices over a body of 4 vertices and 4 faces; Assimp read two
// vertex lines as faces and aborted the process (ai_assert, TriangulateProcess.cpp(238)).
TEST(MeshCounts, PlyWhoseCountsDisagreeWithItsLinesIsRefusedBeforeAssimp) {
  TempDir dir;
  const std::string tet = dir.write("tet.ply", ascii_ply("4", "4"));
  EXPECT_EQ(mesh_load_message(tet), "");
  EXPECT_EQ(load_mesh_file(tet).num_triangles(), 4);
  const std::string two = dir.write("two.ply", ascii_ply("2", "4"));
  EXPECT_EQ(mesh_load_message(two),
            two +
                ": the PLY header's elements take 6 lines (vertex 2, face 4), "
                "the body after end_header has 8");
  const std::string short_body = dir.write("short.ply", ascii_ply("4", "5"));
  EXPECT_EQ(mesh_load_message(short_body),
            short_body +
                ": the PLY header's elements take 9 lines "
                "(vertex 4, face 5), the body after end_header has 8");
  // CR LF line ends and blank lines after the last element are read; a blank line before it is
  // refused (Assimp reads one as an element: a CR LF blank line after end_header aborted it too).
  std::string crlf = ascii_ply("4", "4", std::string(kTetPlyBody) + "\n  \n");
  for (std::size_t at = crlf.find('\n'); at != std::string::npos; at = crlf.find('\n', at + 2))
    crlf.insert(at, "\r");
  const std::string blank =
      dir.write("blank.ply", ascii_ply("4", "4", std::string("\r\n") + kTetPlyBody));
  EXPECT_EQ(mesh_load_message(blank),
            blank +
                ":10: a blank line where vertex 0 of 4 (from 0) should be: the "
                "body is one element a line (Assimp reads a blank line as an element)");
  EXPECT_EQ(mesh_load_message(dir.write("crlf.ply", crlf)), "");
}

// Defect 2: 10^8 vertices promised in a file of a few hundred bytes parsed for over 60 s at
// 1.2 GB; 2·10^9 faces ended in "Assimp: std::bad_alloc". Both numbers are named at once.
TEST(MeshCounts, PlyThatPromisesMoreElementsThanItHoldsIsRefusedAtOnce) {
  TempDir dir;
  // Beyond 64 bits together too: no sum wraps.
  const std::string most = "18446744073709551615";
  for (const auto& [vertices, faces, lines] :
       {std::array<std::string, 3>{"100000000", "4", "100000004"},
        {"4", "2000000000", "2000000004"},
        {most, most, "36893488147419103230"}}) {
    const std::string path =
        dir.write("v" + vertices + "f" + faces + ".ply", ascii_ply(vertices, faces));
    EXPECT_EQ(mesh_load_message(path), path + ": the PLY header's elements take " + lines +
                                           " lines (vertex " + vertices + ", face " + faces +
                                           "), the body after end_header has 8");
  }
  // Binary: the bytes each element needs at least (its lists' counts), against the body's.
  std::string text = binary_ply(false);
  const std::size_t header = text.find("end_header\n") + 11;
  text.replace(text.find("vertex 4"), 8, "vertex 100000000");
  const std::string binary = dir.write("b.ply", text);
  EXPECT_EQ(mesh_load_message(binary),
            binary +
                ": the PLY header's elements take at least 1200000004 "
                "bytes (vertex 100000000 × 12 B, face 4 × at least 1 B), "
                "the body after end_header has " +
                std::to_string(text.size() - header - 8));
}

TEST(MeshCounts, BinaryPlyIsWalkedListByList) {
  TempDir dir;
  for (const bool big : {false, true}) {
    const std::string path = dir.write(big ? "be.ply" : "le.ply", binary_ply(big));
    EXPECT_EQ(mesh_load_message(path), "") << path;
  }
  const std::string body_size = std::to_string(4 * 12 + 4 * 13);
  // A vertex too few: the faces are read from the last vertex's bytes (0.0f: lists of no item,
  // a byte each), and the walk ends 60 bytes before the body does.
  const std::string fewer = dir.write("fewer.ply", binary_ply(false, 3));
  EXPECT_EQ(mesh_load_message(fewer),
            fewer +
                ": the PLY header's elements take 40 bytes (vertex 3, face 4), "
                "the body after end_header has " +
                body_size);
  // Trailing bytes.
  const std::string trailing = dir.write("trailing.ply", binary_ply(false) + "xyz");
  EXPECT_EQ(mesh_load_message(trailing),
            trailing +
                ": the PLY header's elements take 100 bytes (vertex 4, "
                "face 4), the body after end_header has 103");
  // A list longer than the body: its count byte says 200 items.
  std::string text = binary_ply(false);
  text[text.size() - 13] = static_cast<char>(200);
  const std::string past = dir.write("past.ply", text);
  EXPECT_EQ(mesh_load_message(past),
            past +
                ": face 3 of 4 (from 0) runs past the end of the file: the PLY "
                "header's elements (vertex 4, face 4) take more than the " +
                body_size + " bytes after end_header");
  // A body whose first byte is a line feed (the first x, 1.4e-44 as a float): Assimp skipped it
  // and read every value a byte off.
  text = binary_ply(false);
  text[text.find("end_header\n") + 11] = '\n';
  const std::string feed = dir.write("feed.ply", text);
  EXPECT_EQ(mesh_load_message(feed),
            feed +
                ":10: the binary body starts with a line feed byte (0x0A) after "
                "end_header's line feed: Assimp would skip it and read every "
                "value a byte off");
  // A vertex index out of range, and a negative one (it crashed Assimp, SIGSEGV).
  text = binary_ply(false);
  text.replace(text.size() - 4, 4, bytes_of(4, 4, false));
  const std::string out = dir.write("out.ply", text);
  EXPECT_EQ(mesh_load_message(out),
            out + ": face 3 of 4 (from 0) names vertex 4, the file has 4 (PLY counts from 0)");
  text.replace(text.size() - 4, 4, bytes_of(0xFFFFFFFEu, 4, false));
  const std::string negative = dir.write("negative.ply", text);
  EXPECT_EQ(
      mesh_load_message(negative),
      negative + ": face 3 of 4 (from 0) names vertex -2, the file has 4 (PLY counts from 0)");
}

// The lines of an ASCII body: each holds its element's properties, a face at least 3 vertices
// that exist (a face of 0 vertices aborted Assimp, a negative index crashed it).
TEST(MeshCounts, AsciiPlyLinesAreCheckedAtTheirLine) {
  TempDir dir;
  const auto with_face = [&](const std::string& name, const std::string& face) {
    std::string body = kTetPlyBody;
    body.replace(body.find("3 0 2 1"), 7, face);
    return dir.write(name, ascii_ply("4", "4", body));
  };
  const std::string none = with_face("none.ply", "0");
  EXPECT_EQ(mesh_load_message(none),
            none + ":14: face 0 of 4 (from 0): a face needs at least 3 vertices: got 0");
  const std::string two = with_face("two.ply", "2 0 2");
  EXPECT_EQ(mesh_load_message(two),
            two + ":14: face 0 of 4 (from 0): a face needs at least 3 vertices: got 2");
  const std::string negative = with_face("negative.ply", "3 0 -2 1");
  EXPECT_EQ(
      mesh_load_message(negative),
      negative + ":14: face 0 of 4 (from 0) names vertex -2, the file has 4 (PLY counts from 0)");
  const std::string beyond = with_face("beyond.ply", "3 0 2 9");
  EXPECT_EQ(
      mesh_load_message(beyond),
      beyond + ":14: face 0 of 4 (from 0) names vertex 9, the file has 4 (PLY counts from 0)");
  const std::string word = with_face("word.ply", "3 0 two 1");
  EXPECT_EQ(mesh_load_message(word),
            word + ":14: face 0 of 4 (from 0): \"two\" is not a whole number");
  const std::string extra = with_face("extra.ply", "3 0 2 1 7");
  EXPECT_EQ(mesh_load_message(extra),
            extra +
                ":14: face 0 of 4 (from 0): the line has 5 numbers, not what "
                "the header's properties of face take");
  const std::string few = with_face("few.ply", "4 0 2 1");
  EXPECT_EQ(mesh_load_message(few),
            few +
                ":14: face 0 of 4 (from 0): the line has 4 numbers, not what "
                "the header's properties of face take");
  std::string body = kTetPlyBody;
  body.replace(0, 5, "0 x 0");
  const std::string coordinate = dir.write("coordinate.ply", ascii_ply("4", "4", body));
  EXPECT_EQ(mesh_load_message(coordinate),
            coordinate + ":10: vertex 0 of 4 (from 0): \"x\" is not a number");
}

TEST(MeshCounts, PlyHeaderIsCheckedAtItsLine) {
  TempDir dir;
  const auto with_header = [&](const std::string& name, const std::string& from,
                               const std::string& to) {
    std::string text = ascii_ply("4", "4");
    text.replace(text.find(from), from.size(), to);
    return dir.write(name, text);
  };
  const std::string magic = with_header("magic.ply", "ply\n", "plyx\n");
  EXPECT_EQ(mesh_load_message(magic), magic + ":1: a PLY file starts with the line \"ply\"");
  const std::string type = with_header("type.ply", "float y", "float3 y");
  EXPECT_EQ(mesh_load_message(type), type + ":5: unknown PLY type \"float3\"");
  const std::string count = with_header("count.ply", "vertex 4", "vertex -4");
  EXPECT_EQ(mesh_load_message(count),
            count + ":3: expected \"element <name> <count>\", the count a whole number");
  const std::string unknown = with_header("unknown.ply", "format", "colour red\nformat");
  EXPECT_EQ(mesh_load_message(unknown), unknown + ":2: unknown PLY header line \"colour\"");
  const std::string list = with_header("list.ply", "list uchar int", "list float int");
  EXPECT_EQ(mesh_load_message(list),
            list + ":8: a list's count type must be an integer type, not \"float\"");
  const std::string end = dir.write("end.ply", "ply\nformat ascii 1.0\nelement vertex 0\n");
  EXPECT_EQ(mesh_load_message(end), end + ":4: the PLY header has no end_header line");
  const std::string empty =
      with_header("empty.ply", "property float x\nproperty float y\nproperty float z\n", "");
  EXPECT_EQ(mesh_load_message(empty), empty + ":3: element vertex has no property");
}

// A binary STL's count against its size (Assimp also refuses it, without the numbers); the
// count 2^31 + 4 makes 84 + 50 N wrap to the file's 284 bytes in 32 bits.
TEST(MeshCounts, BinaryStlCountIsCheckedAgainstTheFileSize) {
  TempDir dir;
  std::string facets(4 * 50, '\0');
  for (const std::uint64_t n : {std::uint64_t{100000000}, std::uint64_t{2147483652}}) {
    const std::string path = dir.write("n" + std::to_string(n) + ".stl",
                                       std::string(80, ' ') + bytes_of(n, 4, false) + facets);
    EXPECT_EQ(mesh_load_message(path), path + ": a binary STL whose header counts " +
                                           std::to_string(n) + " triangles takes 84 + 50 × " +
                                           std::to_string(n) + " = " + std::to_string(84 + 50 * n) +
                                           " bytes, the file has 284");
  }
  const std::string tiny = dir.write("tiny.stl", "abc");
  EXPECT_EQ(mesh_load_message(tiny),
            tiny +
                ": not an ASCII STL (it does not start with \"solid\") and "
                "shorter than a binary STL's 84-byte header: 3 bytes");
}

}  // namespace
