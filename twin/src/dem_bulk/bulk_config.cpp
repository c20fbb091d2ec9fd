// Strict loader of config/bulk_dem.yaml (BulkDemConfig) on fl::YamlReader, as the engine's
// loader (twin/src/dem/config.cpp): every problem with file:line and key path, unknown keys are
// errors, and the engine's materials and laws come from the file `models.dem_engine` names.
#include <cmath>

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem_bulk/bulk_scene.hpp"

namespace fl {

BulkDemConfig default_bulk_dem_config() {
  BulkDemConfig config;
  config.engine = dem::appendix_b_model_spec();
  return config;
}

BulkDemConfig load_bulk_dem_config(const std::filesystem::path& file) {
  BulkDemConfig config;
  std::string engine_file;
  YamlReader reader = YamlReader::from_file(file);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader models = root.map("models");
      engine_file = models.read_string("dem_engine");
      models.finish();
    }
    {
      YamlMapReader map = root.map("simulation");
      BulkSimulationConfig& s = config.simulation;
      s.sub_particle_radius_mm =
          map.read_double("sub_particle_radius_mm", Range::closed(2.0, 10.0));
      // EDEM advises 20..40 % at most; above 40 % the engine's own check fails.
      s.rayleigh_fraction =
          map.read_double("rayleigh_fraction", Range::above(0.0).and_at_most(0.4));
      s.neighbor_skin_mm = map.read_double("neighbor_skin_mm", Range::above(0.0).and_at_most(20.0));
      s.thread_count = map.read_int<int>("thread_count", Range::closed(1, 256));
      s.control_step_s = map.read_double("control_step_s", Range::above(0.0).and_at_most(0.05));
      s.seed =
          static_cast<std::uint64_t>(map.read_int<std::int64_t>("seed", Range::closed(0, 9.0e15)));
      map.finish();
    }
    {
      YamlMapReader map = root.map("belt");
      BulkBeltConfig& b = config.belt;
      b.half_width_mm = map.read_double("half_width_mm", Range::closed(50.0, 2000.0));
      b.start_mm = map.read_double("start_mm", Range::any());
      b.discharge_mm = map.read_double("discharge_mm", Range::any());
      b.max_speed_mps = map.read_double("max_speed_mps", Range::positive());
      b.speed_mps = map.read_double("speed_mps", Range::any());
      b.side_wall_height_mm = map.read_double("side_wall_height_mm", Range::positive());
      map.finish();
    }
    {
      YamlMapReader map = root.map("hopper");
      BulkHopperConfig& h = config.hopper;
      h.back_mm = map.read_double("back_mm", Range::any());
      h.height_mm = map.read_double("height_mm", Range::positive());
      h.back_slope_deg = map.read_double("back_slope_deg", Range::closed(0.0, 60.0));
      h.wall_gap_mm = map.read_double("wall_gap_mm", Range::closed(0.0, 50.0));
      map.finish();
    }
    {
      YamlMapReader map = root.map("gate");
      BulkGateConfig& g = config.gate;
      g.x_mm = map.read_double("x_mm", Range::any());
      g.opening_mm = map.read_double("opening_mm", Range::non_negative());
      g.min_opening_mm = map.read_double("min_opening_mm", Range::non_negative());
      g.max_opening_mm = map.read_double("max_opening_mm", Range::positive());
      g.cylinder_speed_mmps = map.read_double("cylinder_speed_mmps", Range::positive());
      map.finish();
    }
    {
      YamlMapReader map = root.map("leveller");
      BulkLevellerConfig& l = config.leveller;
      l.x_mm = map.read_double("x_mm", Range::any());
      l.blades = map.read_int<int>("blades", Range::closed(1, 64));
      l.tip_radius_mm = map.read_double("tip_radius_mm", Range::positive());
      l.hub_radius_mm = map.read_double("hub_radius_mm", Range::positive());
      l.tip_clearance_mm = map.read_double("tip_clearance_mm", Range::positive());
      l.speed_rpm = map.read_double("speed_rpm", Range::closed(-1000.0, 1000.0));
      l.hub_segments = map.read_int<int>("hub_segments", Range::closed(6, 256));
      map.finish();
    }
    {
      YamlMapReader map = root.map("feeder");
      BulkFeederConfig& f = config.feeder;
      f.initial_fill = map.read_int<std::uint32_t>("initial_fill", Range::closed(0, 100000));
      f.rate_per_s = map.read_double("rate_per_s", Range::non_negative());
      f.drop_height_mm = map.read_double("drop_height_mm", Range::positive());
      f.max_tilt_deg = map.read_double("max_tilt_deg", Range::closed(0.0, 90.0));
      f.max_fillets = map.read_int<std::uint32_t>("max_fillets", Range::closed(1, 100000));
      map.finish();
    }
    // Optional: the leveller unit's own belt (bulk_line.yaml); without it one belt runs on.
    if (root.has("leveller_belt")) {
      YamlMapReader map = root.map("leveller_belt");
      BulkLevellerBeltConfig& b = config.leveller_belt;
      b.present = true;
      b.from_mm = map.read_double("from_mm", Range::any());
      b.speed_mps = map.read_double("speed_mps", Range::positive());
      b.rotor_rpm = map.read_double("rotor_rpm", Range::above(0.0).and_at_most(1000.0));
      map.finish();
    }
    root.finish();
  }
  const BulkDemConfig& c = config;
  if (c.leveller_belt.present) {
    reader.require(c.gate.x_mm < c.leveller_belt.from_mm &&
                       c.leveller_belt.from_mm < c.leveller.x_mm - c.leveller.tip_radius_mm,
                   {"leveller_belt.from_mm", "gate.x_mm", "leveller.x_mm"},
                   "the leveller's belt must start between the gate and the rotor's tip circle");
    reader.require(c.leveller_belt.speed_mps <= c.belt.max_speed_mps,
                   {"leveller_belt.speed_mps", "belt.max_speed_mps"},
                   "the leveller's belt speed exceeds the belts' maximum");
  }
  reader.require(
      c.belt.start_mm < c.hopper.back_mm - c.hopper.height_mm * std::tan(c.hopper.back_slope_deg *
                                                                         3.141592653589793 / 180.0),
      {"belt.start_mm", "hopper.back_mm", "hopper.back_slope_deg"},
      "the belt must start behind the top of the hopper's back wall");
  reader.require(c.hopper.back_mm < c.gate.x_mm, {"hopper.back_mm", "gate.x_mm"},
                 "the back wall must be upstream of the gate");
  reader.require(c.gate.x_mm < c.leveller.x_mm - c.leveller.tip_radius_mm,
                 {"gate.x_mm", "leveller.x_mm", "leveller.tip_radius_mm"},
                 "the leveller's blades must clear the gate");
  reader.require(c.leveller.x_mm + c.leveller.tip_radius_mm < c.belt.discharge_mm,
                 {"leveller.x_mm", "leveller.tip_radius_mm", "belt.discharge_mm"},
                 "the leveller must sit over the belt, upstream of the discharge edge");
  reader.require(c.leveller.hub_radius_mm < c.leveller.tip_radius_mm,
                 {"leveller.hub_radius_mm", "leveller.tip_radius_mm"},
                 "the blades must reach beyond the hub");
  reader.require(
      c.gate.min_opening_mm <= c.gate.opening_mm && c.gate.opening_mm <= c.gate.max_opening_mm,
      {"gate.opening_mm", "gate.min_opening_mm", "gate.max_opening_mm"},
      "the opening must lie between the end stops");
  reader.require(c.gate.max_opening_mm < c.hopper.height_mm,
                 {"gate.max_opening_mm", "hopper.height_mm"},
                 "the gate must close the hopper's front");
  reader.require(std::abs(c.belt.speed_mps) <= c.belt.max_speed_mps,
                 {"belt.speed_mps", "belt.max_speed_mps"}, "the belt speed exceeds its maximum");
  reader.throw_if_problems();
  config.engine = dem::load_model_spec(file.parent_path() / engine_file);
  return config;
}

}  // namespace fl
