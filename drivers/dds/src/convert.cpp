#include "fl/drivers/dds/convert.hpp"

#include <cmath>
#include <cstring>
#include <type_traits>

namespace fl::drivers::dds {

// The IDL mirrors the process image; these break the build when one side changes alone.
static_assert(fl_CAMERA_COUNT == kCameraCount);
static_assert(fl_MAX_ESTIMATES_PER_FRAME == kMaxEstimatesPerFrame);
static_assert(fl_DRIVE_COUNT == kDriveCount);
static_assert(sizeof(fl_CameraEstimates::estimates) / sizeof(fl_FilletEstimate) ==
              kMaxEstimatesPerFrame);
static_assert(static_cast<int>(fl_HAND_LEFT) == static_cast<int>(Hand::kLeft));
static_assert(static_cast<int>(fl_HAND_RIGHT) == static_cast<int>(Hand::kRight));
static_assert(static_cast<int>(fl_SIDE_SKIN) == static_cast<int>(SideUp::kSkin));
static_assert(static_cast<int>(fl_SIDE_BONE) == static_cast<int>(SideUp::kBone));
static_assert(static_cast<int>(fl_LINE_FAULT) == static_cast<int>(LineState::kFault));

const char* to_string(RejectReason reason) noexcept {
  switch (reason) {
    case RejectReason::kCameraIdOutOfRange:
      return "camera id out of range";
    case RejectReason::kCountOverCapacity:
      return "estimate count over capacity";
    case RejectReason::kNotFinite:
      return "value not finite";
    case RejectReason::kValueOutOfRange:
      return "value out of range";
    case RejectReason::kEnumOutOfRange:
      return "hand or side out of range";
    case RejectReason::kCount:
      break;
  }
  return "unknown";
}

std::optional<RejectReason> validate(const fl_CameraEstimates& sample) noexcept {
  if (sample.camera_id >= kCameraCount) return RejectReason::kCameraIdOutOfRange;
  if (sample.count > kMaxEstimatesPerFrame) return RejectReason::kCountOverCapacity;
  if (sample.frame_time_ns < 0) return RejectReason::kValueOutOfRange;
  for (std::size_t i = 0; i < sample.count; ++i) {
    const fl_FilletEstimate& e = sample.estimates[i];
    if (!std::isfinite(e.x_mm) || !std::isfinite(e.y_mm) || !std::isfinite(e.angle_rad) ||
        !std::isfinite(e.confidence)) {
      return RejectReason::kNotFinite;
    }
    if (std::fabs(e.x_mm) > kMaxAbsPositionMm || std::fabs(e.y_mm) > kMaxAbsPositionMm ||
        std::fabs(e.angle_rad) > kMaxAbsAngleRad || e.confidence < 0.0F || e.confidence > 1.0F) {
      return RejectReason::kValueOutOfRange;
    }
    // Cyclone checks enumerators when it deserialises; a local writer's sample is not
    // deserialised, so check again. Read as the underlying integer: loading an enum object
    // that holds no enumerator's value is undefined behaviour in C++ (UBSan reports it).
    std::underlying_type_t<fl_Hand> hand = 0;
    std::underlying_type_t<fl_SideUp> side = 0;
    std::memcpy(&hand, &e.hand, sizeof hand);
    std::memcpy(&side, &e.side, sizeof side);
    if (hand < fl_HAND_UNKNOWN || hand > fl_HAND_RIGHT || side < fl_SIDE_UNKNOWN ||
        side > fl_SIDE_BONE) {
      return RejectReason::kEnumOutOfRange;
    }
  }
  return std::nullopt;
}

void from_idl(const fl_CameraEstimates& sample, CameraFrame& frame) noexcept {
  frame.frame_time_ns = sample.frame_time_ns;
  frame.sequence = sample.frame_sequence;
  frame.count = sample.count;
  for (std::size_t i = 0; i < kMaxEstimatesPerFrame; ++i) {
    FilletEstimate& e = frame.estimates[i];
    if (i >= sample.count) {
      e = FilletEstimate{};  // no stale entries from an earlier frame behind `count`
      continue;
    }
    const fl_FilletEstimate& s = sample.estimates[i];
    e.x_mm = s.x_mm;
    e.y_mm = s.y_mm;
    e.angle_rad = s.angle_rad;
    e.confidence = s.confidence;
    e.hand = static_cast<Hand>(s.hand);
    e.side = static_cast<SideUp>(s.side);
    e.singulated = s.singulated;
  }
}

void to_idl(CameraId camera, const CameraFrame& frame, fl_CameraEstimates& sample) noexcept {
  std::memset(&sample, 0, sizeof sample);  // padding too: the sample is also a recording
  sample.camera_id = static_cast<std::uint8_t>(index(camera));
  sample.frame_time_ns = frame.frame_time_ns;
  sample.frame_sequence = frame.sequence;
  sample.count = frame.count;
  const std::size_t count =
      frame.count < kMaxEstimatesPerFrame ? frame.count : kMaxEstimatesPerFrame;
  for (std::size_t i = 0; i < count; ++i) {
    const FilletEstimate& e = frame.estimates[i];
    fl_FilletEstimate& s = sample.estimates[i];
    s.x_mm = e.x_mm;
    s.y_mm = e.y_mm;
    s.angle_rad = e.angle_rad;
    s.confidence = e.confidence;
    s.hand = static_cast<fl_Hand>(e.hand);
    s.side = static_cast<fl_SideUp>(e.side);
    s.singulated = e.singulated;
  }
}

void to_idl(std::int64_t time_ns, std::uint64_t scan, const OutputImage& out,
            fl_LineCommand& sample) noexcept {
  std::memset(&sample, 0, sizeof sample);
  sample.time_ns = time_ns;
  sample.scan = scan;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    sample.drives[d].enable = out.drives[d].enable;
    sample.drives[d].speed_mps = out.drives[d].speed_mps;
    sample.drives[d].accel_mps2 = out.drives[d].accel_mps2;
  }
  sample.hopper_opening_mm = out.hopper_opening_mm;
  sample.leveller_speed_rpm = out.leveller_speed_rpm;
  sample.flip_plate1_flip = out.flip_plate1_flip;
  sample.flip_plate2_flip = out.flip_plate2_flip;
  sample.centring_shift_mm = out.centring_shift_mm;
  sample.centring_stroke = out.centring_stroke;
  sample.squeeze_roller_down = out.squeeze_roller_down;
  sample.final_reject = out.final_reject;
}

