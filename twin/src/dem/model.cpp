#include "fl/twin/dem/model.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace fl::dem {

PairMaterial make_pair_material(const Material& a, const Material& b, bool with_wall) {
  PairMaterial pair;
  pair.effective_youngs_modulus_pa =
      1.0 / ((1.0 - a.poisson_ratio * a.poisson_ratio) / a.youngs_modulus_pa +
             (1.0 - b.poisson_ratio * b.poisson_ratio) / b.youngs_modulus_pa);
  pair.effective_shear_modulus_pa =
      1.0 / (2.0 * (2.0 - a.poisson_ratio) * (1.0 + a.poisson_ratio) / a.youngs_modulus_pa +
             2.0 * (2.0 - b.poisson_ratio) * (1.0 + b.poisson_ratio) / b.youngs_modulus_pa);
  pair.with_wall = with_wall;
  return pair;
}

Model::Model(ModelSpec spec, const LawRegistry& registry) : spec_(std::move(spec)) {
  const std::size_t count = spec_.types.size();
  if (count == 0) {
    throw std::invalid_argument("dem model: no particle types");
  }
  for (const ParticleType& type : spec_.types) {
    if (type.material >= spec_.materials.size()) {
      throw std::invalid_argument("dem model: type '" + type.name + "' has no material");
    }
  }
  if (!(spec_.timestep_s > 0.0) || !(spec_.neighbor_skin_m > 0.0) || spec_.thread_count < 1) {
    throw std::invalid_argument("dem model: timestep, skin and thread count must be positive");
  }
  // Walls are identified by their type; a type used by a wall makes its pairs wall pairs.
  std::vector<bool> wall_type(count, false);
  for (const auto& plane : spec_.planes) {
    if (plane.type >= count) throw std::invalid_argument("dem model: plane with unknown type");
    wall_type[plane.type] = true;
  }
  for (const auto& mesh : spec_.meshes) {
    if (mesh.type >= count) throw std::invalid_argument("dem model: mesh with unknown type");
    wall_type[mesh.type] = true;
  }
  table_.resize(count * count);
  for (const InteractionSpec& interaction : spec_.interactions) {
    if (interaction.type_a >= count || interaction.type_b >= count) {
      throw std::invalid_argument("dem model: interaction with unknown type");
    }
    for (const auto& [first, second] : {std::pair{interaction.type_a, interaction.type_b},
                                        std::pair{interaction.type_b, interaction.type_a}}) {
      Interaction& entry = table_[first * count + second];
      entry.material = make_pair_material(material_of_type(first), material_of_type(second),
                                          wall_type[first] || wall_type[second]);
      entry.contact_laws.clear();
      std::vector<std::string> names;
      for (const LawSpec& law : interaction.contact_laws) {
        entry.contact_laws.push_back(
            registry.create_contact_law(law.name, law.parameters, entry.material));
        names.push_back(law.name);
      }
      check_contact_chain(
          "dem model: interaction " + spec_.types[first].name + "-" + spec_.types[second].name,
          names, entry.contact_laws);
      entry.contact_chain = make_contact_chain(entry.contact_laws);
      entry.bond_law = interaction.bond_law ? registry.create_bond_law(
                                                  interaction.bond_law->name,
                                                  interaction.bond_law->parameters, entry.material)
                                            : nullptr;
      entry.contact_between_bonded = interaction.contact_between_bonded;
      if (first == second) {
        break;
      }
    }
  }
  for (Interaction& entry : table_) {  // pairs without a spec: an empty chain
    if (!entry.contact_chain) entry.contact_chain = make_contact_chain(entry.contact_laws);
  }
}

double Model::max_range_m(double max_radius_m) const {
  double range = 0.0;
  for (const Interaction& entry : table_) {
    for (const auto& law : entry.contact_laws) {
      range = std::max(range, law->range_m(max_radius_m));  // range grows with R*
    }
  }
  return range;
}

std::optional<std::uint32_t> Model::find_type(std::string_view name) const {
  for (std::size_t k = 0; k < spec_.types.size(); ++k) {
    if (spec_.types[k].name == name) {
      return static_cast<std::uint32_t>(k);
    }
  }
  return std::nullopt;
}

MeshWallSpec box_mesh_wall(const std::string& name, std::uint32_t type, const Vec3& min_m,
                           const Vec3& max_m) {
  // Corners c[k] with bit 0, 1, 2 of k choosing max in x, y, z.
  std::array<Vec3, 8> c;
  for (std::size_t k = 0; k < 8; ++k) {
    c[k] = Vec3((k & 1U) != 0U ? max_m.x() : min_m.x(), (k & 2U) != 0U ? max_m.y() : min_m.y(),
                (k & 4U) != 0U ? max_m.z() : min_m.z());
  }
  constexpr std::array<std::array<std::size_t, 4>, 6> kFaces = {
      {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};
  MeshWallSpec wall;
  wall.name = name;
  wall.type = type;
  for (const auto& f : kFaces) {
    wall.triangles.push_back({{c[f[0]], c[f[1]], c[f[2]]}});
    wall.triangles.push_back({{c[f[0]], c[f[2]], c[f[3]]}});
  }
  return wall;
}

double rayleigh_time_s(double radius_m, double density_kg_per_m3, double youngs_modulus_pa,
                       double poisson_ratio) {
  const double shear_modulus = youngs_modulus_pa / (2.0 * (1.0 + poisson_ratio));
  return std::numbers::pi * radius_m * std::sqrt(density_kg_per_m3 / shear_modulus) /
         (0.1631 * poisson_ratio + 0.8766);
}

double default_timestep_s(double radius_m, double density_kg_per_m3, double youngs_modulus_pa,
                          double poisson_ratio) {
  return kDefaultRayleighFraction *
         rayleigh_time_s(radius_m, density_kg_per_m3, youngs_modulus_pa, poisson_ratio);
}

}  // namespace fl::dem
