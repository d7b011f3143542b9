/// @file dcf.cpp
/// CiA 306 EDS/DCF reading: libinih splits the file into (section, key, value), this file
/// gives them their CiA 306 meaning and locates every error.

#include "numen/hal/canopen/dcf.hpp"

#include <ini.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>

#include "../hex_text.hpp"

namespace numen::hal {
namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(b, e - b + 1));
}

using detail::hex_digits;

struct Key {
  std::string name;  // as written
  std::string value;
  int line = 0;
};

struct Section {
  std::string name;  // as written
  int line = 0;
  std::map<std::string, Key> keys;  // by lower-case name
};

/// What libinih's callbacks fill: sections by lower-case name, the line counter, the first
/// error a callback found.
struct ParseState {
  std::string_view text;
  std::size_t pos = 0;
  int line = 0;
  std::map<std::string, Section> sections;
  std::string current;  // lower-case name of the section the reader last opened
  bool indented = false;  // the current line starts with white space (a continuation)
  std::optional<DcfError> error;
  std::string file;
};

/// libinih's reader: one line of the text per call, counting lines (the handler then knows
/// the line of each key). A line longer than libinih's buffer is an error of its own.
char* read_line(char* str, int num, void* stream) {
  auto* s = static_cast<ParseState*>(stream);
  if (s->pos >= s->text.size()) return nullptr;
  auto end = s->text.find('\n', s->pos);
  const std::size_t stop = end == std::string_view::npos ? s->text.size() : end + 1;
  const std::string_view line = s->text.substr(s->pos, stop - s->pos);
  s->pos = stop;
  ++s->line;
  const auto room = static_cast<std::size_t>(num - 1);
  if (line.size() > room && !s->error) {
    s->error.emplace(DcfLocation{s->file, s->line, "", ""},
                     "line longer than " + std::to_string(room) + " characters");
  }
  const std::size_t n = std::min(room, line.size());
  std::memcpy(str, line.data(), n);
  str[n] = '\0';
  const std::string t = trim(line);
  s->indented = !t.empty() && (line.front() == ' ' || line.front() == '\t');
  if (t.size() >= 2 && t.front() == '[') {
    const auto close = t.find(']');
    if (close != std::string::npos) {
      const std::string name = trim(std::string_view(t).substr(1, close - 1));
      s->current = lower(name);
      Section& sec = s->sections[s->current];
      if (sec.line != 0 && !s->error) {
        s->error.emplace(DcfLocation{s->file, s->line, name, ""},
                         "section given twice (first on line " + std::to_string(sec.line) + ")");
      }
      sec.name = name;
      sec.line = s->line;
    }
  }
  return str;
}

int on_key(void* user, const char* section, const char* name, const char* value) {
  auto* s = static_cast<ParseState*>(user);
  if (s->error) return 1;
  Section& sec = s->sections[lower(section)];
  const std::string key = lower(name);
  auto it = sec.keys.find(key);
  if (it != sec.keys.end() && !s->indented) {
    s->error.emplace(DcfLocation{s->file, s->line, section, name},
                     "key given twice in the section (first on line " +
                         std::to_string(it->second.line) + ")");
    return 1;
  }
  if (it != sec.keys.end()) {
    it->second.value += std::string(" ") + value;  // libinih's continuation of the same key
    return 1;
  }
  sec.keys.emplace(key, Key{name, value, s->line});
  return 1;
}

class Reader {
 public:
  Reader(ParseState& s, std::uint8_t node_id) : s_(s), node_id_(node_id) {}

  DcfLocation at(const Section& sec, const std::string& key = {}) const {
    const Key* k = find(sec, key);
    return DcfLocation{s_.file, k != nullptr ? k->line : sec.line, sec.name,
                       k != nullptr ? k->name : key};
  }
  [[noreturn]] void fail(const Section& sec, const std::string& key, const std::string& msg) const {
    throw DcfError(at(sec, key), msg);
  }
  static const Key* find(const Section& sec, const std::string& key) {
    if (key.empty()) return nullptr;
    auto it = sec.keys.find(lower(key));
    return it == sec.keys.end() ? nullptr : &it->second;
  }
  const Section* section(const std::string& name) const {
    auto it = s_.sections.find(lower(name));
    return it == s_.sections.end() ? nullptr : &it->second;
  }
  std::string text(const Section& sec, const std::string& key) const {
    const Key* k = find(sec, key);
    return k != nullptr ? trim(k->value) : std::string{};
  }

