#include "bpm_vector_kernel.hpp"

#include <cmath>
#include <numbers>

#include "fl/twin/dem/state.hpp"

// The helpers below pass 256-bit vectors by value but are all forced inline in this file, so
// the calling convention GCC warns about never applies.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace fl::dem::detail {
namespace {

constexpr std::uint32_t kLanes = 4;
// GCC/Clang vector extensions: in the AVX2 function a value is one 256-bit register. (Compiled
// for plain x86-64, the same code split into SSE2 halves ran slower than the scalar loop, so
// there is no such fallback: the scalar law runs instead.)
using Lanes = double __attribute__((vector_size(32)));
using LaneMask = std::int64_t __attribute__((vector_size(32)));

struct Vec3Lanes {
  Lanes x;
  Lanes y;
  Lanes z;
};

// Lanes built whole from four values (assigning lane by lane reads as use before set to GCC).
template <typename Value>
[[gnu::always_inline]] inline Lanes lanes_of(const Value& value) {
  return Lanes{value(0), value(1), value(2), value(3)};
}

[[gnu::always_inline]] inline Vec3Lanes gather(const Vec3* values, const std::uint32_t* index) {
  return Vec3Lanes{lanes_of([&](std::uint32_t l) { return values[index[l]].x(); }),
                   lanes_of([&](std::uint32_t l) { return values[index[l]].y(); }),
                   lanes_of([&](std::uint32_t l) { return values[index[l]].z(); })};
}

[[gnu::always_inline]] inline Lanes lanes_sqrt(const Lanes& value) {
  return lanes_of([&](std::uint32_t l) { return std::sqrt(value[l]); });
}

[[gnu::always_inline]] inline bool all_lanes(const LaneMask& mask) {
  return (mask[0] & mask[1] & mask[2] & mask[3]) != 0;
}

// The kernel's body (forced inline into the AVX2 function, so it is compiled for that target).
// Every expression follows the scalar code (laws.cpp: run_bond_batch, rotate_into_tangent_plane,
// BondedParticleModel::update with ElasticNormal and UniformStiffness) operand for operand:
// IEEE arithmetic lane by lane then gives the scalar code's bits.
[[gnu::always_inline]] inline std::uint32_t kernel_body(const BondBatch& b,
                                                        const BpmElasticConstants& c, bool& broke) {
  constexpr double kPi = std::numbers::pi;
  std::uint32_t k = b.begin;
  for (; k + kLanes <= b.end; k += kLanes) {
    const Bond* bonds = b.bonds + k;
    BondState* states = b.states + k;
    bool live[kLanes];
    bool any_live = false;
    for (std::uint32_t l = 0; l < kLanes; ++l) {
      live[l] = !states[l].broken;
      any_live = any_live || live[l];
    }
    if (!any_live) continue;
    // A broken bond's lane is computed (its indices stay valid) and its result dropped.
    const std::uint32_t index_i[kLanes] = {bonds[0].i, bonds[1].i, bonds[2].i, bonds[3].i};
    const std::uint32_t index_j[kLanes] = {bonds[0].j, bonds[1].j, bonds[2].j, bonds[3].j};
    const Lanes radius_i = lanes_of([&](std::uint32_t l) { return b.radius_m[index_i[l]]; });
    const Lanes radius_j = lanes_of([&](std::uint32_t l) { return b.radius_m[index_j[l]]; });
    const Lanes rest_length = lanes_of([&](std::uint32_t l) { return bonds[l].rest_length_m; });
    const Lanes bond_radius = lanes_of([&](std::uint32_t l) { return bonds[l].bond_radius_m; });
    const Lanes break_distance =
        lanes_of([&](std::uint32_t l) { return bonds[l].break_distance_m; });
    const Vec3Lanes shear{lanes_of([&](std::uint32_t l) { return states[l].shear_force_n.x(); }),
                          lanes_of([&](std::uint32_t l) { return states[l].shear_force_n.y(); }),
                          lanes_of([&](std::uint32_t l) { return states[l].shear_force_n.z(); })};
    const Vec3Lanes position_i = gather(b.position_m, index_i);
    const Vec3Lanes position_j = gather(b.position_m, index_j);
    const Lanes dx = position_i.x - position_j.x;
    const Lanes dy = position_i.y - position_j.y;
    const Lanes dz = position_i.z - position_j.z;
    const Lanes distance = lanes_sqrt(dx * dx + dy * dy + dz * dz);
    const Lanes inverse_distance = 1.0 / distance;
    const Lanes nx = dx * inverse_distance;
    const Lanes ny = dy * inverse_distance;
    const Lanes nz = dz * inverse_distance;
    const Lanes arm_i = distance * radius_i / (radius_i + radius_j);
    const Lanes arm_j = distance - arm_i;
    const Vec3Lanes spin_i = gather(b.angular_velocity_rad_per_s, index_i);
    const Vec3Lanes spin_j = gather(b.angular_velocity_rad_per_s, index_j);
    const Lanes ox = arm_i * spin_i.x + arm_j * spin_j.x;
    const Lanes oy = arm_i * spin_i.y + arm_j * spin_j.y;
    const Lanes oz = arm_i * spin_i.z + arm_j * spin_j.z;
    const Vec3Lanes velocity_i = gather(b.velocity_m_per_s, index_i);
    const Vec3Lanes velocity_j = gather(b.velocity_m_per_s, index_j);
    const Lanes vx = velocity_i.x - velocity_j.x - (oy * nz - oz * ny);
    const Lanes vy = velocity_i.y - velocity_j.y - (oz * nx - ox * nz);
    const Lanes vz = velocity_i.z - velocity_j.z - (ox * ny - oy * nx);

    // the law: normal force, then the shear history turned into the bond's new tangent plane
    const Lanes disk_radius = c.disk_scale * bond_radius;
    const Lanes area = kPi * disk_radius * disk_radius;
    const Lanes normal_force = -(c.normal_stiffness_n_per_m3 * area) * (distance - rest_length);
    const Lanes old_squared = shear.x * shear.x + shear.y * shear.y + shear.z * shear.z;
    const Lanes along = shear.x * nx + shear.y * ny + shear.z * nz;
    const Lanes tx = shear.x - along * nx;
    const Lanes ty = shear.y - along * ny;
    const Lanes tz = shear.z - along * nz;
    const Lanes removed = along * along;
    const Lanes r = removed / old_squared;
    const Lanes series = 1.0 + r * (0.5 + 0.375 * r);
    const Lanes new_squared = tx * tx + ty * ty + tz * tz;
    const LaneMask use_series = removed < kTangentSeriesLimit * old_squared;
    Lanes scale = series;
    // The exact length correction only where the plane turned far within a step (rare): its
    // division and square root cost as much as the rest of the law.
    if (!all_lanes(use_series)) {
      const LaneMask has_length = new_squared > 0.0;
      const Lanes one = {1.0, 1.0, 1.0, 1.0};
      scale = use_series ? series : (has_length ? lanes_sqrt(old_squared / new_squared) : one);
    }
    const LaneMask no_history = old_squared == 0.0;  // left as it was
    const Lanes rx = no_history ? shear.x : tx * scale;
    const Lanes ry = no_history ? shear.y : ty * scale;
    const Lanes rz = no_history ? shear.z : tz * scale;
    const Lanes normal_velocity = vx * nx + vy * ny + vz * nz;
    const Lanes shear_gain = c.shear_stiffness_n_per_m3 * area * b.timestep_s;
    const Lanes sx = rx - shear_gain * (vx - normal_velocity * nx);
    const Lanes sy = ry - shear_gain * (vy - normal_velocity * ny);
    const Lanes sz = rz - shear_gain * (vz - normal_velocity * nz);
    const Lanes shear_limit = c.shear_strength_pa * area;
    const LaneMask too_far = distance > break_distance;
    const LaneMask over_strength = (-normal_force > c.normal_strength_pa * area) |
                                   (sx * sx + sy * sy + sz * sz > shear_limit * shear_limit);

    const Lanes fx = normal_force * nx + sx;
    const Lanes fy = normal_force * ny + sy;
    const Lanes fz = normal_force * nz + sz;
    const Lanes cx = sy * nz - sz * ny;
    const Lanes cy = sz * nx - sx * nz;
    const Lanes cz = sx * ny - sy * nx;
    const Lanes torque_ix = arm_i * cx;
    const Lanes torque_iy = arm_i * cy;
    const Lanes torque_iz = arm_i * cz;
    const Lanes torque_jx = arm_j * cx;
    const Lanes torque_jy = arm_j * cy;
    const Lanes torque_jz = arm_j * cz;
    for (std::uint32_t l = 0; l < kLanes; ++l) {  // in bond order, as the scalar loop adds
      if (!live[l]) continue;
      BondState& state = states[l];
      if (too_far[l] != 0) {  // the scalar law leaves the history as it was
        state.broken = true;
        broke = true;
        continue;
      }
      state.normal_force_n = normal_force[l];
      state.shear_force_n = Vec3(sx[l], sy[l], sz[l]);
      if (over_strength[l] != 0) {
        state.broken = true;
        broke = true;
        continue;
      }
      const Vec3 force(fx[l], fy[l], fz[l]);
      b.force_n[index_i[l]] += force;
      b.force_n[index_j[l]] -= force;
      b.torque_nm[index_i[l]] += Vec3(torque_ix[l], torque_iy[l], torque_iz[l]);
      b.torque_nm[index_j[l]] += Vec3(torque_jx[l], torque_jy[l], torque_jz[l]);
    }
  }
  return k;
}

#if defined(__x86_64__)
__attribute__((target("avx2"))) std::uint32_t avx2_kernel(const BondBatch& b,
                                                          const BpmElasticConstants& c,
                                                          bool& broke) {
  return kernel_body(b, c, broke);
}
#endif

}  // namespace

bool cpu_runs_avx2() {
#if defined(__x86_64__)
  static const bool runs = __builtin_cpu_supports("avx2") != 0;
  return runs;
#else
  return false;
#endif
}

std::uint32_t bpm_elastic_vector_batch(const BondBatch& batch, const BpmElasticConstants& constants,
                                       bool& broke) {
#if defined(__x86_64__)
  if (batch.kernel != BondKernel::kScalar && cpu_runs_avx2()) {
    return avx2_kernel(batch, constants, broke);
  }
#else
  (void)constants;
  (void)broke;
#endif
  return batch.begin;
}

}  // namespace fl::dem::detail

namespace fl::dem {
bool avx2_bond_kernel_available() { return detail::cpu_runs_avx2(); }
}  // namespace fl::dem
