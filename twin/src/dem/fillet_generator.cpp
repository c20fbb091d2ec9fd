// Sub-particle raster and bonds of a fillet meta-particle (fl/twin/dem/fillet_generator.hpp).
#include "fl/twin/dem/fillet_generator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace fl::dem {
namespace {

// Relative slack on the bond limit so rounding in pitch x sqrt(3) vs 2 x r x sqrt(3) cannot
// decide whether a body diagonal bonds; BondLimit decides that explicitly.
constexpr double kBondLimitSlack = 1e-9;

struct RasterIndex {
  std::int64_t i = 0, j = 0, k = 0;
  bool operator==(const RasterIndex&) const = default;
};

struct RasterIndexHash {
  std::size_t operator()(const RasterIndex& index) const {
    auto mix = static_cast<std::uint64_t>(index.i) * 0x9E3779B97F4A7C15ULL;
    mix ^= static_cast<std::uint64_t>(index.j) * 0xC2B2AE3D27D4EB4FULL + (mix << 6U);
    mix ^= static_cast<std::uint64_t>(index.k) * 0x165667B19E3779F9ULL + (mix >> 2U);
    return static_cast<std::size_t>(mix);
  }
};

void check_options(const FilletGeneratorOptions& options) {
  if (!(options.sub_particle_radius_m > 0.0) || !std::isfinite(options.sub_particle_radius_m)) {
    throw std::invalid_argument("FilletGeneratorOptions: sub_particle_radius_m must be > 0");
  }
  // Below 1 even face neighbours (distance 2r) would not bond.
  if (!(options.contact_radius_factor > 1.0) || !std::isfinite(options.contact_radius_factor)) {
    throw std::invalid_argument("FilletGeneratorOptions: contact_radius_factor must be > 1");
  }
  if (!(options.density_kg_m3 > 0.0) || !std::isfinite(options.density_kg_m3)) {
    throw std::invalid_argument("FilletGeneratorOptions: density_kg_m3 must be > 0");
  }
  if (!(options.sphere_protrusion_m >= 0.0) || !options.raster_offset_m.allFinite()) {
    throw std::invalid_argument(
        "FilletGeneratorOptions: sphere_protrusion_m must be >= 0, raster_offset_m finite");
  }
}

bool is_type_a(const RasterIndex& index) { return ((index.i + index.j + index.k) & 1) == 0; }

}  // namespace