  /// An integer expression of CiA 306: N, -N, $NODEID, $NODEID+N, N+$NODEID (N decimal,
  /// 0x hexadecimal or 0 octal). Returns it as a signed 128-bit-safe value via (negative, magnitude).
  bool number(const std::string& raw, __int128& out, std::string& why) const {
    const std::string t = trim(raw);
    if (t.empty()) {
      why = "empty value";
      return false;
    }
    __int128 sum = 0;
    std::size_t start = 0;
    bool any_node = false;
    while (start <= t.size()) {
      const auto plus = t.find('+', start);
      const std::string term = trim(t.substr(start, plus == std::string::npos ? std::string::npos : plus - start));
      if (lower(term) == "$nodeid") {
        if (any_node) {
          why = "'" + t + "': $NODEID given twice";
          return false;
        }
        any_node = true;
        sum += node_id_;
      } else {
        bool neg = false;
        std::string_view d = term;
        if (!d.empty() && d.front() == '-') {
          if (start != 0 || plus != std::string::npos) {
            why = "'" + t + "': a negative number cannot be part of a $NODEID expression";
            return false;
          }
          neg = true;
          d.remove_prefix(1);
        }
        int base = 10;
        if (d.size() > 2 && d[0] == '0' && (d[1] == 'x' || d[1] == 'X')) {
          base = 16;
          d.remove_prefix(2);
        } else if (d.size() > 1 && d[0] == '0') {
          base = 8;
          d.remove_prefix(1);
        }
        unsigned long long v = 0;
        const auto [p, ec] = std::from_chars(d.data(), d.data() + d.size(), v, base);
        if (d.empty() || ec != std::errc() || p != d.data() + d.size()) {
          why = "'" + t + "' is not a number (decimal, 0x hexadecimal, 0 octal) or a $NODEID+N expression";
          return false;
        }
        sum += neg ? -static_cast<__int128>(v) : static_cast<__int128>(v);
      }
      if (plus == std::string::npos) break;
      start = plus + 1;
    }
    out = sum;
    return true;
  }

  std::uint64_t unsigned_key(const Section& sec, const std::string& key, std::uint64_t max,
                             std::uint64_t fallback, bool required) const {
    const Key* k = find(sec, key);
    if (k == nullptr || trim(k->value).empty()) {
      if (required) fail(sec, key, "missing (required)");
      return fallback;
    }
    __int128 v = 0;
    std::string why;
    if (!number(k->value, v, why)) fail(sec, key, why);
    if (v < 0 || v > static_cast<__int128>(max))
      fail(sec, key, "'" + trim(k->value) + "' is outside [0, " + hex_digits(max, 1) + "]");
    return static_cast<std::uint64_t>(v);
  }

