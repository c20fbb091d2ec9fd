// config/model_tests.yaml reader (fl/twin/model_tests/config.hpp), on fl::YamlReader.
#include "fl/twin/model_tests/config.hpp"

#include "fl/controller/yaml_reader.hpp"

namespace fl::model_tests {
namespace {

std::vector<double> read_list(YamlMapReader& map, std::string_view key, const Range& range) {
  std::vector<double> values = map.read_doubles(key, range);
  if (values.empty() && map.has(key)) map.report(key, ProblemKind::kInvalidValue, "list is empty");
  return values;
}

Stiffness read_stiffness(YamlMapReader& map) {
  Stiffness s;
  // Appendix C spans 1e4..1e8; the bpm law accepts any positive value.
  s.normal_n_per_m3 = map.read_double("normal_n_per_m3", Range::positive());
  s.shear_n_per_m3 = map.read_double("shear_n_per_m3", Range::positive());
  return s;
}

ModelTestsConfig read(YamlReader& reader) {
  ModelTestsConfig c;
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader m = root.map("common");
      c.sub_particle_radius_m =
          1e-3 * m.read_double("sub_particle_radius_mm", Range::closed(1.0, 20.0));
      c.variant = static_cast<std::size_t>(m.read_int<int>("variant", Range::closed(0, 5)));
      c.fillet_mesh_stl = m.read_string("fillet_mesh_stl");
      c.rayleigh_fraction = m.read_double("rayleigh_fraction", Range::above(0.0).and_at_most(1.0));
      c.bond_step_fraction = m.read_double("bond_step_fraction", Range::closed(0.0, 1.0));
      c.seed = m.read_int<std::uint32_t>("seed", Range::closed(0, 4294967295.0));
      m.finish();
    }
    {
      YamlMapReader m = root.map("settle");
      c.settle.drop_height_m = m.read_double("drop_height_m", Range::positive());
      c.settle.duration_s = m.read_double("duration_s", Range::positive());
      c.settle.sample_interval_s = m.read_double("sample_interval_s", Range::positive());
      c.basic_drop_height_m = m.read_double("basic_drop_height_m", Range::positive());
      c.basic_duration_s = m.read_double("basic_duration_s", Range::positive());
      c.no_shear_stiffness_n_per_m3 =
          m.read_double("no_shear_stiffness_n_per_m3", Range::positive());
      c.restitution_sweep = read_list(m, "restitution_sweep", Range::above(0.0).and_at_most(1.0));
      m.finish();
    }
    {
      YamlMapReader m = root.map("bend");
      c.bend.table_length_m = m.read_double("table_length_m", Range::positive());
      c.bend.table_width_m = m.read_double("table_width_m", Range::positive());
      c.bend.table_thickness_m = m.read_double("table_thickness_m", Range::positive());
      c.bend.overhang_share = m.read_double("overhang_share", Range::open(0.0, 1.0));
      c.bend.clamp_behind_edge_m = m.read_double("clamp_behind_edge_m", Range::non_negative());
      c.bend.duration_s = m.read_double("duration_s", Range::positive());
      c.bend.sample_interval_s = m.read_double("sample_interval_s", Range::positive());
      c.bend.rest_damping_per_s =
          m.read_double_or("rest_damping_per_s", c.bend.rest_damping_per_s, Range::non_negative());
      c.bend_stiffness_factors = read_list(m, "stiffness_factors", Range::positive());
      m.finish();
    }
    {
      YamlMapReader m = root.map("slide");
      c.slide.plate_length_m = m.read_double("plate_length_m", Range::positive());
      c.slide.plate_width_m = m.read_double("plate_width_m", Range::positive());
      c.slide.plate_thickness_m = m.read_double("plate_thickness_m", Range::positive());
      c.slide.tilt_rate_deg_per_s = m.read_double("tilt_rate_deg_per_s", Range::positive());
      c.slide.max_angle_deg = m.read_double("max_angle_deg", Range::open(0.0, 90.0));
      c.slide.settle_s = m.read_double("settle_s", Range::non_negative());
      c.slide.slide_distance_m = m.read_double("slide_distance_m", Range::positive());
      c.slide.friction_coefficient =
          m.read_double("friction_coefficient", Range::closed(0.0, 100.0));
      c.slide.surface_energy_j_per_m2 =
          m.read_double("surface_energy_j_per_m2", Range::closed(0.0, 1e3));
      c.friction_sweep = read_list(m, "friction_sweep", Range::closed(0.0, 100.0));
      c.surface_energy_sweep_j_per_m2 =
          read_list(m, "surface_energy_sweep_j_per_m2", Range::closed(0.0, 1e3));
      YamlMapReader rigid = m.map("rigid_stiffness");
      c.slide.rigid_stiffness = read_stiffness(rigid);
      rigid.finish();
      m.finish();
    }
    {
      YamlMapReader m = root.map("compress");
      const std::vector<double> n = m.read_doubles("block_spheres", Range::closed(1, 50), 3);
      if (n.size() == 3) {
        c.compress.block_nx = static_cast<int>(n[0]);
        c.compress.block_ny = static_cast<int>(n[1]);
        c.compress.block_nz = static_cast<int>(n[2]);
      }
      c.compress.speed_m_per_s = m.read_double("speed_m_per_s", Range::positive());
      c.compress.max_strain = m.read_double("max_strain", Range::open(0.0, 0.5));
      c.compress.samples = m.read_int<int>("samples", Range::closed(10, 100000));
      m.finish();
      reader.require(c.compress.block_nz >= 2, {"compress.block_spheres"},
                     "the block needs at least 2 layers (nz >= 2)");
    }
    {
      YamlMapReader m = root.map("impact");
      c.impact_speeds_m_per_s = read_list(m, "speeds_m_per_s", Range::non_negative());
      c.impact_drop.duration_s = m.read_double("duration_s", Range::positive());
      c.impact_orientations = m.read_int<int>("orientations", Range::closed(1, 1000));
      m.for_each_map("stiffness_sets", [&](YamlMapReader& e, std::size_t) {
        c.impact_stiffness_sets.push_back(read_stiffness(e));
      });
      m.finish();
    }
    {
      YamlMapReader m = root.map("drop_angle");
      c.angle_drop.speed_m_per_s = m.read_double("speed_m_per_s", Range::non_negative());
      c.angle_drop.duration_s = m.read_double("duration_s", Range::positive());
      c.angle_samples = m.read_int<int>("samples", Range::closed(1, 100000));
      m.finish();
    }
    {
      YamlMapReader m = root.map("scaling");
      c.scales = read_list(m, "scales", Range::positive());
      c.scaling_drop.drop_height_m = m.read_double("drop_height_m", Range::positive());
      c.scaling_drop.duration_s = m.read_double("duration_s", Range::positive());
      c.timestep_factors = read_list(m, "timestep_factors_of_bond_critical", Range::positive());
      m.finish();
    }
    {
      YamlMapReader m = root.map("doe");
      const double normal_first = m.read_double("normal_first_n_per_m3", Range::positive());
      const double shear_first = m.read_double("shear_first_n_per_m3", Range::positive());
      const int decades = m.read_int<int>("decades", Range::closed(1, 10));
      const std::vector<double> mantissas = read_list(m, "mantissas", Range::open(0.0, 10.0));
      c.doe_duration_s = m.read_double("duration_s", Range::positive());
      c.doe_bend = m.read_bool("bend");
      c.doe_bend_duration_s = m.read_double("bend_duration_s", Range::positive());
      m.finish();
      c.doe_normal_levels_n_per_m3 = log_levels(normal_first, decades, mantissas);
      c.doe_shear_levels_n_per_m3 = log_levels(shear_first, decades, mantissas);
    }
    root.finish();
  }
  reader.throw_if_problems();
  return c;
}

}  // namespace

void apply_common(ModelTestsConfig& c, const CommonParams& common) {
  for (CommonParams* p : {&c.settle.common, &c.bend.common, &c.slide.common, &c.compress.common,
                          &c.impact_drop.common, &c.angle_drop.common, &c.scaling_drop.common}) {
    *p = common;
  }
}

ModelTestsConfig load_model_tests_config(const std::filesystem::path& yaml_file) {
  YamlReader reader = YamlReader::from_file(yaml_file);
  return read(reader);
}

ModelTestsConfig load_model_tests_config_text(std::string_view yaml_text,
                                              std::string_view source_name) {
  YamlReader reader = YamlReader::from_text(yaml_text, source_name);
  return read(reader);
}

}  // namespace fl::model_tests
