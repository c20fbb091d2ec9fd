// The model-versus-measurement workbench's commands (issue 6; docs/measurements.md):
//   linectl compare DATASET [--out DIR] [--dem-config config/dem.yaml] [--radius-mm 7]
//     runs the DEM twin under the dataset's conditions, writes DIR/report.html and
//     DIR/report.json, and appends the run to DIR/history.csv (plotted in DIR/history.svg), so
//     that a user adding an effect to the model watches the error fall across runs.
//   linectl diagnose DATASET [--out DIR] [...]
//     fits each candidate effect the model lacks and says which one explains the failure
//     (DIR/diagnosis.json), with the config/dem.yaml change that adds it.
//   linectl calibrate DATASET --param ADDRESS=MIN:MAX[:log] ... [--design hammersley|factorial]
//     fits base parameters of the model (bond stiffness, friction, surface energy) by a design
//     of experiments and a local fit (DIR/calibration.json, DIR/design.csv), with the
//     config/dem.yaml change.
//   linectl dataset generate --out DIR [--experiment compress|slide|drop|line_tracks]
//                            [--effect random|none|LAW] [--seed N]
//     a synthetic dataset with a hidden effect; the truth in DIR.truth.yaml.
// compare, diagnose and calibrate take compress, slide and drop datasets (the twin and the
// candidate effects follow the dataset's experiment).
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace fl::apps {

struct CompareArgs {
  std::string dataset;
  std::string out;         // default: compare_<dataset folder name>
  std::string dem_config;  // default: config/dem.yaml
  // Line tracks taken on the line (machine: line): the line and the DEM plant they replay on.
  std::string line_config;   // default: config/line.yaml
  std::string plant_config;  // default: config/plant_dem.yaml
  double radius_mm = 7.0;    // sub-particle radius of the twin's samples
  int threads = 1;
  // Twin runs per trial: line tracks from first poses within the noise, slide from
  // placements within the tolerance.
  int ensemble = 1;
};

struct GenerateArgs {
  std::string out;
  std::string effect = "random";
  std::string experiment = "compress";
  std::uint64_t seed = 1;
  double force_noise_n = 0.01;
  double displacement_noise_um = 0.0;
  double compress_row_ms = 5.0;
  double angle_noise_deg = 0.3;
  double height_noise_mm = 0.5;
  double bend_angle_noise_deg = 1.0;
  double position_noise_mm = 1.0;
  int fillets_per_trial = 5;
  bool truth_starts_at_true_pose = false;
  bool on_line = false;  // line_tracks: on the line's DEM plant (config/line.yaml, plant_dem.yaml)
  int trials = 0;        // 0: the experiment's default
  std::vector<double> slide_tilt_rates_deg_per_s;
  bool slide_relaid = false;
};

struct CalibrateArgs {
  CompareArgs model;                // dataset, out (default calibrate_<name>), config, threads
  std::vector<std::string> params;  // ADDRESS=MIN:MAX[:log]
  std::string design = "hammersley";
  int points = 16;
  int levels = 3;
  int local_evaluations = 60;
  int profile_evaluations = 0;  // per re-fit along each parameter's profile; 0: no profile
};

CLI::App* add_compare_subcommand(CLI::App& app, CompareArgs& args);
// The same options as compare.
CLI::App* add_diagnose_subcommand(CLI::App& app, CompareArgs& args);
CLI::App* add_dataset_subcommand(CLI::App& app, GenerateArgs& args);
// 0: compared (whatever the error); 2: the dataset or the model config is unusable.
int compare_command(const CompareArgs& args);
// 0: diagnosed (an effect proposed or not); 2: unusable dataset or config.
int diagnose_command(const CompareArgs& args);
int generate_command(const GenerateArgs& args);
CLI::App* add_calibrate_subcommand(CLI::App& app, CalibrateArgs& args);
// 0: calibrated; 2: unusable dataset, config or parameter.
int calibrate_command(const CalibrateArgs& args);

}  // namespace fl::apps
