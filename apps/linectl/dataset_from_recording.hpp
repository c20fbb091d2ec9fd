// linectl dataset from-recording REC.mcap --out DIR [--cameras multilane1,multilane2]
//   A line-track dataset taken on the line (machine: line, docs/measurements.md) from a line
//   recording (linectl record, linectl control --record): each chosen camera's estimates joined
//   into fillet tracks in line coordinates, one trial per camera and hand, and the log of every
//   belt's measured speed and the stations' commands, scan by scan. linectl compare and
//   diagnose then replay it on the DEM plant.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace fl::apps {

struct FromRecordingArgs {
  std::string recording;
  std::string out;
  std::vector<std::string> cameras{"multilane1", "multilane2"};
  std::string config;                 // line configuration; default: the recording's own
  std::string variant = "172x72x32";  // the size the twin gives every fillet
  std::string surface = "dry";        // dry or wet belts
  double position_noise_mm = 0.0;     // the cameras' 1 sigma on x and y; 0: not stated
  double angle_noise_deg = 0.0;       // and on the angle
  double gate_mm = 30.0;              // TrackingSettings::gate_m
  int min_rows = 5;                   // TrackingSettings::min_rows
};

CLI::App* add_from_recording_subcommand(CLI::App& dataset, FromRecordingArgs& args);
// 0: written; 2: the recording or the options are unusable, or no track was found.
int from_recording_command(const FromRecordingArgs& args);

}  // namespace fl::apps
