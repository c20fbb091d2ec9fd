// linectl replay: a recording through the estimator and the controller logic in simulated
// time, compared with its golden result (vision/record/include/fl/vision/record/replay.hpp).
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli_support.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/vision/record/recording.hpp"
#include "fl/vision/record/replay.hpp"
#include "record_replay.hpp"
#include "vision_options.hpp"

namespace fl::apps {
namespace {

namespace rec = fl::vision::record;

std::filesystem::path golden_path(const ReplayArgs& args) {
  if (!args.golden.empty()) return args.golden;
  std::filesystem::path path(args.recording);
  path.replace_extension(".golden.txt");
  return path;
}

}  // namespace

CLI::App* add_replay_subcommand(CLI::App& app, ReplayArgs& args) {
  CLI::App* replay = app.add_subcommand(
      "replay", "replay a recording through vision and controller, compare with its golden result");
  replay->add_option("recording", args.recording, "the MCAP recording")->required();
  replay->add_option("--golden", args.golden, "golden result (default: RECORDING.golden.txt)");
  replay->add_flag("--update-golden", args.update_golden, "write the replay as the new golden");
  replay->add_option("--max-diffs", args.max_differences, "differences printed in full")
      ->check(CLI::Range(0, 1000000));
  replay->add_option("--set", args.estimator_settings,
                     "estimator parameter NAME=VALUE (EstimatorParams), repeatable");
  replay->add_option("--config", args.config, "line configuration (default: the recorded one)");
  replay->add_option("--frames", args.frames,
                     "a camera node's recording (camera serve --record) whose frames the "
                     "controller's recording (control --record) is replayed with; repeatable");
  return replay;
}

int replay_command(const ReplayArgs& args) {
  rec::ReplayOptions options;
  const std::optional<vision::EstimatorParams> estimator =
      estimator_options(args.estimator_settings);
  if (!estimator) return 2;
  options.estimator = *estimator;
  if (!args.config.empty()) options.line_config = load_line_config(args.config);

  const auto wall_start = std::chrono::steady_clock::now();
  rec::ReplayResult result;
  std::int64_t recorded_ns = 0;
  try {
    rec::Recording recording = rec::load_recording(args.recording);
    for (const std::string& frames : args.frames) {
      rec::join_frames(recording, rec::load_recording(frames));
      spdlog::info("{}: frames joined from {}", args.recording, frames);
    }
    if (!recording.scans.empty()) {
      recorded_ns = recording.scans.back().input.time_ns - recording.scans.front().input.time_ns;
    }
    spdlog::info("{}: {} messages, {} scans{}", args.recording, recording.message_count,
                 recording.scans.size(),
                 recording.scans.empty() ? " (no line state: the vision replays alone)" : "");
    result = rec::replay(recording, options);
  } catch (const rec::RecordingError& error) {
    spdlog::error("cannot replay: {}", error.what());
    return 2;
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  spdlog::info(
      "replayed {} frames and {} scans in {:.2f} s{}", result.frames, result.scans, wall_s,
      recorded_ns > 0 && wall_s > 0.0
          ? fmt::format(" ({:.0f}x real time)", static_cast<double>(recorded_ns) / 1e9 / wall_s)
          : std::string());
  if (result.scans_with_recorded_output > 0) {
    if (result.scans_differing_from_recording == 0) {
      spdlog::info("every one of {} scans decided as recorded", result.scans_with_recorded_output);
    } else {
      spdlog::warn("{} of {} scans decided differently from the recording, the first scan {}",
                   result.scans_differing_from_recording, result.scans_with_recorded_output,
                   *result.first_scan_differing);
    }
  }
  if (result.frames_differing_from_recording > 0) {
    spdlog::info(
        "{} frames measure differently from the estimates recorded with them (the "
        "recording was made with another estimator or other parameters)",
        result.frames_differing_from_recording);
  }

  const std::filesystem::path golden = golden_path(args);
  const std::string name = std::filesystem::path(args.recording).filename().string();
  if (args.update_golden) {
    std::ofstream out(golden);
    if (!out) {
      spdlog::error("--golden {}: cannot open for writing", golden.string());
      return 2;
    }
    std::string settings;
    for (const std::string& setting : args.estimator_settings) settings += " --set " + setting;
    out << rec::format_golden(
        result.entries,
        "Golden result of `linectl replay " + name + settings +
            "` (docs/vision.md): what the estimator saw in each frame and what the controller\n"
            "decided in each scan whose outputs changed. Regenerate with --update-golden after\n"
            "checking every difference. " +
            std::to_string(result.frames) + " frames, " + std::to_string(result.scans) + " scans.");
    spdlog::info("golden result written to {} ({} entries)", golden.string(),
                 result.entries.size());
    return 0;
  }

  std::ifstream in(golden);
  if (!in) {
    spdlog::error("no golden result {} for {}: check the replay, then run with --update-golden",
                  golden.string(), args.recording);
    return 2;
  }
  std::stringstream text;
  text << in.rdbuf();
  std::vector<rec::GoldenEntry> expected;
  try {
    expected = rec::parse_golden(text.str(), golden.string());
  } catch (const std::runtime_error& error) {
    spdlog::error("{}", error.what());
    return 2;
  }
  const std::vector<rec::GoldenDifference> differences =
      rec::compare_golden(expected, result.entries);
  if (differences.empty()) {
    spdlog::info("{} matches {} ({} entries)", name, golden.string(), expected.size());
    return 0;
  }
  const std::size_t shown = std::min(differences.size(), args.max_differences);
  for (std::size_t i = 0; i < shown; ++i) {
    std::fputs(rec::format_difference(differences[i]).c_str(), stdout);
  }
  if (shown < differences.size()) {
    std::printf("... and %zu more differences\n", differences.size() - shown);
  }
  spdlog::error("{}: {} differences against {} (- golden, + replay)", name, differences.size(),
                golden.string());
  return 1;
}

}  // namespace fl::apps
