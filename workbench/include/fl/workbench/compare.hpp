// Model against measurement: run a model under each trial's conditions, align it with the
// measured rows, and say where it fails: the error per channel, trial, condition and phase,
// ranked, with every trace kept for the report (report.hpp writes JSON and HTML).
//
//   TwinCompressModel twin(options);                  // or any TrialModel
//   const CompareReport report = compare(dataset, twin);
//   report.cells.front()                               // the worst segment
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fl/workbench/dataset.hpp"

namespace fl::workbench {

// Reproduces trials. The model returns its response channels (same names and quantities as
// the measured ones) at the trial's rows; the driving channels (time, displacement, ...) are
// the measured ones.
class TrialModel {
 public:
  TrialModel() = default;
  TrialModel(const TrialModel&) = delete;
  TrialModel& operator=(const TrialModel&) = delete;
  virtual ~TrialModel() = default;

  // "DEM twin: appendix B, r 7 mm, effects: bpm_viscoelastic": goes into the report.
  [[nodiscard]] virtual std::string describe() const = 0;
  // Throws std::runtime_error when the trial cannot be run (a condition it does not support).
  virtual Table run(const Dataset& dataset, const Trial& trial) = 0;
  // The phase of each of the trial's rows where the model knows what the data alone cannot
  // tell (on the line: the belt under the row, from the line's geometry); nullopt: compare
  // takes phases_of's.
  [[nodiscard]] virtual std::optional<std::vector<std::string>> row_phases(
      const Dataset& dataset, const Trial& trial) const {
    (void)dataset;
    (void)trial;
    return std::nullopt;
  }
};

// The channels a model is judged on, per experiment (the others drive it).
std::vector<std::string_view> response_channels(ExperimentType type);

// Phase of each row: compress has "loading", "hold" and "unloading" (from the measured
// displacement's rate); drop has "fall", "landing" (100 ms from the impact, which the
// drop_height gives) and "settling"; other experiments one phase, "all". A compress trial's
// rates are read over a window sized from its displacement noise: the
// `stated_displacement_noise_m` (the manifest's, as the compress twin's plate path takes it)
// when given, else the rows' own estimate.
std::vector<std::string> phases_of(
    ExperimentType type, const Trial& trial,
    std::optional<double> stated_displacement_noise_m = std::nullopt);

struct ChannelTrace {
  std::string channel;
  Unit unit;  // the measurement's, for plots in the user's units
  std::vector<double> measured_si;
  std::vector<double> model_si;
  // The model's own spread per row, 1 sigma, when it answers a "<channel>_spread" channel (an
  // ensemble: TwinLineTracksModel); empty otherwise.
  std::vector<double> model_spread_si;
};

struct TrialTrace {
  std::string trial;
  // The plots' x: time in s; bulk flow: the opening in the file's unit; else the row number.
  std::vector<double> time_s;
  std::string x_label = "time (s)";
  std::vector<std::string> phase;
  std::vector<ChannelTrace> channels;
};

// The error of one channel over one group of rows.
struct ErrorCell {
  std::string channel;
  std::string group;  // "trial fast", "phase hold", "surface=wet", "all"
  std::string trial;  // the trial, or empty when the group spans trials
  std::string phase;  // the phase, or empty
  std::size_t samples = 0;
  double rmse_si = 0.0;
  double bias_si = 0.0;  // mean of model - measured
  double max_abs_si = 0.0;
  double max_abs_time_s = 0.0;  // where the largest residual is (time or row)
  double noise_si = 0.0;        // the dataset's 1-sigma noise; 0 when not given
  // The model's own spread over the rows (RMS of its per-row 1 sigma); 0 without an ensemble.
  double model_spread_si = 0.0;
  // The RMS of the residuals each in its row's sigma, sqrt(noise^2 + the model's spread there^2),
  // when the noise is known (rmse / noise for a single run; 1: the model is as right as the
  // noise and its own spread let anyone tell), else rmse / rms(measured): how bad, comparable
  // across channels. Cells are ranked by it.
  double score = 0.0;
};

struct CompareReport {
  std::string dataset;
  ExperimentType experiment = ExperimentType::kCompress;
  std::string model;
  std::vector<TrialTrace> traces;
  std::vector<ErrorCell> cells;            // worst first; the "all" cells of every channel included
  std::vector<std::string> failed_trials;  // "id: reason" for trials the model could not run

  // The "all" cell of a channel; throws std::out_of_range when there is none.
  [[nodiscard]] const ErrorCell& overall(std::string_view channel) const;
};

// Runs every trial; a trial the model cannot run is listed in failed_trials, not fatal.
// Throws std::runtime_error when no trial could be run.
CompareReport compare(const Dataset& dataset, TrialModel& model);

}  // namespace fl::workbench
