#include "fl/controller/yaml_reader.hpp"

#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/parser.h>

#include <algorithm>
#include <charconv>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <system_error>
#include <utility>

namespace fl {

// ---------------------------------------------------------------- problems

std::string_view to_string(ProblemKind kind) {
  switch (kind) {
    case ProblemKind::kFile:
      return "cannot read file";
    case ProblemKind::kSyntax:
      return "invalid YAML syntax";
    case ProblemKind::kEmptyFile:
      return "empty file";
    case ProblemKind::kUnknownKey:
      return "unknown key";
    case ProblemKind::kDuplicateKey:
      return "duplicate key";
    case ProblemKind::kMissingKey:
      return "missing key";
    case ProblemKind::kWrongType:
      return "wrong type";
    case ProblemKind::kOutOfRange:
      return "out of range";
    case ProblemKind::kInvalidValue:
      return "invalid value";
    case ProblemKind::kInconsistent:
      return "inconsistent values";
  }
  return "problem";
}

std::string ConfigProblem::to_string() const {
  std::string text = file;
  if (line > 0) {
    text += ":" + std::to_string(line) + ":" + std::to_string(column);
  }
  text += ": ";
  if (!key_path.empty()) {
    text += key_path + ": ";
  }
  text += fl::to_string(kind);
  if (!detail.empty()) {
    text += ": " + detail;
  }
  return text;
}

namespace {

std::string build_message(const std::vector<ConfigProblem>& problems) {
  std::string text = std::to_string(problems.size()) + " configuration problem" +
                     (problems.size() == 1 ? "" : "s") + ":";
  for (const ConfigProblem& problem : problems) {
    text += "\n" + problem.to_string();
  }
  return text;
}

}  // namespace

ConfigError::ConfigError(std::vector<ConfigProblem> problems)
    : std::runtime_error(build_message(problems)), problems_(std::move(problems)) {}

// ---------------------------------------------------------------- numbers and ranges

namespace {

template <typename Number>
std::string format_shortest(Number value) {
  std::array<char, 64> buffer{};
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  return std::string(buffer.data(), result.ptr);
}

}  // namespace

std::string format_number(double value) { return format_shortest(value); }
std::string format_number(float value) { return format_shortest(value); }

bool Range::contains(double value) const {
  if (min_ && (min_open_ ? !(value > *min_) : !(value >= *min_))) {
    return false;
  }
  if (max_ && (max_open_ ? !(value < *max_) : !(value <= *max_))) {
    return false;
  }
  return true;
}

std::string Range::describe() const {
  if (min_ && max_) {
    return std::string("in ") + (min_open_ ? "(" : "[") + format_number(*min_) + ", " +
           format_number(*max_) + (max_open_ ? ")" : "]");
  }
  if (min_) {
    return (min_open_ ? "> " : ">= ") + format_number(*min_);
  }
  if (max_) {
    return (max_open_ ? "< " : "<= ") + format_number(*max_);
  }
  return "any number";
}

Range Range::with_min(double min, bool open) const {
  Range range = *this;
  range.min_ = min;
  range.min_open_ = open;
  return range;
}

Range Range::with_max(double max, bool open) const {
  Range range = *this;
  range.max_ = max;
  range.max_open_ = open;
  return range;
}

namespace {

bool is_digit(char c) { return c >= '0' && c <= '9'; }

// YAML 1.2 core-schema decimal number: [-+]? ( .digits | digits ( . digits? )? ) exponent?
// Hex, octal, underscores ("1_000") and .inf/.nan are refused: none belongs in a config and
// each has surprised someone.
bool is_decimal_number(std::string_view text) {
  std::size_t i = 0;
  auto digits = [&] {
    const std::size_t start = i;
    while (i < text.size() && is_digit(text[i])) {
      ++i;
    }
    return i - start;
  };
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) {
    ++i;
  }
  const std::size_t integer_digits = digits();
  std::size_t fraction_digits = 0;
  if (i < text.size() && text[i] == '.') {
    ++i;
    fraction_digits = digits();
  }
  if (integer_digits == 0 && fraction_digits == 0) {
    return false;
  }
  if (i < text.size() && (text[i] == 'e' || text[i] == 'E')) {
    ++i;
    if (i < text.size() && (text[i] == '-' || text[i] == '+')) {
      ++i;
    }
    if (digits() == 0) {
      return false;
    }
  }
  return i == text.size();
}

bool is_decimal_integer(std::string_view text) {
  std::size_t i = 0;
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) {
    ++i;
  }
  if (i == text.size()) {
    return false;
  }
  return std::all_of(text.begin() + static_cast<std::ptrdiff_t>(i), text.end(), is_digit);
}

