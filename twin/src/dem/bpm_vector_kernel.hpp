// The elastic bonded particle model ("bpm", laws.cpp) for four bonds at once: the bonded
// race spends about three quarters of its time in the bond loop, whose one-bond-at-a-time code
// is a chain of dependent operations (square root, division, rotation, break test) that leaves
// most of the core idle. Internal to fl_twin_dem.
#pragma once

#include <cstdint>

#include "fl/twin/dem/laws.hpp"

namespace fl::dem::detail {

// Below this (v.n)^2 / |v|^2 the shear history's length correction uses its series (laws.cpp,
// rotate_into_tangent_plane); the vector kernel must switch at the same point to give the
// same bits.
inline constexpr double kTangentSeriesLimit = 1e-4;

struct BpmElasticConstants {
  double normal_stiffness_n_per_m3 = 0.0;
  double shear_stiffness_n_per_m3 = 0.0;
  double normal_strength_pa = 0.0;
  double shear_strength_pa = 0.0;
  double disk_scale = 1.0;
};

// Runs whole groups of four bonds of [batch.begin, batch.end) in AVX2 registers unless
// batch.kernel is kScalar or the CPU has no AVX2. Returns the first bond it left, which the
// caller runs one at a time (the last few, or all of them); sets `broke` when a bond broke.
// Bit-identical to the scalar law: same expressions in the same order, and each bond's forces added
// in bond order.
std::uint32_t bpm_elastic_vector_batch(const BondBatch& batch, const BpmElasticConstants& constants,
                                       bool& broke);

bool cpu_runs_avx2();

}  // namespace fl::dem::detail
