// dem::State: everything that changes during a run (MuJoCo's mjData), as structure of arrays.
// Index k of every per-particle vector belongs to one particle; the engine may re-order
// particles by cell for cache locality (then `id` keeps each particle's creation number).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "fl/twin/dem/laws.hpp"

namespace fl::dem {

struct Bond {
  std::uint32_t i = 0;  // particle indices (current order)
  std::uint32_t j = 0;
  double rest_length_m = 0.0;
  double bond_radius_m = 0.0;     // smaller particle radius; the law applies the disk scale
  double break_distance_m = 0.0;  // sum of both contact radii
  double thickness_m = 0.0;       // the body's local thickness at the bond; 0: not given
};

// Kinematics of one wall: a rigid motion of its geometry about `pivot_m` plus a surface
// velocity (a belt moves its surface while the geometry stays). Commanded by the caller.
struct WallState {
  Vec3 pivot_m = Vec3::Zero();  // rotation centre, in the model's wall frame
  Vec3 translation_m = Vec3::Zero();
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Vec3 linear_velocity_m_per_s = Vec3::Zero();
  Vec3 angular_velocity_rad_per_s = Vec3::Zero();  // about the moved pivot
  Vec3 surface_velocity_m_per_s = Vec3::Zero();    // tangential part is used

  // Where a point of the wall's reference geometry is now.
  [[nodiscard]] Vec3 place(const Vec3& reference_m) const {
    return rotation * (reference_m - pivot_m) + pivot_m + translation_m;
  }
};

struct State {
  // per particle
  std::vector<Vec3> position_m;
  std::vector<Vec3> velocity_m_per_s;
  std::vector<Vec3> angular_velocity_rad_per_s;
  std::vector<Vec3> force_n;  // total of the last force evaluation (gravity excluded)
  std::vector<Vec3> torque_nm;
  std::vector<double> radius_m;
  std::vector<double> inverse_mass_per_kg;
  std::vector<double> inverse_inertia_per_kg_m2;  // solid sphere: 1 / (2/5 m r^2)
  std::vector<std::uint32_t> type;
  std::vector<std::uint32_t> body;  // body number from add_body (or a fresh one per sphere)
  std::vector<std::uint32_t> id;    // creation number; stable under re-ordering

  // bonds: fixed list, one state each
  std::vector<Bond> bonds;
  std::vector<BondState> bond_states;

  // walls: planes first, then meshes (ModelSpec order)
  std::vector<WallState> walls;
  // per wall, of the last force evaluation: the particles' total force on the wall, and its
  // torque about the wall's moved pivot (pivot_m + translation_m), as EDEM's geometry forces
  std::vector<Vec3> wall_force_n;
  std::vector<Vec3> wall_torque_nm;

  double time_s = 0.0;
  std::uint64_t step = 0;

  [[nodiscard]] std::size_t size() const { return position_m.size(); }
  [[nodiscard]] double mass_kg(std::size_t k) const { return 1.0 / inverse_mass_per_kg[k]; }
};

}  // namespace fl::dem