// std::from_chars takes no leading '+'.
std::string_view without_plus(std::string_view text) {
  return !text.empty() && text.front() == '+' ? text.substr(1) : text;
}

template <typename Number>
std::errc parse_number(std::string_view text, Number& value) {
  const std::string_view digits = without_plus(text);
  const auto result = std::from_chars(digits.data(), digits.data() + digits.size(), value);
  if (result.ec == std::errc{} && result.ptr != digits.data() + digits.size()) {
    return std::errc::invalid_argument;
  }
  return result.ec;
}

std::string in_quotes(std::string_view text) { return "\"" + std::string(text) + "\""; }

std::string describe_node(const YAML::Node& node) {
  if (!node.IsDefined() || node.IsNull()) {
    return "an empty value";
  }
  if (node.IsMap()) {
    return "a mapping";
  }
  if (node.IsSequence()) {
    return "a sequence";
  }
  if (node.Tag() == "!") {
    return "the quoted string " + in_quotes(node.Scalar());
  }
  return in_quotes(node.Scalar());
}

std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> previous(b.size() + 1);
  std::vector<std::size_t> current(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) {
    previous[j] = j;
  }
  for (std::size_t i = 1; i <= a.size(); ++i) {
    current[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = previous[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      current[j] = std::min({previous[j] + 1, current[j - 1] + 1, substitution});
    }
    std::swap(previous, current);
  }
  return previous[b.size()];
}

// Walks a YAML stream's documents without building nodes, to find where the parser stops
// advancing. yaml-cpp 0.7 (Debian 12) has a parser that, on a token no node can start with
// (a ',' outside any flow collection), reports an empty document without consuming the token,
// again and again: YAML::LoadAll then never returns and grows without bound (upstream issue
// jbeder/yaml-cpp#1040, fixed after 0.8.0; found by fuzz/fuzz_line_config). Two documents
// that start at the same position are that loop.
class DocumentWalker final : public YAML::EventHandler {
 public:
  // The mark the parser is stuck at, or nothing when the stream ends normally. Throws what
  // the parser throws for a syntax error.
  static std::optional<YAML::Mark> find_stuck_parser(const std::string& text) {
    std::istringstream stream(text);
    YAML::Parser parser(stream);
    DocumentWalker walker;
    while (parser.HandleNextDocument(walker)) {
      if (walker.stuck_) {
        return walker.previous_start_;
      }
    }
    return std::nullopt;
  }

  void OnDocumentStart(const YAML::Mark& mark) override {
    stuck_ = started_ && mark.pos == previous_start_.pos;
    started_ = true;
    previous_start_ = mark;
  }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t,
                const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}

 private:
  bool started_ = false;
  bool stuck_ = false;
  YAML::Mark previous_start_ = YAML::Mark::null_mark();
};

}  // namespace

// ---------------------------------------------------------------- reader state

struct YamlReader::State {
  std::string source_name;
  YAML::Node document;
  bool document_usable = false;  // parsed into exactly one document
  std::vector<ConfigProblem> problems;
  std::map<std::string, YAML::Mark, std::less<>> key_marks;  // every key seen, by full path
  std::set<std::string, std::less<>> read_ok;  // full paths of values read without a problem

