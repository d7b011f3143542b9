/// @file mesh_counts.cpp
/// A mesh file's counts against what it holds (see mesh_counts.hpp).

#include "mesh_counts.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "numen/sim/input/input_error.hpp"

namespace numen::sim {
namespace {

using Count = unsigned __int128;  // sums of 64-bit counts times sizes, never wrapped

/// `v` in decimal.
std::string decimal(Count v) {
  std::string out;
  do {
    out.insert(out.begin(), static_cast<char>('0' + static_cast<int>(v % 10)));
    v /= 10;
  } while (v != 0);
  return out;
}

/// A PLY scalar type: its bytes, whether it is an integer, whether signed.
struct PlyType {
  int bytes = 0;
  bool integer = false;
  bool is_signed = false;
};

/// The type named `name` (PLY's names and their sized aliases); bytes 0 when unknown.
PlyType ply_type(std::string_view name) {
  struct Named {
    std::string_view a, b;
    PlyType type;
  };
  static constexpr Named kTypes[] = {
      {"char", "int8", {1, true, true}},      {"uchar", "uint8", {1, true, false}},
      {"short", "int16", {2, true, true}},    {"ushort", "uint16", {2, true, false}},
      {"int", "int32", {4, true, true}},      {"uint", "uint32", {4, true, false}},
      {"float", "float32", {4, false, true}}, {"double", "float64", {8, false, true}},
  };
  for (const Named& t : kTypes)
    if (name == t.a || name == t.b) return t.type;
  return {};
}

struct PlyProperty {
  PlyType value;   ///< the scalar's type, or a list's items'
  PlyType count;   ///< a list's count type; bytes 0 for a scalar
  long min_index;  ///< a vertex-index list: its smallest index (0, or −1 in a tristrip)
  int min_items;   ///< a vertex-index list: its fewest items
  bool indices;    ///< a face's or tristrip's vertex-index list
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  int line = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  enum class Format { kAscii, kLittle, kBig } format = Format::kAscii;
  std::vector<PlyElement> elements;
  std::uint64_t vertices = 0;  ///< the `vertex` element's count
  std::streamoff body = 0;     ///< byte offset of the body
  int body_line = 0;           ///< line number of the body's first line
};

/// The fields of `line` split at spaces and tabs (a trailing '\r' dropped).
std::vector<std::string_view> fields_of(std::string_view line) {
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (true) {
    i = line.find_first_not_of(" \t", i);
    if (i == std::string_view::npos) break;
    const std::size_t j = std::min(line.find_first_of(" \t", i), line.size());
    out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

/// `text` as a whole integer, false when it is not one.
template <class T>
bool whole_integer(std::string_view text, T& v) {
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  return ec == std::errc() && end == text.data() + text.size();
}

/// True when `text` is a whole number as strtod reads it (nan and inf included: a vertex's
/// finiteness is checked after Assimp, for every format).
bool is_number(std::string_view text) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  const std::string s(text);
  char* end = nullptr;
  std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size();  // a NUL byte inside stops it short
}

/// The list of `elements` with their counts: "vertex 2, face 4".
std::string counts_of(const std::vector<PlyElement>& elements) {
  std::string out;
  for (const PlyElement& e : elements)
    out += (out.empty() ? "" : ", ") + e.name + " " + std::to_string(e.count);
  return out;
}

/// "face 3 of 4 (from 0)".
std::string item_of(const PlyElement& e, std::uint64_t i) {
  return e.name + " " + std::to_string(i) + " of " + std::to_string(e.count) + " (from 0)";
}

PlyHeader read_ply_header(const std::string& path, std::ifstream& in) {
  PlyHeader h;
  std::string line;
  int n = 0;
  const auto fail = [&](const std::string& why) { throw InputError(path, n, 0, "", why); };
  bool format = false;
  while (true) {
    if (!std::getline(in, line)) {
      ++n;
      fail("the PLY header has no end_header line");
    }
    ++n;
    const std::vector<std::string_view> f = fields_of(line);
    if (n == 1) {
      if (f.size() != 1 || f[0] != "ply") fail("a PLY file starts with the line \"ply\"");
      continue;
    }
    if (f.empty()) continue;
    const std::string_view key = f[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "end_header") break;
    if (key == "format") {
      if (f.size() != 3)
        fail("expected \"format <ascii | binary_little_endian | binary_big_endian> 1.0\"");
      if (f[1] == "ascii")
        h.format = PlyHeader::Format::kAscii;
      else if (f[1] == "binary_little_endian")
        h.format = PlyHeader::Format::kLittle;
      else if (f[1] == "binary_big_endian")
        h.format = PlyHeader::Format::kBig;
      else
        fail("unknown PLY format \"" + InputError::visible(f[1], true) + "\"");
      format = true;
    } else if (key == "element") {
      PlyElement e;
      if (f.size() != 3 || !whole_integer(f[2], e.count))
        fail("expected \"element <name> <count>\", the count a whole number");
      e.name = std::string(f[1]);
      e.line = n;
      if (e.name == "vertex" && !h.elements.empty() &&
          std::any_of(h.elements.begin(), h.elements.end(),
                      [](const PlyElement& x) { return x.name == "vertex"; }))
        fail("a second element \"vertex\"");
      h.elements.push_back(std::move(e));
    } else if (key == "property") {
      if (h.elements.empty()) fail("a property before the first element");
      PlyElement& e = h.elements.back();
      const bool list = f.size() == 5 && f[1] == "list";
      if (!list && f.size() != 3)
        fail(
            "expected \"property <type> <name>\" or \"property list <count type> <item type> "
            "<name>\"");
      PlyProperty p{};
      p.value = ply_type(f[list ? 3 : 1]);
      if (p.value.bytes == 0)
        fail("unknown PLY type \"" + InputError::visible(f[list ? 3 : 1], true) + "\"");
      if (list) {
        p.count = ply_type(f[2]);
        if (!p.count.integer)
          fail("a list's count type must be an integer type, not \"" +
               InputError::visible(f[2], true) + "\"");
        const std::string_view name = f[4];
        p.indices = (e.name == "face" && (name == "vertex_indices" || name == "vertex_index")) ||
                    (e.name == "tristrips" && name == "vertex_indices");
        p.min_index = e.name == "tristrips" ? -1 : 0;
        p.min_items = e.name == "face" ? 3 : 0;
        if (p.indices && !p.value.integer) fail("vertex indices must have an integer type");
      }
      e.properties.push_back(p);
    } else {
      fail("unknown PLY header line \"" + InputError::visible(key, true) + "\"");
    }
  }
  if (!format) throw InputError(path, n, 0, "", "the PLY header has no format line");
  for (const PlyElement& e : h.elements) {
    if (e.count > 0 && e.properties.empty())
      throw InputError(path, e.line, 0, "", "element " + e.name + " has no property");
    if (e.name == "vertex") h.vertices = e.count;
  }
  h.body = in.tellg();
  h.body_line = n + 1;
  return h;
}

/// Checks one index of a vertex-index list.
void check_index(const std::string& path, int line, const PlyElement& e, std::uint64_t i,
                 const PlyProperty& p, long long index, std::uint64_t vertices) {
  if (index < p.min_index || (index >= 0 && static_cast<std::uint64_t>(index) >= vertices))
    throw InputError(path, line, 0, "",
                     item_of(e, i) + " names vertex " + std::to_string(index) + ", the file has " +
                         std::to_string(vertices) + " (PLY counts from 0)");
}

void check_items(const std::string& path, int line, const PlyElement& e, std::uint64_t i,
                 const PlyProperty& p, long long items) {
  if (items < p.min_items)
    throw InputError(
        path, line, 0, "",
        item_of(e, i) + ": a face needs at least 3 vertices: got " + std::to_string(items));
}

void check_ply_ascii(const std::string& path, std::ifstream& in, const PlyHeader& h) {
  Count expected = 0;
  for (const PlyElement& e : h.elements) expected += e.count;
  std::string line;
  Count lines = 0;
  while (std::getline(in, line))
    if (!fields_of(line).empty()) ++lines;
  if (lines != expected)
    throw InputError(path, 0, 0, "",
                     "the PLY header's elements take " + decimal(expected) + " lines (" +
                         counts_of(h.elements) + "), the body after end_header has " +
                         decimal(lines));
  in.clear();
  in.seekg(h.body);
  int n = h.body_line - 1;
  for (const PlyElement& e : h.elements) {
    for (std::uint64_t i = 0; i < e.count; ++i) {
      std::getline(in, line);  // there: the non-blank lines were counted
      ++n;
      const std::vector<std::string_view> f = fields_of(line);
      if (f.empty())
        throw InputError(path, n, 0, "",
                         "a blank line where " + item_of(e, i) +
                             " should be: the body is one element a line (Assimp reads a blank "
                             "line as an element)");
      std::size_t k = 0;
      const auto number = [&](bool integer, long long& v) {
        if (k >= f.size()) return false;
        const std::string_view t = f[k++];
        if (integer ? whole_integer(t, v) : is_number(t)) return true;
        throw InputError(path, n, 0, "",
                         item_of(e, i) + ": \"" + InputError::visible(t, true) + "\" is not " +
                             (integer ? "a whole number" : "a number"));
      };
      bool short_line = false;
      for (const PlyProperty& p : e.properties) {
        long long v = 0;
        if (p.count.bytes == 0) {
          short_line = short_line || !number(false, v);
          continue;
        }
        long long items = 0;
        if (!number(true, items)) {
          short_line = true;
          continue;
        }
        if (items < 0)
          throw InputError(path, n, 0, "",
                           item_of(e, i) + ": a list of " + std::to_string(items) + " items");
        if (p.indices) check_items(path, n, e, i, p, items);
        if (static_cast<unsigned long long>(items) > f.size() - k) {
          short_line = true;
          break;
        }
        for (long long m = 0; m < items; ++m) {
          number(p.indices || p.value.integer, v);
          if (p.indices) check_index(path, n, e, i, p, v, h.vertices);
        }
      }
      if (short_line || k != f.size())
        throw InputError(path, n, 0, "",
                         item_of(e, i) + ": the line has " + std::to_string(f.size()) +
                             " numbers, not what the header's properties of " + e.name + " take");
    }
  }
}

/// Reads a binary body through a buffer, counting what is left of it.
class PlyBytes {
 public:
  PlyBytes(std::ifstream& in, std::uint64_t size, bool big)
      : in_(in), size_(size), left_(size), big_(big) {}
  std::uint64_t left() const { return left_; }
  std::uint64_t size() const { return size_; }
  /// Skips `n` bytes; false past the end.
  bool skip(std::uint64_t n) {
    if (n > left_) return false;
    left_ -= n;
    const std::uint64_t buffered = end_ - at_;
    if (n <= buffered) {
      at_ += n;
      return true;
    }
    in_.seekg(static_cast<std::streamoff>(n - buffered), std::ios::cur);
    at_ = end_ = 0;
    return true;
  }
  /// Reads a value of `t` as an integer (floats truncated); false past the end.
  bool integer(const PlyType& t, long long& v) {
    const auto n = static_cast<std::uint64_t>(t.bytes);
    if (n > left_) return false;
    if (end_ - at_ < n) refill();
    if (end_ - at_ < n) return false;  // the file shrank since its size was read
    unsigned char b[8] = {};
    std::memcpy(b, buffer_.data() + at_, n);
    at_ += n;
    left_ -= n;
    if (big_) std::reverse(b, b + n);
    std::uint64_t u = 0;
    for (std::uint64_t k = n; k-- > 0;) u = (u << 8) | b[k];
    if (!t.integer) {
      double d = 0.0;
      if (n == 4) {
        float f = 0.0f;
        std::memcpy(&f, b, 4);
        d = f;
      } else {
        std::memcpy(&d, b, 8);
      }
      v = d > -1e18 && d < 1e18 ? static_cast<long long>(d) : -1;
    } else if (t.is_signed && n < 8 && (u >> (8 * n - 1)) != 0) {
      v = static_cast<long long>(u | (~std::uint64_t{0} << (8 * n)));
    } else {
      v = static_cast<long long>(u);
    }
    return true;
  }

 private:
  void refill() {
    const std::uint64_t kept = end_ - at_;
    std::memmove(buffer_.data(), buffer_.data() + at_, kept);
    in_.read(buffer_.data() + kept, static_cast<std::streamsize>(buffer_.size() - kept));
    at_ = 0;
    end_ = kept + static_cast<std::uint64_t>(in_.gcount());
  }
  std::ifstream& in_;
  std::uint64_t size_;
  std::uint64_t left_;
  bool big_;
  std::vector<char> buffer_ = std::vector<char>(std::size_t{1} << 16);
  std::uint64_t at_ = 0, end_ = 0;
};

/// Walks a binary body through `h`'s elements, list by list; with `indices`, checks the faces'
/// vertex indices too (else skips them as any list).
void walk_ply_binary(const std::string& path, const PlyHeader& h, PlyBytes& body, bool indices) {
  const auto past_end = [&](const PlyElement& e, std::uint64_t i) {
    return InputError(path, 0, 0, "",
                      item_of(e, i) +
                          " runs past the end of the file: the PLY header's elements (" +
                          counts_of(h.elements) + ") take more than the " +
                          std::to_string(body.size()) + " bytes after end_header");
  };
  for (const PlyElement& e : h.elements) {
    const bool lists = std::any_of(e.properties.begin(), e.properties.end(),
                                   [](const PlyProperty& p) { return p.count.bytes > 0; });
    if (!lists) {  // a fixed size, within the body (check_ply_binary's least bytes)
      std::uint64_t bytes = 0;
      for (const PlyProperty& p : e.properties) bytes += static_cast<std::uint64_t>(p.value.bytes);
      if (!body.skip(bytes * e.count)) throw past_end(e, 0);
      continue;
    }
    for (std::uint64_t i = 0; i < e.count; ++i)
      for (const PlyProperty& p : e.properties) {
        if (p.count.bytes == 0) {
          if (!body.skip(static_cast<std::uint64_t>(p.value.bytes))) throw past_end(e, i);
          continue;
        }
        long long items = 0;
        if (!body.integer(p.count, items)) throw past_end(e, i);
        if (items < 0)
          throw InputError(path, 0, 0, "",
                           item_of(e, i) + ": a list of " + std::to_string(items) + " items");
        if (!(indices && p.indices)) {
          if (!body.skip(static_cast<std::uint64_t>(items) *
                         static_cast<std::uint64_t>(p.value.bytes)))
            throw past_end(e, i);
          continue;
        }
        check_items(path, 0, e, i, p, items);
        for (long long m = 0; m < items; ++m) {
          long long v = 0;
          if (!body.integer(p.value, v)) throw past_end(e, i);
          check_index(path, 0, e, i, p, v, h.vertices);
        }
      }
  }
}

void check_ply_binary(const std::string& path, std::ifstream& in, const PlyHeader& h,
                      std::uint64_t body_bytes) {
  // At least each element's scalars and list counts, before walking the lists.
  Count least = 0;
  std::string sizes;
  for (const PlyElement& e : h.elements) {
    int bytes = 0;
    bool lists = false;
    for (const PlyProperty& p : e.properties) {
      bytes += p.count.bytes > 0 ? p.count.bytes : p.value.bytes;
      lists = lists || p.count.bytes > 0;
    }
    least += Count{e.count} * static_cast<unsigned>(bytes);
    sizes += (sizes.empty() ? "" : ", ") + e.name + " " + std::to_string(e.count) + " × " +
             (lists ? "at least " : "") + std::to_string(bytes) + " B";
  }
  if (least > body_bytes)
    throw InputError(path, 0, 0, "",
                     "the PLY header's elements take at least " + decimal(least) + " bytes (" +
                         sizes + "), the body after end_header has " + std::to_string(body_bytes));
  // Two walks: the sizes first (the lists' counts), so that counts that disagree with the body
  // are named with both numbers; then the faces' vertex indices.
  for (const bool indices : {false, true}) {
    in.clear();
    in.seekg(h.body);
    PlyBytes body(in, body_bytes, h.format == PlyHeader::Format::kBig);
    walk_ply_binary(path, h, body, indices);
    if (body.left() != 0)
      throw InputError(path, 0, 0, "",
                       "the PLY header's elements take " +
                           std::to_string(body_bytes - body.left()) + " bytes (" +
                           counts_of(h.elements) + "), the body after end_header has " +
                           std::to_string(body_bytes));
  }
}

}  // namespace

void check_ply_counts(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, 0, "", "cannot open the mesh file");
  const PlyHeader h = read_ply_header(path, in);
  if (h.format == PlyHeader::Format::kAscii) {
    check_ply_ascii(path, in, h);
    return;
  }
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec || h.body < 0 || size < static_cast<std::uintmax_t>(h.body))
    throw InputError(path, 0, 0, "", "cannot read the mesh file's size");
  if (in.peek() == '\n')  // Assimp takes it for the end of the header's last line
    throw InputError(path, h.body_line, 0, "",
                     "the binary body starts with a line feed byte (0x0A) after end_header's line "
                     "feed: Assimp would skip it and read every value a byte off");
  check_ply_binary(path, in, h,
                   static_cast<std::uint64_t>(size - static_cast<std::uintmax_t>(h.body)));
}

