// The controller's process image: everything the logic reads (InputImage) and writes
// (OutputImage) in one scan. Both are fixed-size and trivially copyable so that drivers,
// plants and the runtime can copy them without allocating, and so that a recorded sequence
// of input images replays the logic bit-identically.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <type_traits>

namespace fl {

// ---------------------------------------------------------------- identifiers

// Every motor-driven conveyor of the line (thesis section 5.3, figure 5.16), in flow order.
enum class DriveId : std::uint8_t {
  kBulk,         // belt under the mailbox hopper, speed regulated from the level sensor
  kTakt,         // takt conveyor: standard speed, accelerates to pull a row out
  kTransition1,  // speed transitions that pull the line apart
  kTransition2,
  kGuide,           // inclined belt with guiding rails, camera 1 at its end
  kReject,          // belt after the flip plates; reverses to drop a fillet into the crate
  kCentring,        // belt under camera 2 and the centring unit
  kMultilane1Left,  // orienting unit 1: two side-by-side belts
  kMultilane1Right,
  kMultilane2Left,  // orienting unit 2
  kMultilane2Right,
  kSqueeze,  // belt under the squeeze roller and the final camera
  kOutfeed,  // hands placed fillets to the portion cutter
  kCount
};
inline constexpr std::size_t kDriveCount = static_cast<std::size_t>(DriveId::kCount);

enum class CameraId : std::uint8_t {
  kOrientation,  // camera 1, end of the guide section: hand, side, angle, singulation
  kPosition,     // camera 2, before the centring unit: lateral position
  kMultilane1,   // angle feedback on orienting unit 1 (about every 25 ms)
  kMultilane2,
  kFinal,  // final inspection after the squeeze roller
  kCount
};
inline constexpr std::size_t kCameraCount = static_cast<std::size_t>(CameraId::kCount);

inline constexpr std::size_t index(DriveId id) { return static_cast<std::size_t>(id); }
inline constexpr std::size_t index(CameraId id) { return static_cast<std::size_t>(id); }

enum class Hand : std::uint8_t { kUnknown, kLeft, kRight };
enum class SideUp : std::uint8_t { kUnknown, kSkin, kBone };

// What the line as a whole is doing (OutputImage::state).
enum class LineState : std::uint8_t { kStopped, kStarting, kRunning, kStopping, kFault };

// ---------------------------------------------------------------- names

// The one spelling of every identifier, used as config/line.yaml keys, in the HMI's JSON and
// in replay goldens. Indexed by the enum's value.
inline constexpr std::array<std::string_view, kDriveCount> kDriveNames{"bulk",
                                                                       "takt",
                                                                       "transition1",
                                                                       "transition2",
                                                                       "guide",
                                                                       "reject",
                                                                       "centring",
                                                                       "multilane1_left",
                                                                       "multilane1_right",
                                                                       "multilane2_left",
                                                                       "multilane2_right",
                                                                       "squeeze",
                                                                       "outfeed"};
inline constexpr std::array<std::string_view, kCameraCount> kCameraNames{
    "orientation", "position", "multilane1", "multilane2", "final"};
inline constexpr std::array<std::string_view, 3> kHandNames{"unknown", "left", "right"};
inline constexpr std::array<std::string_view, 3> kSideUpNames{"unknown", "skin", "bone"};
inline constexpr std::array<std::string_view, 5> kLineStateNames{"stopped", "starting", "running",
                                                                 "stopping", "fault"};

namespace detail {
constexpr const auto& names_of(DriveId /*tag*/) { return kDriveNames; }
constexpr const auto& names_of(CameraId /*tag*/) { return kCameraNames; }
constexpr const auto& names_of(Hand /*tag*/) { return kHandNames; }
constexpr const auto& names_of(SideUp /*tag*/) { return kSideUpNames; }
constexpr const auto& names_of(LineState /*tag*/) { return kLineStateNames; }

template <typename Id>
constexpr std::string_view name_of(Id id) {
  const auto& names = names_of(id);
  const auto i = static_cast<std::size_t>(id);
  return i < names.size() ? names[i] : std::string_view("unknown");
}
}  // namespace detail

// "multilane1_left", "orientation", "left", "skin", "running"; "unknown" for a value outside
// the enum.
constexpr std::string_view to_string(DriveId id) { return detail::name_of(id); }
constexpr std::string_view to_string(CameraId id) { return detail::name_of(id); }
constexpr std::string_view to_string(Hand hand) { return detail::name_of(hand); }
constexpr std::string_view to_string(SideUp side) { return detail::name_of(side); }
constexpr std::string_view to_string(LineState state) { return detail::name_of(state); }

// The inverse of to_string: parse<DriveId>("takt"); nullopt for a name it does not give.
template <typename Id>
requires requires(Id id) { detail::names_of(id); }
constexpr std::optional<Id> parse(std::string_view name) {
  const auto& names = detail::names_of(Id{});
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<Id>(i);
  }
  return std::nullopt;
}

