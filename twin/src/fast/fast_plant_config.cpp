// Strict loader of config/plant_fast.yaml (FastPlantConfig), on fl::YamlReader: every key
// required, unknown keys refused, ranges and cross-checks reported with file, key and line.
#include "fl/twin/fast_plant_config.hpp"

#include <array>
#include <string>
#include <string_view>

#include "fl/controller/yaml_reader.hpp"

namespace fl {
namespace {

Range probability() { return Range::closed(0.0, 1.0); }
Range share() { return Range::open(0.0, 1.0); }

void read_fillets(YamlMapReader& root, FastFilletConfig& fillet) {
  YamlMapReader map = root.map("fillets");
  std::size_t count = 0;
  map.for_each_map("variants", [&](YamlMapReader& element, std::size_t i) {
    ++count;
    if (i >= kFilletSizeVariants) return;  // reported below; the rest of it is not read
    FilletSizeVariant& variant = fillet.variants[i];
    variant.length_mm = element.read_float("length_mm", Range::positive());
    variant.width_mm = element.read_float("width_mm", Range::positive());
    variant.thickness_mm = element.read_float("thickness_mm", Range::positive());
  });
  if (map.has("variants") && count != kFilletSizeVariants) {
    map.report("variants", ProblemKind::kInvalidValue,
               "expected " + std::to_string(kFilletSizeVariants) +
                   " size variants (thesis table 3.1), found " + std::to_string(count));
  }
  fillet.scale_spread = map.read_float("scale_spread", Range::closed(0.0, 0.5));
  fillet.thickest_from_thick_end = map.read_float("thickest_from_thick_end", share());
  fillet.thickest_spread = map.read_float("thickest_spread", Range::closed(0.0, 0.5));
  fillet.thick_end_ratio = map.read_float("thick_end_ratio", Range::closed(0.0, 1.0));
  fillet.tip_ratio = map.read_float("tip_ratio", Range::closed(0.0, 1.0));
  fillet.touching_pair_prob = map.read_float("touching_pair_prob", probability());
  map.finish();
}

void read_infeed(YamlMapReader& root, FastInfeedConfig& infeed) {
  YamlMapReader map = root.map("infeed");
  infeed.hopper_initial_fillets =
      map.read_int<std::uint32_t>("hopper_initial_fillets", Range::non_negative());
  infeed.hopper_min_opening_mm = map.read_float("hopper_min_opening_mm", Range::non_negative());
  infeed.hopper_max_opening_mm = map.read_float("hopper_max_opening_mm", Range::positive());
  infeed.hopper_cylinder_speed_mmps =
      map.read_float("hopper_cylinder_speed_mmps", Range::positive());
  infeed.hopper_initial_opening_mm =
      map.read_float("hopper_initial_opening_mm", Range::non_negative());
  infeed.outflow_fillets_per_m_mm =
      map.read_float("outflow_fillets_per_m_mm", Range::non_negative());
  infeed.block_opening_mm = map.read_float("block_opening_mm", Range::non_negative());
  infeed.flow_opening_mm = map.read_float("flow_opening_mm", Range::positive());
  infeed.block_hazard_per_s = map.read_float("block_hazard_per_s", Range::non_negative());
  infeed.unblock_opening_delta_mm =
      map.read_float("unblock_opening_delta_mm", Range::non_negative());
  infeed.unblock_hazard_per_s = map.read_float("unblock_hazard_per_s", Range::non_negative());
  infeed.layer_mm_per_fillet = map.read_float("layer_mm_per_fillet", Range::positive());
  infeed.layer_max_mm = map.read_float("layer_max_mm", Range::positive());
  infeed.level_noise_mm = map.read_float("level_noise_mm", Range::non_negative());
  infeed.leveller_time_constant_s = map.read_float("leveller_time_constant_s", Range::positive());
  infeed.leveller_pass_min_rpm = map.read_float("leveller_pass_min_rpm", Range::non_negative());
  infeed.leveller_overload_layer_mm =
      map.read_float("leveller_overload_layer_mm", Range::positive());
  infeed.leveller_stall_rpm = map.read_float("leveller_stall_rpm", Range::non_negative());
  infeed.takt_gap_min_mm = map.read_float("takt_gap_min_mm", Range::non_negative());
  infeed.takt_gap_max_mm = map.read_float("takt_gap_max_mm", Range::non_negative());
  infeed.takt_lateral_spread_mm = map.read_float("takt_lateral_spread_mm", Range::non_negative());
  infeed.takt_heading_sigma_rad = map.read_float("takt_heading_sigma_rad", Range::non_negative());
  infeed.takt_beam_window_mm = map.read_float("takt_beam_window_mm", Range::non_negative());
  map.finish();
}

void read_belts(YamlMapReader& root, FastBeltConfig& belts) {
  YamlMapReader map = root.map("belts");
  belts.mu_belt = map.read_float("mu_belt", Range::positive());
  belts.gravity_mps2 = map.read_float("gravity_mps2", Range::positive());
  belts.belt_half_width_mm = map.read_float("belt_half_width_mm", Range::positive());
  belts.drive_delay_s = map.read_float("drive_delay_s", Range::closed(0.0, 0.1));
  map.finish();
}

void read_stations(YamlMapReader& root, FastPlantConfig& config) {
  {
    YamlMapReader map = root.map("guide");
    config.guide.band_half_width_mm = map.read_float("band_half_width_mm", Range::non_negative());
    config.guide.lateral_rate_per_s = map.read_float("lateral_rate_per_s", Range::non_negative());
    config.guide.heading_rate_per_s = map.read_float("heading_rate_per_s", Range::non_negative());
    config.guide.heading_residual_sigma_rad =
        map.read_float("heading_residual_sigma_rad", Range::non_negative());
    map.finish();
  }
  {
    YamlMapReader map = root.map("flip");
    config.flip.misflip_angle_rad = map.read_float("misflip_angle_rad", Range::non_negative());
    map.finish();
  }
  {
    YamlMapReader map = root.map("centring");
    config.centring.window_half_mm = map.read_float("window_half_mm", Range::positive());
    map.finish();
  }
  {
    YamlMapReader map = root.map("multilane");
    FastMultilaneConfig& multilane = config.multilane;
    multilane.omega_lag_s = map.read_float("omega_lag_s", Range::positive());
    multilane.max_omega_radps = map.read_float("max_omega_radps", Range::positive());
    multilane.grip_lateral_mm = map.read_float("grip_lateral_mm", Range::non_negative());
    multilane.off_centre_rotation_fraction =
        map.read_float("off_centre_rotation_fraction", Range::closed(0.0, 1.0));
    multilane.disturbance_rad_per_sqrt_s =
        map.read_float("disturbance_rad_per_sqrt_s", Range::non_negative());
    map.finish();
  }
  {
    YamlMapReader map = root.map("squeeze");
    config.squeeze.contact_fraction =
        map.read_float("contact_fraction", Range::above(0.0).and_at_most(1.0));
    config.squeeze.stuck_disturbance_rad_per_sqrt_s =
        map.read_float("stuck_disturbance_rad_per_sqrt_s", Range::non_negative());
    map.finish();
  }
  {
    YamlMapReader map = root.map("final_reject");
    config.final_reject.window_half_mm = map.read_float("window_half_mm", Range::positive());
    map.finish();
  }
}

void read_camera(YamlMapReader& cameras, CameraId id, FastCameraConfig& camera) {
  YamlMapReader map = cameras.map(to_string(id));
  camera.latency_s = map.read_float("latency_s", Range::closed(0.0, 1.0));
  camera.jitter_s = map.read_float("jitter_s", Range::closed(0.0, 0.1));
  camera.position_sigma_mm = map.read_float("position_sigma_mm", Range::non_negative());
  camera.angle_sigma_rad = map.read_float("angle_sigma_rad", Range::non_negative());
  camera.classifies = map.read_bool("classifies");
  camera.hand_flip_prob = map.read_float("hand_flip_prob", probability());
  camera.side_flip_prob = map.read_float("side_flip_prob", probability());
  camera.singulation_error_prob = map.read_float("singulation_error_prob", probability());
  camera.miss_prob = map.read_float("miss_prob", probability());
  camera.confidence_ok_min = map.read_float("confidence_ok_min", probability());
  camera.confidence_ok_max = map.read_float("confidence_ok_max", probability());
  camera.confidence_bad_min = map.read_float("confidence_bad_min", probability());
  camera.confidence_bad_max = map.read_float("confidence_bad_max", probability());
  map.finish();
}

std::string camera_key(std::size_t c, std::string_view field) {
  return "cameras." + std::string(to_string(static_cast<CameraId>(c))) + "." + std::string(field);
}

void cross_check(YamlReader& reader, const FastPlantConfig& config) {
  const FastInfeedConfig& infeed = config.infeed;
  reader.require(infeed.hopper_min_opening_mm < infeed.hopper_max_opening_mm,
                 {"infeed.hopper_min_opening_mm", "infeed.hopper_max_opening_mm"},
                 "the minimum opening must be below the maximum");
  reader.require(infeed.hopper_initial_opening_mm >= infeed.hopper_min_opening_mm &&
                     infeed.hopper_initial_opening_mm <= infeed.hopper_max_opening_mm,
                 {"infeed.hopper_initial_opening_mm", "infeed.hopper_min_opening_mm",
                  "infeed.hopper_max_opening_mm"},
                 "the initial opening must lie between the cylinder's end stops");
  reader.require(infeed.block_opening_mm < infeed.flow_opening_mm,
                 {"infeed.block_opening_mm", "infeed.flow_opening_mm"},
                 "the blocking opening must be below the free-flowing one (thesis 6.1)");
  reader.require(infeed.takt_gap_min_mm <= infeed.takt_gap_max_mm,
                 {"infeed.takt_gap_min_mm", "infeed.takt_gap_max_mm"},
                 "the minimum gap must not exceed the maximum");
  const FastFilletConfig& fillet = config.fillet;
  reader.require(fillet.thickest_from_thick_end - fillet.thickest_spread > 0.0F &&
                     fillet.thickest_from_thick_end + fillet.thickest_spread < 1.0F,
                 {"fillets.thickest_from_thick_end", "fillets.thickest_spread"},
                 "the thickest section must stay inside the fillet");
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const FastCameraConfig& camera = config.cameras[c];
    const std::string ok_min = camera_key(c, "confidence_ok_min");
    const std::string ok_max = camera_key(c, "confidence_ok_max");
    const std::string bad_min = camera_key(c, "confidence_bad_min");
    const std::string bad_max = camera_key(c, "confidence_bad_max");
    reader.require(camera.confidence_ok_min <= camera.confidence_ok_max, {ok_min, ok_max},
                   "the confidence range is empty");
    reader.require(camera.confidence_bad_min <= camera.confidence_bad_max, {bad_min, bad_max},
                   "the confidence range is empty");
  }
}

}  // namespace

FastPlantConfig load_fast_plant_config(const std::filesystem::path& file) {
  FastPlantConfig config;
  YamlReader reader = YamlReader::from_file(file);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader simulation = root.map("simulation");
      // Above 10 ms the step would skip the drive delay and the 25 ms camera period.
      config.internal_step_s =
          simulation.read_float("internal_step_s", Range::above(0.0).and_at_most(0.01));
      config.max_bodies = simulation.read_int<std::uint32_t>("max_bodies", Range::closed(1, 4096));
      config.exit_capacity =
          simulation.read_int<std::uint32_t>("exit_capacity", Range::closed(1, 1000000));
      simulation.finish();
    }
    read_fillets(root, config.fillet);
    read_infeed(root, config.infeed);
    read_belts(root, config.belts);
    read_stations(root, config);
    {
      YamlMapReader cameras = root.map("cameras");
      for (std::size_t c = 0; c < kCameraCount; ++c) {
        read_camera(cameras, static_cast<CameraId>(c), config.cameras[c]);
      }
      cameras.finish();
    }
    root.finish();
  }
  cross_check(reader, config);
  reader.throw_if_problems();
  return config;
}

}  // namespace fl
