#include "dataset_from_recording.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/vision/record/recording.hpp"
#include "fl/workbench/camera_tracks.hpp"
#include "fl/workbench/generator.hpp"

namespace fl::apps {
namespace {

namespace rec = fl::vision::record;
using namespace fl::workbench;

constexpr double kNsPerS = 1e9;
constexpr double kMm = 1e-3;

// Every scan's measured belt speeds, for the command log and for carrying tracks between
// frames.
class ScanLog {
 public:
  ScanLog(const rec::Recording& recording, const LineConfig& line)
      : line_(line), start_ns_(recording.scans.front().input.time_ns) {
    for (const rec::RecordedScan& scan : recording.scans) {
      time_s_.push_back(static_cast<double>(scan.input.time_ns - start_ns_) / kNsPerS);
      std::array<double, kDriveCount> speed{};
      for (std::size_t d = 0; d < kDriveCount; ++d) speed[d] = scan.input.drives[d].speed_mps;
      speed_mps_.push_back(speed);
    }
  }
  [[nodiscard]] std::int64_t start_ns() const { return start_ns_; }

  // The measured speed under s at a time: the scan at or before it; a multilane unit's mean of
  // its two belts.
  [[nodiscard]] double speed_at(double s_m, double time_s) const {
    const auto after = std::upper_bound(time_s_.begin(), time_s_.end(), time_s);
    const std::size_t k =
        after == time_s_.begin() ? 0 : static_cast<std::size_t>(after - time_s_.begin()) - 1;
    return carrying_speed(line_, s_m / kMm,
                          [&](DriveId drive) { return speed_mps_[k][index(drive)]; });
  }

  // The line log (docs/measurements.md, machine: line): time, every belt of the path at its
  // measured speed, the stations as commanded; the stations are left out (at rest) when the
  // recording has no commands.
  [[nodiscard]] Table commands(const rec::Recording& recording) const {
    Table log;
    log.channels.push_back({"time", *find_unit("s"), time_s_});
    const bool commanded =
        std::all_of(recording.scans.begin(), recording.scans.end(),
                    [](const rec::RecordedScan& scan) { return scan.recorded_output.has_value(); });
    // The speeds as commanded: the twin's drives then ramp and lag as the line's did. Measured
    // speeds fed to them would lag twice.
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      if (static_cast<DriveId>(d) == DriveId::kBulk) continue;
      std::vector<double> speed;
      speed.reserve(speed_mps_.size());
      for (std::size_t k = 0; k < speed_mps_.size(); ++k) {
        speed.push_back(commanded ? recording.scans[k].recorded_output->drives[d].speed_mps
                                  : speed_mps_[k][d]);
      }
      log.channels.push_back({std::string(kDriveNames[d]), *find_unit("m/s"), speed});
    }
    if (commanded) {
      std::array<std::vector<double>, kLineLogFlags.size()> flags;
      std::vector<double> shift_m;
      for (const rec::RecordedScan& scan : recording.scans) {
        const OutputImage& out = *scan.recorded_output;
        for (std::size_t f = 0; f < kLineLogFlags.size(); ++f) {
          flags[f].push_back(out.*kLineLogFlags[f].field ? 1.0 : 0.0);
        }
        shift_m.push_back(out.centring_shift_mm * kMm);
      }
      for (std::size_t f = 0; f < flags.size(); ++f) {
        log.channels.push_back({std::string(kLineLogFlags[f].column), *find_unit("1"), flags[f]});
      }
      log.channels.push_back({std::string(kLineLogCentringShift), *find_unit("mm"), shift_m});
    } else {
      spdlog::warn(
          "dataset from-recording: {} has no line commands for some scans; the log gives the "
          "belts' measured speeds (which the twin's drives lag once more) and keeps the plates, "
          "the centring unit, the roller and the air knife at rest",
          recording.path.string());
    }
    log.lines.resize(time_s_.size());
    return log;
  }

 private:
  const LineConfig& line_;
  std::int64_t start_ns_ = 0;
  std::vector<double> time_s_;
  std::vector<std::array<double, kDriveCount>> speed_mps_;
};

// One camera's frames in line coordinates, each frame once, in exposure order.
std::vector<SightingFrame> sightings_of(const rec::Recording& recording, CameraId camera,
                                        const CameraMount& mount, std::int64_t start_ns) {
  std::vector<SightingFrame> frames;
  std::set<std::uint32_t> seen;
  std::size_t before_first_scan = 0;
  for (const rec::RecordedEstimates& estimates : recording.estimates) {
    if (estimates.camera != camera || !seen.insert(estimates.frame.sequence).second) continue;
    // No belt log covers a frame exposed before the first scan (a camera node started first).
    if (estimates.frame.frame_time_ns < start_ns) {
      ++before_first_scan;
      continue;
    }
    SightingFrame frame;
    frame.time_s = static_cast<double>(estimates.frame.frame_time_ns - start_ns) / kNsPerS;
    for (std::size_t k = 0; k < estimates.frame.count && k < kMaxEstimatesPerFrame; ++k) {
      const FilletEstimate& e = estimates.frame.estimates[k];
      // The camera's frame has its origin under the optical axis at the mount's s.
      frame.fillets.push_back({(mount.s_mm + e.x_mm) * kMm, e.y_mm * kMm, e.angle_rad, e.hand});
    }
    frames.push_back(std::move(frame));
  }
  std::stable_sort(
      frames.begin(), frames.end(),
      [](const SightingFrame& a, const SightingFrame& b) { return a.time_s < b.time_s; });
  if (before_first_scan > 0) {
    spdlog::warn(
        "camera {}: {} frames exposed before the first scan are left out (no belt log "
        "covers them)",
        rec::camera_name(camera), before_first_scan);
  }
  return frames;
}

}  // namespace

