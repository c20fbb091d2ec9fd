// The line's cameras as both plants emulate them: exposures at each mount's period with
// jitter, one detection per item in view in camera-local coordinates with position and angle
// noise, misses, misclassification of hand, side and singulation, confidences, delivery into
// the input image after the camera's latency, and the injectable faults (dropped frames, NaN
// fields, stale camera, duplicates, out-of-order timestamps, phantom detections, a flooding
// detection count).
//
// The emulator knows nothing of how bodies move: a plant hands it its ground truth through a
// CameraScene at each of its steps, and it writes InputImage::cameras. Each camera draws from
// its own stream (kCameraStreamBase + index of the plant seed), in the same order for every
// plant: the fault draws of a frame, then per item in view (in the scene's order) the miss,
// x, y and angle noise, the singulation error, hand and side flips and the confidence.
// Nothing here allocates.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>

#include "fl/controller/line_config.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/twin/sensors/twin_rng.hpp"

namespace fl {

// Angle into (-pi, pi] (std::remainder is exact, so this is portable).
inline double wrap_angle_rad(double angle_rad) {
  // In range already: remainder() would return it unchanged, so skip the library call.
  if (angle_rad > -std::numbers::pi && angle_rad <= std::numbers::pi) return angle_rad;
  double wrapped = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (wrapped <= -std::numbers::pi) wrapped += 2.0 * std::numbers::pi;
  return wrapped;
}

// The measurement model of one camera (config/plant_fast.yaml, `cameras`).
struct CameraModelConfig {
  float latency_s = 0.02F;   // exposure to delivery into the input image
  float jitter_s = 0.0005F;  // exposure time jitter (sigma), clipped to a quarter period
  float position_sigma_mm = 2.0F;
  float angle_sigma_rad = 0.02F;
  bool classifies = false;  // reports hand and side; otherwise both are kUnknown
  float hand_flip_prob = 0.0F;
  float side_flip_prob = 0.0F;
  float singulation_error_prob = 0.01F;  // singulated flag reported wrong
  float miss_prob = 0.005F;              // an item in view missing from one frame
  // Confidence drawn uniformly: correct classifications high, misclassified or touching
  // items lower (so that a confidence threshold catches part of them).
  float confidence_ok_min = 0.75F;
  float confidence_ok_max = 0.99F;
  float confidence_bad_min = 0.35F;
  float confidence_bad_max = 0.8F;
  bool operator==(const CameraModelConfig&) const = default;
};

// Injectable faults of one camera, read at every exposure and delivery.
struct CameraFaults {
  float drop_frame_prob = 0.0F;    // a captured frame is never delivered
  float nan_prob = 0.0F;           // per frame: one field of one estimate is NaN
  float duplicate_prob = 0.0F;     // per frame: one detection is reported twice
  float out_of_order_prob = 0.0F;  // per frame: exposure time before the previous frame's
  float phantom_prob = 0.0F;       // per frame: a detection where there is no item
  bool stale = false;              // stops delivering: the input keeps its last frame
  bool flood = false;              // every frame's count claims 255 detections (at most 8 fit)
};
using CameraFaultSet = std::array<CameraFaults, kCameraCount>;

struct CameraCounters {
  std::array<std::uint64_t, kCameraCount> frames_captured{};
  std::array<std::uint64_t, kCameraCount> frames_published{};
  std::array<std::uint64_t, kCameraCount> frames_dropped{};        // drop fault or stale camera
  std::array<std::uint64_t, kCameraCount> frames_superseded{};     // two ready in one step
  std::array<std::uint64_t, kCameraCount> detections_truncated{};  // beyond 8 per frame
};

// What a camera can know of one item at the exposure, in line coordinates.
struct CameraTruth {
  double y_mm = 0.0;
  double angle_rad = 0.0;  // thick end to tip, CCW from travel, any range
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;  // true side up
  bool touching = false;           // one blob with another fillet: not singulated
};

// A plant's ground truth at one instant, item by item in a fixed order (the order is part of
// the random sequence). s_mm() is asked for every item at every exposure; truth() only for
// the items in a camera's field of view, so a plant may compute it lazily.
class CameraScene {
 public:
  [[nodiscard]] virtual std::size_t size() const = 0;
  [[nodiscard]] virtual double s_mm(std::size_t item) const = 0;  // centre along the line
  [[nodiscard]] virtual CameraTruth truth(std::size_t item) const = 0;

 protected:
  CameraScene() = default;
  CameraScene(const CameraScene&) = default;
  CameraScene& operator=(const CameraScene&) = default;
  ~CameraScene() = default;
};

class CameraEmulator {
 public:
  // step_ns: the plant's step; exposures happen at step ends, so a period shorter than a
  // step gives one frame per step.
  CameraEmulator(const std::array<CameraMount, kCameraCount>& mounts,
                 const std::array<CameraModelConfig, kCameraCount>& models, std::int64_t step_ns);

  // Empties the cameras, seeds their streams from the plant seed and draws each free-running
  // camera's phase from time_ns on.
  void reset(std::uint64_t seed, std::int64_t time_ns);

  // At the end of a plant step (time_ns): exposes every camera whose exposure is due.
  void capture_due(std::int64_t time_ns, const CameraScene& scene, const CameraFaultSet& faults);

  // Before the input image is handed out: the newest frame whose latency has passed replaces
  // the camera's frame in `frames` (an older one ready in the same step is superseded).
  void publish(std::int64_t time_ns, const CameraFaultSet& faults,
               std::array<CameraFrame, kCameraCount>& frames);

  [[nodiscard]] const CameraCounters& counters() const { return counters_; }
  [[nodiscard]] const CameraModelConfig& model(CameraId camera) const {
    return models_[index(camera)];
  }

 private:
  struct PendingFrame {
    CameraFrame frame;
    std::int64_t publish_ns = 0;
    bool out_of_order = false;  // fault: stamped before the previous frame when published
  };
  // More than any latency over period in the configuration needs (50 ms over 25 ms).
  static constexpr std::size_t kPendingFrames = 16;
  struct CameraState {
    std::int64_t next_nominal_ns = 0;
    std::int64_t next_exposure_ns = 0;
    std::uint32_t sequence = 0;
    std::int64_t last_frame_time_ns = 0;
    std::array<PendingFrame, kPendingFrames> pending{};
    std::size_t pending_count = 0;
  };

  void schedule_exposure(std::size_t camera, std::int64_t time_ns, bool first);
  void capture(std::size_t camera, std::int64_t time_ns, const CameraScene& scene,
               const CameraFaults& faults);

  std::array<CameraMount, kCameraCount> mounts_;
  std::array<CameraModelConfig, kCameraCount> models_;
  std::int64_t step_ns_;
  std::array<CameraState, kCameraCount> cameras_{};
  std::array<TwinRng, kCameraCount> rngs_{};
  CameraCounters counters_{};
};

}  // namespace fl
