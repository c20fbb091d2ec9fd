// The run history of a dataset's comparisons: one CSV line per run and channel (when, which
// model, the overall error), and a plot of the error across runs, so that a user adding
// effects to the model watches the error fall.
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
};

// Appends the report's overall cells (creating the file with its header); throws
// std::runtime_error when the file cannot be written.
void append_history(const std::filesystem::path& csv, const CompareReport& report,
                    const std::string& run_utc);
// Reads a history back; a malformed line is skipped with a warning naming file and line.
std::vector<HistoryEntry> read_history(const std::filesystem::path& csv);
// Score per channel over the runs, as an SVG plot.
void plot_history(const std::vector<HistoryEntry>& history, const std::filesystem::path& svg);

}  // namespace fl::workbench
