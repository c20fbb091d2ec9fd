#include "fl/workbench/dataset.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <numbers>
#include <set>
#include <unordered_map>
#include <utility>

#include "csv_reader.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "text.hpp"

namespace fl::workbench {
namespace {

constexpr std::string_view kFormat = "fillet-measurements/1";
constexpr std::string_view kManifest = "manifest.yaml";
// Past this many problems in one CSV file the rest are counted, not listed: a file with a
// wrong delimiter would otherwise bury the one message that matters.
constexpr std::size_t kProblemsListedPerFile = 25;
constexpr double kPi = std::numbers::pi;

using Kind = ConditionRule::Kind;

// "an angle", "a speed".
std::string with_article(std::string_view noun) {
  const bool vowel =
      !noun.empty() && std::string_view("aeiou").find(noun.front()) != std::string_view::npos;
  return (vowel ? "an " : "a ") + std::string(noun);
}

std::vector<ConditionRule> common_conditions() {
  // The thesis' three size variants (table 3.1), each mirrored or not; dry or wet surface.
  return {{"variant",
           Kind::kLabel,
           Quantity::kDimensionless,
           0,
           0,
           {"144x72x40", "172x72x32", "176x72x40"},
           false},
          {"mirrored", Kind::kFlag, Quantity::kDimensionless, 0, 0, {}, false},
          {"surface", Kind::kLabel, Quantity::kDimensionless, 0, 0, {"dry", "wet"}, false}};
}

ExperimentSchema make_schema(ExperimentType type) {
  ExperimentSchema schema;
  schema.type = type;
  schema.conditions = common_conditions();
  // Ranges are what a lab could measure on a fillet, wide enough never to reject a real
  // value and narrow enough to catch a wrong unit (mm written as m) or a sign error.
  const ColumnRule time{"time", Quantity::kTime, 0.0, 24.0 * 3600.0, true};
  const ColumnRule height{"height", Quantity::kLength, -0.1, 5.0, true};
  switch (type) {
    case ExperimentType::kSlide:
      schema.columns = {{"onset_angle", Quantity::kAngle, 0.0, kPi / 2.0, true}};
      // The plate's tilt rate: 0.1 deg/s reaches 80 deg in 13 minutes, beyond 90 deg/s a
      // fillet's slide is no longer the slow tilt the test means.
      schema.conditions.push_back({"tilt_rate",
                                   Kind::kNumber,
                                   Quantity::kAngularSpeed,
                                   0.1 * kPi / 180.0,
                                   kPi / 2.0,
                                   {},
                                   false});
      // How the repetitions were laid: the fillet put back (turned a little) for each, or laid
      // once for all. It decides how an ensemble's placement spread is judged (diagnose).
      schema.conditions.push_back({"placement",
                                   Kind::kLabel,
                                   Quantity::kDimensionless,
                                   0,
                                   0,
                                   {"relaid", "laid_once"},
                                   false});
      break;
    case ExperimentType::kBend:
      schema.columns = {{"bend_angle", Quantity::kAngle, -kPi, kPi, true}};
      schema.conditions.push_back(
          {"overhang", Kind::kNumber, Quantity::kLength, 0.0, 0.3, {}, true});
      break;
    case ExperimentType::kSettle:
      schema.columns = {time, height};
      schema.time_ordered = true;
      break;
    case ExperimentType::kDrop:
      schema.columns = {time, height};
      schema.conditions.push_back(
          {"drop_height", Kind::kNumber, Quantity::kLength, 0.0, 5.0, {}, true});
      schema.time_ordered = true;
      break;
    case ExperimentType::kCompress:
      schema.columns = {time,
                        {"displacement", Quantity::kLength, -0.2, 0.2, true},
                        {"force", Quantity::kForce, -1e4, 1e4, true}};
      schema.conditions.push_back({"rate", Kind::kNumber, Quantity::kSpeed, 0.0, 1.0, {}, true});
      schema.conditions.push_back(
          {"hold", Kind::kNumber, Quantity::kTime, 0.0, 24.0 * 3600.0, {}, false});
      // A cut sample's size; the twin builds its block to it.
      schema.conditions.push_back(
          {"sample_side", Kind::kNumber, Quantity::kLength, 1e-3, 0.3, {}, false});
      schema.conditions.push_back(
          {"sample_height", Kind::kNumber, Quantity::kLength, 1e-3, 0.3, {}, false});
      schema.time_ordered = true;
      break;
    case ExperimentType::kLineTracks:
      schema.columns = {time,
                        {"fillet", Quantity::kDimensionless, 0.0, 1e9, true},
                        {"x", Quantity::kLength, -100.0, 100.0, true},
                        {"y", Quantity::kLength, -10.0, 10.0, true},
                        {"angle", Quantity::kAngle, -2.0 * kPi, 2.0 * kPi, true}};
      schema.conditions.push_back(
          {"belt_speed", Kind::kNumber, Quantity::kSpeed, 0.0, 5.0, {}, false});
      // Where the tracks were taken: one lab belt, or the line from the takt barrier on (x is
      // then the line coordinate s, and the command log names every belt and station).
      schema.conditions.push_back({"machine",
                                   Kind::kLabel,
                                   Quantity::kDimensionless,
                                   0,
                                   0,
                                   {std::string_view(kMachineBelt), std::string_view(kMachineLine)},
                                   false});
      schema.time_ordered = true;
      schema.has_commands = true;
      break;
    case ExperimentType::kBulkFlow:
      schema.columns = {{"opening", Quantity::kLength, 0.0, 1.0, true},
                        {"outflow", Quantity::kMassFlow, 0.0, 100.0, true}};
      schema.conditions.push_back(
          {"belt_speed", Kind::kNumber, Quantity::kSpeed, 0.0, 5.0, {}, false});
      // Fillets in the hopper when the belt starts (the thesis filled it up: 450 in its bulk
      // run; 600 is the twin scene's limit).
      schema.conditions.push_back(
          {"fill", Kind::kNumber, Quantity::kDimensionless, 1.0, 600.0, {}, false});
      // Fillets dropped into the hopper per second while it runs, as the line's supply feeds
      // the mailbox: the outflow then settles to a steady state (up to 20 a second, four
      // times the line's 2.4 to 5 fillets a second at the takt).
      schema.conditions.push_back(
          {"feed_rate", Kind::kNumber, Quantity::kRate, 0.0, 20.0, {}, false});
      break;
  }
  return schema;
}

constexpr std::array kExperimentNames{
    std::pair{ExperimentType::kSlide, std::string_view("slide")},
    std::pair{ExperimentType::kBend, std::string_view("bend")},
    std::pair{ExperimentType::kSettle, std::string_view("settle")},
    std::pair{ExperimentType::kDrop, std::string_view("drop")},
    std::pair{ExperimentType::kCompress, std::string_view("compress")},
    std::pair{ExperimentType::kLineTracks, std::string_view("line_tracks")},
    std::pair{ExperimentType::kBulkFlow, std::string_view("bulk_flow")},
};

// A value in the given unit, for messages in the user's units.
std::string in_unit(double value_si, const Unit& unit) {
  return detail::significant(value_si / unit.to_si, 6) + " " + std::string(unit.symbol);
}

std::string join(const std::vector<std::string_view>& names) {
  std::string text;
  for (const std::string_view name : names) text += (text.empty() ? "" : ", ") + std::string(name);
  return text;
}

// Collects one file's problems with the per-file cap.
class FileProblems {
 public:
  FileProblems(std::vector<DatasetProblem>& sink, std::string file)
      : sink_(sink), file_(std::move(file)) {}
  FileProblems(const FileProblems&) = delete;
  FileProblems& operator=(const FileProblems&) = delete;
  ~FileProblems() {
    if (suppressed_ > 0) {
      sink_.push_back(
          {file_, 0, 0, std::to_string(suppressed_) + " more problems in this file not listed"});
    }
  }
  void add(int line, int column, std::string message) {
    if (listed_ >= kProblemsListedPerFile) {
      ++suppressed_;
      return;
    }
    ++listed_;
    sink_.push_back({file_, line, column, std::move(message)});
  }
  [[nodiscard]] std::size_t count() const { return listed_ + suppressed_; }

