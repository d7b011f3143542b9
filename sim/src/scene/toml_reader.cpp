/// @file toml_reader.cpp

#include "toml_reader.hpp"

#include <cmath>
#include <filesystem>
#include <system_error>
#include <sstream>

namespace numen::sim {

std::string TomlTable::key_path(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

namespace {
InputError located_error(const toml::node& node, const std::string& file, const std::string& key,
                         const std::string& message) {
  const toml::source_region& src = node.source();
  return InputError(file, static_cast<int>(src.begin.line), static_cast<int>(src.begin.column),
                    key, message);
}
}  // namespace

void TomlTable::fail_at(const toml::node* node, const std::string& key,
                        const std::string& message) const {
  throw located_error(node ? *node : *table_, *file_, key, message);
}

void TomlTable::fail(std::string_view key, const std::string& message) const {
  throw error(key, message);
}

InputError TomlTable::error(std::string_view key, const std::string& message) const {
  const toml::node* node = table_->get(key);
  return located_error(node ? *node : *table_, *file_, key_path(key), message);
}

namespace {
const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::table: return "a table";
    case toml::node_type::array: return "an array";
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a number";
    case toml::node_type::boolean: return "a boolean";
    default: return "a date/time";
  }
}
std::optional<double> as_number(const toml::node& n) {
  if (auto v = n.as_floating_point()) return v->get();
  if (auto v = n.as_integer()) return static_cast<double>(v->get());
  return std::nullopt;
}
}  // namespace

std::optional<double> TomlTable::optional_number(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (!n) return std::nullopt;
  auto v = as_number(*n);
  if (!v) fail(key, std::string("expected a number, found ") + type_name(*n));
  if (!std::isfinite(*v)) fail(key, "must be finite");
  return v;
}

double TomlTable::number(std::string_view key) const {
  auto v = optional_number(key);
  if (!v) fail(key, "missing (a number is required)");
  return *v;
}

double TomlTable::number_or(std::string_view key, double fallback) const {
  return optional_number(key).value_or(fallback);
}

double TomlTable::number_in(std::string_view key, double lo, double hi,
                            std::optional<double> fallback) const {
  auto v = optional_number(key);
  if (!v) {
    if (fallback) return *fallback;
    fail(key, "missing (a number is required)");
  }
  if (*v < lo || *v > hi) {
    std::ostringstream os;
    os << "must be in [" << lo << ", " << hi << "], got " << *v;
    fail(key, os.str());
  }
  return *v;
}

std::int64_t TomlTable::integer(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (!n) fail(key, "missing (an integer is required)");
  if (auto v = n->as_integer()) return v->get();
  fail(key, std::string("expected an integer, found ") + type_name(*n));
}

std::int64_t TomlTable::integer_or(std::string_view key, std::int64_t fallback) const {
  return has(key) ? integer(key) : fallback;
}

bool TomlTable::boolean_or(std::string_view key, bool fallback) const {
  const toml::node* n = table_->get(key);
  if (!n) return fallback;
  if (auto v = n->as_boolean()) return v->get();
  fail(key, std::string("expected true or false, found ") + type_name(*n));
}

std::string TomlTable::string(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (!n) fail(key, "missing (a string is required)");
  if (auto v = n->as_string()) return v->get();
  fail(key, std::string("expected a string, found ") + type_name(*n));
}

std::string TomlTable::string_or(std::string_view key, std::string fallback) const {
  return has(key) ? string(key) : fallback;
}

std::string TomlTable::choice(std::string_view key, const std::vector<std::string>& choices,
                              std::optional<std::string> fallback) const {
  if (!has(key)) {
    if (fallback) return *fallback;
    fail(key, "missing");
  }
  std::string v = string(key);
  for (const auto& c : choices)
    if (c == v) return v;
  std::string list;
  for (const auto& c : choices) list += (list.empty() ? "" : ", ") + ("\"" + c + "\"");
  fail(key, "unknown value \"" + v + "\" (expected one of " + list + ")");
}

std::vector<double> TomlTable::numbers(std::string_view key, int n) const {
  const toml::node* node = table_->get(key);
  if (!node) fail(key, "missing (an array of numbers is required)");
  return array_numbers(*node, key_path(key), n);
}

