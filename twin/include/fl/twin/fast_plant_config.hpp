// Configuration of the fast 2D plant (FastPlant): every physical constant the model uses that
// the line configuration does not already give. Plain data with defaults; config/plant_fast.yaml
// holds the same values and load_fast_plant_config() reads it strictly (a test keeps the two
// equal). Line geometry (belt sections, camera mounts, station positions, drive limits) comes
// from LineConfig and is not repeated here.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>

#include "fl/controller/process_image.hpp"
#include "fl/twin/sensors/camera_emulator.hpp"

namespace fl {

// One size variant of the thesis' DEM fillet model (table 3.1).
struct FilletSizeVariant {
  float length_mm = 0.0F;
  float width_mm = 0.0F;
  float thickness_mm = 0.0F;
  bool operator==(const FilletSizeVariant&) const = default;
};

inline constexpr std::size_t kFilletSizeVariants = 3;

struct FastFilletConfig {
  // Thesis table 3.1: the base model scaled to three variants, each mirrored to left and right.
  std::array<FilletSizeVariant, kFilletSizeVariants> variants{{
      {144.0F, 72.0F, 40.0F},
      {172.0F, 72.0F, 32.0F},
      {176.0F, 72.0F, 40.0F},
  }};
  // Uniform relative scale on top of the variant (+-5 %): real fillets spread between sizes.
  float scale_spread = 0.05F;
  // Thickest section, share of the length from the thick end (thesis 6.2: thickness grows
  // from the tip towards the base; the line config assumes 0.3), with a per-fillet spread.
  float thickest_from_thick_end = 0.3F;
  float thickest_spread = 0.03F;
  // Thickness at the thick end and at the tip relative to the thickest section: the base is
  // rounded off, the tip is thin. Only the profile's shape, for the HMI and the roller.
  float thick_end_ratio = 0.75F;
  float tip_ratio = 0.15F;
  // A fed item is two fillets stuck together with this probability: fillets are sticky
  // (thesis 3.2, JKR adhesion) and the leveller does not always part them.
  float touching_pair_prob = 0.04F;
  bool operator==(const FastFilletConfig&) const = default;
};

struct FastInfeedConfig {
  // About a day at 70 fillets per minute: a run never empties the hopper unless asked to.
  std::uint32_t hopper_initial_fillets = 100000;
  // Cylinder end stops and speed (pneumatic with a flow restrictor: 60 -> 90 mm in 0.6 s).
  float hopper_min_opening_mm = 20.0F;
  float hopper_max_opening_mm = 150.0F;
  float hopper_cylinder_speed_mmps = 50.0F;
  // Where reset() leaves the cylinder: the stable-flow opening, as the line was left.
  float hopper_initial_opening_mm = 60.0F;
  // Outflow [fillets/s] = this x bulk speed [m/s] x opening [mm]: a 60 mm high, 300 mm wide
  // layer at about 50 % packing holds about 30 fillets per metre of belt.
  float outflow_fillets_per_m_mm = 0.5F;
  // Thesis 6.1: at 4.5 cm the outflow stalled (the belt slid under the fillets), at 6 cm it
  // flowed stably. The blockage rate while the belt runs is block_hazard_per_s at or below
  // block_opening_mm and falls linearly to zero at flow_opening_mm.
  float block_opening_mm = 45.0F;
  float flow_opening_mm = 60.0F;
  float block_hazard_per_s = 0.3F;
  // A blockage clears when the opening grows this much beyond where it blocked (the
  // controller's unblock stroke 60 -> 90 mm), or by itself at unblock_hazard_per_s.
  float unblock_opening_delta_mm = 15.0F;
  float unblock_hazard_per_s = 0.1F;
  // Heap in front of the leveller: each waiting fillet raises it this much (spread over the
  // belt width); at layer_max_mm it reaches the hopper and the belt slides under the bulk.
  float layer_mm_per_fillet = 8.0F;
  float layer_max_mm = 200.0F;
  float level_noise_mm = 1.0F;  // laser level sensor over an uneven heap surface
  // Leveller rotor: first-order spin-up; below pass_min_rpm the blades do not clear the
  // layer and nothing passes; a heap above overload_layer_mm stalls a rotor that turns
  // slower than stall_rpm (blades cannot start against it): leveller_overload.
  float leveller_time_constant_s = 0.4F;
  float leveller_pass_min_rpm = 40.0F;
  float leveller_overload_layer_mm = 150.0F;
  float leveller_stall_rpm = 20.0F;
  // The levelled fillets on the takt conveyor: random small gaps, lateral position across
  // the belt, heading roughly aligned around 0 or pi (about 20 degrees spread).
  float takt_gap_min_mm = 5.0F;
  float takt_gap_max_mm = 40.0F;
  float takt_lateral_spread_mm = 100.0F;
  float takt_heading_sigma_rad = 0.35F;
  // The barrier is broken while a body covers s in [-takt_beam_window_mm, 0].
  float takt_beam_window_mm = 5.0F;
  bool operator==(const FastInfeedConfig&) const = default;
};

struct FastBeltConfig {
  // Wet fillet on a food-grade belt; friction limits how fast an item follows a belt.
  float mu_belt = 0.4F;
  float gravity_mps2 = 9.81F;
  // 400 mm wide belts: a centre beyond this lateral distance has left the belt.
  float belt_half_width_mm = 200.0F;
  // Thesis 5.3: transmitting a command to the frequency controller takes about 5 ms.
  float drive_delay_s = 0.005F;
  bool operator==(const FastBeltConfig&) const = default;
};

struct FastGuideConfig {
  // The rails funnel items into +-band of the centre line; offsets beyond it and the heading
  // error to the nearer of 0 and pi decay exponentially at these rates (2 s on the guide at
  // 0.5 m/s: e^-8 for the offset, e^-6 for the heading).
  float band_half_width_mm = 40.0F;
  float lateral_rate_per_s = 4.0F;
  float heading_rate_per_s = 3.0F;
  // The rails leave a few degrees of heading error (per item, drawn at the leveller).
  float heading_residual_sigma_rad = 0.05F;
  bool operator==(const FastGuideConfig&) const = default;
};

struct FastFlipConfig {
  // A plate caught in mid-travel flips the item with a probability equal to its travel
  // fraction and throws its heading by up to +-this.
  float misflip_angle_rad = 0.6F;
  bool operator==(const FastFlipConfig&) const = default;
};

struct FastCentringConfig {
  // The pusher acts on an item whose centre is within +-this of the unit.
  float window_half_mm = 20.0F;
  bool operator==(const FastCentringConfig&) const = default;
};

struct FastMultilaneConfig {
  // The item's rotation rate follows (v_right - v_left) / belt_track with this first-order
  // lag (the flesh shears before the whole fillet turns) and saturates at max_omega (slip).
  float omega_lag_s = 0.02F;
  float max_omega_radps = 8.0F;
  // Thesis 5.3: centring is needed for both belts to grip. Beyond |y| > grip_lateral_mm one
  // belt loses grip and the item gets only this fraction of the rotation.
  float grip_lateral_mm = 15.0F;
  float off_centre_rotation_fraction = 0.3F;
  // Random-walk angle disturbance while on a unit (uneven flesh, belt seams).
  float disturbance_rad_per_sqrt_s = 0.02F;
  bool operator==(const FastMultilaneConfig&) const = default;
};

struct FastSqueezeConfig {
  // The roller touches a fillet at this fraction of its stroke; the end switch
  // (squeeze_roller_down) closes only at the end of the stroke.
  float contact_fraction = 0.5F;
  // A fillet stuck behind the lowered roller pivots while the belt slides under it.
  float stuck_disturbance_rad_per_sqrt_s = 0.5F;
  bool operator==(const FastSqueezeConfig&) const = default;
};

struct FastFinalRejectConfig {
  // The air knife blows off an item whose centre is within +-this of it while it blows.
  float window_half_mm = 20.0F;
  bool operator==(const FastFinalRejectConfig&) const = default;
};

// The cameras' measurement model is the shared emulator's (fl/twin/sensors).
using FastCameraConfig = CameraModelConfig;

// Per-camera defaults (indexed by CameraId).
constexpr std::array<FastCameraConfig, kCameraCount> default_fast_camera_configs() {
  std::array<FastCameraConfig, kCameraCount> cameras{};
  // Camera 1, AI classification: thesis 5.3, the answer comes within 100 ms.
  auto& orientation = cameras[index(CameraId::kOrientation)];
  orientation.latency_s = 0.05F;
  orientation.position_sigma_mm = 2.0F;
  orientation.angle_sigma_rad = 0.03F;
  orientation.classifies = true;
  orientation.hand_flip_prob = 0.02F;
  orientation.side_flip_prob = 0.02F;
  // Camera 2 only measures the lateral position.
  auto& position = cameras[index(CameraId::kPosition)];
  position.latency_s = 0.02F;
  position.position_sigma_mm = 1.5F;
  position.angle_sigma_rad = 0.05F;
  // Multilane cameras: thesis 5.3, about 10 ms for the angle measurement in the 25 ms loop.
  for (CameraId id : {CameraId::kMultilane1, CameraId::kMultilane2}) {
    auto& camera = cameras[index(id)];
    camera.latency_s = 0.008F;
    camera.position_sigma_mm = 2.0F;
    camera.angle_sigma_rad = 0.015F;
  }
  // Final inspection checks side and angle.
  auto& final_camera = cameras[index(CameraId::kFinal)];
  final_camera.latency_s = 0.03F;
  final_camera.position_sigma_mm = 2.0F;
  final_camera.angle_sigma_rad = 0.02F;
  final_camera.classifies = true;
  final_camera.hand_flip_prob = 0.01F;
  final_camera.side_flip_prob = 0.01F;
  return cameras;
}

struct FastPlantConfig {
  // Internal integration step: 2 ms resolves the 5 ms drive delay (to within a step), the
  // 25 ms camera period and 0.6 m/s x 2 ms = 1.2 mm of travel per step. 1 ms gave the same
  // closed-loop KPIs (10 min, seed 1: 99.35 against 99.03 % in spec) at 1.6 times the cost.
  float internal_step_s = 0.002F;
  // Body pool and exit buffer capacities, allocated once at construction. 64 bodies is more
  // than twice what the 6 m line holds at 70 fillets per minute.
  std::uint32_t max_bodies = 64;
  std::uint32_t exit_capacity = 1024;

  FastFilletConfig fillet;
  FastInfeedConfig infeed;
  FastBeltConfig belts;
  FastGuideConfig guide;
  FastFlipConfig flip;
  FastCentringConfig centring;
  FastMultilaneConfig multilane;
  FastSqueezeConfig squeeze;
  FastFinalRejectConfig final_reject;
  std::array<FastCameraConfig, kCameraCount> cameras = default_fast_camera_configs();

  bool operator==(const FastPlantConfig&) const = default;
};

// Reads config/plant_fast.yaml strictly (fl::YamlReader): every key required, unknown keys
// refused, ranges checked. Throws ConfigError listing every problem with file, key and line.
FastPlantConfig load_fast_plant_config(const std::filesystem::path& file);

}  // namespace fl
