// linectl compare (issue 6; docs/measurements.md, docs/workbench.md):
//   linectl compare DATASET [--out DIR] [--dem-config config/dem.yaml] [--radius-mm 7]
// runs the DEM twin under the dataset's conditions, writes DIR/report.html and
// DIR/report.json, and appends the run to DIR/history.csv (plotted in DIR/history.svg), so
// that a user adding an effect to the model watches the error fall across runs.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace fl::apps {

struct CompareArgs {
  std::string dataset;
  std::string out;         // default: compare_<dataset folder name>
  std::string dem_config;  // default: config/dem.yaml
  double radius_mm = 7.0;  // sub-particle radius of the twin's samples
  int threads = 1;
};

CLI::App* add_compare_subcommand(CLI::App& app, CompareArgs& args);
// 0: compared (whatever the error); 2: the dataset or the model config is unusable.
int compare_command(const CompareArgs& args);

}  // namespace fl::apps
