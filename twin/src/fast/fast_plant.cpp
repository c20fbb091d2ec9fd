// FastPlant: construction, reset, the step loop, the input image, bodies and exits. The drives
// and cameras are the shared emulators; this file hands them commands and ground truth.
#include "fl/twin/fast_plant.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace fl {
namespace {

std::int64_t to_ns(double seconds) { return std::llround(seconds * 1e9); }

std::int64_t internal_step_ns(const FastPlantConfig& config) {
  return std::max<std::int64_t>(1, to_ns(config.internal_step_s));
}

// The bodies as the cameras see them: downstream first, the first member's classes, a
// touching pair as one blob.
class BodyScene final : public CameraScene {
 public:
  explicit BodyScene(std::span<const FilletBody> bodies) : bodies_(bodies) {}
  [[nodiscard]] std::size_t size() const override { return bodies_.size(); }
  [[nodiscard]] double s_mm(std::size_t item) const override { return bodies_[item].s_mm; }
  [[nodiscard]] CameraTruth truth(std::size_t item) const override {
    const FilletBody& body = bodies_[item];
    return {body.y_mm, body.angle_rad, body.members[0].hand, body.members[0].side,
            body.member_count > 1};
  }

 private:
  std::span<const FilletBody> bodies_;
};

}  // namespace

float fillet_thickness_mm(const FilletBody& body, float u_from_thick_end) {
  const float u = std::clamp(u_from_thick_end, 0.0F, 1.0F);
  const float peak = std::clamp(body.thickest_from_thick_end, 0.01F, 0.99F);
  const float ratio = u <= peak ? body.thick_end_ratio + (1.0F - body.thick_end_ratio) * (u / peak)
                                : 1.0F + (body.tip_ratio - 1.0F) * ((u - peak) / (1.0F - peak));
  return body.thickness_mm * ratio;
}

FastPlant::FastPlant(const LineConfig& line, const FastPlantConfig& plant)
    : line_(line),
      config_(plant),
      step_ns_(internal_step_ns(plant)),
      drives_(line.limits, static_cast<double>(plant.belts.drive_delay_s)),
      cameras_(line.cameras, plant.cameras, internal_step_ns(plant)) {
  if (!(config_.internal_step_s > 0.0F)) throw std::invalid_argument("internal_step_s must be > 0");
  if (config_.max_bodies == 0) throw std::invalid_argument("max_bodies must be > 0");
  bodies_.reserve(config_.max_bodies);
  exits_.resize(std::max<std::size_t>(config_.exit_capacity, 1));
  build_segments();
  InputImage scratch{};
  reset(0, scratch);
}

FastPlant::~FastPlant() = default;

void FastPlant::reset(std::uint64_t seed, InputImage& in) {
  state_ = FastPlantState{};
  counters_ = FastPlantCounters{};
  faults_ = FastPlantFaults{};
  bodies_.clear();
  exit_count_ = 0;
  exits_drained_ = 0;
  drives_.reset();
  pool_was_full_ = false;
  roller_went_down_ = false;
  last_plant_id_ = 0;
  last_group_id_ = 0;

  feed_rng_.seed_with(stream_seed(seed, 1));
  body_rng_.seed_with(stream_seed(seed, 2));
  sensor_rng_.seed_with(stream_seed(seed, 3));

  state_.infeed.hopper_fillets = config_.infeed.hopper_initial_fillets;
  state_.infeed.hopper_opening_mm =
      std::clamp(static_cast<double>(config_.infeed.hopper_initial_opening_mm),
                 static_cast<double>(config_.infeed.hopper_min_opening_mm),
                 static_cast<double>(config_.infeed.hopper_max_opening_mm));
  draw_next_feed();

  std::memset(static_cast<void*>(&image_), 0, sizeof(image_));
  cameras_.reset(seed, state_.time_ns);
  write_image(in);
}

void FastPlant::step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) {
  // Exits handed out by drain_exits() are dropped now (their span was valid until here).
  if (exits_drained_ > 0) {
    const std::size_t left = exit_count_ - exits_drained_;
    for (std::size_t i = 0; i < left; ++i) exits_[i] = exits_[exits_drained_ + i];
    exit_count_ = left;
    exits_drained_ = 0;
  }

  drives_.command(out.drives, state_.time_ns);

  std::int64_t remaining = dt_ns;
  while (remaining > 0) {
    const std::int64_t h_ns = std::min(remaining, step_ns_);
    substep(h_ns, out);
    remaining -= h_ns;
  }
  cameras_.publish(state_.time_ns, faults_.cameras, image_.cameras);
  write_image(in);
}

void FastPlant::substep(std::int64_t h_ns, const OutputImage& out) {
  const double h_s = static_cast<double>(h_ns) * 1e-9;
  // The safety chain cuts every drive (STO).
  drives_.step(state_.time_ns, h_s, faults_.drive_fault, !faults_.estop_open);
  step_stations(h_s, out);
  step_infeed(h_s, out);
  step_bodies(h_s, out);
  resolve_contacts();
  sort_bodies();
  state_.time_ns += h_ns;
  cameras_.capture_due(state_.time_ns, BodyScene(bodies()), faults_.cameras);
}