void from_idl(const fl_LineCommand& sample, OutputImage& out) noexcept {
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    out.drives[d].enable = sample.drives[d].enable;
    out.drives[d].speed_mps = sample.drives[d].speed_mps;
    out.drives[d].accel_mps2 = sample.drives[d].accel_mps2;
  }
  out.hopper_opening_mm = sample.hopper_opening_mm;
  out.leveller_speed_rpm = sample.leveller_speed_rpm;
  out.flip_plate1_flip = sample.flip_plate1_flip;
  out.flip_plate2_flip = sample.flip_plate2_flip;
  out.centring_shift_mm = sample.centring_shift_mm;
  out.centring_stroke = sample.centring_stroke;
  out.squeeze_roller_down = sample.squeeze_roller_down;
  out.final_reject = sample.final_reject;
}

void to_idl(DriveId drive, std::int64_t time_ns, const DriveFeedback& feedback,
            fl_DriveFeedback& sample) noexcept {
  std::memset(&sample, 0, sizeof sample);
  sample.drive_id = static_cast<std::uint8_t>(index(drive));
  sample.time_ns = time_ns;
  sample.speed_mps = feedback.speed_mps;
  sample.encoder_counts = feedback.encoder_counts;
  sample.ready = feedback.ready;
  sample.fault = feedback.fault;
}

bool from_idl(const fl_DriveFeedback& sample, DriveId& drive, DriveFeedback& feedback) noexcept {
  if (sample.drive_id >= kDriveCount) return false;
  drive = static_cast<DriveId>(sample.drive_id);
  feedback.speed_mps = sample.speed_mps;
  feedback.encoder_counts = sample.encoder_counts;
  feedback.ready = sample.ready;
  feedback.fault = sample.fault;
  return true;
}

fl_LineState to_idl(LineState state) noexcept { return static_cast<fl_LineState>(state); }

void to_idl(std::uint64_t scan, const InputImage& in, fl_LineSensors& sample) noexcept {
  std::memset(&sample, 0, sizeof sample);
  sample.time_ns = in.time_ns;
  sample.scan = scan;
  sample.takt_beam_broken = in.takt_beam_broken;
  sample.level_mm = in.level_mm;
  sample.hopper_opening_mm = in.hopper_opening_mm;
  sample.leveller_speed_rpm = in.leveller_speed_rpm;
  sample.leveller_overload = in.leveller_overload;
  sample.flip_plate1_flipping = in.flip_plate1_flipping;
  sample.flip_plate2_flipping = in.flip_plate2_flipping;
  sample.centring_position_mm = in.centring_position_mm;
  sample.squeeze_roller_down = in.squeeze_roller_down;
  sample.estop_ok = in.estop_ok;
  sample.start_request = in.start_request;
  sample.stop_request = in.stop_request;
  sample.fault_reset_request = in.fault_reset_request;
}

bool from_idl(const fl_LineSensors& sample, InputImage& in) noexcept {
  // A corrupt analogue value would drive the level regulation or the centring unit: refuse
  // the whole sample, as for estimates.
  for (const float value : {sample.level_mm, sample.hopper_opening_mm, sample.leveller_speed_rpm,
                            sample.centring_position_mm}) {
    if (!std::isfinite(value)) return false;
  }
  in.takt_beam_broken = sample.takt_beam_broken;
  in.level_mm = sample.level_mm;
  in.hopper_opening_mm = sample.hopper_opening_mm;
  in.leveller_speed_rpm = sample.leveller_speed_rpm;
  in.leveller_overload = sample.leveller_overload;
  in.flip_plate1_flipping = sample.flip_plate1_flipping;
  in.flip_plate2_flipping = sample.flip_plate2_flipping;
  in.centring_position_mm = sample.centring_position_mm;
  in.squeeze_roller_down = sample.squeeze_roller_down;
  in.estop_ok = sample.estop_ok;
  in.start_request = sample.start_request;
  in.stop_request = sample.stop_request;
  in.fault_reset_request = sample.fault_reset_request;
  return true;
}

}  // namespace fl::drivers::dds