  void add(std::string key_path, const YAML::Mark& mark, ProblemKind kind, std::string detail) {
    // A value with a problem of its own holds a placeholder: keep cross-checks off it. A
    // cross-check's finding leaves the values usable, so that every broken rule is reported.
    if (kind != ProblemKind::kInconsistent) {
      read_ok.erase(key_path);
    }
    ConfigProblem problem;
    problem.file = source_name;
    problem.key_path = std::move(key_path);
    if (!mark.is_null()) {
      problem.line = mark.line + 1;  // yaml-cpp counts from 0, editors from 1
      problem.column = mark.column + 1;
    }
    problem.kind = kind;
    problem.detail = std::move(detail);
    problems.push_back(std::move(problem));
  }

  void parse(const std::string& text) {
    std::vector<YAML::Node> documents;
    try {
      if (const auto stuck = DocumentWalker::find_stuck_parser(text)) {
        add("", *stuck, ProblemKind::kSyntax,
            "no YAML value can start here (a ',' outside [ ] or { }?)");
        return;
      }
      documents = YAML::LoadAll(text);
    } catch (const YAML::ParserException& error) {
      add("", error.mark, ProblemKind::kSyntax, error.msg);
      return;
    } catch (const YAML::Exception& error) {
      add("", error.mark, ProblemKind::kSyntax, error.msg);
      return;
    }
    if (documents.empty()) {
      add("", YAML::Mark::null_mark(), ProblemKind::kEmptyFile, "no YAML document in the file");
      return;
    }
    if (documents.size() > 1) {
      // A second document would be ignored silently by a plain load.
      add("", documents[1].Mark(), ProblemKind::kSyntax,
          std::to_string(documents.size()) + " YAML documents (separated by ---), expected one");
      return;
    }
    document = documents.front();
    document_usable = true;
  }
};

YamlReader::YamlReader(std::unique_ptr<State> state) : state_(std::move(state)) {}
YamlReader::YamlReader(YamlReader&&) noexcept = default;
YamlReader& YamlReader::operator=(YamlReader&&) noexcept = default;
YamlReader::~YamlReader() = default;

YamlReader YamlReader::from_file(const std::filesystem::path& file) {
  auto state = std::make_unique<State>();
  state->source_name = file.string();
  std::error_code error;
  const auto status = std::filesystem::status(file, error);
  if (!std::filesystem::exists(status)) {
    state->add("", YAML::Mark::null_mark(), ProblemKind::kFile, "no such file");
  } else if (!std::filesystem::is_regular_file(status)) {
    state->add("", YAML::Mark::null_mark(), ProblemKind::kFile, "not a regular file");
  } else {
    std::ifstream stream(file, std::ios::binary);
    std::string text;
    if (stream.is_open()) {
      text.assign(std::istreambuf_iterator<char>(stream), {});
    }
    if (!stream.is_open() || stream.bad()) {
      state->add("", YAML::Mark::null_mark(), ProblemKind::kFile, "cannot be opened for reading");
    } else {
      state->parse(text);
    }
  }
  return YamlReader(std::move(state));
}

YamlReader YamlReader::from_text(std::string_view yaml_text, std::string_view source_name) {
  auto state = std::make_unique<State>();
  state->source_name = std::string(source_name);
  state->parse(std::string(yaml_text));
  return YamlReader(std::move(state));
}

YamlMapReader YamlReader::root() {
  if (!state_->document_usable) {
    return YamlMapReader(state_.get(), "", YAML::Node());
  }
  const YAML::Node& document = state_->document;
  if (document.IsNull()) {
    state_->add("", document.Mark(), ProblemKind::kEmptyFile, "the document holds no settings");
  } else if (!document.IsMap()) {
    state_->add(
        "", document.Mark(), ProblemKind::kWrongType,
        "expected a mapping of settings at the top level, found " + describe_node(document));
  }
  return YamlMapReader(state_.get(), "", document);
}

const std::string& YamlReader::source_name() const { return state_->source_name; }
bool YamlReader::ok() const { return state_->problems.empty(); }
const std::vector<ConfigProblem>& YamlReader::problems() const { return state_->problems; }

void YamlReader::throw_if_problems() const {
  if (!state_->problems.empty()) {
    throw ConfigError(state_->problems);
  }
}

bool YamlReader::all_read_ok(std::initializer_list<std::string_view> key_paths) const {
  return std::all_of(key_paths.begin(), key_paths.end(), [&](std::string_view key_path) {
    return state_->read_ok.find(key_path) != state_->read_ok.end();
  });
}