void check_stl_counts(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[84] = {};
  in.read(head, sizeof head);
  const auto got = static_cast<std::size_t>(in.gcount());
  std::string_view text(head, got);
  const std::size_t first = text.find_first_not_of(" \t\r\n\f\v");
  if (first != std::string_view::npos && text.substr(first, 5) == "solid") return;  // ASCII
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, 0, 0, "", "cannot read the mesh file's size");
  if (got < sizeof head)
    throw InputError(
        path, 0, 0, "",
        "not an ASCII STL (it does not start with \"solid\") and shorter than a binary "
        "STL's 84-byte header: " +
            std::to_string(size) + " bytes");
  const std::uint64_t triangles =
      static_cast<unsigned char>(head[80]) |
      static_cast<std::uint64_t>(static_cast<unsigned char>(head[81])) << 8 |
      static_cast<std::uint64_t>(static_cast<unsigned char>(head[82])) << 16 |
      static_cast<std::uint64_t>(static_cast<unsigned char>(head[83])) << 24;
  const std::uint64_t expected = 84 + 50 * triangles;
  if (expected != size)
    throw InputError(path, 0, 0, "",
                     "a binary STL whose header counts " + std::to_string(triangles) +
                         " triangles takes 84 + 50 × " + std::to_string(triangles) + " = " +
                         std::to_string(expected) + " bytes, the file has " + std::to_string(size));
}

}  // namespace numen::sim