 private:
  std::vector<DatasetProblem>& sink_;
  std::string file_;
  std::size_t listed_ = 0;
  std::size_t suppressed_ = 0;
};

struct HeaderColumn {
  std::string name;
  Unit unit;
  const ColumnRule* rule = nullptr;  // null for command-log speed columns
  // false: its header was refused (unit, name, twice); its cells are still checked for being
  // finite numbers, so that one bad header hides no problem of the rows.
  bool usable = true;
};

// "force [N]" -> force, N. Reports and returns false when malformed.
bool parse_header_field(std::string_view field, int line, int column, FileProblems& problems,
                        std::string& name, Unit& unit, Quantity expected, bool quantity_known) {
  const std::string_view text = detail::trim(field);
  const auto open = text.find('[');
  if (open == std::string_view::npos || text.back() != ']') {
    problems.add(line, column,
                 "column '" + std::string(text) + "' has no unit: write it as 'name [unit]'" +
                     (quantity_known ? ", e.g. '" + std::string(text) + " [" +
                                           std::string(si_unit(expected)) + "]'"
                                     : std::string()));
    return false;
  }
  name = std::string(detail::trim(text.substr(0, open)));
  const std::string_view symbol = detail::trim(text.substr(open + 1, text.size() - open - 2));
  if (name.empty()) {
    problems.add(line, column, "a column has a unit but no name");
    return false;
  }
  const std::optional<Unit> found = find_unit(symbol);
  if (!found) {
    problems.add(line, column,
                 name + ": unknown unit '" + std::string(symbol) + "'" +
                     (quantity_known ? " (a " + std::string(to_string(expected)) + ": use one of " +
                                           units_of(expected) + ")"
                                     : std::string()));
    return false;
  }
  unit = *found;
  return true;
}

// What a CSV file holds: a trial's data (the schema's columns), a lab belt's command log (time
// plus speeds of any name) or a line's (time, every belt by its drive name, the stations).
enum class TableKind : std::uint8_t { kData, kBeltLog, kLineLog };

// The columns of a line's command log: time, the speed of every belt on the product path (all
// required: a belt left out would run at a guessed speed), the stations' flags and the centring
// unit's shift (optional: at rest when absent).
const std::vector<ColumnRule>& line_log_columns() {
  static const std::vector<ColumnRule> columns = [] {
    std::vector<ColumnRule> rules{{"time", Quantity::kTime, 0.0, 24.0 * 3600.0, true}};
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      if (static_cast<DriveId>(d) == DriveId::kBulk) continue;  // upstream of the path
      // A belt of the line runs under 5 m/s either way (the reject belt reverses).
      rules.push_back({kDriveNames[d], Quantity::kSpeed, -5.0, 5.0, true});
    }
    for (const LineLogFlag& flag : kLineLogFlags) {
      rules.push_back({flag.column, Quantity::kDimensionless, 0.0, 1.0, false});
    }
    // The pusher's stroke across a 400 mm belt.
    rules.push_back({kLineLogCentringShift, Quantity::kLength, -0.2, 0.2, false});
    return rules;
  }();
  return columns;
}

// Reads one CSV file into a Table: the schema's columns, or a command log.
std::optional<Table> read_table(const std::filesystem::path& path, const std::string& shown_name,
                                const ExperimentSchema* schema, TableKind kind,
                                std::vector<DatasetProblem>& sink) {
  const bool commands = kind != TableKind::kData;
  const std::vector<ColumnRule>* rules = nullptr;
  if (kind == TableKind::kData) rules = &schema->columns;
  if (kind == TableKind::kLineLog) rules = &line_log_columns();
  FileProblems problems(sink, shown_name);
  std::vector<detail::CsvRow> rows;
  std::vector<detail::CsvIssue> issues;
  const bool opened = detail::read_csv(path, rows, issues);
  for (const auto& issue : issues) problems.add(issue.line, issue.column, issue.message);
  if (!opened) return std::nullopt;
  if (rows.empty()) {
    problems.add(0, 0, "no header row and no data");
    return std::nullopt;
  }

  // Header.
  static const ColumnRule command_time_rule{"time", Quantity::kTime, 0.0, 24.0 * 3600.0, true};
  const detail::CsvRow& header = rows.front();
  std::vector<HeaderColumn> columns;
  std::set<std::string, std::less<>> seen;
  bool header_ok = true;
  // A column whose header is refused stays in place, unusable, under its written name (not
  // reported missing as well).
  const auto refuse = [&](HeaderColumn& entry, std::string_view bare) {
    header_ok = false;
    entry.name = std::string(bare);
    entry.usable = false;
    seen.insert(entry.name);
    columns.push_back(std::move(entry));
  };
  for (std::size_t c = 0; c < header.fields.size(); ++c) {
    const int column = static_cast<int>(c) + 1;
    const std::string_view raw = detail::trim(header.fields[c]);
    const std::string_view bare = detail::trim(raw.substr(0, raw.find('[')));
    const ColumnRule* rule = nullptr;
    if (rules == nullptr) {
      if (bare == "time") rule = &command_time_rule;
    } else {
      for (const ColumnRule& r : *rules) {
        if (r.name == bare) rule = &r;
      }
    }
    HeaderColumn entry;
    const Quantity expected = rule != nullptr ? rule->quantity : Quantity::kSpeed;
    if (!parse_header_field(header.fields[c], header.line, column, problems, entry.name, entry.unit,
                            expected, rule != nullptr || commands)) {
      refuse(entry, bare);
      continue;
    }
    if (rules != nullptr && rule == nullptr) {
      std::vector<std::string_view> names;
      for (const ColumnRule& r : *rules) names.push_back(r.name);
      problems.add(header.line, column,
                   "unknown column '" + entry.name + "' for " +
                       (kind == TableKind::kLineLog
                            ? std::string("a line's command log (machine: line)")
                            : "a " + std::string(to_string(schema->type)) + " dataset") +
                       " (its columns: " + join(names) + ")");
      refuse(entry, bare);
      continue;
    }
    if (entry.unit.quantity != expected) {
      problems.add(header.line, column,
                   entry.name + ": '" + std::string(entry.unit.symbol) + "' is a unit of " +
                       std::string(to_string(entry.unit.quantity)) + ", the column is a " +
                       std::string(to_string(expected)) + " (use " + units_of(expected) + ")");
      refuse(entry, bare);
      continue;
    }
    if (!seen.insert(entry.name).second) {
      problems.add(header.line, column, "column '" + entry.name + "' appears twice");
      refuse(entry, bare);
      continue;
    }
    entry.rule = rule;
    columns.push_back(std::move(entry));
  }
  const auto require_column = [&](std::string_view name) {
    if (!seen.contains(name)) {
      problems.add(header.line, 0, "required column '" + std::string(name) + "' is missing");
      header_ok = false;
    }
  };
  if (rules == nullptr) {
    require_column("time");
  } else {
    for (const ColumnRule& r : *rules) {
      if (r.required) require_column(r.name);
    }
  }

  // Data rows.
  Table table;
  table.file = path;
  for (const HeaderColumn& column : columns) {
    table.channels.push_back({column.name, column.unit, {}});
    table.channels.back().values_si.reserve(rows.size());
  }
  for (std::size_t r = 1; r < rows.size(); ++r) {
    const detail::CsvRow& row = rows[r];
    if (row.fields.size() != columns.size()) {
      problems.add(row.line, 0,
                   std::to_string(row.fields.size()) + " fields, the header has " +
                       std::to_string(columns.size()));
      continue;
    }
    bool row_ok = true;
    std::vector<double> values(columns.size(), 0.0);
    for (std::size_t c = 0; c < columns.size(); ++c) {
      const int column = static_cast<int>(c) + 1;
      const HeaderColumn& h = columns[c];
      const std::string_view cell = detail::trim(row.fields[c]);
      if (cell.empty()) {
        problems.add(row.line, column, h.name + ": empty cell (a missing value is not allowed)");
        row_ok = false;
        continue;
      }
      double value = 0.0;
      const auto [end, error] = std::from_chars(cell.data(), cell.data() + cell.size(), value);
      if (error != std::errc{} || end != cell.data() + cell.size()) {
        problems.add(row.line, column, h.name + ": '" + std::string(cell) + "' is not a number");
        row_ok = false;
        continue;
      }
      if (!std::isfinite(value)) {
        problems.add(row.line, column, h.name + ": '" + std::string(cell) + "' is not finite");
        row_ok = false;
        continue;
      }
      const double value_si = h.usable ? value * h.unit.to_si : value;
      const ColumnRule* rule = h.usable ? h.rule : nullptr;
      if (kind == TableKind::kLineLog && rule != nullptr &&
          rule->quantity == Quantity::kDimensionless && value != 0.0 && value != 1.0) {
        problems.add(row.line, column,
                     h.name + ": '" + std::string(cell) + "' is not 0 or 1 (off or on)");
        row_ok = false;
        continue;
      }
      if (rule != nullptr && (value_si < rule->min_si || value_si > rule->max_si)) {
        problems.add(row.line, column,
                     h.name + ": " + std::string(cell) + " " + std::string(h.unit.symbol) +
                         " is out of range [" + in_unit(rule->min_si, h.unit) + ", " +
                         in_unit(rule->max_si, h.unit) + "]");
        row_ok = false;
        continue;
      }
      if (rule != nullptr && rule->name == "fillet" && value != std::floor(value)) {
        problems.add(row.line, column, "fillet: '" + std::string(cell) + "' is not a whole number");
        row_ok = false;
        continue;
      }
      values[c] = value_si;
    }
    if (!row_ok) continue;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      table.channels[c].values_si.push_back(values[c]);
    }
    table.lines.push_back(row.line);
  }
  if (rows.size() == 1) problems.add(header.line, 0, "a header but no data rows");

