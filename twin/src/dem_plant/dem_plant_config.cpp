// Strict loader of config/plant_dem.yaml (DemPlantConfig) on fl::YamlReader.
#include "fl/twin/dem_plant/dem_plant_config.hpp"

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/config.hpp"

namespace fl {
namespace {

constexpr std::array<EnumName<DemInfeedSource>, 2> kInfeedSources{{
    {"levelled_layer", DemInfeedSource::kLevelledLayer},
    {"dem_bulk_end", DemInfeedSource::kDemBulkEnd},
}};

constexpr std::array<EnumName<DemCentringUnit>, 2> kCentringUnits{{
    {"pusher", DemCentringUnit::kPusher},
    {"jaws", DemCentringUnit::kJaws},
}};

ConfigProblem inconsistent(const std::filesystem::path& file, std::string key_path,
                           std::string detail) {
  ConfigProblem problem;
  problem.file = file.string();
  problem.key_path = std::move(key_path);
  problem.kind = ProblemKind::kInconsistent;
  problem.detail = std::move(detail);
  return problem;
}

// The bulk end against the plant that hands its fillets on: checked whichever infeed is
// chosen, so that switching to it never finds a broken pair of files.
void check_bulk_end(const DemPlantConfig& config, const std::filesystem::path& plant_file,
                    const std::filesystem::path& bulk_file) {
  const BulkDemConfig& bulk = config.bulk_end;
  std::vector<ConfigProblem> problems;
  // The takt belt receives the plant's own template of the handed-over variant: the same raster.
  if (std::abs(bulk.simulation.sub_particle_radius_mm -
               static_cast<double>(config.simulation.sub_particle_radius_mm)) > 1e-9) {
    problems.push_back(inconsistent(
        bulk_file, "simulation.sub_particle_radius_mm",
        "got " + format_number(bulk.simulation.sub_particle_radius_mm) + ", must equal " +
            plant_file.filename().string() + "'s simulation.sub_particle_radius_mm (" +
            format_number(config.simulation.sub_particle_radius_mm) + ")"));
  }
  // The scene runs whole control steps of its own inside the plant's.
  const double ratio = bulk.simulation.control_step_s / config.simulation.control_step_s;
  if (std::abs(ratio - std::round(ratio)) > 1e-6 || ratio < 0.5) {
    problems.push_back(inconsistent(
        bulk_file, "simulation.control_step_s",
        "got " + format_number(bulk.simulation.control_step_s) + ", must be a whole multiple of " +
            plant_file.filename().string() + "'s simulation.control_step_s (" +
            format_number(config.simulation.control_step_s) + ")"));
  }
  // In front of the leveller: downstream of the gate, upstream of the rotor's tip circle.
  const double rotor_front_mm = bulk.leveller.x_mm - bulk.leveller.tip_radius_mm;
  if (config.feeder.level_sensor_from_mm < bulk.gate.x_mm ||
      config.feeder.level_sensor_to_mm > rotor_front_mm) {
    problems.push_back(inconsistent(
        plant_file, "feeder.level_sensor_from_mm",
        "the level sensor's window " + format_number(config.feeder.level_sensor_from_mm) + ".." +
            format_number(config.feeder.level_sensor_to_mm) +
            " mm must lie in front of the "
            "leveller, between the gate (" +
            format_number(bulk.gate.x_mm) + " mm) and the rotor's tip circle (" +
            format_number(rotor_front_mm) + " mm) of " + bulk_file.filename().string()));
  }
  // The controller stops the bulk belt while the heap stands over its setpoint; on one belt
  // that also stops the levelled layer, and nothing ever reaches the takt (seen: a 65 mm heap
  // of 7 mm fillets against the 60 mm setpoint held the line empty for 30 s).
  if (!bulk.leveller_belt.present) {
    problems.push_back(inconsistent(bulk_file, "leveller_belt",
                                    "missing: the line's bulk end needs the leveller's own belt"));
  }
  if (!problems.empty()) throw ConfigError(std::move(problems));
}

}  // namespace

DemPlantConfig default_dem_plant_config() {
  DemPlantConfig config;
  config.engine = dem::appendix_b_model_spec();
  config.bulk_end = default_bulk_dem_config();
  return config;
}

DemPlantConfig load_dem_plant_config(const std::filesystem::path& file) {
  DemPlantConfig config;
  std::string engine_file;
  std::string shared_file;
  std::string bulk_file;
  YamlReader reader = YamlReader::from_file(file);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader models = root.map("models");
      engine_file = models.read_string("dem_engine");
      shared_file = models.read_string("cameras_and_infeed");
      bulk_file = models.read_string("bulk_end");
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
      m.pusher_brake_mps2 = map.read_float("pusher_brake_mps2", Range::positive());
      m.centring_unit = map.read_enum("centring_unit", kCentringUnits);
      m.jaw_grip_force_n = map.read_float("jaw_grip_force_n", Range::positive());
      m.jaw_min_half_gap_mm = map.read_float("jaw_min_half_gap_mm", Range::positive());
      m.jaw_half_length_mm = map.read_float("jaw_half_length_mm", Range::positive());
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
      DemFeederConfig& f = config.feeder;
      f.spawn_lift_mm = map.read_float("spawn_lift_mm", Range::closed(0.0, 50.0));
      f.source = map.read_enum("source", kInfeedSources);
      f.level_sensor_from_mm = map.read_float("level_sensor_from_mm", Range::any());
      f.level_sensor_to_mm = map.read_float("level_sensor_to_mm", Range::any());
      f.handover_gap_mm = map.read_float("handover_gap_mm", Range::closed(0.0, 500.0));
      f.leveller_trip_torque_nm = map.read_float("leveller_trip_torque_nm", Range::positive());
      map.finish();
      reader.require(f.level_sensor_from_mm < f.level_sensor_to_mm,
                     {"feeder.level_sensor_from_mm", "feeder.level_sensor_to_mm"},
                     "the level sensor's window must run downstream");
    }
    root.finish();
  }
  reader.throw_if_problems();
  const std::filesystem::path folder = file.parent_path();
  config.engine = dem::load_model_spec(folder / engine_file);
  config.shared = load_fast_plant_config(folder / shared_file);
  config.bulk_end = load_bulk_dem_config(folder / bulk_file);
  check_bulk_end(config, file, folder / bulk_file);
  return config;
}

}  // namespace fl