  /// A value of numeric data type `type` as its unsigned bits.
  std::uint64_t typed_value(const Section& sec, const std::string& key, std::uint16_t type) const {
    const Key* k = find(sec, key);
    const std::string t = trim(k->value);
    if (type == CanopenDataType::kReal32) {
      float f = 0;
      const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), f);
      if (ec != std::errc() || p != t.data() + t.size()) fail(sec, key, "'" + t + "' is not a REAL32 number");
      std::uint32_t bits = 0;
      std::memcpy(&bits, &f, sizeof bits);
      return bits;
    }
    __int128 v = 0;
    std::string why;
    if (!number(t, v, why)) fail(sec, key, why);
    const std::size_t bytes = data_type_size(type);
    const int bits = static_cast<int>(8 * bytes);
    __int128 lo = 0;
    __int128 hi = 0;
    if (type == CanopenDataType::kBoolean) {
      hi = 1;
    } else if (data_type_signed(type)) {
      lo = -(static_cast<__int128>(1) << (bits - 1));
      hi = (static_cast<__int128>(1) << (bits - 1)) - 1;
    } else {
      hi = (static_cast<__int128>(1) << bits) - 1;
    }
    if (v < lo || v > hi) {
      fail(sec, key,
           "'" + t + "' does not fit the data type " + hex_digits(type, 4) + " (range " +
               std::to_string(static_cast<long long>(lo)) + " to " +
               (bits == 64 && hi > static_cast<__int128>(INT64_MAX)
                    ? std::string("18446744073709551615")
                    : std::to_string(static_cast<long long>(hi))) +
               ")");
    }
    const std::uint64_t mask = bits == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << bits) - 1);
    return static_cast<std::uint64_t>(v) & mask;
  }

  DcfEntry entry(const Section& sec, SdoAddress address) const {
    DcfEntry e;
    e.address = address;
    e.name = text(sec, "ParameterName");
    e.data_type = static_cast<std::uint16_t>(unsigned_key(sec, "DataType", 0xFFFF, 0, true));
    const bool numeric = data_type_size(e.data_type) != 0;
    const bool textual = e.data_type == CanopenDataType::kVisibleString ||
                         e.data_type == CanopenDataType::kOctetString ||
                         e.data_type == CanopenDataType::kUnicodeString ||
                         e.data_type == CanopenDataType::kDomain;
    if (!numeric && !textual)
      fail(sec, "DataType",
           hex_digits(e.data_type, 4) +
               " is not a data type numen reads (BOOLEAN, "
               "INTEGERn, UNSIGNEDn, REAL32, strings, DOMAIN)");
    const std::string access = lower(text(sec, "AccessType"));
    if (access == "ro") e.access = DcfAccess::kReadOnly;
    else if (access == "wo") e.access = DcfAccess::kWriteOnly;
    else if (access == "rw") e.access = DcfAccess::kReadWrite;
    else if (access == "rwr") e.access = DcfAccess::kReadWriteRead;
    else if (access == "rww") e.access = DcfAccess::kReadWriteWrite;
    else if (access == "const") e.access = DcfAccess::kConst;
    else if (access.empty()) fail(sec, "AccessType", "missing (required)");
    else fail(sec, "AccessType", "'" + text(sec, "AccessType") + "' is not ro, wo, rw, rwr, rww or const");
    e.pdo_mappable = unsigned_key(sec, "PDOMapping", 1, 0, false) == 1;
    const Key* param = find(sec, "ParameterValue");
    const Key* def = find(sec, "DefaultValue");
    e.configured = param != nullptr && !trim(param->value).empty();
    e.has_default = def != nullptr && !trim(def->value).empty();
    const std::string used = e.configured ? "ParameterValue" : e.has_default ? "DefaultValue" : "";
    e.location = at(sec, used);
    if (e.data_type == CanopenDataType::kDomain && e.configured)
      fail(sec, "ParameterValue", "a DOMAIN value is not configured by numen");
    if (!used.empty()) {
      if (numeric) {
        // Check the DefaultValue too when a ParameterValue overrides it.
        if (e.configured && e.has_default) (void)typed_value(sec, "DefaultValue", e.data_type);
        e.value = typed_value(sec, used, e.data_type);
      } else {
        e.text = trim(find(sec, used)->value);
      }
    }
    return e;
  }

 private:
  ParseState& s_;
  std::uint8_t node_id_;
};

/// "1A00" → 0x1A00; "1A00sub1" → (0x1A00, 1). False for any other section name.
bool object_section(const std::string& lname, std::uint16_t& index, int& sub) {
  auto hexnum = [](std::string_view d, std::uint32_t max, std::uint32_t& v) {
    const auto [p, ec] = std::from_chars(d.data(), d.data() + d.size(), v, 16);
    return !d.empty() && ec == std::errc() && p == d.data() + d.size() && v <= max;
  };
  std::uint32_t v = 0;
  if (lname.size() < 4 || !hexnum(std::string_view(lname).substr(0, 4), 0xFFFF, v)) return false;
  index = static_cast<std::uint16_t>(v);
  if (lname.size() == 4) {
    sub = -1;
    return true;
  }
  if (lname.compare(4, 3, "sub") != 0) return false;
  std::uint32_t s = 0;
  if (!hexnum(std::string_view(lname).substr(7), 0xFF, s)) return false;
  sub = static_cast<int>(s);
  return true;
}