  // Time order: per fillet for line tracks, over the file otherwise.
  const bool ordered = commands || (schema != nullptr && schema->time_ordered);
  const Channel* time = table.find("time");
  if (ordered && time != nullptr) {
    const Channel* fillet = commands ? nullptr : table.find("fillet");
    std::unordered_map<std::int64_t, std::size_t> last_row;
    for (std::size_t k = 0; k < table.rows(); ++k) {
      const auto key = fillet != nullptr ? static_cast<std::int64_t>(fillet->values_si[k]) : 0;
      const auto found = last_row.find(key);
      if (found != last_row.end() && time->values_si[k] <= time->values_si[found->second]) {
        problems.add(table.lines[k], 0,
                     "time " + in_unit(time->values_si[k], time->unit) + " does not increase" +
                         (fillet != nullptr ? " for fillet " + std::to_string(key) : "") +
                         " (line " + std::to_string(table.lines[found->second]) + " had " +
                         in_unit(time->values_si[found->second], time->unit) + ")");
      }
      last_row[key] = k;
    }
  }
  // Compression is the plate's travel into the sample, positive. A trial whose force peaks
  // (|force - first force| largest) below its first displacement by more than an encoder's
  // jitter (10 um), while the displacement never rises above the start by a tenth of that,
  // was most likely recorded with compression negative: run as it stands, the twin's plate
  // would lift off and answer 0 N at every row. Judged at the force's peak, a return past the
  // start after unloading or a back-off before a pre-loaded test is not mistaken for it.
  const Channel* displacement = table.find("displacement");
  const Channel* force = table.find("force");
  if (header_ok && schema != nullptr && schema->type == ExperimentType::kCompress &&
      displacement != nullptr && force != nullptr && table.rows() > 0) {
    constexpr double kEncoderJitterM = 10e-6;
    const std::vector<double>& d = displacement->values_si;
    const std::vector<double>& f = force->values_si;
    std::size_t peak = 0;
    for (std::size_t k = 1; k < f.size(); ++k) {
      if (std::abs(f[k] - f.front()) > std::abs(f[peak] - f.front())) peak = k;
    }
    const double rise = *std::max_element(d.begin(), d.end()) - d.front();
    const double fall_at_peak = d.front() - d[peak];
    if (fall_at_peak > kEncoderJitterM && rise < 0.1 * fall_at_peak) {
      problems.add(table.lines[peak], 0,
                   "the force peaks where the displacement is " +
                       in_unit(d[peak], displacement->unit) + ", below its first value (" +
                       in_unit(d.front(), displacement->unit) + "), and it never rises more than " +
                       in_unit(rise, displacement->unit) +
                       " above that: compression is positive in this format; if the machine "
                       "records it negative, write the column with its sign changed (or the "
                       "first row is not where the test starts)");
    }
  }
  if (problems.count() > 0) return std::nullopt;
  return table;
}

