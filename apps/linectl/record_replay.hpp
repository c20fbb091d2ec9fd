// linectl record and linectl replay (issue 4 items 3 and 4; docs/vision.md):
//   linectl record --plant fast|dem --duration 9s --out run.mcap [--cameras orientation,...]
//   linectl record --images DIR | --device N | --video FILE --calibration CAM.yaml --out run.mcap
//   linectl replay run.mcap [--golden run.golden.txt] [--update-golden] [--set NAME=VALUE]
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace fl::apps {

struct RecordArgs {
  std::string plant;  // fast or dem: the twin's cameras
  std::string images_dir;
  int device = -1;
  std::string video_file;
  std::string out;
  std::string duration = "10s";
  std::uint64_t seed = 1;
  std::string config;        // line configuration
  std::string plant_config;  // plant configuration (default per plant)
  std::vector<std::string> cameras{"orientation"};
  int width_px = 640;  // twin frames as delivered
  int height_px = 480;
  int binning = 1;  // twin cameras: sensor pixels averaged per delivered pixel and axis
  // Twin cameras: the sensor's long side across the belt (all 400 mm; the default) or along
  // it (225 mm across at 4:3); docs/vision.md "Twin cameras"
  std::string sensor_mount = "across";
  double noise_sigma = 0.0;            // sensor noise of the rendered frames, grey levels
  double belt_grain = 0.0;             // belt texture amplitude of the rendered frames
  double latency_ms = 20.0;            // exposure to delivery of the vision estimates
  int png_compression = 6;             // 0..9
  std::string calibration;             // real cameras: the camera's belt calibration (YAML)
  std::string camera = "orientation";  // real cameras: which line camera it is
  double fps = 25.0;                   // --images: frame rate the images are stamped with
};

struct ReplayArgs {
  std::string recording;
  std::string golden;  // default: the recording's path with .golden.txt instead of .mcap
  bool update_golden = false;
  std::size_t max_differences = 20;
  std::vector<std::string> estimator_settings;  // NAME=VALUE
  std::string config;                           // line configuration; default: the one recorded
  std::vector<std::string> frames;              // camera node recordings joined (join_frames)
};

CLI::App* add_record_subcommand(CLI::App& app, RecordArgs& args);
CLI::App* add_replay_subcommand(CLI::App& app, ReplayArgs& args);
int record_command(const RecordArgs& args);
// 0: matches the golden (or --update-golden wrote it); 1: differences; 2: the recording,
// golden file or options are unusable.
int replay_command(const ReplayArgs& args);

}  // namespace fl::apps
