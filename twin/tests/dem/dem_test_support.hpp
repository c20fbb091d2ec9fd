// Small models for the DEM engine tests.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/simulation.hpp"

namespace fl::dem::test {

inline constexpr double kRadius = 0.004;  // m, the fillet sub-particle
inline constexpr double kYoungs = 3.7e5;  // Pa, appendix B
inline constexpr double kPoisson = 0.37;
inline constexpr double kDensity = 940.0;

inline double sphere_mass(double radius = kRadius) {
  return kDensity * 4.0 / 3.0 * 3.14159265358979323846 * radius * radius * radius;
}

// Hertz' maximum overlap for a central impact of two kRadius spheres of the test material
// closing at `closing_speed_mps`, without damping: delta = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5)
// (Johnson, Contact Mechanics, 11.2), with m* = m/2, R* = r/2 and E* = E / (2 (1 - nu^2)).
inline double hertz_peak_overlap_m(double closing_speed_mps) {
  const double reduced_mass = sphere_mass() / 2.0;
  const double reduced_radius = kRadius / 2.0;
  const double reduced_modulus = kYoungs / (2.0 * (1.0 - kPoisson * kPoisson));
  return std::pow(15.0 * reduced_mass * closing_speed_mps * closing_speed_mps /
                      (16.0 * reduced_modulus * std::sqrt(reduced_radius)),
                  0.4);
}

// One fillet material; type 0 "ball", type 1 "wall" (same material). `ball_laws` applies to
// ball-ball and ball-wall pairs.
inline ModelSpec ball_model(std::vector<LawSpec> ball_laws, double timestep_s,
                            const Vec3& gravity = Vec3::Zero(), bool with_plane = false) {
  ModelSpec spec;
  spec.materials = {{"fillet", kYoungs, kPoisson, kDensity}};
  spec.types = {{"ball", 0}, {"wall", 0}};
  spec.interactions = {{0, 0, ball_laws, std::nullopt, false},
                       {0, 1, ball_laws, std::nullopt, false}};
  spec.timestep_s = timestep_s;
  spec.gravity_m_per_s2 = gravity;
  spec.domain.lower_m = Vec3(-0.2, -0.2, -0.05);
  spec.domain.upper_m = Vec3(0.2, 0.2, 0.3);
  if (with_plane) {
    spec.planes.push_back({"floor", 1, Vec3::Zero(), Vec3::UnitZ()});
  }
  return spec;
}

inline LawSpec hertz(double restitution) {
  return {"hertz_mindlin", {{"restitution", restitution}}};
}
inline LawSpec coulomb(double mu) { return {"coulomb", {{"friction_coefficient", mu}}}; }
inline LawSpec bpm(double normal_n_per_m3, double shear_n_per_m3, double normal_strength_pa = 1e300,
                   double shear_strength_pa = 1e300) {
  return {"bpm",
          {{"normal_stiffness_n_per_m3", normal_n_per_m3},
           {"shear_stiffness_n_per_m3", shear_n_per_m3},
           {"normal_strength_pa", normal_strength_pa},
           {"shear_strength_pa", shear_strength_pa}}};
}

// Sphere centres of a 5 x 4 x 3 block touching its face neighbours (pitch: one diameter).
inline std::vector<Vec3> block_5x4x3_positions() {
  std::vector<Vec3> positions;
  const double pitch = 2.0 * kRadius;
  for (int x = 0; x < 5; ++x) {
    for (int y = 0; y < 4; ++y) {
      for (int z = 0; z < 3; ++z) positions.emplace_back(x * pitch, y * pitch, z * pitch);
    }
  }
  return positions;
}

// Appendix B bonds between every two centres closer than `reach_in_pitches` pitches (a 0.1 %
// margin over the lattice distance asked for): sqrt(2) bonds face and edge neighbours, sqrt(3)
// also the body diagonals, which sit at the break distance of two contact radii.
inline std::vector<BodyBond> block_bonds(const std::vector<Vec3>& positions,
                                         double reach_in_pitches) {
  std::vector<BodyBond> bonds;
  const double reach_m = 2.0 * kRadius * reach_in_pitches * 1.001;
  for (std::uint32_t a = 0; a < positions.size(); ++a) {
    for (std::uint32_t b = a + 1; b < positions.size(); ++b) {
      if ((positions[a] - positions[b]).norm() < reach_m) {
        bonds.push_back({a, b, kAppendixBContactRadiusM});
      }
    }
  }
  return bonds;
}

}  // namespace fl::dem::test