struct RawTrial {
  std::string id;
  std::string file;
  std::string commands;
  Conditions conditions;
  std::size_t index = 0;
};

void read_conditions(YamlMapReader& map, const ExperimentSchema& schema, Conditions& out) {
  for (const ConditionRule& rule : schema.conditions) {
    if (!map.has(rule.name)) continue;
    switch (rule.kind) {
      case Kind::kFlag:
        out[std::string(rule.name)] = map.read_bool(rule.name);
        break;
      case Kind::kLabel: {
        const std::string label = map.read_string(rule.name);
        if (std::find(rule.labels.begin(), rule.labels.end(), label) == rule.labels.end()) {
          map.report(rule.name, ProblemKind::kInvalidValue,
                     "'" + label + "' is not one of " + join(rule.labels));
        } else {
          out[std::string(rule.name)] = label;
        }
        break;
      }
      case Kind::kNumber: {
        const std::string text = map.read_string(rule.name);
        const QuantityParse parsed = parse_quantity(text);
        if (!parsed.value) {
          map.report(rule.name, ProblemKind::kInvalidValue, parsed.error);
        } else if (parsed.value->unit.quantity != rule.quantity) {
          map.report(rule.name, ProblemKind::kInvalidValue,
                     "'" + text + "' is not " + with_article(to_string(rule.quantity)) +
                         " (write it with one of " + units_of(rule.quantity) + ")");
        } else if (parsed.value->value_si < rule.min_si || parsed.value->value_si > rule.max_si) {
          const Unit& unit = parsed.value->unit;
          map.report(rule.name, ProblemKind::kOutOfRange,
                     "'" + text + "' is out of range [" + in_unit(rule.min_si, unit) + ", " +
                         in_unit(rule.max_si, unit) + "]");
        } else {
          out[std::string(rule.name)] = parsed.value->value_si;
        }
        break;
      }
    }
  }
}

