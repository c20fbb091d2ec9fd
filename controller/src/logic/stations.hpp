// The line's stations, each a small unit with its own state and an update() per scan.
// They read the input image and the tracker, and write their part of the output image.
// Internal to the logic library; tests include this header directly.
#pragma once

#include <array>
#include <cstdint>

#include "tracker.hpp"

namespace fl::logic {

// What every station sees in one scan.
struct ScanContext {
  const InputImage& in;
  float dt_s;
  bool running;         // line in the running state
  bool infeed_enabled;  // bulk, leveller and takt may feed (off while stopping or on overload)
  Tracker& tracker;
  EventRing& events;
  RecordRing& records;
  ControllerCounters& counters;
};

void set_drive(OutputImage& out, DriveId drive, const LineConfig& config, float speed_mps,
               bool enable);

// --- 1. Mailbox bulk: level in front of the leveller regulates the bulk belt (PI).
class BulkFeedStation {
 public:
  explicit BulkFeedStation(const LineConfig& config) : config_(config) {}
  void reset();
  void update(const ScanContext& ctx, OutputImage& out);
  [[nodiscard]] bool unblocking() const { return unblock_remaining_s_ > 0.0F; }

 private:
  const LineConfig& config_;
  float integral_mps_ = 0.0F;
  float starved_s_ = 0.0F;
  float unblock_remaining_s_ = 0.0F;
};

// --- 2. Universal leveller: runs while feeding; a jam or overload is a fault.
class LevellerStation {
 public:
  explicit LevellerStation(const LineConfig& config) : config_(config) {}
  void reset() { running_s_ = 0.0F; }
  // Returns true when the leveller is jammed or overloaded.
  bool update(const ScanContext& ctx, OutputImage& out);

 private:
  const LineConfig& config_;
  float running_s_ = 0.0F;
};

// --- 3. Takt conveyor: a beam break pulls one row out; each stroke creates one item.
class TaktStation {
 public:
  enum class Phase : std::uint8_t { kIndex, kWaitGap, kPull };
  explicit TaktStation(const LineConfig& config) : config_(config) {}
  void reset();
  void update(const ScanContext& ctx, OutputImage& out);
  [[nodiscard]] Phase phase() const { return phase_; }

 private:
  bool gap_clear(const ScanContext& ctx) const;
  const LineConfig& config_;
  Phase phase_ = Phase::kIndex;
  float beam_stable_s_ = 0.0F;
  float beam_clear_s_ = 0.0F;
  // A stroke needs the beam to have been clear since the last one: the pulled fillet's
  // tail keeps the beam broken for a while, and must not count as the next row. Only a
  // clear beam after the pull counts (the pulled fillet may reach the beam during it).
  bool armed_ = true;
  // A row touching the pulled fillet (or behind a gap shorter than the debounce) never
  // shows a clear beam: once the belt has moved a whole fillet since the stroke, a broken
  // beam is taken for it (takt.rearm_travel_mm). Only once before the beam is clear again,
  // so that a fillet stuck under the beam makes one extra item, not one a period. Armed
  // with this still set, the takt was armed by travel: a clear beam resets both.
  [[nodiscard]] bool armed_by_travel() const { return armed_ && travel_rearm_used_; }
  bool travel_rearm_used_ = false;
  bool beam_was_broken_ = false;
  bool broke_after_pull_ = false;  // the beam broke again after the pull: the next row's front
  float travel_since_stroke_mm_ = 0.0F;
  float travel_since_break_mm_ = 0.0F;
  float since_stroke_s_ = 1e9F;
  float pulled_mm_ = 0.0F;
};

// --- 6. Flip plates: classification at camera 1 and the plates' schedule.
struct FlipPlan {
  bool plate1 = false;  // end over end: side toggles, heading -> pi - heading
  bool plate2 = false;  // sideways: side toggles, heading -> -heading
};
// Which plates to retract so that `target` ends up and the tip leads (thick end trails).
FlipPlan plan_flips(SideUp seen, float angle_rad, SideUp target);
// Heading and side after passing a plate in the given state.
void apply_plate(bool end_over_end, bool flipping, SideUp& side, float& angle_rad);

class FlipStation {
 public:
  explicit FlipStation(const LineConfig& config) : config_(config) {}
  void reset();
  void update(const ScanContext& ctx, OutputImage& out);
  // Line position at which camera 1's evidence is turned into a decision.
  [[nodiscard]] float decision_s_mm() const;