// ---------------------------------------------------------------- inputs

// One fillet seen in one camera frame. Positions are in the camera's own belt-plane frame
// (origin under the optical axis, x along travel, y to the left looking downstream): the
// camera knows its calibration, not the line geometry. The controller maps them to line
// coordinates with the camera's configured mounting position.
struct FilletEstimate {
  float x_mm = 0.0F;
  float y_mm = 0.0F;
  // Direction from the thick end to the tip, counter-clockwise from the travel direction
  // seen from above, in (-pi, pi].
  float angle_rad = 0.0F;
  float confidence = 0.0F;  // 0..1
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;
  bool singulated = false;  // false: touching or overlapping fillets in one blob
  bool operator==(const FilletEstimate&) const = default;
};

inline constexpr std::size_t kMaxEstimatesPerFrame = 8;

// The newest frame of one camera. `sequence` increments per frame; the controller acts only
// on a frame whose sequence it has not seen.
struct CameraFrame {
  std::int64_t frame_time_ns = 0;  // exposure time on the controller's clock
  std::uint32_t sequence = 0;
  std::uint8_t count = 0;  // valid entries in `estimates`
  std::array<FilletEstimate, kMaxEstimatesPerFrame> estimates{};
  bool operator==(const CameraFrame&) const = default;
};

struct DriveFeedback {
  float speed_mps = 0.0F;           // measured belt surface speed
  std::int64_t encoder_counts = 0;  // monotonic within a run; sign follows direction
  bool ready = false;               // drive enabled and following its command
  bool fault = false;               // drive reports a fault (CiA 402 fault state)
  bool operator==(const DriveFeedback&) const = default;
};

struct InputImage {
  std::int64_t time_ns = 0;  // the cycle's time; logic never reads a clock of its own
  std::array<DriveFeedback, kDriveCount> drives{};
  std::array<CameraFrame, kCameraCount> cameras{};

  bool takt_beam_broken = false;   // laser barrier at the end of the takt conveyor
  float level_mm = 0.0F;           // layer height measured in front of the leveller
  float hopper_opening_mm = 0.0F;  // cylinder position at the mailbox opening
  float leveller_speed_rpm = 0.0F;
  bool leveller_overload = false;     // blade jam or motor overload
  bool flip_plate1_flipping = false;  // end switches: true = plate retracted (fillet flips)
  bool flip_plate2_flipping = false;
  float centring_position_mm = 0.0F;  // lateral position of the centring pusher
  bool squeeze_roller_down = false;

  bool estop_ok = false;  // safety chain closed
  bool start_request = false;
  bool stop_request = false;
  bool fault_reset_request = false;
  // Member by member (determinism tests): memcmp would also compare the padding bytes.
  bool operator==(const InputImage&) const = default;
};

// ---------------------------------------------------------------- outputs

struct DriveCommand {
  bool enable = false;
  float speed_mps = 0.0F;   // target surface speed, negative reverses
  float accel_mps2 = 0.0F;  // ramp the drive must keep (within its configured limit)
  bool operator==(const DriveCommand&) const = default;
};

struct OutputImage {
  std::array<DriveCommand, kDriveCount> drives{};
  float hopper_opening_mm = 0.0F;
  float leveller_speed_rpm = 0.0F;
  bool flip_plate1_flip = false;  // true: retract plate 1 so the fillet flips end over end
  bool flip_plate2_flip = false;  // true: retract plate 2 so the fillet flips sideways
  // Lateral shift the centring unit applies to the fillet passing it; the unit strokes while
  // centring_stroke is true and parks when it is false.
  float centring_shift_mm = 0.0F;
  bool centring_stroke = false;
  bool squeeze_roller_down = false;
  bool final_reject = false;  // air knife at the end that blows a fillet off the outfeed
  LineState state = LineState::kStopped;
  std::uint32_t active_faults = 0;  // bit set of FaultCode
  bool operator==(const OutputImage&) const = default;
};

static_assert(std::is_trivially_copyable_v<InputImage>);
static_assert(std::is_trivially_copyable_v<OutputImage>);

}  // namespace fl
