// linectl record: the twin's cameras (rendered from the plant's ground truth, measured by the
// estimator, the controller acting on the estimates in lock step) or real cameras (a
// directory of images, a VideoCapture device or video file) into an MCAP recording.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>

#include "cli_support.hpp"
#include "duration.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "fl/vision/fillet_estimator.hpp"
#include "fl/vision/record/frame_source.hpp"
#include "fl/vision/record/recording.hpp"
#include "fl/vision/record/twin_frame_source.hpp"
#include "record_replay.hpp"
#include "vision_options.hpp"

namespace fl::apps {
namespace {

namespace rec = fl::vision::record;
constexpr std::int64_t kScanPeriodNs = 10'000'000;  // the controller's 10 ms scan
constexpr double kNsPerS = 1e9;
// Fillets whose centre lies farther than this outside a camera's field along travel cannot
// reach into the frame (the longest fillet of table 3.1 is 176 mm, at most 1.05 scaled).
constexpr double kRenderMarginMm = 100.0;

// The plant's fillets as one camera sees them (camera belt frame: x = s - mount).
class PlantScene final : public rec::TwinScene {
 public:
  PlantScene(const Plant& plant, const render::FilletRenderer& renderer, const CameraMount& mount)
      : plant_(plant), renderer_(renderer), mount_(mount) {}
  void set_time(std::int64_t time_ns) { time_ns_ = time_ns; }
  [[nodiscard]] std::int64_t time_ns() const override { return time_ns_; }

  [[nodiscard]] std::vector<render::FilletInstance> fillets() const override {
    std::vector<render::FilletInstance> out;
    const double half_field_mm = 0.5 * static_cast<double>(mount_.field_of_view_mm);
    const auto in_view = [&](double s_mm) {
      return std::abs(s_mm - static_cast<double>(mount_.s_mm)) <= half_field_mm + kRenderMarginMm;
    };
    if (const auto* fast = dynamic_cast<const FastPlant*>(&plant_)) {
      for (const FilletBody& body : fast->bodies()) {
        if (!in_view(body.s_mm)) continue;
        add_fast_body(body, out);
      }
    } else if (const auto* dem = dynamic_cast<const DemPlant*>(&plant_)) {
      for (const DemFilletView& view : dem->fillets()) {
        if (!in_view(view.s_mm)) continue;
        render::FilletInstance fillet;
        fillet.x_mm = view.s_mm - static_cast<double>(mount_.s_mm);
        fillet.y_mm = view.y_mm;
        fillet.angle_rad = view.angle_rad;
        fillet.hand = view.hand;
        fillet.side = view.side;
        // The template's table 3.1 size, drawn at its nominal length: the DEM fillet is that
        // mesh, not a scaled one.
        fillet.size_variant = view.size_variant;
        // Drawn bent as the engine bent it in the belt plane. Tighter than the renderer's
        // limit, the fillet is folded (on a plate, or over another); the arc is drawn at the
        // limit, as close as a bend in the plane gets.
        fillet.bend_per_mm =
            std::clamp(view.bend_per_mm, -render::kMaxBendPerMm, render::kMaxBendPerMm);
        fillet.group_id = view.touching ? static_cast<int>(view.group_id) : -1;
        out.push_back(fillet);
      }
    }
    return out;
  }

 private:
  void add_fast_body(const FilletBody& body, std::vector<render::FilletInstance>& out) const {
    const auto instance = [&](const FilletMember& member) {
      render::FilletInstance fillet;
      fillet.x_mm = body.s_mm - static_cast<double>(mount_.s_mm);
      fillet.y_mm = body.y_mm;
      fillet.angle_rad = body.angle_rad;
      fillet.hand = member.hand;
      fillet.side = member.side;
      fillet.size_variant = std::min<int>(member.variant, 2);
      const cv::Size2d nominal = renderer_.silhouette_size_mm(fillet.size_variant);
      fillet.scale =
          nominal.width > 0.0 ? static_cast<double>(member.length_mm) / nominal.width : 1.0;
      return fillet;
    };
    if (body.member_count < 2) {
      out.push_back(instance(body.members[0]));
      return;
    }
    // A touching pair lies side by side across the body's axis: the first member on the
    // right half, the partner pushed against it from the left.
    render::FilletInstance first = instance(body.members[0]);
    const double quarter_width_mm = 0.25 * static_cast<double>(body.width_mm);
    first.x_mm += quarter_width_mm * body.sin_angle;
    first.y_mm -= quarter_width_mm * body.cos_angle;
    // 2 mm flattened contact: clearly one blob, as two fillets pressed together.
    constexpr double kContactOverlapMm = 2.0;
    const render::FilletInstance partner =
        render::make_touching_partner(renderer_, first, instance(body.members[1]), true, 0.0, 0.0,
                                      kContactOverlapMm, static_cast<int>(body.group_id));
    out.push_back(first);
    out.push_back(partner);
  }

