// Strict YAML reading on top of yaml-cpp, for every configuration file of the project (line,
// plants, drivers, vision). Strict means: every value the caller asks for must be present
// unless the call itself names a default, has the asked-for type (a quoted "0.5" is a string,
// not a number; only true/false are booleans) and lies in the asked-for range; every key the
// caller did not ask for is reported as unknown, so that a typo never silently falls back to
// a default.
//
// Problems are collected, not thrown one by one, so that a user fixes a file in one pass.
// Each names the file, the key path ("takt.min_period_s"), line:column and the reason. After
// reading, throw_if_problems() throws one ConfigError with all of them.
//
// Usage:
//   fl::YamlReader reader = fl::YamlReader::from_file(path);
//   {
//     fl::YamlMapReader root = reader.root();
//     fl::YamlMapReader takt = root.map("takt");
//     settings.period_s = takt.read_float("period_s", fl::Range::positive());
//     settings.gain = takt.read_float_or("gain", 1.0F, fl::Range::at_least(0.0));
//     takt.finish();  // reports takt's unknown keys (the destructor does it otherwise)
//     root.finish();
//   }
//   reader.require(settings.a_mm < settings.b_mm, {"takt.a_mm", "takt.b_mm"}, "a before b");
//   reader.throw_if_problems();
//
// On a problem a read returns a placeholder (zero, false, empty, the table's first entry): the
// caller must not use what it read unless throw_if_problems() does not throw.
#pragma once

#include <yaml-cpp/yaml.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace fl {

// ---------------------------------------------------------------- problems

enum class ProblemKind : std::uint8_t {
  kFile,          // the file cannot be read
  kSyntax,        // not valid YAML
  kEmptyFile,     // no YAML document at all (empty or only comments)
  kUnknownKey,    // a key nobody asked for (usually a typo)
  kDuplicateKey,  // the same key twice in one mapping
  kMissingKey,    // a required key is absent
  kWrongType,     // e.g. a string where a number is required
  kOutOfRange,    // a number outside its allowed range
  kInvalidValue,  // a string that is not one of the allowed choices
  kInconsistent,  // values that are fine alone but contradict each other
};

// The reason's lead words in messages, e.g. "unknown key".
std::string_view to_string(ProblemKind kind);

struct ConfigProblem {
  std::string file;      // source name as given to the reader
  std::string key_path;  // "takt.min_period_s"; empty when the problem is the whole file
  int line = 0;          // 1-based; 0 when there is no position (file missing, key missing
  int column = 0;        // from a mapping that has no position of its own)
  ProblemKind kind = ProblemKind::kSyntax;
  std::string detail;  // what is wrong, e.g. "got -0.5, must be > 0"

  // "line.yaml:12:3: takt.min_period_s: out of range: got -0.5, must be > 0"
  [[nodiscard]] std::string to_string() const;
};

class ConfigError : public std::runtime_error {
 public:
  explicit ConfigError(std::vector<ConfigProblem> problems);

  [[nodiscard]] const std::vector<ConfigProblem>& problems() const noexcept { return problems_; }

 private:
  std::vector<ConfigProblem> problems_;
};

// ---------------------------------------------------------------- ranges

// Allowed interval of a number, each bound closed (value may equal it) or open. Bounds are
// compared with the value as written in the file (parsed to double), so that a bound of 0.1
// admits "0.1" even where the stored value is a float.
class Range {
 public:
  static Range any() { return Range{}; }
  static Range positive() { return above(0.0); }         // > 0
  static Range non_negative() { return at_least(0.0); }  // >= 0
  static Range at_least(double min) { return Range{}.and_at_least(min); }
  static Range above(double min) { return Range{}.and_above(min); }
  static Range at_most(double max) { return Range{}.and_at_most(max); }
  static Range below(double max) { return Range{}.and_below(max); }
  static Range closed(double min, double max) { return at_least(min).and_at_most(max); }
  static Range open(double min, double max) { return above(min).and_below(max); }

  // Combine into half-open intervals: Range::above(0.0).and_at_most(1.0) is (0, 1].
  [[nodiscard]] Range and_at_least(double min) const { return with_min(min, false); }
  [[nodiscard]] Range and_above(double min) const { return with_min(min, true); }
  [[nodiscard]] Range and_at_most(double max) const { return with_max(max, false); }
  [[nodiscard]] Range and_below(double max) const { return with_max(max, true); }

  [[nodiscard]] bool contains(double value) const;
  // "> 0", "in [0, 1]", "in (0, 180]", "any number"
  [[nodiscard]] std::string describe() const;

 private:
  [[nodiscard]] Range with_min(double min, bool open) const;
  [[nodiscard]] Range with_max(double max, bool open) const;