void YamlReader::report_at(std::string_view key_path, ProblemKind kind, std::string detail) {
  const auto found = state_->key_marks.find(key_path);
  const YAML::Mark mark =
      found != state_->key_marks.end() ? found->second : YAML::Mark::null_mark();
  state_->add(std::string(key_path), mark, kind, std::move(detail));
}

bool YamlReader::require(bool holds, std::initializer_list<std::string_view> key_paths,
                         std::string detail) {
  if (holds || key_paths.size() == 0 || !all_read_ok(key_paths)) {
    return holds;
  }
  report_at(*key_paths.begin(), ProblemKind::kInconsistent, std::move(detail));
  return false;
}

// ---------------------------------------------------------------- map reader

YamlMapReader::YamlMapReader(YamlReader::State* state, std::string path, const YAML::Node& node)
    : state_(state), path_(std::move(path)), inert_(!node.IsMap()), finished_(!node.IsMap()) {
  if (inert_) {
    return;
  }
  mark_ = node.Mark();
  for (auto it = node.begin(); it != node.end(); ++it) {
    // Copies: the iterator's pair is a temporary that it->first would dangle into.
    const YAML::Node key_node = it->first;
    const YAML::Node value = it->second;
    if (!key_node.IsScalar()) {
      state_->add(path_, key_node.Mark(), ProblemKind::kWrongType,
                  "a key must be a plain name, found " + describe_node(key_node));
      continue;
    }
    entries_.push_back(Entry{key_node.Scalar(), key_node, value, false});
    state_->key_marks.emplace(path_of(key_node.Scalar()), key_node.Mark());
  }
}

YamlMapReader::YamlMapReader(YamlMapReader&& other) noexcept
    : state_(other.state_),
      path_(std::move(other.path_)),
      mark_(other.mark_),
      entries_(std::move(other.entries_)),
      requested_keys_(std::move(other.requested_keys_)),
      inert_(other.inert_),
      finished_(other.finished_) {
  other.inert_ = true;
  other.finished_ = true;
}

YamlMapReader& YamlMapReader::operator=(YamlMapReader&& other) noexcept {
  if (this == &other) {
    return *this;
  }
  if (!finished_) {
    try {
      finish();
    } catch (...) {  // only allocation can fail here; losing a report beats terminating
    }
  }
  state_ = other.state_;
  path_ = std::move(other.path_);
  mark_ = other.mark_;
  entries_ = std::move(other.entries_);
  requested_keys_ = std::move(other.requested_keys_);
  inert_ = other.inert_;
  finished_ = other.finished_;
  other.inert_ = true;
  other.finished_ = true;
  return *this;
}

YamlMapReader::~YamlMapReader() {
  if (finished_) {
    return;
  }
  try {
    finish();
  } catch (...) {  // only allocation can fail here; losing a report beats terminating
  }
}

