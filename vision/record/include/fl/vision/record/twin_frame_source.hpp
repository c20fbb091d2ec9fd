// Frames of the digital twin's cameras: the top-down renderer (twin/render) fed with the
// fillets a plant holds at the frame's time, in the camera's own belt frame. The plant side is
// behind TwinScene so that this library knows no plant: apps/linectl adapts the fast plant's
// bodies and the DEM plant's fitted poses to it.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "fl/twin/render/fillet_renderer.hpp"
#include "fl/vision/accuracy.hpp"
#include "fl/vision/calibration.hpp"
#include "fl/vision/record/frame_source.hpp"

namespace fl::vision::record {

// What the renderer put in a frame, as the accuracy tally and the recordings' truth channel
// take it.
std::vector<TrueFillet> true_fillets(const render::RenderedFrame& frame);

// The twin's ground truth as a camera sees it, at the plant's current time.
class TwinScene {
 public:
  TwinScene() = default;
  TwinScene(const TwinScene&) = delete;
  TwinScene& operator=(const TwinScene&) = delete;
  virtual ~TwinScene() = default;
  [[nodiscard]] virtual std::int64_t time_ns() const = 0;
  // Fillets in the camera's belt frame (origin under the optical axis, x along travel).
  [[nodiscard]] virtual std::vector<render::FilletInstance> fillets() const = 0;
};

// Which side of the sensor runs along the belt. With the long side across, a 4:3 camera that
// sees config/line.yaml's 300 mm along travel sees 400 mm across: the line's whole belt, so
// fillets lying side by side are wholly in view. With it along, it sees 225 mm across.
enum class SensorMount { kLongSideAlongTravel, kLongSideAcrossTravel };

struct TwinCameraSettings {
  int width_px = 640;  // the delivered frame
  int height_px = 480;
  int binning = 1;  // sensor pixels averaged per delivered pixel and axis (render::RenderCamera)
  double field_along_travel_mm = 300.0;                    // config/line.yaml's field_of_view_mm
  SensorMount mount = SensorMount::kLongSideAcrossTravel;  // the whole belt width in view
  render::BeltAppearance belt;
  render::ImagingConditions imaging;
  std::uint64_t seed = 1;  // the frame's texture and noise seed is seed + sequence
  int supersampling = 2;
};

// Straight top-down camera (render::make_top_down_camera) over the field, turned a quarter
// turn for SensorMount::kLongSideAcrossTravel (travel runs up the image); its calibration is
// the exact inverse of the renderer's homography, as fl_calibrate would measure it.
class TwinFrameSource final : public FrameSource {
 public:
  TwinFrameSource(std::shared_ptr<const render::FilletRenderer> renderer, const TwinScene& scene,
                  TwinCameraSettings settings, std::string camera_name);
  // Renders the scene as it is now (no end: the plant decides when to stop).
  std::optional<SourceFrame> next() override;
  [[nodiscard]] std::string describe() const override;
  [[nodiscard]] const BeltCalibration& calibration() const { return calibration_; }
  [[nodiscard]] const render::RenderCamera& camera() const { return camera_; }
  // The fillets of the frame next() returned last, as they truly lay (camera belt frame).
  [[nodiscard]] const std::vector<TrueFillet>& last_truth() const { return last_truth_; }

 private:
  std::shared_ptr<const render::FilletRenderer> renderer_;
  const TwinScene& scene_;
  TwinCameraSettings settings_;
  render::RenderCamera camera_;
  BeltCalibration calibration_;
  std::uint32_t sequence_ = 0;
  std::vector<TrueFillet> last_truth_;
};

}  // namespace fl::vision::record