std::vector<double> TomlTable::array_numbers(const toml::node& node, const std::string& key, int n) const {
  const toml::array* arr = node.as_array();
  if (!arr) fail_at(&node, key, std::string("expected an array of numbers, found ") + type_name(node));
  if (n >= 0 && static_cast<int>(arr->size()) != n)
    fail_at(&node, key, "expected " + std::to_string(n) + " numbers, found " + std::to_string(arr->size()));
  std::vector<double> out;
  out.reserve(arr->size());
  for (std::size_t i = 0; i < arr->size(); ++i) {
    auto v = as_number(*arr->get(i));
    const std::string k = key + "[" + std::to_string(i) + "]";
    if (!v) fail_at(arr->get(i), k, std::string("expected a number, found ") + type_name(*arr->get(i)));
    if (!std::isfinite(*v)) fail_at(arr->get(i), k, "must be finite");
    out.push_back(*v);
  }
  return out;
}

core::Vec3 TomlTable::vec3(std::string_view key) const {
  auto v = numbers(key, 3);
  return core::Vec3(v[0], v[1], v[2]);
}

core::Vec3 TomlTable::vec3_or(std::string_view key, const core::Vec3& fallback) const {
  return has(key) ? vec3(key) : fallback;
}

std::vector<core::Vec3> TomlTable::points(std::string_view key) const {
  const toml::node* node = table_->get(key);
  const toml::array* arr = node ? node->as_array() : nullptr;
  if (!arr || arr->empty() || !arr->get(0)->is_array()) return {vec3(key)};  // one point
  std::vector<core::Vec3> out;
  out.reserve(arr->size());
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const toml::node& p = *arr->get(i);
    const std::string k = key_path(key) + "[" + std::to_string(i) + "]";
    if (!p.is_array()) fail_at(&p, k, std::string("expected a point [x, y, z], found ") + type_name(p));
    const std::vector<double> v = array_numbers(p, k, 3);
    out.emplace_back(v[0], v[1], v[2]);
  }
  return out;
}

core::Quat TomlTable::quaternion_or(std::string_view key, const core::Quat& fallback) const {
  if (!has(key)) return fallback;
  auto v = numbers(key, 4);
  core::Quat q(v[0], v[1], v[2], v[3]);
  if (q.norm() < 1e-9) fail(key, "quaternion [w, x, y, z] must not be zero");
  q.normalize();
  return q;
}

std::optional<TomlTable> TomlTable::table(std::string_view key) const {
  const toml::node* n = table_->get(key);
  if (!n) return std::nullopt;
  const toml::table* t = n->as_table();
  if (!t) fail(key, std::string("expected a table, found ") + type_name(*n));
  return TomlTable(*t, key_path(key), *file_);
}

std::vector<TomlTable> TomlTable::tables(std::string_view key) const {
  std::vector<TomlTable> out;
  const toml::node* n = table_->get(key);
  if (!n) return out;
  if (const toml::table* t = n->as_table()) {  // a single [key] table is accepted too
    out.emplace_back(*t, key_path(key), *file_);
    return out;
  }
  const toml::array* arr = n->as_array();
  if (!arr) fail(key, std::string("expected an array of tables, found ") + type_name(*n));
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const toml::table* t = arr->get(i)->as_table();
    const std::string k = key_path(key) + "[" + std::to_string(i) + "]";
    if (!t) fail_at(arr->get(i), k, "expected a table");
    out.emplace_back(*t, k, *file_);
  }
  return out;
}

void TomlTable::allow_only(std::initializer_list<std::string_view> keys) const {
  for (const auto& [k, v] : *table_) {
    bool ok = false;
    for (auto a : keys) ok = ok || (k.str() == a);
    if (!ok) {
      std::string list;
      for (auto a : keys) list += (list.empty() ? "" : ", ") + std::string(a);
      fail_at(&v, key_path(k.str()), "unknown key (allowed here: " + list + ")");
    }
  }
}

toml::table parse_toml_file(const std::string& path) {
  std::error_code ec;
  // toml++ reads a directory as an empty document: the error would be a missing [trajectory].
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path, 0, 0, "", "is a directory, not a scene file");
  try {
    return toml::parse_file(path);
  } catch (const toml::parse_error& e) {
    std::string desc(e.description());
    if (desc.find("File could not be opened") != std::string::npos)
      throw InputError(path, 0, 0, "", "cannot open the scene file");
    // A byte order mark is only allowed at the start; elsewhere toml++ shows it as '\uFEFF'.
    if (desc.find("\\uFEFF") != std::string::npos) desc += " (a UTF-8 byte order mark)";
    throw InputError(path, static_cast<int>(e.source().begin.line),
                     static_cast<int>(e.source().begin.column), "", "TOML syntax: " + desc);
  }
}

}  // namespace numen::sim