  const Plant& plant_;
  const render::FilletRenderer& renderer_;
  CameraMount mount_;
  std::int64_t time_ns_ = 0;
};

// One rendered camera: scene, renderer source, estimator and the estimates in flight.
struct CameraRig {
  CameraId camera = CameraId::kOrientation;
  std::unique_ptr<PlantScene> scene;
  std::unique_ptr<rec::TwinFrameSource> source;
  std::unique_ptr<vision::FilletEstimator> estimator;
  std::int64_t period_ns = 0;
  std::int64_t next_exposure_ns = 0;
  std::deque<std::pair<std::int64_t, CameraFrame>> in_flight;  // (delivery time, frame)
  CameraFrame delivered{};
};

int record_twin(const RecordArgs& args, double duration_s) {
  const std::filesystem::path config_file = config_or_default(args.config, "line.yaml");
  const LineConfig line = load_line_config(config_file);
  std::unique_ptr<Plant> plant = make_plant(args.plant, args.plant_config, line);
  auto renderer = std::make_shared<render::FilletRenderer>();

  rec::WriterSettings settings;
  settings.png_compression = args.png_compression;
  settings.info = {
      {"source", "twin"},
      {"plant", args.plant},
      {"seed", std::to_string(args.seed)},
      {"duration_s", std::to_string(duration_s)},
      {"frame_size_px", std::to_string(args.width_px) + "x" + std::to_string(args.height_px)},
      {"binning", std::to_string(args.binning)},
      {"sensor_mount", args.sensor_mount},
      {"latency_ms", std::to_string(args.latency_ms)}};
  rec::RecordingWriter writer(args.out, settings);
  writer.attach_line_config(read_text(config_file));

  std::vector<CameraRig> rigs;
  std::array<bool, kCameraCount> rendered{};
  for (const std::string& name : args.cameras) {
    const std::optional<CameraId> camera = rec::camera_from_name(name);
    if (!camera) throw std::invalid_argument("--cameras " + name + ": unknown camera");
    if (rendered[index(*camera)]) throw std::invalid_argument("--cameras " + name + ": twice");
    rendered[index(*camera)] = true;
    const CameraMount& mount = line.cameras[index(*camera)];
    CameraRig rig;
    rig.camera = *camera;
    rig.scene = std::make_unique<PlantScene>(*plant, *renderer, mount);
    rec::TwinCameraSettings camera_settings;
    camera_settings.width_px = args.width_px;
    camera_settings.height_px = args.height_px;
    camera_settings.binning = args.binning;
    camera_settings.field_along_travel_mm = static_cast<double>(mount.field_of_view_mm);
    camera_settings.mount = args.sensor_mount == "along" ? rec::SensorMount::kLongSideAlongTravel
                                                         : rec::SensorMount::kLongSideAcrossTravel;
    camera_settings.belt.grain_amplitude = args.belt_grain;
    camera_settings.imaging.noise_sigma = args.noise_sigma;
    camera_settings.seed = args.seed * 1000 + index(*camera);
    rig.source = std::make_unique<rec::TwinFrameSource>(renderer, *rig.scene, camera_settings,
                                                        std::string(name));
    rig.estimator = std::make_unique<vision::FilletEstimator>(rig.source->calibration());
    rig.period_ns = std::llround(static_cast<double>(mount.period_s) * kNsPerS);
    rigs.push_back(std::move(rig));
  }
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const auto camera = static_cast<CameraId>(c);
    std::optional<vision::BeltCalibration> calibration;
    for (const CameraRig& rig : rigs) {
      if (rig.camera == camera) calibration = rig.source->calibration();
    }
    writer.add_camera(camera, calibration);
  }
  std::string camera_list;
  for (const std::string& name : args.cameras) {
    camera_list += (camera_list.empty() ? "" : ", ") + name;
  }
  spdlog::info("recording the {} plant (seed {}) for {} s into {}: frames of {} at {} x {} px",
               plant->name(), args.seed, duration_s, args.out, camera_list, args.width_px,
               args.height_px);