FilletTemplate generate_fillet_template(const TriangleMesh& mesh_m, const std::string& name,
                                        const FilletGeneratorOptions& options) {
  check_options(options);
  if (!is_closed_outward(mesh_m)) {
    throw std::invalid_argument(
        "generate_fillet_template(" + name +
        "): mesh is not closed and outward: " + check_topology(mesh_m).describe());
  }
  const double radius_m = options.sub_particle_radius_m;
  const double pitch_m = 2.0 * radius_m;  // touching spheres
  const Eigen::Vector3d origin_m = volume_centroid(mesh_m) + options.raster_offset_m;
  const auto box = bounding_box(mesh_m);

  // Raster points inside the box, x fastest so the order is reproducible.
  const auto first = [&](Eigen::Index axis) {
    return static_cast<std::int64_t>(std::ceil((box.min[axis] - origin_m[axis]) / pitch_m));
  };
  const auto last = [&](Eigen::Index axis) {
    return static_cast<std::int64_t>(std::floor((box.max[axis] - origin_m[axis]) / pitch_m));
  };
  std::vector<RasterIndex> indices;
  std::vector<Eigen::Vector3d> centres_m;
  for (auto k = first(2); k <= last(2); ++k) {
    for (auto j = first(1); j <= last(1); ++j) {
      for (auto i = first(0); i <= last(0); ++i) {
        const Eigen::Vector3d centre_m =
            origin_m + pitch_m * Eigen::Vector3d(static_cast<double>(i), static_cast<double>(j),
                                                 static_cast<double>(k));
        if (!contains_point(mesh_m, centre_m)) continue;
        if (options.inclusion == RasterInclusion::kSphereInside &&
            distance_to_surface(mesh_m, centre_m) < radius_m - options.sphere_protrusion_m) {
          continue;
        }
        indices.push_back({i, j, k});
        centres_m.push_back(centre_m);
      }
    }
  }
  if (centres_m.empty()) {
    throw std::runtime_error("generate_fillet_template(" + name +
                             "): no raster point lies inside the mesh; use smaller spheres");
  }

  FilletTemplate result;
  result.name = name;
  const auto count = centres_m.size();
  Eigen::Vector3d centroid_m = Eigen::Vector3d::Zero();
  for (const auto& centre : centres_m) centroid_m += centre;
  centroid_m /= static_cast<double>(count);
  result.centroid_in_mesh_m = centroid_m;
  result.positions_m.reserve(count);
  for (const auto& centre : centres_m) result.positions_m.push_back(centre - centroid_m);
  result.radii_m.assign(count, radius_m);
  result.types.reserve(count);
  for (const auto& index : indices) {
    result.types.push_back(is_type_a(index) ? kFilletTypeA : kFilletTypeB);
  }

  // Each raster column's thickness, bottom of its lowest sphere to top of its highest: where a
  // bond sits in a thin tip or a thick rear (graded bond laws scale with it).
  std::map<std::pair<std::int64_t, std::int64_t>, std::pair<std::int64_t, std::int64_t>> column_k;
  for (const auto& index : indices) {
    const auto [found, added] = column_k.try_emplace({index.i, index.j}, index.k, index.k);
    if (!added) {
      found->second.first = std::min(found->second.first, index.k);
      found->second.second = std::max(found->second.second, index.k);
    }
  }
  const auto column_thickness_m = [&](const RasterIndex& index) {
    const auto& [low, high] = column_k.at({index.i, index.j});
    return static_cast<double>(high - low) * pitch_m + 2.0 * radius_m;
  };

  // Bonds: A-B pairs whose contact radii overlap. Only raster offsets with an odd index sum
  // join an A to a B; search every such offset within reach, each pair once (offset > 0 in
  // lexicographic order).
  const double contact_radius_m = options.contact_radius_factor * radius_m;
  const double bond_distance_m =
      2.0 * contact_radius_m *
      (options.bond_limit == BondLimit::kInclusive ? 1.0 + kBondLimitSlack : 1.0 - kBondLimitSlack);
  const auto reach = static_cast<std::int64_t>(std::floor(bond_distance_m / pitch_m));
  std::unordered_map<RasterIndex, std::uint32_t, RasterIndexHash> index_of;
  index_of.reserve(count);
  for (std::size_t n = 0; n < count; ++n) {
    index_of.emplace(indices[n], static_cast<std::uint32_t>(n));
  }
  for (std::size_t n = 0; n < count; ++n) {
    const auto& here = indices[n];
    for (std::int64_t dk = 0; dk <= reach; ++dk) {
      for (std::int64_t dj = -reach; dj <= reach; ++dj) {
        for (std::int64_t di = -reach; di <= reach; ++di) {
          const bool forward = dk > 0 || (dk == 0 && (dj > 0 || (dj == 0 && di > 0)));
          if (!forward || ((di + dj + dk) & 1) == 0) continue;  // same type: never bonded
          const double distance_m =
              pitch_m * std::sqrt(static_cast<double>(di * di + dj * dj + dk * dk));
          const bool bonded = options.bond_limit == BondLimit::kInclusive
                                  ? distance_m <= bond_distance_m
                                  : distance_m < bond_distance_m;
          if (!bonded) continue;
          const auto other = index_of.find({here.i + di, here.j + dj, here.k + dk});
          if (other == index_of.end()) continue;
          const auto a = static_cast<std::uint32_t>(n);
          const auto b = other->second;
          const double thickness_m =
              0.5 * (column_thickness_m(here) + column_thickness_m(other->first));
          result.bonds.push_back({std::min(a, b), std::max(a, b), contact_radius_m, thickness_m});
        }
      }
    }
  }
  std::sort(result.bonds.begin(), result.bonds.end(), [](const FilletBond& x, const FilletBond& y) {
    return x.i != y.i ? x.i < y.i : x.j < y.j;
  });

  const double sphere_volume_m3 = 4.0 / 3.0 * std::numbers::pi * std::pow(radius_m, 3);
  const double spheres_volume_m3 = sphere_volume_m3 * static_cast<double>(count);
  result.mesh_volume_m3 = signed_volume(mesh_m);
  result.mass_kg =
      options.density_kg_m3 * (options.match_mesh_mass ? result.mesh_volume_m3 : spheres_volume_m3);
  result.particle_density_kg_m3 = result.mass_kg / spheres_volume_m3;
  for (const auto& position : result.positions_m) {
    result.half_extent_m =
        result.half_extent_m.cwiseMax(position.cwiseAbs() + Eigen::Vector3d::Constant(radius_m));
  }
  return result;
}

std::vector<FilletTemplate> generate_thesis_fillets(const TriangleMesh& base_mesh_m,
                                                    const FilletGeneratorOptions& options) {
  std::vector<FilletTemplate> templates;
  for (const auto& variant : thesis_fillet_variants()) {
    auto variant_options = options;
    if (variant.side == FilletSide::kRight) variant_options.raster_offset_m.y() *= -1.0;
    templates.push_back(generate_fillet_template(make_variant_mesh(base_mesh_m, variant),
                                                 variant.name, variant_options));
  }
  return templates;
}

std::vector<FilletTemplate> thesis_fillet_templates(double sub_particle_radius_m) {
  FilletGeneratorOptions options;
  options.sub_particle_radius_m = sub_particle_radius_m;
  return generate_thesis_fillets(make_fillet_mesh(), options);
}

}  // namespace fl::dem
