// Measured datasets for the model-versus-measurement workbench (docs/measurements.md).
//
// A dataset is a folder: manifest.yaml (experiment type, conditions, known sensor noise, the
// trials) and one CSV file per trial whose header names each column with its unit,
// "time [s],displacement [mm],force [N]". Loading converts every value to SI and checks the
// manifest, the units, the columns and the ranges; it reports every problem at once, each
// with file, line and column, and returns nothing partial.
//
//   const fl::workbench::Dataset data = fl::workbench::load_dataset("lab/compress_2026_11");
//   const auto& force_n = data.trials[0].data.at("force").values_si;
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/workbench/units.hpp"

namespace fl::workbench {

enum class ExperimentType : std::uint8_t {
  kSlide,       // tilt angle at slide onset, per repetition
  kBend,        // bend angle of a fillet overhanging an edge, per repetition
  kSettle,      // height of the centre of mass over time after release at rest
  kDrop,        // height over time after a drop from a height
  kCompress,    // displacement and force over time: load, hold, unload cycles
  kLineTracks,  // per fillet and camera frame: time, x, y, angle; with the belt commands
  kBulkFlow,    // mailbox outflow against the opening height
};

// "slide", "line_tracks", ...: the names used in manifests.
std::string_view to_string(ExperimentType type);
std::optional<ExperimentType> experiment_from_string(std::string_view name);

// A condition: a number in SI (written with its unit), a label (one of a fixed set) or a flag.
using ConditionValue = std::variant<double, std::string, bool>;
using Conditions = std::map<std::string, ConditionValue, std::less<>>;

struct Channel {
  std::string name;  // "force"
  Unit unit;         // as written in the file, for reports in the user's units
  std::vector<double> values_si;
};

// One CSV file, converted.
struct Table {
  std::filesystem::path file;
  std::vector<Channel> channels;
  std::vector<int> lines;  // file line of each row, for messages about a row

  [[nodiscard]] std::size_t rows() const { return lines.size(); }
  [[nodiscard]] const Channel* find(std::string_view name) const;
  // Throws std::out_of_range naming the channel and the file when it is absent.
  [[nodiscard]] const Channel& at(std::string_view name) const;
};

// The speed a lab belt's command log (machine: belt) drives the belt with: its first column
// after time (every such column is a speed, as loading checks); nullptr when it has none.
[[nodiscard]] const Channel* belt_log_speed(const Table& log);

struct Trial {
  std::string id;
  Conditions conditions;  // the dataset's, overridden by the trial's own
  Table data;
  std::optional<Table> commands;  // line tracks: the belt's or the line's command log
};

// Line tracks' `machine` condition: tracks on one lab belt (the default), or on the line from
// the takt barrier on, whose command log names every belt of the product path by its drive
// name (fl::kDriveNames but bulk, speeds) and may give the stations below (0 or 1: plate 1 and
// plate 2 retracted to flip, the centring unit stroking, the squeeze roller down, the air knife
// blowing) and the centring unit's shift (a length). A station left out stays at rest.
inline constexpr std::string_view kMachineBelt = "belt";
inline constexpr std::string_view kMachineLine = "line";
struct LineLogFlag {
  std::string_view column;
  bool OutputImage::*field;  // the output image's command the column logs
};
inline constexpr std::array<LineLogFlag, 5> kLineLogFlags{
    {{"flip_plate1", &OutputImage::flip_plate1_flip},
     {"flip_plate2", &OutputImage::flip_plate2_flip},
     {"centring_stroke", &OutputImage::centring_stroke},
     {"squeeze_roller_down", &OutputImage::squeeze_roller_down},
     {"final_reject", &OutputImage::final_reject}}};
inline constexpr std::string_view kLineLogCentringShift = "centring_shift";
// Whether a trial's tracks were taken on the line (machine: line).
bool runs_on_line(const Conditions& conditions);

// A line-track data table from SI columns, in the units a camera log is written in (time s,
// fillet 1, x and y mm, angle deg); a row's line unknown (0), as for made-up data.
Table line_tracks_table(std::vector<double> time_s, std::vector<double> fillet,
                        std::vector<double> x_m, std::vector<double> y_m,
                        std::vector<double> angle_rad);

struct Dataset {
  std::filesystem::path folder;
  std::string name;
  std::string description;
  ExperimentType experiment = ExperimentType::kCompress;
  std::map<std::string, double, std::less<>> noise_si;  // channel -> 1 sigma, SI
  std::vector<Trial> trials;
};

struct DatasetProblem {
  std::string file;  // path as given to load_dataset, joined with the file's name
  int line = 0;      // 1-based; 0 when the problem is the whole file
  int column = 0;    // 1-based (CSV: field number); 0 when unknown
  std::string message;

  // "lab/compress/t1.csv:12:3: force: 'abc' is not a number"
  [[nodiscard]] std::string to_string() const;
};

class DatasetError : public std::runtime_error {
 public:
  explicit DatasetError(std::vector<DatasetProblem> problems);
  [[nodiscard]] const std::vector<DatasetProblem>& problems() const noexcept { return problems_; }

 private:
  std::vector<DatasetProblem> problems_;
};

// Throws DatasetError with every problem found (manifest, files, columns, units, values).
Dataset load_dataset(const std::filesystem::path& folder);

// What each experiment type requires, for docs and for tools that write datasets.
struct ColumnRule {
  std::string_view name;
  Quantity quantity = Quantity::kDimensionless;
  double min_si = 0.0;  // allowed range, SI
  double max_si = 0.0;
  bool required = true;
};
struct ConditionRule {
  enum class Kind : std::uint8_t { kNumber, kLabel, kFlag };
  std::string_view name;
  Kind kind = Kind::kNumber;
  Quantity quantity = Quantity::kDimensionless;  // kNumber
  double min_si = 0.0;                           // kNumber
  double max_si = 0.0;
  std::vector<std::string_view> labels;  // kLabel
  bool required = false;
};
struct ExperimentSchema {
  ExperimentType type = ExperimentType::kCompress;
  std::vector<ColumnRule> columns;
  std::vector<ConditionRule> conditions;
  bool time_ordered = false;  // the time column increases (per fillet for line tracks)
  bool has_commands = false;  // trials may name a belt command log
};
const ExperimentSchema& schema_of(ExperimentType type);

}  // namespace fl::workbench