DatasetProblem from_config_problem(const ConfigProblem& problem) {
  std::string message;
  if (!problem.key_path.empty()) message = problem.key_path + ": ";
  message += std::string(to_string(problem.kind));
  if (!problem.detail.empty()) message += ": " + problem.detail;
  return {problem.file, problem.line, problem.column, std::move(message)};
}

}  // namespace

std::string_view to_string(ExperimentType type) {
  for (const auto& [value, name] : kExperimentNames) {
    if (value == type) return name;
  }
  return "unknown";
}

Table line_tracks_table(std::vector<double> time_s, std::vector<double> fillet,
                        std::vector<double> x_m, std::vector<double> y_m,
                        std::vector<double> angle_rad) {
  Table table;
  table.lines.resize(time_s.size());
  table.channels = {{"time", *find_unit("s"), std::move(time_s)},
                    {"fillet", *find_unit("1"), std::move(fillet)},
                    {"x", *find_unit("mm"), std::move(x_m)},
                    {"y", *find_unit("mm"), std::move(y_m)},
                    {"angle", *find_unit("deg"), std::move(angle_rad)}};
  return table;
}

bool runs_on_line(const Conditions& conditions) {
  const auto machine = conditions.find("machine");
  if (machine == conditions.end()) return false;
  const auto* label = std::get_if<std::string>(&machine->second);
  return label != nullptr && *label == kMachineLine;
}

