// A fillet as the DEM engine builds it: a bonded meta-particle of equal spheres (thesis 3.3).
// Plain data, produced by fl/twin/dem/fillet_generator.hpp; the engine's add_body takes the
// vectors as they are. Body frame: x along the length (thick end at -x, tip at +x), y across,
// z up (bone side down, skin side up); positions are relative to the centroid of the spheres.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace fl::dem {

// Sub-particle types: bonds form only between an A and a B (thesis figure 3.5).
inline constexpr std::uint8_t kFilletTypeA = 0;
inline constexpr std::uint8_t kFilletTypeB = 1;

// A bond between spheres i < j. It breaks when the spheres separate beyond 2 x the contact
// radius (the contact radii no longer overlap; thesis 3.3.1).
struct FilletBond {
  std::uint32_t i = 0, j = 0;
  double contact_radius_m = 0.0;
  // The fillet's thickness where the bond sits: the mean of the two spheres' raster columns
  // (top of the highest sphere to the bottom of the lowest). Graded bond laws scale with it.
  double thickness_m = 0.0;
};

struct FilletTemplate {
  std::string name;  // e.g. "s172x72x32_left"
  std::vector<Eigen::Vector3d> positions_m;
  std::vector<double> radii_m;
  std::vector<std::uint8_t> types;  // kFilletTypeA or kFilletTypeB
  std::vector<FilletBond> bonds;
  double mass_kg = 0.0;  // all spheres together
  // Density to give each sphere so the spheres add up to mass_kg: the material density, or
  // that density scaled up when FilletGeneratorOptions::match_mesh_mass is set.
  double particle_density_kg_m3 = 0.0;
  // Half-size of the smallest box centred on the origin (the spheres' centroid) that holds
  // every sphere including its radius: a broad-phase bound for the body.
  Eigen::Vector3d half_extent_m = Eigen::Vector3d::Zero();
  double mesh_volume_m3 = 0.0;  // volume of the mesh the raster was cut from
  // Where the spheres' centroid lies in the mesh's coordinates: sphere i sits at
  // positions_m[i] + this in the mesh the template was generated from.
  Eigen::Vector3d centroid_in_mesh_m = Eigen::Vector3d::Zero();
};

}  // namespace fl::dem