Dcf build(ParseState& s, const std::string& name, std::uint8_t node_id) {
  Reader r(s, node_id);
  Dcf dcf;
  dcf.path = name;
  dcf.resolved_node_id = node_id;
  if (const Section* fi = r.section("FileInfo")) {
    dcf.file_info = DcfFileInfo{r.text(*fi, "FileName"), r.text(*fi, "Description"),
                                r.text(*fi, "CreatedBy"), r.text(*fi, "EDSVersion")};
  }
  if (const Section* di = r.section("DeviceInfo")) {
    dcf.device_info.vendor_name = r.text(*di, "VendorName");
    dcf.device_info.product_name = r.text(*di, "ProductName");
    dcf.device_info.vendor_number = static_cast<std::uint32_t>(r.unsigned_key(*di, "VendorNumber", 0xFFFFFFFF, 0, false));
    dcf.device_info.product_number = static_cast<std::uint32_t>(r.unsigned_key(*di, "ProductNumber", 0xFFFFFFFF, 0, false));
    dcf.device_info.revision_number = static_cast<std::uint32_t>(r.unsigned_key(*di, "RevisionNumber", 0xFFFFFFFF, 0, false));
  }
  if (const Section* dc = r.section("DeviceComissioning")) {
    if (Reader::find(*dc, "NodeID") != nullptr) {
      const auto id = static_cast<std::uint8_t>(r.unsigned_key(*dc, "NodeID", 127, 0, true));
      if (id < 1) r.fail(*dc, "NodeID", "must be a node id in [1, 127]");
      if (id != node_id)
        r.fail(*dc, "NodeID", "this DCF configures node " + std::to_string(id) + ", the scene gives node " +
                                  std::to_string(node_id));
      dcf.node_id = id;
    }
  }
  // Objects and their sub-indices.
  std::map<std::uint16_t, const Section*> objects;
  std::map<std::uint16_t, std::map<int, const Section*>> subs;
  for (const auto& [lname, sec] : s.sections) {
    std::uint16_t index = 0;
    int sub = -1;
    if (!object_section(lname, index, sub)) continue;
    if (sub < 0) objects[index] = &sec;
    else subs[index][sub] = &sec;
  }
  for (const auto& [index, ss] : subs) {
    if (objects.count(index) == 0) {
      const Section& first = *ss.begin()->second;
      throw DcfError(
          DcfLocation{s.file, first.line, first.name, ""},
          "sub-index section without its object section [" + hex_digits(index, 4).substr(2) + "]");
    }
  }
  for (const auto& [index, sec] : objects) {
    if (Reader::find(*sec, "CompactSubObj") != nullptr && r.text(*sec, "CompactSubObj") != "0")
      r.fail(*sec, "CompactSubObj", "compact sub-objects are not read by numen: give one [" +
                                        sec->name + "subN] section per sub-index");
    const auto type = r.unsigned_key(*sec, "ObjectType", 0xFF, 0x7, false);
    if (type == 0x7) {
      if (subs.count(index) != 0) {
        const Section& first = *subs[index].begin()->second;
        throw DcfError(DcfLocation{s.file, first.line, first.name, ""},
                       "a VAR object (ObjectType 0x7) has no sub-index sections");
      }
      dcf.entries.push_back(r.entry(*sec, SdoAddress{index, 0}));
    } else if (type == 0x8 || type == 0x9) {
      const auto n = r.unsigned_key(*sec, "SubNumber", 0xFF, 0, true);
      const auto& ss = subs[index];
      if (ss.size() != n)
        r.fail(*sec, "SubNumber", std::to_string(n) + " sub-indices announced, " +
                                      std::to_string(ss.size()) + " [" + sec->name + "subN] sections given");
      for (const auto& [sub, subsec] : ss) {
        if (r.unsigned_key(*subsec, "ObjectType", 0xFF, 0x7, false) != 0x7)
          r.fail(*subsec, "ObjectType", "a sub-index is a VAR (0x7)");
        dcf.entries.push_back(r.entry(*subsec, SdoAddress{index, static_cast<std::uint8_t>(sub)}));
      }
    } else {
      r.fail(*sec, "ObjectType",
             hex_digits(type, 1) + " is not 0x7 (VAR), 0x8 (ARRAY) or 0x9 (RECORD)");
    }
  }
  // Every listed object has its section.
  for (const char* list : {"MandatoryObjects", "OptionalObjects", "ManufacturerObjects"}) {
    const Section* sec = r.section(list);
    if (sec == nullptr) continue;
    const auto n = r.unsigned_key(*sec, "SupportedObjects", 0xFFFF, 0, true);
    for (std::uint64_t i = 1; i <= n; ++i) {
      const std::string key = std::to_string(i);
      const auto index = static_cast<std::uint16_t>(r.unsigned_key(*sec, key, 0xFFFF, 0, true));
      if (objects.count(index) == 0)
        r.fail(*sec, key,
               "object " + hex_digits(index, 4) + " is listed but has no [" +
                   hex_digits(index, 4).substr(2) + "] section");
    }
  }
  std::sort(dcf.entries.begin(), dcf.entries.end(), [](const DcfEntry& a, const DcfEntry& b) {
    return a.address.index != b.address.index ? a.address.index < b.address.index
                                              : a.address.subindex < b.address.subindex;
  });
  return dcf;
}

}  // namespace