std::optional<ExperimentType> experiment_from_string(std::string_view name) {
  for (const auto& [value, text] : kExperimentNames) {
    if (text == name) return value;
  }
  return std::nullopt;
}

const ExperimentSchema& schema_of(ExperimentType type) {
  static const std::vector<ExperimentSchema> schemas = [] {
    std::vector<ExperimentSchema> all;
    all.reserve(kExperimentNames.size());
    for (const auto& entry : kExperimentNames) all.push_back(make_schema(entry.first));
    return all;
  }();
  for (const ExperimentSchema& schema : schemas) {
    if (schema.type == type) return schema;
  }
  return schemas.front();
}

const Channel* Table::find(std::string_view name) const {
  for (const Channel& channel : channels) {
    if (channel.name == name) return &channel;
  }
  return nullptr;
}

const Channel& Table::at(std::string_view name) const {
  const Channel* channel = find(name);
  if (channel == nullptr) {
    throw std::out_of_range("no channel '" + std::string(name) + "' in " + file.string());
  }
  return *channel;
}

const Channel* belt_log_speed(const Table& log) {
  for (const Channel& channel : log.channels) {
    if (channel.name != "time" && channel.unit.quantity == Quantity::kSpeed) return &channel;
  }
  return nullptr;
}

std::string DatasetProblem::to_string() const {
  std::string text = file;
  if (line > 0) text += ":" + std::to_string(line);
  if (line > 0 && column > 0) text += ":" + std::to_string(column);
  return text + ": " + message;
}