  LineController controller(line);
  InputImage in;
  OutputImage out;
  plant->reset(args.seed, in);
  controller.reset();
  const auto latency_ns = std::llround(args.latency_ms * 1e6);
  const auto scans = static_cast<std::uint64_t>(
      std::llround(duration_s * kNsPerS / static_cast<double>(kScanPeriodNs)));
  std::array<CameraFrame, kCameraCount> last_recorded{};
  int last_decile = -1;
  for (std::uint64_t scan = 0; scan < scans; ++scan) {
    for (CameraRig& rig : rigs) {
      if (in.time_ns >= rig.next_exposure_ns) {
        rig.scene->set_time(in.time_ns);
        rec::SourceFrame frame = *rig.source->next();
        // Frame sequences count from 1: the controller treats sequence 0 as "no frame yet".
        const std::uint32_t sequence = frame.sequence + 1;
        const vision::FrameResult result = rig.estimator->estimate(frame.bgr, in.time_ns, sequence);
        if (result.status != vision::FrameStatus::kOk) {
          spdlog::warn("camera {} frame {}: {} ({})", rec::camera_name(rig.camera), sequence,
                       vision::to_string(result.status), result.message);
        }
        writer.write_frame(rig.camera, sequence, in.time_ns, frame.bgr);
        writer.write_truth(rig.camera, sequence, in.time_ns, rig.source->last_truth());
        // A refused frame is recorded (replay measures it again) but, as from a camera node,
        // not delivered to the controller.
        if (result.deliverable()) {
          rig.in_flight.emplace_back(in.time_ns + latency_ns, result.to_camera_frame());
        }
        rig.next_exposure_ns += rig.period_ns;
      }
      while (!rig.in_flight.empty() && rig.in_flight.front().first <= in.time_ns) {
        rig.delivered = rig.in_flight.front().second;
        rig.in_flight.pop_front();
      }
      // The vision's estimates replace the plant's emulated ones for this camera.
      in.cameras[index(rig.camera)] = rig.delivered;
    }
    // The operator's start, through the input image so that the replay sees it too.
    if (scan == 0) in.start_request = true;
    for (std::size_t c = 0; c < kCameraCount; ++c) {
      const CameraFrame& frame = in.cameras[c];
      if (frame.sequence != last_recorded[c].sequence ||
          frame.frame_time_ns != last_recorded[c].frame_time_ns) {
        writer.write_estimates(static_cast<CameraId>(c), in.time_ns, frame);
        last_recorded[c] = frame;
      }
    }
    controller.update(in, out);
    writer.write_scan(scan, in, out);
    while (auto event = controller.events().pop()) {
      spdlog::debug("{} item {} at {:.3f} s", to_string(event->code), event->item_id,
                    static_cast<double>(event->time_ns) / kNsPerS);
    }
    while (auto record = controller.closed_records().pop()) {
      spdlog::debug("item {} closed: {}", record->id, to_string(record->outcome));
    }
    (void)plant->drain_exits();
    const int decile = static_cast<int>(10 * (scan + 1) / scans);
    if (decile != last_decile) {
      last_decile = decile;
      spdlog::info("recorded {:.1f} of {:.1f} s: {} frames, {:.0f} kB",
                   static_cast<double>(in.time_ns) / kNsPerS, duration_s, writer.frames_written(),
                   static_cast<double>(writer.bytes_written()) / 1e3);
    }
    plant->step(out, kScanPeriodNs, in);
  }
  writer.close();
  spdlog::info(
      "{}: {} scans, {} frames ({:.0f} kB of PNG), {:.0f} kB in all; items created {}, "
      "closed {}",
      args.out, scans, writer.frames_written(), static_cast<double>(writer.frame_bytes()) / 1e3,
      static_cast<double>(std::filesystem::file_size(args.out)) / 1e3,
      controller.counters().items_created, controller.counters().items_closed);
  return 0;
}

int record_camera(const RecordArgs& args, double duration_s) {
  if (args.calibration.empty()) {
    spdlog::error("--calibration: a real camera needs its belt calibration (fl_calibrate)");
    return 2;
  }
  const std::optional<CameraId> camera = camera_option(args.camera);
  if (!camera) return 2;
  if (!(args.fps > 0.0)) {
    spdlog::error("--fps {}: must be positive", args.fps);
    return 2;
  }
  const vision::BeltCalibration calibration = vision::load_calibration(args.calibration);
  const auto period_ns = std::llround(kNsPerS / args.fps);
  const std::unique_ptr<rec::FrameSource> source =
      open_camera_frames(args.images_dir, args.video_file, args.device, period_ns);
  rec::WriterSettings settings;
  settings.png_compression = args.png_compression;
  settings.info = {{"source", source->describe()}, {"camera", args.camera}};
  rec::RecordingWriter writer(args.out, settings);
  writer.add_camera(*camera, calibration);
  vision::FilletEstimator estimator(calibration);
  spdlog::info("recording {} as camera {} into {} (at most {} s)", source->describe(), args.camera,
               args.out, duration_s);
  const auto duration_ns = std::llround(duration_s * kNsPerS);
  std::uint64_t problems = 0;
  while (auto frame = source->next()) {
    if (frame->time_ns > duration_ns) break;
    const std::uint32_t sequence = frame->sequence + 1;  // 0 means "no frame yet"
    const vision::FrameResult result = estimator.estimate(frame->bgr, frame->time_ns, sequence);
    if (result.status != vision::FrameStatus::kOk) {
      ++problems;
      spdlog::warn("{}: {} ({})", frame->origin, vision::to_string(result.status), result.message);
    }
    writer.write_frame(*camera, sequence, frame->time_ns, frame->bgr);
    writer.write_estimates(*camera, frame->time_ns, result.to_camera_frame());
    if (writer.frames_written() % 25 == 0) {
      spdlog::info("{} frames, {:.0f} kB", writer.frames_written(),
                   static_cast<double>(writer.bytes_written()) / 1e3);
    }
  }
  writer.close();
  spdlog::info("{}: {} frames ({} not measurable), {:.0f} kB", args.out, writer.frames_written(),
               problems, static_cast<double>(std::filesystem::file_size(args.out)) / 1e3);
  return writer.frames_written() > 0 ? 0 : 1;
}

}  // namespace

