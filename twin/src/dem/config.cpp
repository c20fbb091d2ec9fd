#include "fl/twin/dem/config.hpp"

#include <stdexcept>

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/stl.hpp"

namespace fl::dem {
namespace {

constexpr std::uint32_t kFilletA = 0;
constexpr std::uint32_t kFilletB = 1;
constexpr std::uint32_t kEquipment = 2;

std::vector<LawSpec> fillet_chain(double friction_coefficient) {
  return {{"hertz_mindlin", {{"restitution", 1e-4}}},
          {"jkr", {{"surface_energy_j_per_m2", 0.055}}},
          {"coulomb", {{"friction_coefficient", friction_coefficient}}}};
}

// A required 3-vector: a box without a corner is a problem, not a box at the origin. A wrong
// one is reported by the reader (and the load throws), so its value here is never used.
Vec3 read_required_vec3(YamlMapReader& map, std::string_view key) {
  const std::vector<double> values = map.read_doubles(key, Range::any(), 3);
  return values.size() == 3 ? Vec3(values[0], values[1], values[2]) : Vec3::Zero();
}

Vec3 read_vec3(YamlMapReader& map, std::string_view key, const Vec3& fallback) {
  return map.has(key) ? read_required_vec3(map, key) : fallback;
}

LawParameters read_law_parameters(YamlMapReader& map, const std::vector<LawParameterInfo>& info) {
  LawParameters parameters;
  for (const LawParameterInfo& p : info) {
    const Range range = Range::closed(p.min, p.max);
    parameters[p.name] = p.default_value ? map.read_double_or(p.name, *p.default_value, range)
                                         : map.read_double(p.name, range);
  }
  return parameters;
}

}  // namespace

ModelSpec appendix_b_model_spec() {
  ModelSpec spec;
  spec.materials = {{"fillet", 3.7e5, 0.37, 940.0}, {"steel", 2.0e11, 0.3, 7850.0}};
  spec.types = {{"fillet_a", 0}, {"fillet_b", 0}, {"equipment", 1}};
  const LawSpec bpm{"bpm",
                    {{"normal_stiffness_n_per_m3", 1e6},
                     {"shear_stiffness_n_per_m3", 6e4},
                     {"normal_strength_pa", 1e300},
                     {"shear_strength_pa", 1e300},
                     {"bonded_disk_scale", 1.0}}};
  spec.interactions = {
      {kFilletA, kFilletA, fillet_chain(0.1), std::nullopt, false},
      {kFilletB, kFilletB, fillet_chain(0.1), std::nullopt, false},
      {kFilletA, kFilletB, fillet_chain(0.1), bpm, false},  // A-B bonds only (thesis 3.3.1)
      {kFilletA, kEquipment, fillet_chain(0.5), std::nullopt, false},
      {kFilletB, kEquipment, fillet_chain(0.5), std::nullopt, false},
  };
  spec.timestep_s = default_timestep_s(0.004, 940.0, 3.7e5, 0.37);
  return spec;
}

ModelSpec load_model_spec(const std::filesystem::path& yaml_file, const LawRegistry& registry) {
  ModelSpec spec;
  YamlReader reader = YamlReader::from_file(yaml_file);
  {
    YamlMapReader root = reader.root();
    {
      YamlMapReader solver = root.map("solver");
      spec.timestep_s = solver.read_double("timestep_s", Range::above(0.0).and_below(1.0));
      spec.neighbor_skin_m =
          solver.read_double("neighbor_skin_m", Range::above(0.0).and_below(1.0));
      spec.thread_count = solver.read_int<int>("thread_count", Range::closed(1, 256));
      spec.min_particles_per_thread = solver.read_int_or<int>(
          "min_particles_per_thread", spec.min_particles_per_thread, Range::closed(1, 1e9));
      spec.sort_every_rebuilds =
          solver.read_int_or<int>("sort_every_rebuilds", 20, Range::closed(0, 1e6));
      spec.gravity_m_per_s2 = read_vec3(solver, "gravity_m_per_s2", spec.gravity_m_per_s2);
      solver.finish();
    }
    {
      YamlMapReader domain = root.map("domain");
      spec.domain.lower_m = read_vec3(domain, "lower_m", spec.domain.lower_m);
      spec.domain.upper_m = read_vec3(domain, "upper_m", spec.domain.upper_m);
      domain.finish();
    }
    root.for_each_map("materials", [&](YamlMapReader& m, std::size_t) {
      Material material;
      material.name = m.read_string("name");
      material.youngs_modulus_pa = m.read_double("youngs_modulus_pa", Range::positive());
      material.poisson_ratio = m.read_double("poisson_ratio", Range::closed(0.0, 0.5));
      material.density_kg_per_m3 = m.read_double("density_kg_per_m3", Range::positive());
      spec.materials.push_back(material);
    });
    auto material_index = [&](YamlMapReader& m, std::string_view key) -> std::uint32_t {
      const std::string name = m.read_string(key);
      for (std::size_t k = 0; k < spec.materials.size(); ++k) {
        if (spec.materials[k].name == name) return static_cast<std::uint32_t>(k);
      }
      m.report(key, ProblemKind::kInvalidValue, "no material named '" + name + "'");
      return 0;
    };
    root.for_each_map("types", [&](YamlMapReader& m, std::size_t) {
      ParticleType type;
      type.name = m.read_string("name");
      type.material = material_index(m, "material");
      spec.types.push_back(type);
    });
    auto type_index = [&](YamlMapReader& m, std::string_view key) -> std::uint32_t {
      const std::string name = m.read_string(key);
      for (std::size_t k = 0; k < spec.types.size(); ++k) {
        if (spec.types[k].name == name) return static_cast<std::uint32_t>(k);
      }
      m.report(key, ProblemKind::kInvalidValue, "no type named '" + name + "'");
      return 0;
    };
    root.for_each_map("interactions", [&](YamlMapReader& m, std::size_t) {
      InteractionSpec interaction;
      interaction.type_a = type_index(m, "type_a");
      interaction.type_b = type_index(m, "type_b");
      m.for_each_map("contact_laws", [&](YamlMapReader& law, std::size_t) {
        LawSpec spec_of_law;
        spec_of_law.name = law.read_string("law");
        const auto* info = registry.find_contact_law(spec_of_law.name);
        if (info == nullptr) {
          law.report("law", ProblemKind::kInvalidValue,
                     "unknown contact law '" + spec_of_law.name + "'");
          return;
        }
        spec_of_law.parameters = read_law_parameters(law, info->parameters);
        interaction.contact_laws.push_back(spec_of_law);
      });
      if (m.has("bond_law")) {
        YamlMapReader law = m.map("bond_law");
        LawSpec spec_of_law;
        spec_of_law.name = law.read_string("law");
        const auto* info = registry.find_bond_law(spec_of_law.name);
        if (info == nullptr) {
          law.report("law", ProblemKind::kInvalidValue,
                     "unknown bond law '" + spec_of_law.name + "'");
        } else {
          spec_of_law.parameters = read_law_parameters(law, info->parameters);
          interaction.bond_law = spec_of_law;
        }
        law.finish();
      }
      interaction.contact_between_bonded = m.read_bool_or("contact_between_bonded", false);
      spec.interactions.push_back(interaction);
    });
    // Walls from the file: boxes, and triangle meshes from STL files (paths relative to this
    // file; the STL's unit times `scale` is metres, then moved by `offset_m`).
    if (root.has("boxes")) {
      root.for_each_map("boxes", [&](YamlMapReader& m, std::size_t) {
        const std::string name = m.read_string("name");
        const std::uint32_t type = type_index(m, "type");
        const Vec3 min_m = read_required_vec3(m, "min_m");
        const Vec3 max_m = read_required_vec3(m, "max_m");
        if (m.has("min_m") && m.has("max_m") && !(min_m.array() < max_m.array()).all()) {
          m.report("max_m", ProblemKind::kInconsistent,
                   "a box needs max_m above min_m on every axis");
          return;
        }
        spec.meshes.push_back(box_mesh_wall(name, type, min_m, max_m));
      });
    }
    if (root.has("meshes")) {
      root.for_each_map("meshes", [&](YamlMapReader& m, std::size_t) {
        MeshWallSpec wall;
        wall.name = m.read_string("name");
        wall.type = type_index(m, "type");
        const std::string stl = m.read_string("stl");
        StlReadOptions options;
        options.require_closed = false;  // a chute or a guide is an open surface
        options.scale = m.read_double_or("scale", 1.0, Range::positive());
        const Vec3 offset_m = read_vec3(m, "offset_m", Vec3::Zero());
        if (stl.empty()) return;  // reported by read_string
        const std::filesystem::path file = yaml_file.parent_path() / stl;
        try {
          const StlReadResult read = read_stl(file, options);
          for (const IndexedTriangle& t : read.mesh.triangles) {
            wall.triangles.push_back(
                {{read.mesh.vertices[t[0]] + offset_m, read.mesh.vertices[t[1]] + offset_m,
                  read.mesh.vertices[t[2]] + offset_m}});
          }
        } catch (const StlError& error) {
          m.report("stl", ProblemKind::kInvalidValue, error.what());
          return;
        }
        spec.meshes.push_back(std::move(wall));
      });
    }
    if (root.has("planes")) {
      root.for_each_map("planes", [&](YamlMapReader& m, std::size_t) {
        PlaneWallSpec plane;
        plane.name = m.read_string("name");
        plane.type = type_index(m, "type");
        plane.point_m = read_vec3(m, "point_m", plane.point_m);
        plane.normal = read_vec3(m, "normal", plane.normal);
        if (plane.normal.norm() > 0.0) plane.normal.normalize();
        spec.planes.push_back(plane);
      });
    }
    root.finish();
  }
  reader.throw_if_problems();
  return spec;
}

}  // namespace fl::dem
