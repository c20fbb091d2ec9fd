// Strict loader of config/plant_dem.yaml (DemPlantConfig) on fl::YamlReader.
#include "fl/twin/dem_plant/dem_plant_config.hpp"

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/config.hpp"

namespace fl {

DemPlantConfig default_dem_plant_config() {
  DemPlantConfig config;
  config.engine = dem::appendix_b_model_spec();
  return config;
}

DemPlantConfig load_dem_plant_config(const std::filesystem::path& file) {
  DemPlantConfig config;
  std::string engine_file;
  std::string shared_file;
  YamlReader reader = YamlReader::from_file(file);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader models = root.map("models");
      engine_file = models.read_string("dem_engine");
      shared_file = models.read_string("cameras_and_infeed");
      models.finish();
    }
    {
      YamlMapReader map = root.map("simulation");
      DemSimulationConfig& s = config.simulation;
      s.sub_particle_radius_mm = map.read_float("sub_particle_radius_mm", Range::closed(2.0, 10.0));
      // EDEM advises 20..40 % at most; above 40 % the engine's own check fails.
      s.rayleigh_fraction = map.read_float("rayleigh_fraction", Range::above(0.0).and_at_most(0.4));
      s.neighbor_skin_mm = map.read_float("neighbor_skin_mm", Range::above(0.0).and_at_most(20.0));
      s.thread_count = map.read_int<int>("thread_count", Range::closed(1, 256));
      s.min_particles_per_thread =
          map.read_int<int>("min_particles_per_thread", Range::closed(1, 1000000));
      // Above 5 ms the step would skip the drive delay.
      s.control_step_s = map.read_float("control_step_s", Range::above(0.0).and_at_most(0.005));
      s.max_fillets = map.read_int<std::uint32_t>("max_fillets", Range::closed(1, 4096));
      s.exit_capacity = map.read_int<std::uint32_t>("exit_capacity", Range::closed(1, 1000000));
      map.finish();
    }
    {
      YamlMapReader map = root.map("machinery");
      DemMachineryConfig& m = config.machinery;
      m.belt_half_width_mm = map.read_float("belt_half_width_mm", Range::positive());
      m.belt_gap_mm = map.read_float("belt_gap_mm", Range::closed(0.0, 20.0));
      m.multilane_gap_mm = map.read_float("multilane_gap_mm", Range::closed(0.0, 20.0));
      m.side_wall_height_mm = map.read_float("side_wall_height_mm", Range::positive());
      m.rail_channel_half_width_mm =
          map.read_float("rail_channel_half_width_mm", Range::positive());
      m.rail_funnel_length_mm = map.read_float("rail_funnel_length_mm", Range::positive());
      m.rail_height_mm = map.read_float("rail_height_mm", Range::positive());
      m.pusher_half_length_mm = map.read_float("pusher_half_length_mm", Range::positive());
      m.pusher_height_mm = map.read_float("pusher_height_mm", Range::positive());
      m.pusher_window_half_mm = map.read_float("pusher_window_half_mm", Range::positive());
      m.pusher_accel_mps2 = map.read_float("pusher_accel_mps2", Range::positive());
      m.roller_radius_mm = map.read_float("roller_radius_mm", Range::positive());
      m.roller_up_gap_mm = map.read_float("roller_up_gap_mm", Range::positive());
      m.roller_down_gap_mm = map.read_float("roller_down_gap_mm", Range::non_negative());
      m.roller_segments = map.read_int<int>("roller_segments", Range::closed(6, 256));
      m.beam_height_mm = map.read_float("beam_height_mm", Range::positive());
      m.guide_rise_mm = map.read_float("guide_rise_mm", Range::closed(0.0, 500.0));
      m.plate1_drop_mm = map.read_float("plate1_drop_mm", Range::closed(20.0, 500.0));
      m.plate1_end_height_mm = map.read_float("plate1_end_height_mm", Range::non_negative());
      m.plate_swing_deg = map.read_float("plate_swing_deg", Range::closed(30.0, 150.0));
      map.finish();
      reader.require(m.guide_rise_mm <= m.plate1_drop_mm,
                     {"machinery.guide_rise_mm", "machinery.plate1_drop_mm"},
                     "the guide cannot start below the reject belt: its rise is at most plate "
                     "1's drop");
      reader.require(m.plate1_end_height_mm < m.plate1_drop_mm,
                     {"machinery.plate1_end_height_mm", "machinery.plate1_drop_mm"},
                     "plate 1 must slide down: its end lower than the guide's raised end");
      reader.require(m.rail_channel_half_width_mm < m.belt_half_width_mm,
                     {"machinery.rail_channel_half_width_mm", "machinery.belt_half_width_mm"},
                     "the rail channel must be narrower than the belt");
      reader.require(m.roller_down_gap_mm < m.roller_up_gap_mm,
                     {"machinery.roller_down_gap_mm", "machinery.roller_up_gap_mm"},
                     "the roller must come down when lowered");
    }
    {
      YamlMapReader map = root.map("losses");
      DemLossConfig& l = config.losses;
      l.fell_below_mm = map.read_float("fell_below_mm", Range::below(0.0));
      l.stuck_after_s = map.read_float("stuck_after_s", Range::positive());
      l.stuck_progress_mm = map.read_float("stuck_progress_mm", Range::positive());
      l.crate_overhang_mm = map.read_float("crate_overhang_mm", Range::non_negative());
      map.finish();
    }
    {
      YamlMapReader map = root.map("feeder");
      config.feeder.spawn_lift_mm = map.read_float("spawn_lift_mm", Range::closed(0.0, 50.0));
      map.finish();
    }
    root.finish();
  }
  reader.throw_if_problems();
  const std::filesystem::path folder = file.parent_path();
  config.engine = dem::load_model_spec(folder / engine_file);
  config.shared = load_fast_plant_config(folder / shared_file);
  return config;
}

}  // namespace fl