 private:
  void classify(Item& item) const;
  void schedule_plate(const ScanContext& ctx, bool end_over_end, bool& command);
  const LineConfig& config_;
  bool plate1_command_ = false;
  bool plate2_command_ = false;
};

// --- 6b. Reject reversal: the belt after the plates runs back to drop an item in the crate.
class RejectStation {
 public:
  explicit RejectStation(const LineConfig& config) : config_(config) {}
  void reset();
  // Writes the reject belt and decides whether the guide belt must hold.
  void update(const ScanContext& ctx, OutputImage& out, bool& hold_guide);
  [[nodiscard]] bool reversing() const { return target_id_ != 0; }

 private:
  const LineConfig& config_;
  std::uint32_t target_id_ = 0;
};

// --- 7. Centring unit: camera 2's lateral position becomes one stroke per item.
class CentringStation {
 public:
  explicit CentringStation(const LineConfig& config) : config_(config) {}
  void update(const ScanContext& ctx, OutputImage& out);

 private:
  const LineConfig& config_;
};

// --- 8. Multilane orienting units: assignment and the angle loop.
struct UnitCommand {
  float left_mps = 0.0F;
  float right_mps = 0.0F;
};
// Differential speeds that turn the item toward its target within the drives' limits.
// turn_gain: the share of the belts' rotation (differential over track) the item follows,
// as the station estimates it online; 1 is the rigid-rolling model. blind_s: how long a
// change in the item's rate can go unseen before the command reacts to the camera (0: the
// heading is known continuously).
UnitCommand orient_command(const MultilaneConfig& config, const DriveLimits& limits,
                           float error_rad, float turn_gain = 1.0F, float blind_s = 0.0F);

class MultilaneStation {
 public:
  static constexpr std::size_t kUnits = 2;
  explicit MultilaneStation(const LineConfig& config) : config_(config) {}
  void reset();
  // Integrates the units' rotation from the encoders; call before update().
  void integrate_rotation(const ScanContext& ctx);
  // Heading of an item measured at frame_time_ns, brought forward to now.
  [[nodiscard]] float rotation_since_rad(std::size_t unit, std::int64_t frame_time_ns) const;
  void update(const ScanContext& ctx, OutputImage& out);
  // Which unit carries line position s, or -1.
  [[nodiscard]] int unit_at(float s_mm) const;
  [[nodiscard]] std::uint32_t controlled_item(std::size_t unit) const { return controlled_[unit]; }
  // Rotation items make between unit 2 and the final camera, towards more turned (learnt).
  [[nodiscard]] float transfer_bias_rad() const { return transfer_bias_rad_; }

 private:
  static constexpr std::size_t kHistory = 64;  // 0.64 s of scans, longer than any latency
  void assign(const ScanContext& ctx);
  // Updates the item's turn gain from its new frame and the previous one on the same unit.
  void learn_turn_gain(Item& item, std::size_t unit, float since_exposure_rad) const;
  // Learns the transfer bias from an item's first frame at the final camera.
  void learn_transfer_bias(Item& item);
  // The heading the units aim at: the target less the rotation still to come after them.
  [[nodiscard]] float aim_rad(const Item& item) const;
  const LineConfig& config_;
  std::array<float, kUnits> rotation_rad_{};
  std::array<std::array<float, kHistory>, kUnits> rotation_history_{};
  std::array<std::int64_t, kHistory> time_history_{};
  std::size_t history_head_ = 0;
  std::size_t history_size_ = 0;
  std::array<std::uint32_t, kUnits> controlled_{};
  float transfer_bias_rad_ = 0.0F;
};

// --- 9. Squeeze roller: down only behind the thickest section.
// Line position of the thickest section and of the rearmost point of an item.
float thickest_section_s_mm(const Item& item, float thickest_from_rear);
float rear_s_mm(const Item& item);

class SqueezeStation {
 public:
  explicit SqueezeStation(const LineConfig& config) : config_(config) {}
  void update(const ScanContext& ctx, OutputImage& out);

 private:
  const LineConfig& config_;
};

// --- 10. Final inspection and the outfeed: tolerance check, air knife, ledger closing.
class FinalStation {
 public:
  explicit FinalStation(const LineConfig& config) : config_(config) {}
  void update(const ScanContext& ctx, OutputImage& out);
  [[nodiscard]] float decision_s_mm() const;

 private:
  void inspect(Item& item) const;
  const LineConfig& config_;
};

}  // namespace fl::logic