std::size_t data_type_size(std::uint16_t type) noexcept {
  switch (type) {
    case CanopenDataType::kBoolean:
    case CanopenDataType::kInteger8:
    case CanopenDataType::kUnsigned8:
      return 1;
    case CanopenDataType::kInteger16:
    case CanopenDataType::kUnsigned16:
      return 2;
    case CanopenDataType::kInteger32:
    case CanopenDataType::kUnsigned32:
    case CanopenDataType::kReal32:
      return 4;
    case CanopenDataType::kInteger64:
    case CanopenDataType::kUnsigned64:
      return 8;
    default:
      return 0;
  }
}

bool data_type_signed(std::uint16_t type) noexcept {
  return type == CanopenDataType::kInteger8 || type == CanopenDataType::kInteger16 ||
         type == CanopenDataType::kInteger32 || type == CanopenDataType::kInteger64;
}

std::string to_string(const DcfLocation& l) {
  std::string s = l.file;
  if (l.line > 0) s += ":" + std::to_string(l.line);
  s += ":";
  if (!l.section.empty()) s += " [" + l.section + "]";
  if (!l.key.empty()) s += " " + l.key;
  return s;
}

DcfError::DcfError(DcfLocation location, const std::string& message)
    : std::runtime_error(to_string(location) + ": " + message),
      location_(std::move(location)),
      message_(message) {}

const DcfEntry* Dcf::find(SdoAddress address) const noexcept {
  const auto it = std::lower_bound(entries.begin(), entries.end(), address,
                                   [](const DcfEntry& e, SdoAddress a) {
                                     return e.address.index != a.index ? e.address.index < a.index
                                                                       : e.address.subindex < a.subindex;
                                   });
  return it != entries.end() && it->address == address ? &*it : nullptr;
}

Dcf parse_dcf_text(std::string_view text, const std::string& name, std::uint8_t node_id) {
  if (node_id < 1 || node_id > 127)
    throw DcfError(DcfLocation{name, 0, "", ""}, "node id " + std::to_string(node_id) + " is not in [1, 127]");
  ParseState s;
  s.text = text;
  s.file = name;
  const int rc = ini_parse_stream(&read_line, &s, &on_key, &s);
  if (s.error && (rc <= 0 || s.error->location().line <= rc)) throw *s.error;
  if (rc > 0) {
    throw DcfError(DcfLocation{name, rc, "", ""},
                   "not an INI line (expected [section], key=value, or a ; comment)");
  }
  if (rc < 0) throw DcfError(DcfLocation{name, 0, "", ""}, "libinih could not read the text");
  return build(s, name, node_id);
}

Dcf parse_dcf_file(const std::string& path, std::uint8_t node_id) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw DcfError(DcfLocation{path, 0, "", ""}, std::string("cannot open: ") + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_dcf_text(ss.str(), path, node_id);
}

}  // namespace numen::hal
