#include "fl/vision/record/twin_frame_source.hpp"

#include <numbers>
#include <stdexcept>

namespace fl::vision::record {

std::vector<TrueFillet> true_fillets(const render::RenderedFrame& frame) {
  std::vector<TrueFillet> fillets;
  fillets.reserve(frame.truth.size());
  for (const render::FilletTruth& truth : frame.truth) {
    TrueFillet fillet;
    fillet.x_mm = truth.fillet.x_mm;
    fillet.y_mm = truth.fillet.y_mm;
    fillet.angle_rad = truth.fillet.angle_rad;
    fillet.hand = truth.fillet.hand;
    fillet.side = truth.fillet.side;
    fillet.group_id = truth.fillet.group_id;
    fillet.singulated = truth.singulated;
    fillet.fully_visible = truth.fully_visible;
    fillet.gap_mm = truth.gap_to_nearest_mm;
    fillets.push_back(fillet);
  }
  return fillets;
}

TwinFrameSource::TwinFrameSource(std::shared_ptr<const render::FilletRenderer> renderer,
                                 const TwinScene& scene, TwinCameraSettings settings,
                                 std::string camera_name)
    : renderer_(std::move(renderer)), scene_(scene), settings_(std::move(settings)) {
  if (!renderer_) throw std::invalid_argument("TwinFrameSource needs a renderer");
  if (settings_.width_px <= 0 || settings_.height_px <= 0 || settings_.binning < 1 ||
      !(settings_.field_along_travel_mm > 0.0)) {
    throw std::invalid_argument("twin camera " + camera_name +
                                ": size, binning and field must be positive");
  }
  const bool across = settings_.mount == SensorMount::kLongSideAcrossTravel;
  const int px_along_travel = across ? settings_.height_px : settings_.width_px;
  camera_ = render::make_top_down_camera(
      settings_.width_px, settings_.height_px,
      settings_.field_along_travel_mm / static_cast<double>(px_along_travel),
      across ? 0.5 * std::numbers::pi : 0.0);
  camera_.binning = settings_.binning;
  calibration_.camera_name = std::move(camera_name);
  calibration_.image_width_px = settings_.width_px;
  calibration_.image_height_px = settings_.height_px;
  calibration_.image_to_belt = camera_.belt_to_image.inv();
  calibration_.reprojection_rms_px = 0.0;
}

std::optional<SourceFrame> TwinFrameSource::next() {
  render::Scene scene;
  scene.fillets = scene_.fillets();
  scene.belt = settings_.belt;
  scene.imaging = settings_.imaging;
  scene.seed = settings_.seed + sequence_;
  scene.supersampling = settings_.supersampling;
  SourceFrame frame;
  render::RenderedFrame rendered = renderer_->render(camera_, scene);
  frame.bgr = std::move(rendered.bgr);
  last_truth_ = true_fillets(rendered);
  frame.time_ns = scene_.time_ns();
  frame.sequence = sequence_++;
  frame.origin = "twin camera " + calibration_.camera_name;
  return frame;
}

std::string TwinFrameSource::describe() const {
  return "twin camera " + calibration_.camera_name + " (" + std::to_string(settings_.width_px) +
         " x " + std::to_string(settings_.height_px) + " px" +
         (settings_.binning > 1 ? ", binned " + std::to_string(settings_.binning) + " x " +
                                      std::to_string(settings_.binning)
                                : std::string()) +
         " over " + std::to_string(settings_.field_along_travel_mm) +
         " mm along travel, long side " +
         (settings_.mount == SensorMount::kLongSideAcrossTravel ? "across" : "along") + ")";
}

}  // namespace fl::vision::record