CLI::App* add_record_subcommand(CLI::App& app, RecordArgs& args) {
  CLI::App* record = app.add_subcommand(
      "record", "record camera frames, estimates and line state into an MCAP file");
  auto* plant = record->add_option("--plant", args.plant, "record the twin's cameras: fast or dem")
                    ->check(CLI::IsMember({"fast", "dem"}));
  auto* images = record->add_option("--images", args.images_dir, "record a directory of images");
  auto* device =
      record->add_option("--device", args.device, "record camera device N (VideoCapture)");
  auto* video =
      record->add_option("--video", args.video_file, "record a video file (VideoCapture)");
  plant->excludes(images, device, video);
  images->excludes(device, video);
  device->excludes(video);
  record->add_option("--out", args.out, "the MCAP file to write")->required();
  record->add_option("--duration", args.duration, "recording length, e.g. 9s, 2m");
  record->add_option("--seed", args.seed, "plant seed (twin)");
  record->add_option("--config", args.config, "line configuration (twin)");
  record->add_option("--plant-config", args.plant_config, "plant configuration (twin)");
  record->add_option("--cameras", args.cameras, "twin cameras with frames (others: estimates only)")
      ->delimiter(',');
  record->add_option("--width", args.width_px, "twin frame width, px")->check(CLI::Range(64, 4096));
  record->add_option("--height", args.height_px, "twin frame height, px")
      ->check(CLI::Range(48, 4096));
  record
      ->add_option("--binning", args.binning,
                   "twin cameras bin N x N sensor pixels into one (the line cameras: "
                   "--width 640 --height 512 --binning 2)")
      ->check(CLI::Range(1, 4));
  record
      ->add_option("--sensor-mount", args.sensor_mount,
                   "twin cameras: the sensor's long side across the belt (whole width) or along")
      ->check(CLI::IsMember({"across", "along"}));
  record->add_option("--noise", args.noise_sigma, "twin sensor noise sigma, grey levels")
      ->check(CLI::Range(0.0, 50.0));
  record->add_option("--belt-grain", args.belt_grain, "twin belt texture amplitude, grey levels")
      ->check(CLI::Range(0.0, 50.0));
  record->add_option("--latency-ms", args.latency_ms, "twin: exposure to estimate delivery, ms")
      ->check(CLI::Range(0.0, 1000.0));
  record->add_option("--png-level", args.png_compression, "PNG compression 0..9")
      ->check(CLI::Range(0, 9));
  record->add_option("--calibration", args.calibration, "real camera: belt calibration YAML");
  record->add_option("--camera", args.camera, "real camera: which line camera it is");
  record->add_option("--fps", args.fps, "--images/--video: frame rate to stamp frames with");
  return record;
}

int record_command(const RecordArgs& args) {
  const std::optional<double> duration_s = parse_duration_s(args.duration);
  if (!duration_s) {
    spdlog::error("--duration {}: not a positive duration (examples: 9s, 2m)", args.duration);
    return 2;
  }
  if (!args.plant.empty()) return record_twin(args, *duration_s);
  if (args.images_dir.empty() && args.device < 0 && args.video_file.empty()) {
    spdlog::error(
        "record: name a source: --plant fast|dem, --images DIR, --device N or --video FILE");
    return 2;
  }
  return record_camera(args, *duration_s);
}

}  // namespace fl::apps