  std::optional<double> min_;
  bool min_open_ = false;
  std::optional<double> max_;
  bool max_open_ = false;
};

// One entry of a string-to-enum table for YamlMapReader::read_enum.
template <typename Enum>
struct EnumName {
  std::string_view name;
  Enum value;
};

// Shortest text that reads back to the same value ("0.85", "-600"), for messages.
std::string format_number(double value);
std::string format_number(float value);

// ---------------------------------------------------------------- reader

class YamlMapReader;

// One YAML file (or text) being read: owns the parsed document and the problem list.
// Map readers obtained from it must not outlive it.
class YamlReader {
 public:
  // Never throws for a bad file: a missing file or a syntax error becomes a problem, and
  // root() then yields a reader that reads nothing and reports nothing more.
  static YamlReader from_file(const std::filesystem::path& file);
  static YamlReader from_text(std::string_view yaml_text, std::string_view source_name);

  YamlReader(YamlReader&&) noexcept;
  YamlReader& operator=(YamlReader&&) noexcept;
  YamlReader(const YamlReader&) = delete;
  YamlReader& operator=(const YamlReader&) = delete;
  ~YamlReader();

  // The top-level mapping. Reports "empty file" or a wrong type when there is none.
  [[nodiscard]] YamlMapReader root();

  [[nodiscard]] const std::string& source_name() const;
  [[nodiscard]] bool ok() const;
  [[nodiscard]] const std::vector<ConfigProblem>& problems() const;
  // Throws ConfigError with every problem found so far, if there is any.
  void throw_if_problems() const;

  // True when every value at these full key paths was read without a problem. Cross-checks
  // use it to stay quiet about values already reported (they hold placeholders).
  [[nodiscard]] bool all_read_ok(std::initializer_list<std::string_view> key_paths) const;

  // Reports a problem at a full key path, with that key's line:column when it was in the file.
  void report_at(std::string_view key_path, ProblemKind kind, std::string detail);

  // Cross-check between values: when every key was read without a problem and `holds` is
  // false, reports kInconsistent at the first key with `detail`. Returns `holds`.
  bool require(bool holds, std::initializer_list<std::string_view> key_paths, std::string detail);

  struct State;  // shared with the map readers; defined in yaml_reader.cpp

 private:
  explicit YamlReader(std::unique_ptr<State> state);
  std::unique_ptr<State> state_;
};

// Reads one mapping. Every read consumes its key; finish() (or the destructor) reports the
// keys that were never read as unknown, and duplicated keys.
class YamlMapReader {
 public:
  YamlMapReader(YamlMapReader&& other) noexcept;
  YamlMapReader& operator=(YamlMapReader&& other) noexcept;
  YamlMapReader(const YamlMapReader&) = delete;
  YamlMapReader& operator=(const YamlMapReader&) = delete;
  ~YamlMapReader();

  // Full key path of this mapping ("" for the root, "drives.takt" below).
  [[nodiscard]] const std::string& path() const { return path_; }
  // Full key path of one of its keys.
  [[nodiscard]] std::string path_of(std::string_view key) const;

  // Present in the file (without consuming it): for optional blocks.
  [[nodiscard]] bool has(std::string_view key) const;

  // Required values.
  float read_float(std::string_view key, const Range& range);
  double read_double(std::string_view key, const Range& range);
  template <typename Int>
  Int read_int(std::string_view key, const Range& range);
  bool read_bool(std::string_view key);
  std::string read_string(std::string_view key);
  template <typename Enum, std::size_t kCount>
  Enum read_enum(std::string_view key, const std::array<EnumName<Enum>, kCount>& table);

  // Optional values: `fallback` when the key is absent; a present key is checked as strictly
  // as a required one (an empty value is a wrong type, not the fallback).
  float read_float_or(std::string_view key, float fallback, const Range& range);
  double read_double_or(std::string_view key, double fallback, const Range& range);
  template <typename Int>
  Int read_int_or(std::string_view key, Int fallback, const Range& range);
  bool read_bool_or(std::string_view key, bool fallback);
  std::string read_string_or(std::string_view key, std::string_view fallback);
  template <typename Enum, std::size_t kCount>
  Enum read_enum_or(std::string_view key, Enum fallback,
                    const std::array<EnumName<Enum>, kCount>& table);

  // A nested mapping. Missing or not a mapping: reported, and the returned reader reads
  // nothing and reports nothing more (no cascade of missing keys below it).
  YamlMapReader map(std::string_view key);