std::string YamlMapReader::path_of(std::string_view key) const {
  return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

bool YamlMapReader::has(std::string_view key) const {
  return std::any_of(entries_.begin(), entries_.end(),
                     [&](const Entry& entry) { return entry.key == key; });
}

const YamlMapReader::Entry* YamlMapReader::take_optional(std::string_view key) {
  requested_keys_.emplace(key);
  const Entry* first = nullptr;
  for (Entry& entry : entries_) {
    if (entry.key != key) {
      continue;
    }
    entry.consumed = true;  // duplicates too: finish() reports them as duplicates, not unknown
    if (first == nullptr) {
      first = &entry;
    }
  }
  return first;
}

bool YamlMapReader::use_fallback(std::string_view key) {
  if (take_optional(key) != nullptr) {
    return false;
  }
  if (!inert_) {
    state_->read_ok.insert(path_of(key));
  }
  return true;
}

const YamlMapReader::Entry* YamlMapReader::take(std::string_view key) {
  const Entry* entry = take_optional(key);
  if (entry == nullptr && !inert_) {
    state_->add(path_of(key), mark_, ProblemKind::kMissingKey,
                "required, not in " + (path_.empty() ? std::string("the file") : path_));
  }
  return entry;
}

void YamlMapReader::report_value(const Entry& entry, ProblemKind kind, std::string detail) {
  // An empty value has no position of its own (yaml-cpp gives the next token's): use the key's.
  const YAML::Mark mark = entry.value.IsNull() ? entry.key_node.Mark() : entry.value.Mark();
  state_->add(path_of(entry.key), mark, kind, std::move(detail));
}

void YamlMapReader::report(std::string_view key, ProblemKind kind, std::string detail) {
  const auto found = std::find_if(entries_.begin(), entries_.end(),
                                  [&](const Entry& entry) { return entry.key == key; });
  if (found != entries_.end()) {
    found->consumed = true;  // reported once, not again as unknown
    state_->add(path_of(key), found->key_node.Mark(), kind, std::move(detail));
  } else {
    state_->add(path_of(key), mark_, kind, std::move(detail));
  }
}

void YamlMapReader::mark_read_ok(const Entry& entry) { state_->read_ok.insert(path_of(entry.key)); }

bool YamlMapReader::expect_plain_scalar(const Entry& entry, std::string_view expected) {
  const YAML::Node& value = entry.value;
  if (value.IsScalar() && value.Tag() == "?") {
    return true;  // "?": plain, neither quoted nor tagged
  }
  std::string detail = "expected " + std::string(expected) + ", found " + describe_node(value);
  if (value.IsScalar() && value.Tag() == "!") {
    detail += " (write it without quotes)";
  } else if (value.IsScalar()) {
    detail += " with tag " + value.Tag() + " (tags are not supported)";
  }
  report_value(entry, ProblemKind::kWrongType, std::move(detail));
  return false;
}

std::optional<double> YamlMapReader::parse_double(const Entry& entry, const Range& range) {
  if (!expect_plain_scalar(entry, "a number")) {
    return std::nullopt;
  }
  const std::string& text = entry.value.Scalar();
  if (!is_decimal_number(text)) {
    report_value(entry, ProblemKind::kWrongType, "expected a number, found " + in_quotes(text));
    return std::nullopt;
  }
  double value = 0.0;
  if (parse_number(text, value) != std::errc{}) {
    report_value(entry, ProblemKind::kOutOfRange, "got " + text + ", beyond a double's range");
    return std::nullopt;
  }
  if (!range.contains(value)) {
    report_value(entry, ProblemKind::kOutOfRange, "got " + text + ", must be " + range.describe());
    return std::nullopt;
  }
  mark_read_ok(entry);
  return value;
}

std::optional<float> YamlMapReader::parse_float(const Entry& entry, const Range& range) {
  if (!parse_double(entry, range)) {
    return std::nullopt;
  }
  // Parsed again directly as float: decimal -> double -> float can round differently from the
  // same literal written with an F suffix in C++.
  float value = 0.0F;
  if (parse_number(entry.value.Scalar(), value) != std::errc{}) {
    report_value(entry, ProblemKind::kOutOfRange,
                 "got " + entry.value.Scalar() + ", beyond a 32-bit float's range");
    return std::nullopt;
  }
  return value;
}

std::optional<std::int64_t> YamlMapReader::parse_integer(const Entry& entry, const Range& range,
                                                         std::int64_t type_min,
                                                         std::int64_t type_max) {
  if (!expect_plain_scalar(entry, "an integer")) {
    return std::nullopt;
  }
  const std::string& text = entry.value.Scalar();
  if (!is_decimal_integer(text)) {
    report_value(entry, ProblemKind::kWrongType, "expected an integer, found " + in_quotes(text));
    return std::nullopt;
  }
  std::int64_t value = 0;
  if (parse_number(text, value) != std::errc{} || value < type_min || value > type_max) {
    report_value(entry, ProblemKind::kOutOfRange,
                 "got " + text + ", must be in [" + std::to_string(type_min) + ", " +
                     std::to_string(type_max) + "] to fit its type");
    return std::nullopt;
  }
  if (!range.contains(static_cast<double>(value))) {
    report_value(entry, ProblemKind::kOutOfRange, "got " + text + ", must be " + range.describe());
    return std::nullopt;
  }
  mark_read_ok(entry);
  return value;
}

std::optional<bool> YamlMapReader::parse_bool(const Entry& entry) {
  if (!expect_plain_scalar(entry, "true or false")) {
    return std::nullopt;
  }
  // YAML 1.2 booleans only: "yes", "on", "y" are YAML 1.1 and read as strings elsewhere.
  const std::string& text = entry.value.Scalar();
  if (text == "true" || text == "True" || text == "TRUE") {
    mark_read_ok(entry);
    return true;
  }
  if (text == "false" || text == "False" || text == "FALSE") {
    mark_read_ok(entry);
    return false;
  }
  report_value(entry, ProblemKind::kWrongType, "expected true or false, found " + in_quotes(text));
  return std::nullopt;
}

std::optional<std::string> YamlMapReader::parse_string(const Entry& entry) {
  if (!entry.value.IsScalar()) {
    report_value(entry, ProblemKind::kWrongType,
                 "expected a string, found " + describe_node(entry.value));
    return std::nullopt;
  }
  mark_read_ok(entry);
  return entry.value.Scalar();
}

std::optional<std::size_t> YamlMapReader::parse_choice(const Entry& entry,
                                                       std::span<const std::string_view> names) {
  const std::optional<std::string> text = parse_string(entry);
  if (!text) {
    return std::nullopt;
  }
  const auto found = std::find(names.begin(), names.end(), *text);
  if (found != names.end()) {
    return static_cast<std::size_t>(found - names.begin());
  }
  std::string allowed;
  for (std::string_view name : names) {
    allowed += (allowed.empty() ? "" : ", ") + std::string(name);
  }
  report_value(entry, ProblemKind::kInvalidValue,
               "got " + in_quotes(*text) + ", expected one of: " + allowed);
  return std::nullopt;
}

float YamlMapReader::read_float(std::string_view key, const Range& range) {
  const Entry* entry = take(key);
  return entry == nullptr ? 0.0F : parse_float(*entry, range).value_or(0.0F);
}

double YamlMapReader::read_double(std::string_view key, const Range& range) {
  const Entry* entry = take(key);
  return entry == nullptr ? 0.0 : parse_double(*entry, range).value_or(0.0);
}

bool YamlMapReader::read_bool(std::string_view key) {
  const Entry* entry = take(key);
  return entry == nullptr ? false : parse_bool(*entry).value_or(false);
}

std::string YamlMapReader::read_string(std::string_view key) {
  const Entry* entry = take(key);
  return entry == nullptr ? std::string() : parse_string(*entry).value_or(std::string());
}

float YamlMapReader::read_float_or(std::string_view key, float fallback, const Range& range) {
  return use_fallback(key) ? fallback : read_float(key, range);
}

double YamlMapReader::read_double_or(std::string_view key, double fallback, const Range& range) {
  return use_fallback(key) ? fallback : read_double(key, range);
}

bool YamlMapReader::read_bool_or(std::string_view key, bool fallback) {
  return use_fallback(key) ? fallback : read_bool(key);
}

std::string YamlMapReader::read_string_or(std::string_view key, std::string_view fallback) {
  return use_fallback(key) ? std::string(fallback) : read_string(key);
}

YamlMapReader YamlMapReader::map(std::string_view key) {
  const Entry* entry = take(key);
  if (entry == nullptr) {
    return YamlMapReader(state_, path_of(key), YAML::Node());
  }
  if (!entry->value.IsMap()) {
    report_value(*entry, ProblemKind::kWrongType,
                 "expected a mapping, found " + describe_node(entry->value));
  }
  return YamlMapReader(state_, path_of(key), entry->value);
}

template <typename Value, typename Parse>
std::vector<Value> YamlMapReader::read_sequence(std::string_view key,
                                                std::optional<std::size_t> expected_size,
                                                Parse parse_element) {
  const Entry* entry = take(key);
  if (entry == nullptr) {
    return {};
  }
  if (!entry->value.IsSequence()) {
    report_value(*entry, ProblemKind::kWrongType,
                 "expected a sequence, found " + describe_node(entry->value));
    return {};
  }
  const std::size_t size = entry->value.size();
  if (expected_size && size != *expected_size) {
    report_value(
        *entry, ProblemKind::kInvalidValue,
        "has " + std::to_string(size) + " elements, expected " + std::to_string(*expected_size));
    return {};
  }
  std::vector<Value> values;
  values.reserve(size);
  bool all_ok = true;
  for (std::size_t i = 0; i < size; ++i) {
    const Entry element{std::string(key) + "[" + std::to_string(i) + "]", entry->key_node,
                        entry->value[i], true};
    const std::optional<Value> value = parse_element(element);
    all_ok = all_ok && value.has_value();
    values.push_back(value.value_or(Value{}));
  }
  if (all_ok) {
    mark_read_ok(*entry);
  }
  return values;
}

std::vector<float> YamlMapReader::read_floats(std::string_view key, const Range& range,
                                              std::optional<std::size_t> expected_size) {
  return read_sequence<float>(key, expected_size,
                              [&](const Entry& element) { return parse_float(element, range); });
}

std::vector<double> YamlMapReader::read_doubles(std::string_view key, const Range& range,
                                                std::optional<std::size_t> expected_size) {
  return read_sequence<double>(key, expected_size,
                               [&](const Entry& element) { return parse_double(element, range); });
}

std::vector<std::string> YamlMapReader::read_strings(std::string_view key,
                                                     std::optional<std::size_t> expected_size) {
  return read_sequence<std::string>(key, expected_size,
                                    [&](const Entry& element) { return parse_string(element); });
}

void YamlMapReader::for_each_map(
    std::string_view key,
    const std::function<void(YamlMapReader& element, std::size_t index)>& read_element) {
  const Entry* entry = take(key);
  if (entry == nullptr) {
    return;
  }
  if (!entry->value.IsSequence()) {
    report_value(*entry, ProblemKind::kWrongType,
                 "expected a sequence of mappings, found " + describe_node(entry->value));
    return;
  }
  for (std::size_t i = 0; i < entry->value.size(); ++i) {
    const std::string element_key = std::string(key) + "[" + std::to_string(i) + "]";
    const YAML::Node element_node = entry->value[i];
    // A check made after reading (report_at on "trials[2]") still finds the element's line.
    state_->key_marks.emplace(path_of(element_key), element_node.Mark());
    if (!element_node.IsMap()) {
      state_->add(path_of(element_key), element_node.Mark(), ProblemKind::kWrongType,
                  "expected a mapping, found " + describe_node(element_node));
      continue;
    }
    YamlMapReader element(state_, path_of(element_key), element_node);
    read_element(element, i);
    element.finish();
  }
}

void YamlMapReader::finish() {
  if (finished_) {
    return;
  }
  finished_ = true;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const Entry& entry = entries_[i];
    const auto earlier =
        std::find_if(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(i),
                     [&](const Entry& other) { return other.key == entry.key; });
    if (earlier != entries_.begin() + static_cast<std::ptrdiff_t>(i)) {
      // yaml-cpp keeps both; which one a lookup sees is an accident, so neither may stand.
      state_->add(path_of(entry.key), entry.key_node.Mark(), ProblemKind::kDuplicateKey,
                  "already given at line " + std::to_string(earlier->key_node.Mark().line + 1));
      continue;
    }
    if (entry.consumed) {
      continue;
    }
    std::string detail = "not a setting of " + (path_.empty() ? std::string("the file") : path_);
    // Suggest the closest key that was asked for, as typos are the usual cause.
    std::string_view suggestion;
    std::size_t best_distance = std::max<std::size_t>(2, entry.key.size() / 4) + 1;
    for (const std::string& requested : requested_keys_) {
      const std::size_t distance = edit_distance(entry.key, requested);
      if (distance < best_distance) {
        best_distance = distance;
        suggestion = requested;
      }
    }
    if (!suggestion.empty()) {
      detail += " (did you mean " + in_quotes(suggestion) + "?)";
    }
    state_->add(path_of(entry.key), entry.key_node.Mark(), ProblemKind::kUnknownKey,
                std::move(detail));
  }
}

}  // namespace fl
