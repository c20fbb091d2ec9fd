// Fillets tracked through the whole line: the DEM plant driven by a recorded command log (every
// belt's speed, the plates, the centring unit, the roller, the air knife), each fillet placed
// where the line's cameras first saw it, and its pose answered at every later camera row. What
// the workbench's line-track experiment runs for a dataset recorded on the line (machine: line)
// rather than on one lab belt.
//
//   LineTracksRun run;
//   run.line = line;
//   run.plant = plant;
//   run.commands = [&log](double t_s) { return log.at(t_s); };
//   run.first = {{0.0, 150.0, 10.0, 0.2}};
//   run.samples = {{0, 0.0}, {0, 0.5}};
//   const LineTracksResult result = run_line_tracks(run);
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/twin/dem_plant/dem_plant_config.hpp"

namespace fl {

// Where and when a fillet first appears, in line coordinates (s from the takt barrier along the
// product path, y to the left looking downstream; angle from the thick end to the tip,
// counter-clockwise from the travel, as the controller's cameras report it).
struct LineTrackStart {
  double time_s = 0.0;
  double s_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;
};

// One camera row to answer: a fillet (index into LineTracksRun::first) at a time.
struct LineTrackSample {
  std::size_t fillet = 0;
  double time_s = 0.0;
};

struct LineTrackPose {
  double s_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;  // unwrapped along the fillet's own track
  // false: the fillet had left the twin's line (placed, crate, air knife, fell off) before this
  // row; the pose is where the twin last had it.
  bool on_line = true;
};

struct LineTracksRun {
  LineConfig line;
  DemPlantConfig plant;
  // The line's commands at a time (seconds from the log's start). Called once per command
  // period; the plant's infeed is kept off whatever it returns (the log's fillets are the
  // ones placed from `first`).
  std::function<OutputImage(double time_s)> commands;
  double command_period_s = 0.01;  // the controller's scan
  std::uint8_t variant = 2;        // thesis_fillet_variants() index, every fillet's
  SideUp side = SideUp::kSkin;
  std::vector<LineTrackStart> first;
  std::vector<LineTrackSample> samples;  // ascending in time
  std::uint64_t seed = 1;
};

struct LineTracksResult {
  std::vector<LineTrackPose> poses;  // one per sample, in the samples' order
  std::size_t rows_after_leaving = 0;
};

// Throws std::invalid_argument naming the problem for samples out of time order, a sample of a
// fillet without a start, a fillet seen before its start, a start off the product path, and more
// fillets than the plant holds; std::runtime_error if the plant refuses to place a fillet.
LineTracksResult run_line_tracks(const LineTracksRun& run);

}  // namespace fl