  // Sequences. Element paths are "key[3]". `expected_size` reports a wrong count.
  std::vector<float> read_floats(std::string_view key, const Range& range,
                                 std::optional<std::size_t> expected_size = std::nullopt);
  std::vector<double> read_doubles(std::string_view key, const Range& range,
                                   std::optional<std::size_t> expected_size = std::nullopt);
  std::vector<std::string> read_strings(std::string_view key,
                                        std::optional<std::size_t> expected_size = std::nullopt);
  // Calls `read_element` for each mapping of a sequence of mappings; each element reader is
  // finished after the call.
  void for_each_map(
      std::string_view key,
      const std::function<void(YamlMapReader& element, std::size_t index)>& read_element);

  // A problem of this reader's own check on one of its keys, at that key's position.
  void report(std::string_view key, ProblemKind kind, std::string detail);

  // Reports unknown and duplicated keys once; later calls do nothing.
  void finish();

 private:
  friend class YamlReader;
  struct Entry {
    std::string key;
    YAML::Node key_node;
    YAML::Node value;
    bool consumed = false;
  };

  // Inert unless `node` is a mapping.
  YamlMapReader(YamlReader::State* state, std::string path, const YAML::Node& node);

  // The value of a required key, consumed; nullptr (missing key reported) when absent.
  const Entry* take(std::string_view key);
  // Like take() but silent when absent.
  const Entry* take_optional(std::string_view key);
  // True when an optional key is absent, so that its fallback counts as read.
  bool use_fallback(std::string_view key);
  // Checks the value is a plain (unquoted) scalar; reports the wrong type otherwise.
  bool expect_plain_scalar(const Entry& entry, std::string_view expected);
  // The parse_* functions report what is wrong with `entry`'s value, or record it as read.
  std::optional<double> parse_double(const Entry& entry, const Range& range);
  std::optional<float> parse_float(const Entry& entry, const Range& range);
  std::optional<std::int64_t> parse_integer(const Entry& entry, const Range& range,
                                            std::int64_t type_min, std::int64_t type_max);
  std::optional<bool> parse_bool(const Entry& entry);
  std::optional<std::string> parse_string(const Entry& entry);
  std::optional<std::size_t> parse_choice(const Entry& entry,
                                          std::span<const std::string_view> names);
  template <typename Value, typename Parse>
  std::vector<Value> read_sequence(std::string_view key, std::optional<std::size_t> expected_size,
                                   Parse parse_element);
  void report_value(const Entry& entry, ProblemKind kind, std::string detail);
  void mark_read_ok(const Entry& entry);

  YamlReader::State* state_ = nullptr;
  std::string path_;
  YAML::Mark mark_;
  std::vector<Entry> entries_;
  std::set<std::string, std::less<>> requested_keys_;  // for "did you mean" on unknown keys
  bool inert_ = true;     // stands for a missing or broken mapping: reads nothing
  bool finished_ = true;  // unknown keys reported (or nothing to report)
};

// ---------------------------------------------------------------- templates

template <typename Int>
Int YamlMapReader::read_int(std::string_view key, const Range& range) {
  static_assert(std::is_integral_v<Int> && !std::is_same_v<Int, bool>);
  static_assert(sizeof(Int) < sizeof(std::int64_t) || std::is_signed_v<Int>,
                "64-bit unsigned values beyond int64 are not supported");
  const Entry* entry = take(key);
  if (entry == nullptr) {
    return Int{};
  }
  const auto value = parse_integer(*entry, range, std::numeric_limits<Int>::min(),
                                   static_cast<std::int64_t>(std::numeric_limits<Int>::max()));
  return value ? static_cast<Int>(*value) : Int{};
}

template <typename Int>
Int YamlMapReader::read_int_or(std::string_view key, Int fallback, const Range& range) {
  if (use_fallback(key)) {
    return fallback;
  }
  return read_int<Int>(key, range);
}

template <typename Enum, std::size_t kCount>
Enum YamlMapReader::read_enum(std::string_view key,
                              const std::array<EnumName<Enum>, kCount>& table) {
  static_assert(kCount > 0);
  std::array<std::string_view, kCount> names{};
  for (std::size_t i = 0; i < kCount; ++i) {
    names[i] = table[i].name;
  }
  const Entry* entry = take(key);
  if (entry == nullptr) {
    return table[0].value;
  }
  const auto chosen = parse_choice(*entry, names);
  return chosen ? table[*chosen].value : table[0].value;
}

template <typename Enum, std::size_t kCount>
Enum YamlMapReader::read_enum_or(std::string_view key, Enum fallback,
                                 const std::array<EnumName<Enum>, kCount>& table) {
  if (use_fallback(key)) {
    return fallback;
  }
  return read_enum(key, table);
}

}  // namespace fl
