// The run history of a dataset's comparisons: one CSV line per run and channel (when, which
// model, the overall error, the effects in the model with their parameters), and a plot of the
// error across runs, so that a user adding effects to the model watches the error fall.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fl/workbench/compare.hpp"

namespace fl::workbench {

struct HistoryEntry {
  std::string run_utc;
  std::string dataset;
  std::string channel;
  double rmse_si = 0.0;
  double score = 0.0;
  std::string model;
  std::string effects;  // model_effects (twin_models.hpp); empty on a line of an older history
};

// Appends the report's overall cells with the model's `effects` (creating the file with its
// header; a history written before the effects column gets it, empty on its old lines); throws
// std::runtime_error when the file cannot be written.
void append_history(const std::filesystem::path& csv, const CompareReport& report,
                    const std::string& run_utc, const std::string& effects);
// Reads a history back, with or without the effects column; a malformed line is skipped with
// a warning naming file and line.
std::vector<HistoryEntry> read_history(const std::filesystem::path& csv);
// Score per channel over the runs, as an SVG plot.
void plot_history(const std::vector<HistoryEntry>& history, const std::filesystem::path& svg);

}  // namespace fl::workbench
