#pragma once
/// @file toml_reader.hpp
/// Typed, located access to a TOML table of a scene file (toml++). Every
/// error is an InputError naming the file, line, column and dotted key.
/// Load time only (allocates, throws).

#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <toml++/toml.h>

#include "numen/core/types.hpp"
#include "numen/sim/input/input_error.hpp"

namespace numen::sim {

/// The upper bound `number_in()` takes for a key that has none (+∞).
inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// A view of one TOML table with its dotted key path (e.g. "body[2].coupling").
class TomlTable {
 public:
  TomlTable(const toml::table& table, std::string path, const std::string& file)
      : table_(&table), path_(std::move(path)), file_(&file) {}

  /// Dotted key of `key` inside this table.
  std::string key_path(std::string_view key) const;
  bool has(std::string_view key) const { return table_->contains(key); }

  double number(std::string_view key) const;
  double number_or(std::string_view key, double fallback) const;
  std::optional<double> optional_number(std::string_view key) const;
  /// A number that must satisfy lo <= v <= hi (use infinities for open bounds).
  double number_in(std::string_view key, double lo, double hi, std::optional<double> fallback) const;
  std::int64_t integer_or(std::string_view key, std::int64_t fallback) const;
  std::int64_t integer(std::string_view key) const;
  bool boolean_or(std::string_view key, bool fallback) const;
  std::string string(std::string_view key) const;
  std::string string_or(std::string_view key, std::string fallback) const;
  /// One of `choices`; the error lists them.
  std::string choice(std::string_view key, const std::vector<std::string>& choices,
                     std::optional<std::string> fallback) const;
  /// [x, y, z], finite.
  core::Vec3 vec3(std::string_view key) const;
  core::Vec3 vec3_or(std::string_view key, const core::Vec3& fallback) const;
  /// One point [x, y, z] or a list of them [[x, y, z], ...] (at least one), each finite; the
  /// error names the element (`key[i]`, `key[i][j]`).
  std::vector<core::Vec3> points(std::string_view key) const;
  /// [w, x, y, z], non-zero, returned normalised.
  core::Quat quaternion_or(std::string_view key, const core::Quat& fallback) const;
  /// A list of numbers of length n (n < 0: any length).
  std::vector<double> numbers(std::string_view key, int n) const;
  std::optional<TomlTable> table(std::string_view key) const;
  /// An array of tables ([[key]]); empty if absent.
  std::vector<TomlTable> tables(std::string_view key) const;
  /// Raw node, nullptr if absent.
  const toml::node* node(std::string_view key) const { return table_->get(key); }

  /// Rejects keys not listed: a typo in a scene must not pass silently.
  void allow_only(std::initializer_list<std::string_view> keys) const;

  /// Throws error(key, message).
  [[noreturn]] void fail(std::string_view key, const std::string& message) const;
  /// The InputError located at `key`'s value (or at this table if absent), not thrown.
  InputError error(std::string_view key, const std::string& message) const;
  /// Throws InputError located at `node`, with the given dotted key.
  [[noreturn]] void fail_at(const toml::node* node, const std::string& key,
                            const std::string& message) const;

  const std::string& file() const { return *file_; }
  const std::string& path() const { return path_; }
  const toml::table& raw() const { return *table_; }

 private:
  /// `node` as a list of n finite numbers (n < 0: any length); errors located at it as `key`.
  std::vector<double> array_numbers(const toml::node& node, const std::string& key, int n) const;

  const toml::table* table_;
  std::string path_;
  const std::string* file_;
};

/// Parses `path` as TOML; a syntax error becomes an InputError with its place.
toml::table parse_toml_file(const std::string& path);

}  // namespace numen::sim
