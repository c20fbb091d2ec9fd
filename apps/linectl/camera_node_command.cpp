// linectl camera serve: the estimator as a camera node on DDS (camera_node_command.hpp).
#include "camera_node_command.hpp"

#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <ctime>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "cli_support.hpp"
#include "duration.hpp"
#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/monotonic_clock.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "fl/drivers/dds/qos.hpp"
#include "fl/vision/fillet_estimator.hpp"
#include "fl/vision/record/frame_source.hpp"
#include "fl/vision/record/recording.hpp"
#include "fl/vision/record/replay.hpp"
#include "vision_options.hpp"

namespace fl::apps {
namespace {

namespace dds = fl::drivers::dds;
namespace rec = fl::vision::record;

constexpr double kNsPerS = 1e9;
// Frames stamped on arrival (a camera's own recording) spread around their nominal period:
// a 25 Hz camera's median spacing may read a little over 40 ms. Sources up to this much
// slower than the slowest line camera are served.
constexpr double kPeriodTolerance = 1.1;
constexpr std::int64_t kAckTimeoutNs = 1'000'000'000;  // for the last frames at the end
constexpr double kProgressEveryS = 10.0;

std::atomic<bool> g_camera_interrupted{false};
extern "C" void on_camera_signal(int /*signal*/) { g_camera_interrupted.store(true); }

struct NodeStats {
  std::uint64_t frames_read = 0;
  std::uint64_t frames_published = 0;
  std::uint64_t frames_unreadable = 0;    // the source could not deliver them (logged)
  std::uint64_t frames_refused = 0;       // the estimator refused them: not published
  std::uint64_t frames_dropped_late = 0;  // due before the node was done with the previous
  std::uint64_t publish_failures = 0;
  std::uint64_t fillets_published = 0;
  std::map<std::string, std::uint64_t> frame_status;  // by vision::FrameStatus name
};

// The source the options name, and its frame period.
struct OpenedSource {
  std::unique_ptr<rec::FrameSource> source;
  std::optional<vision::BeltCalibration> recorded_calibration;
  std::int64_t period_ns = 0;  // between frames at the source's own pace
  bool live = false;           // a device: frames are stamped when they arrive, not paced
};

// nullopt (logged) when the options do not name exactly one usable source.
std::optional<OpenedSource> open_source(const CameraServeArgs& args, CameraId camera) {
  const int named = static_cast<int>(!args.recording.empty()) +
                    static_cast<int>(!args.images_dir.empty()) +
                    static_cast<int>(!args.video_file.empty()) + static_cast<int>(args.device >= 0);
  if (named != 1) {
    spdlog::error(
        "camera serve: name exactly one source: --recording, --images, --video or "
        "--device ({} given)",
        named);
    return std::nullopt;
  }
  const auto period_ns = std::llround(kNsPerS / args.fps);
  OpenedSource opened;
  try {
    if (!args.recording.empty()) {
      auto source = std::make_unique<rec::RecordingFrameSource>(args.recording, camera);
      opened.recorded_calibration = source->calibration();
      opened.period_ns = source->median_period_ns() > 0 ? source->median_period_ns() : period_ns;
      opened.source = std::move(source);
    } else {
      opened.source = open_camera_frames(args.images_dir, args.video_file, args.device, period_ns);
      // A video file paces at its own frame rate; a device's frames are stamped as they come.
      opened.period_ns = opened.source->period_ns();
      opened.live = args.device >= 0;
    }
  } catch (const std::exception& error) {
    spdlog::error("camera serve: {}", error.what());
    return std::nullopt;
  }
  return opened;
}

std::optional<vision::BeltCalibration> choose_calibration(const CameraServeArgs& args,
                                                          const OpenedSource& opened) {
  if (!args.calibration.empty()) {
    try {
      return vision::load_calibration(args.calibration);
    } catch (const std::exception& error) {
      spdlog::error("--calibration: {}", error.what());
      return std::nullopt;
    }
  }
  if (opened.recorded_calibration) return opened.recorded_calibration;
  spdlog::error(
      "--calibration: this source has no belt calibration of its own; name the "
      "camera's (fl_calibrate writes it, config/camera_<name>.yaml)");
  return std::nullopt;
}

nlohmann::json stats_json(const CameraServeArgs& args, const NodeStats& stats,
                          const DurationHistogram& estimate, const DurationHistogram& lateness,
                          double wall_s) {
  return {{"camera", args.camera},
          {"wall_s", wall_s},
          {"frames_read", stats.frames_read},
          {"frames_published", stats.frames_published},
          {"frames_unreadable", stats.frames_unreadable},
          {"frames_refused", stats.frames_refused},
          {"frames_dropped_late", stats.frames_dropped_late},
          {"publish_failures", stats.publish_failures},
          {"fillets_published", stats.fillets_published},
          {"frame_status", stats.frame_status},
          {"estimate_us", summary_json(estimate.summary())},
          {"exposure_to_publish_us", summary_json(lateness.summary())}};
}

}  // namespace

CLI::App* add_camera_subcommand(CLI::App& app, CameraServeArgs& args) {
  CLI::App* camera = app.add_subcommand("camera", "camera node tools");
  camera->require_subcommand(1);
  CLI::App* serve = camera->add_subcommand(
      "serve", "measure frames with the estimator and publish the estimates on DDS");
  serve->add_option("--camera", args.camera,
                    "which line camera: orientation, position, multilane1, multilane2, final");
  serve->add_option("--calibration", args.calibration,
                    "the camera's belt calibration (YAML; default: a recording's own)");
  serve->add_option("--recording", args.recording, "serve this camera's frames of an MCAP file");
  serve->add_option("--images", args.images_dir, "serve a directory of images, in name order");
  serve->add_option("--video", args.video_file, "serve a video file");
  serve->add_option("--device", args.device, "serve a camera device (VideoCapture index)")
      ->check(CLI::NonNegativeNumber);
  serve->add_option("--fps", args.fps, "frame rate of --images (and of a video without one)")
      ->check(CLI::PositiveNumber);
  serve->add_option("--speed", args.speed, "files: serve at this multiple of their pace")
      ->check(CLI::Range(0.01, 100.0));
  serve->add_option("--duration", args.duration,
                    "stop after this long, e.g. 60s (default: "
                    "when the source ends)");
  serve->add_option("--set", args.estimator_settings, "estimator parameter NAME=VALUE");
  serve->add_option("--domain", args.domain, "DDS domain id (default: CYCLONEDDS_URI's)")
      ->check(CLI::Range(0, 232));
  serve->add_option("--wait", args.wait, "how long to wait for a reader, e.g. 30s");
  serve->add_option("--json", args.json_path, "write the node's statistics as JSON");
  serve->add_option("--record", args.record_path,
                    "record every frame served and the estimates published (MCAP); linectl "
                    "replay --frames joins it with the controller's --record");
  return serve;
}

int camera_serve_command(const CameraServeArgs& args) {
  // From the start, so that a stop while a recording loads or a reader is awaited counts.
  std::signal(SIGINT, on_camera_signal);
  std::signal(SIGTERM, on_camera_signal);
  const std::optional<CameraId> camera = camera_option(args.camera);
  if (!camera) return 2;
  const std::optional<double> wait_s = parse_duration_s(args.wait);
  std::optional<double> duration_s;
  if (!args.duration.empty()) duration_s = parse_duration_s(args.duration);
  if (!wait_s || (!args.duration.empty() && !duration_s)) {
    spdlog::error("--wait {} / --duration {}: not a positive duration (examples: 30s, 10m)",
                  args.wait, args.duration);
    return 2;
  }
  const std::optional<vision::EstimatorParams> params = estimator_options(args.estimator_settings);
  if (!params) return 2;
  std::optional<OpenedSource> opened = open_source(args, *camera);
  if (!opened) return 2;
  const std::optional<vision::BeltCalibration> calibration = choose_calibration(args, *opened);
  if (!calibration) return 2;

  // The controller's reader expects a frame at least every slowest-camera period (3 of them
  // are its deadline); a source clearly slower than that would keep tripping it and the
  // controller's silence limit: refuse it here. A device's rate is its own; its stalls show
  // as the controller's stale camera.
  const std::int64_t period_ns =
      opened->live ? dds::kSlowestCameraPeriodNs
                   : std::llround(static_cast<double>(opened->period_ns) / args.speed);
  if (static_cast<double>(period_ns) >
      kPeriodTolerance * static_cast<double>(dds::kSlowestCameraPeriodNs)) {
    spdlog::error(
        "{} at --speed {}: a frame every {:.1f} ms is slower than the line's slowest "
        "camera ({:.0f} ms); the controller would call this camera stale",
        opened->source->describe(), args.speed, static_cast<double>(period_ns) / 1e6,
        static_cast<double>(dds::kSlowestCameraPeriodNs) / 1e6);
    return 2;
  }
  std::unique_ptr<vision::FilletEstimator> estimator;
  try {
    estimator = std::make_unique<vision::FilletEstimator>(*calibration, *params);
  } catch (const std::invalid_argument& error) {
    spdlog::error("camera serve: {}", error.what());
    return 2;
  }

  std::unique_ptr<rec::RecordingWriter> recorder;
  if (!args.record_path.empty()) {
    rec::WriterSettings settings;
    settings.info = {{"source", "linectl camera serve: " + opened->source->describe()},
                     {"camera", args.camera}};
    try {
      recorder = std::make_unique<rec::RecordingWriter>(args.record_path, settings);
      recorder->add_camera(*camera, *calibration);
    } catch (const std::exception& error) {
      spdlog::error("camera serve: --record {}: {}", args.record_path, error.what());
      return 2;
    }
  }

  const dds_domainid_t domain =
      args.domain < 0 ? DDS_DOMAIN_DEFAULT : static_cast<dds_domainid_t>(args.domain);
  dds::Participant participant(domain);
  dds::DdsCameraPublisher publisher(participant, dds::kSlowestCameraPeriodNs);

  spdlog::info("camera {}: {}; waiting up to {} s for a reader of the estimates", args.camera,
               opened->source->describe(), *wait_s);
  if (!wait_until([&] { return publisher.matched_readers() > 0; }, *wait_s,
                  [] { return g_camera_interrupted.load(); }, std::chrono::milliseconds(5))) {
    if (g_camera_interrupted.load()) {
      spdlog::info("camera {}: stopped before a reader matched; nothing published", args.camera);
      return 1;
    }
    spdlog::error(
        "camera {}: no reader matched the estimates topic within {} s (is linectl "
        "control running on the same domain and CYCLONEDDS_URI?)",
        args.camera, *wait_s);
    return 4;
  }

  NodeStats stats;
  DurationHistogram estimate_time(10'000, 100'000'000);  // 10 us bins up to 100 ms
  DurationHistogram lateness(10'000, 100'000'000);
  const std::int64_t start_ns = monotonic_now_ns();
  const std::int64_t end_ns = duration_s ? start_ns + std::llround(*duration_s * kNsPerS)
                                         : std::numeric_limits<std::int64_t>::max();
  std::int64_t next_progress_ns = start_ns + std::llround(kProgressEveryS * kNsPerS);
  bool source_failed = false;
  while (!g_camera_interrupted.load()) {
    std::optional<rec::SourceFrame> frame;
    try {
      frame = opened->source->next();
    } catch (const std::exception& error) {  // OpenCV's errors too
      // A file that does not read: logged and counted, the next one served; the controller
      // sees a sequence gap, as for a frame a real camera lost.
      ++stats.frames_unreadable;
      spdlog::error("camera {}: {}", args.camera, error.what());
      if (opened->live) {
        source_failed = true;
        break;
      }
      continue;
    }
    if (!frame) {
      // A file ends; a camera device does not: its end is a camera that stopped delivering.
      if (opened->live && !g_camera_interrupted.load()) {
        spdlog::error("camera {}: {} stopped delivering frames", args.camera,
                      opened->source->describe());
        source_failed = true;
      }
      break;
    }
    ++stats.frames_read;
    // Exposure on this host's CLOCK_MONOTONIC, which the controller's frame ages are on. A
    // file's frames keep their own spacing (scaled by --speed) from the start; a device's
    // frame is stamped on arrival.
    std::int64_t exposure_ns = monotonic_now_ns();
    if (!opened->live) {
      exposure_ns = start_ns + std::llround(static_cast<double>(frame->time_ns) / args.speed);
      if (exposure_ns > end_ns) break;
      // Not served before its successor was due: dropped, as a camera drops frames its host
      // does not take in time (the controller wants the newest frame, not a queue).
      if (monotonic_now_ns() > exposure_ns + period_ns) {
        ++stats.frames_dropped_late;
        continue;
      }
      sleep_until_ns(exposure_ns, g_camera_interrupted);
      if (g_camera_interrupted.load()) break;
    } else if (exposure_ns > end_ns) {
      break;
    }
    const std::uint32_t sequence = frame->sequence + 1;  // 0 is "no frame yet" on the wire
    const std::int64_t estimate_start_ns = monotonic_now_ns();
    const vision::FrameResult result = estimator->estimate(frame->bgr, exposure_ns, sequence);
    estimate_time.record(monotonic_now_ns() - estimate_start_ns);
    ++stats.frame_status[std::string(vision::to_string(result.status))];
    bool published = false;
    if (!result.deliverable()) {
      // Not "no fillet": the frame shows nothing of the belt. Its sequence stays a gap; a
      // camera that keeps refusing misses its DDS deadline and the controller's silence limit.
      ++stats.frames_refused;
      spdlog::warn("camera {}: {}: {} ({}); not published", args.camera, frame->origin,
                   vision::to_string(result.status), result.message);
    } else {
      const CameraFrame estimates = result.to_camera_frame();
      try {
        publisher.publish(*camera, estimates);
        ++stats.frames_published;
        stats.fillets_published += estimates.count;
        published = true;
      } catch (const std::exception& error) {
        ++stats.publish_failures;
        spdlog::error("camera {}: frame {} not published: {}", args.camera, sequence, error.what());
      }
    }
    // After publishing, so that the PNG encoding never delays the estimates: every frame
    // under the sequence and exposure it was measured with, and what was published of it.
    if (recorder) {
      recorder->write_frame(*camera, sequence, exposure_ns, frame->bgr);
      if (published) recorder->write_estimates(*camera, exposure_ns, result.to_camera_frame());
    }
    const std::int64_t now_ns = monotonic_now_ns();
    lateness.record(now_ns - exposure_ns);
    if (now_ns >= next_progress_ns) {
      next_progress_ns += std::llround(kProgressEveryS * kNsPerS);
      spdlog::info("camera {}: {} frames published, {} fillets, {} readers", args.camera,
                   stats.frames_published, stats.fillets_published, publisher.matched_readers());
    }
  }
  // Reliable delivery of the last frames before the writer goes: a reader that has not
  // acknowledged them within a second is gone or stalled, and the log says so.
  if (recorder) {
    recorder->close();
    spdlog::info("camera {}: {} frames recorded to {}", args.camera, recorder->frames_written(),
                 args.record_path);
  }
  if (dds_wait_for_acks(publisher.writer(), kAckTimeoutNs) != DDS_RETCODE_OK) {
    spdlog::warn("camera {}: not every reader acknowledged the last frames within 1 s",
                 args.camera);
  }
  const double wall_s = static_cast<double>(monotonic_now_ns() - start_ns) / kNsPerS;
  const DistributionSummary estimate_summary = estimate_time.summary();
  const DistributionSummary lateness_summary = lateness.summary();
  std::printf(
      "camera %s: %llu frames read, %llu published (%llu fillets), %llu unreadable, "
      "%llu refused, %llu dropped late, in %.1f s\n",
      args.camera.c_str(), static_cast<unsigned long long>(stats.frames_read),
      static_cast<unsigned long long>(stats.frames_published),
      static_cast<unsigned long long>(stats.fillets_published),
      static_cast<unsigned long long>(stats.frames_unreadable),
      static_cast<unsigned long long>(stats.frames_refused),
      static_cast<unsigned long long>(stats.frames_dropped_late), wall_s);
  std::printf(
      "estimate        p50 %.0f us, p99 %.0f us, max %.0f us; exposure to publish p99 "
      "%.0f us\n",
      static_cast<double>(estimate_summary.p50_ns) / 1e3,
      static_cast<double>(estimate_summary.p99_ns) / 1e3,
      static_cast<double>(estimate_summary.max_ns) / 1e3,
      static_cast<double>(lateness_summary.p99_ns) / 1e3);
  std::fflush(stdout);
  if (!args.json_path.empty() &&
      !write_json_option(args.json_path,
                         stats_json(args, stats, estimate_time, lateness, wall_s))) {
    return 1;
  }
  if (source_failed) return 1;
  return stats.frames_published > 0 ? 0 : 1;
}

}  // namespace fl::apps