void FastPlant::write_image(InputImage& in) {
  InputImage& image = image_;
  image.time_ns = state_.time_ns;
  drives_.write(image.drives);
  // image.cameras is written by the camera emulator's publish().
  FastInfeedState& infeed = state_.infeed;
  infeed.level_reading_mm =
      std::max(0.0, infeed.layer_mm +
                        static_cast<double>(config_.infeed.level_noise_mm) * sensor_rng_.normal());
  image.takt_beam_broken = beam_broken();
  image.level_mm = static_cast<float>(infeed.level_reading_mm);
  image.hopper_opening_mm = static_cast<float>(infeed.hopper_opening_mm);
  image.leveller_speed_rpm = static_cast<float>(infeed.leveller_rpm);
  image.leveller_overload = infeed.leveller_overload;
  const FastStationState& stations = state_.stations;
  image.flip_plate1_flipping = stations.plate1_travel >= 1.0;
  image.flip_plate2_flipping = stations.plate2_travel >= 1.0;
  image.centring_position_mm = static_cast<float>(stations.pusher_mm);
  image.squeeze_roller_down = stations.roller_travel >= 1.0;
  image.estop_ok = !faults_.estop_open;
  image.start_request = false;
  image.stop_request = false;
  image.fault_reset_request = false;
  // Byte copy, padding included, so that equal runs give byte-equal images.
  std::memcpy(static_cast<void*>(&in), static_cast<const void*>(&image_), sizeof(InputImage));
}

std::span<const TrueFilletExit> FastPlant::drain_exits() {
  const std::span<const TrueFilletExit> fresh(exits_.data() + exits_drained_,
                                              exit_count_ - exits_drained_);
  exits_drained_ = exit_count_;
  return fresh;
}

std::uint64_t FastPlant::fillets_on_line() const {
  std::uint64_t count = 0;
  for (const FilletBody& body : bodies_) {
    if (body.fed) count += body.member_count;
  }
  return count;
}

std::span<const FilletBody> FastPlant::bodies() const { return {bodies_.data(), bodies_.size()}; }

void FastPlant::record_exit(const FilletBody& body, TrueExit exit) {
  if (!body.fed) {  // never crossed the barrier: not part of the fed balance
    counters_.unfed_losses += body.member_count;
    return;
  }
  for (std::uint8_t m = 0; m < body.member_count; ++m) {
    ++counters_.exits[static_cast<std::size_t>(exit)];
    if (exit_count_ >= exits_.size()) {
      ++counters_.exits_not_recorded;
      continue;
    }
    TrueFilletExit& record = exits_[exit_count_++];
    record = TrueFilletExit{};
    record.plant_id = body.members[m].plant_id;
    record.group_id = body.group_id;
    record.time_ns = state_.time_ns;
    record.exit = exit;
    record.hand = body.members[m].hand;
    record.side = body.members[m].side;
    record.angle_rad = static_cast<float>(body.angle_rad);
    record.y_mm = static_cast<float>(body.y_mm);
    record.singulated = body.member_count == 1;
    record.squeezed_ok = body.squeezed_ok;
  }
}

void FastPlant::insert_body(const FilletBody& body) {
  // Keep the pool sorted downstream first; the capacity was reserved, so no allocation.
  auto at = std::find_if(bodies_.begin(), bodies_.end(),
                         [&](const FilletBody& other) { return other.s_mm < body.s_mm; });
  bodies_.insert(at, body);
}

void FastPlant::remove_body(std::size_t index) {
  bodies_.erase(bodies_.begin() + static_cast<std::ptrdiff_t>(index));
}

std::optional<std::uint32_t> FastPlant::spawn_body(const BodySpawn& spawn) {
  if (bodies_.size() >= config_.max_bodies) return std::nullopt;
  FilletBody body{};
  body.member_count = spawn.touching_pair ? 2 : 1;
  const std::uint8_t variant =
      std::min<std::uint8_t>(spawn.variant, static_cast<std::uint8_t>(kFilletSizeVariants - 1));
  const FilletSizeVariant& size = config_.fillet.variants[variant];
  for (std::uint8_t m = 0; m < body.member_count; ++m) {
    FilletMember& member = body.members[m];
    member.plant_id = next_plant_id();
    member.hand = spawn.hand;
    member.side = spawn.side;
    member.variant = variant;
    member.length_mm = size.length_mm * spawn.scale;
    member.width_mm = size.width_mm * spawn.scale;
    member.thickness_mm = size.thickness_mm * spawn.scale;
  }
  body.length_mm = body.members[0].length_mm;
  body.width_mm = body.members[0].width_mm * static_cast<float>(body.member_count);
  body.thickness_mm = body.members[0].thickness_mm;
  body.thickest_from_thick_end = config_.fillet.thickest_from_thick_end;
  body.thick_end_ratio = config_.fillet.thick_end_ratio;
  body.tip_ratio = config_.fillet.tip_ratio;
  body.group_id = next_group_id();
  body.s_mm = spawn.s_mm;
  body.y_mm = spawn.y_mm;
  body.v_mps = spawn.v_mps;
  set_body_angle(body, spawn.angle_rad);
  if (body.s_mm >= 0.0) {
    body.fed = true;
    counters_.fillets_fed += body.member_count;
  }
  body.thick_passed_roller = thickest_section_s_mm(body) >= line_.squeeze.roller_s_mm;
  locate(body);
  counters_.fillets_spawned += body.member_count;
  if (body.member_count > 1) ++counters_.groups_spawned;
  insert_body(body);
  return body.group_id;
}

}  // namespace fl