DatasetError::DatasetError(std::vector<DatasetProblem> problems)
    : std::runtime_error([&problems] {
        std::string text =
            std::to_string(problems.size()) + " problem(s) in the dataset, nothing loaded:";
        for (const DatasetProblem& problem : problems) text += "\n  " + problem.to_string();
        return text;
      }()),
      problems_(std::move(problems)) {}

Dataset load_dataset(const std::filesystem::path& folder) {
  std::vector<DatasetProblem> problems;
  const std::filesystem::path manifest_path = folder / kManifest;
  if (!std::filesystem::is_directory(folder)) {
    throw DatasetError(
        {{folder.string(), 0, 0,
          "not a folder (a dataset is a folder with " + std::string(kManifest) + ")"}});
  }
  Dataset dataset;
  dataset.folder = folder;
  std::vector<RawTrial> raw_trials;
  const ExperimentSchema* schema = nullptr;
  YamlReader reader = YamlReader::from_file(manifest_path);
  {
    YamlMapReader root = reader.root();
    const std::string format = root.read_string("format");
    if (reader.all_read_ok({"format"}) && format != kFormat) {
      root.report("format", ProblemKind::kInvalidValue,
                  "'" + format + "' is not " + std::string(kFormat));
    }
    dataset.name = root.read_string("name");
    dataset.description = root.read_string_or("description", "");
    const std::string experiment = root.read_string("experiment");
    if (const auto type = experiment_from_string(experiment)) {
      dataset.experiment = *type;
      schema = &schema_of(*type);
    } else if (reader.all_read_ok({"experiment"})) {
      std::vector<std::string_view> names;
      names.reserve(kExperimentNames.size());
      for (const auto& entry : kExperimentNames) names.push_back(entry.second);
      root.report("experiment", ProblemKind::kInvalidValue,
                  "'" + experiment + "' is not one of " + join(names));
    }
    Conditions shared;
    if (schema != nullptr && root.has("conditions")) {
      YamlMapReader map = root.map("conditions");
      read_conditions(map, *schema, shared);
    }
    if (schema != nullptr && root.has("noise")) {
      YamlMapReader noise = root.map("noise");
      for (const ColumnRule& column : schema->columns) {
        if (!noise.has(column.name)) continue;
        const std::string text = noise.read_string(column.name);
        const QuantityParse parsed = parse_quantity(text);
        if (!parsed.value || parsed.value->unit.quantity != column.quantity ||
            parsed.value->value_si < 0.0) {
          noise.report(column.name, ProblemKind::kInvalidValue,
                       "'" + text + "' is not a non-negative " +
                           std::string(to_string(column.quantity)) +
                           " (units: " + units_of(column.quantity) + ")");
        } else {
          dataset.noise_si[std::string(column.name)] = parsed.value->value_si;
        }
      }
    }
    std::set<std::string, std::less<>> ids;
    root.for_each_map("trials", [&](YamlMapReader& element, std::size_t index) {
      RawTrial trial;
      trial.index = index;
      trial.id = element.read_string("id");
      if (!trial.id.empty() && !ids.insert(trial.id).second) {
        element.report("id", ProblemKind::kDuplicateKey,
                       "trial id '" + trial.id + "' is used twice");
      }
      trial.file = element.read_string("file");
      if (schema != nullptr && schema->has_commands) {
        trial.commands = element.read_string_or("commands", "");
      }
      trial.conditions = shared;
      if (schema != nullptr && element.has("conditions")) {
        YamlMapReader map = element.map("conditions");
        read_conditions(map, *schema, trial.conditions);
      }
      raw_trials.push_back(std::move(trial));
    });
    const bool trials_reported =
        std::any_of(reader.problems().begin(), reader.problems().end(),
                    [](const ConfigProblem& p) { return p.key_path.starts_with("trials"); });
    if (raw_trials.empty() && !trials_reported) {
      root.report("trials", ProblemKind::kInvalidValue, "no trials: a dataset needs at least one");
    }
    root.finish();
  }
  // A required condition may sit at either level: checked after the merge.
  if (schema != nullptr) {
    for (const RawTrial& trial : raw_trials) {
      if (runs_on_line(trial.conditions) && trial.commands.empty()) {
        reader.report_at("trials[" + std::to_string(trial.index) + "]", ProblemKind::kMissingKey,
                         "trial '" + trial.id +
                             "' ran on the line (machine: line) and names no command log: give "
                             "the belts' speeds and the stations as 'commands:'");
      }
      for (const ConditionRule& rule : schema->conditions) {
        if (rule.required && !trial.conditions.contains(rule.name)) {
          reader.report_at("trials[" + std::to_string(trial.index) + "]", ProblemKind::kMissingKey,
                           "trial '" + trial.id + "' has no condition '" + std::string(rule.name) +
                               "' (set it under the dataset's or the trial's conditions)");
        }
      }
    }
  }
  for (const ConfigProblem& problem : reader.problems()) {
    problems.push_back(from_config_problem(problem));
  }

  if (schema != nullptr) {
    const std::string shown_folder = folder.string();
    for (RawTrial& raw : raw_trials) {
      if (raw.file.empty()) continue;  // reported above
      Trial trial;
      trial.id = raw.id;
      trial.conditions = std::move(raw.conditions);
      const std::filesystem::path file = folder / raw.file;
      std::optional<Table> data =
          read_table(file, (std::filesystem::path(shown_folder) / raw.file).string(), schema,
                     TableKind::kData, problems);
      if (!raw.commands.empty()) {
        trial.commands = read_table(
            folder / raw.commands, (std::filesystem::path(shown_folder) / raw.commands).string(),
            schema, runs_on_line(trial.conditions) ? TableKind::kLineLog : TableKind::kBeltLog,
            problems);
      }
      if (data) {
        trial.data = std::move(*data);
        dataset.trials.push_back(std::move(trial));
      }
    }
  }
  if (!problems.empty()) throw DatasetError(std::move(problems));
  return dataset;
}

}  // namespace fl::workbench