CLI::App* add_from_recording_subcommand(CLI::App& dataset, FromRecordingArgs& args) {
  CLI::App* command = dataset.add_subcommand(
      "from-recording",
      "a line-track dataset taken on the line from a line recording (the cameras' fillet tracks "
      "and the belts' log), for linectl compare and diagnose");
  command
      ->add_option("recording", args.recording,
                   "MCAP recording (linectl record or control --record)")
      ->required();
  command->add_option("--out", args.out, "dataset folder to write")->required();
  command->add_option("--cameras", args.cameras, "cameras whose tracks to take")
      ->delimiter(',')
      ->check(CLI::IsMember({"orientation", "position", "multilane1", "multilane2", "final"}));
  command->add_option("--config", args.config,
                      "line configuration (default: the one attached to the recording)");
  command->add_option("--variant", args.variant, "the fillet size the twin replays them with")
      ->check(CLI::IsMember({"144x72x40", "172x72x32", "176x72x40"}));
  command->add_option("--surface", args.surface, "dry or wet belts")
      ->check(CLI::IsMember({"dry", "wet"}));
  command
      ->add_option("--position-noise-mm", args.position_noise_mm,
                   "the cameras' 1-sigma error on x and y, written into the manifest")
      ->check(CLI::Range(0.0, 50.0));
  command
      ->add_option("--angle-noise-deg", args.angle_noise_deg,
                   "the cameras' 1-sigma error on the angle")
      ->check(CLI::Range(0.0, 30.0));
  command
      ->add_option("--gate-mm", args.gate_mm,
                   "a sighting this close to where the belt carried a track continues it")
      ->check(CLI::Range(1.0, 200.0));
  command->add_option("--min-rows", args.min_rows, "shorter tracks are dropped")
      ->check(CLI::Range(2, 10000));
  return command;
}

int from_recording_command(const FromRecordingArgs& args) {
  rec::Recording recording;
  try {
    recording = rec::load_recording(args.recording);
  } catch (const rec::RecordingError& error) {
    spdlog::error("{}", error.what());
    return 2;
  }
  if (recording.scans.empty()) {
    spdlog::error("{}: no scans recorded: no belt speeds to replay", args.recording);
    return 2;
  }
  LineConfig line;
  try {
    if (!args.config.empty()) {
      line = load_line_config(args.config);
    } else if (recording.line_config_yaml) {
      line = parse_line_config(*recording.line_config_yaml, args.recording + " (line.yaml)");
    } else {
      spdlog::error("{}: no line configuration attached; name one with --config", args.recording);
      return 2;
    }
  } catch (const ConfigError& error) {
    spdlog::error("{}", error.what());
    return 2;
  }

  const ScanLog scans(recording, line);
  const Table commands = scans.commands(recording);
  TrackingSettings settings;
  settings.gate_m = args.gate_mm * kMm;
  settings.min_rows = static_cast<std::size_t>(args.min_rows);
  const BeltSpeedAt belt_speed = [&scans](double s_m, double time_s) {
    return scans.speed_at(s_m, time_s);
  };

  Dataset dataset;
  dataset.name = "line tracks from " + std::filesystem::path(args.recording).filename().string();
  dataset.description = "made by linectl dataset from-recording";
  dataset.experiment = ExperimentType::kLineTracks;
  if (args.position_noise_mm > 0.0) {
    dataset.noise_si["x"] = args.position_noise_mm * kMm;
    dataset.noise_si["y"] = args.position_noise_mm * kMm;
  }
  if (args.angle_noise_deg > 0.0) {
    dataset.noise_si["angle"] = args.angle_noise_deg * std::numbers::pi / 180.0;
  }
  std::size_t unknown_hand = 0;
  for (const std::string& name : args.cameras) {
    const CameraId camera = *rec::camera_from_name(name);  // checked by the option
    const std::vector<CameraTrack> tracks = track_fillets(
        sightings_of(recording, camera, line.cameras[index(camera)], scans.start_ns()), belt_speed,
        settings);
    // One trial per hand: the twin gives a trial's fillets one variant, mirrored or not.
    std::map<Hand, std::vector<CameraTrack>> by_hand;
    for (const CameraTrack& track : tracks) by_hand[track_hand(track)].push_back(track);
    for (const auto& [hand, hand_tracks] : by_hand) {
      Trial trial;
      trial.id =
          name + "_" + std::string(to_string(hand)) + (hand == Hand::kUnknown ? "_hand" : "");
      trial.conditions["machine"] = std::string(kMachineLine);
      trial.conditions["variant"] = args.variant;
      trial.conditions["surface"] = args.surface;
      if (hand != Hand::kUnknown) trial.conditions["mirrored"] = hand == Hand::kRight;
      if (hand == Hand::kUnknown) unknown_hand += hand_tracks.size();
      trial.data = tracks_table(hand_tracks);
      trial.commands = commands;
      spdlog::info("camera {}: {} {} fillets tracked, {} rows", name, hand_tracks.size(),
                   to_string(hand), trial.data.rows());
      dataset.trials.push_back(std::move(trial));
    }
  }
  if (unknown_hand > 0) {
    spdlog::warn(
        "{} tracks have no hand (the camera gave none, or as many left as right): their trials "
        "('*_unknown_hand') are replayed with the left-hand variant",
        unknown_hand);
  }
  if (dataset.trials.empty()) {
    spdlog::error("{}: no fillet was tracked over {} frames or more on camera(s) {}",
                  args.recording, args.min_rows, fmt::join(args.cameras, ", "));
    return 2;
  }
  write_dataset(dataset, args.out);
  spdlog::info("dataset written to {} ({} trials, {} scans of belt log)", args.out,
               dataset.trials.size(), commands.rows());
  return 0;
}

}  // namespace fl::apps
