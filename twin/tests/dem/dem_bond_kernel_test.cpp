// The default bonded law four bonds at a time in AVX2 registers (twin/src/dem/
// bpm_vector_kernel.cpp) against its one-bond-at-a-time code: the same bits, bond for bond.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>

#include "dem_test_support.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {
namespace {

using test::kRadius;

// Bit-for-bit equality (== would let -0.0 pass for 0.0).
bool same_bits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}
bool same_bits(const Vec3& a, const Vec3& b) {
  return same_bits(a.x(), b.x()) && same_bits(a.y(), b.y()) && same_bits(a.z(), b.z());
}

struct BondArrays {  // what one compute_batch() call reads and writes
  std::vector<Bond> bonds;
  std::vector<BondState> states;
  std::vector<Vec3> position_m;
  std::vector<Vec3> velocity_m_per_s;
  std::vector<Vec3> angular_velocity_rad_per_s;
  std::vector<double> radius_m;
  std::vector<Vec3> force_n;
  std::vector<Vec3> torque_nm;

  BondBatch batch(BondKernel kernel, double timestep_s) {
    BondBatch b;
    b.bonds = bonds.data();
    b.states = states.data();
    b.begin = 0;
    b.end = static_cast<std::uint32_t>(bonds.size());
    b.position_m = position_m.data();
    b.velocity_m_per_s = velocity_m_per_s.data();
    b.angular_velocity_rad_per_s = angular_velocity_rad_per_s.data();
    b.radius_m = radius_m.data();
    b.force_n = force_n.data();
    b.torque_nm = torque_nm.data();
    b.timestep_s = timestep_s;
    b.kernel = kernel;
    return b;
  }
};

// Bonds between random particles in a 3 cm box, with every case the law distinguishes: bonds
// already broken (a whole group of four among them), stretched past the break distance, past
// the normal or the shear strength, no shear history, a history nearly in the tangent plane
// (the series length correction) and one far out of it (the exact one). 203 bonds: the last
// three are left to the scalar code.
BondArrays random_bonds(std::uint32_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const auto vector = [&](double scale) {
    return Vec3(scale * unit(random), scale * unit(random), scale * unit(random));
  };
  BondArrays a;
  constexpr std::uint32_t kParticles = 60;
  for (std::uint32_t p = 0; p < kParticles; ++p) {
    a.position_m.push_back(vector(0.015));
    a.velocity_m_per_s.push_back(vector(0.5));
    a.angular_velocity_rad_per_s.push_back(vector(20.0));
    a.radius_m.push_back(kRadius * (1.0 + 0.25 * unit(random)));
    a.force_n.push_back(vector(0.01));  // the batch adds to what is there
    a.torque_nm.push_back(vector(1e-4));
  }
  std::uniform_int_distribution<std::uint32_t> particle(0, kParticles - 1);
  for (std::uint32_t k = 0; k < 203; ++k) {
    Bond bond;
    bond.i = particle(random);
    do {
      bond.j = particle(random);
    } while (bond.j == bond.i);
    const Vec3 offset = a.position_m[bond.i] - a.position_m[bond.j];
    const double distance = offset.norm();
    bond.rest_length_m = distance * (1.0 + 0.02 * unit(random));
    bond.bond_radius_m = std::min(a.radius_m[bond.i], a.radius_m[bond.j]);
    bond.break_distance_m = distance * (k % 7 == 3 ? 0.99 : 1.5);
    BondState state;
    state.broken = (k >= 8 && k < 12) || k % 11 == 5;
    const Vec3 normal = offset / distance;
    const Vec3 tangent = normal.cross(vector(1.0)).normalized();
    switch (k % 3) {
      case 0:
        break;  // no shear history yet
      case 1:   // nearly in the tangent plane: (v.n)^2 / |v|^2 about 1e-6
        state.shear_force_n = 0.02 * unit(random) * (tangent + 1e-3 * normal);
        break;
      default:  // far out of it
        state.shear_force_n = vector(0.02);
    }
    state.normal_force_n = 0.01 * unit(random);
    a.bonds.push_back(bond);
    a.states.push_back(state);
  }
  return a;
}

std::unique_ptr<BondLaw> bpm_law() {
  const Material fillet{"fillet", test::kYoungs, test::kPoisson, test::kDensity};
  // Strengths at about the stresses the random stretch and histories give, so that some bonds
  // hold and some break on each criterion: k A = 1e6 pi (4 mm)^2 = 50 N/m, 2 % of 3 cm is
  // 0.6 mm, 0.03 N over 5e-5 m^2 = 600 Pa; 0.02 N of shear is 400 Pa.
  const LawSpec spec = test::bpm(1e6, 6e5, 300.0, 300.0);
  return LawRegistry::builtin().create_bond_law(spec.name, spec.parameters,
                                                make_pair_material(fillet, fillet, false));
}

TEST(DemBondKernel, VectorKernelGivesTheScalarBits) {
  if (!avx2_bond_kernel_available()) GTEST_SKIP() << "this CPU has no AVX2";
  const auto law = bpm_law();
  const double dt = 1.678512e-4;  // the production step
  for (const std::uint32_t seed : {1U, 2U, 3U}) {
    BondArrays scalar = random_bonds(seed);
    BondArrays vector = scalar;
    const bool scalar_broke = law->compute_batch(scalar.batch(BondKernel::kScalar, dt));
    const bool vector_broke = law->compute_batch(vector.batch(BondKernel::kAvx2Vector, dt));
    EXPECT_EQ(scalar_broke, vector_broke);
    std::size_t newly_broken = 0;
    std::size_t holding = 0;
    for (std::size_t k = 0; k < scalar.bonds.size(); ++k) {
      const BondState& s = scalar.states[k];
      const BondState& v = vector.states[k];
      EXPECT_EQ(s.broken, v.broken) << "seed " << seed << " bond " << k;
      EXPECT_TRUE(same_bits(s.normal_force_n, v.normal_force_n))
          << "seed " << seed << " bond " << k;
      EXPECT_TRUE(same_bits(s.shear_force_n, v.shear_force_n)) << "seed " << seed << " bond " << k;
      const BondState before = random_bonds(seed).states[k];
      newly_broken += s.broken && !before.broken ? 1 : 0;
      holding += s.broken ? 0 : 1;
    }
    for (std::size_t p = 0; p < scalar.force_n.size(); ++p) {
      EXPECT_TRUE(same_bits(scalar.force_n[p], vector.force_n[p])) << "seed " << seed << " " << p;
      EXPECT_TRUE(same_bits(scalar.torque_nm[p], vector.torque_nm[p]))
          << "seed " << seed << " " << p;
    }
    // the comparison covered bonds that broke here and bonds that pass force on
    EXPECT_GT(newly_broken, 10U) << "seed " << seed;
    EXPECT_GT(holding, 50U) << "seed " << seed;
  }
}

// Two bonded 5x4x3 blocks dropped spinning onto a plane on two threads (a thread's share of the
// bonds starts and ends anywhere in a group of four), bonds breaking on impact: the whole run,
// 2000 steps, is the same to the bit with either kernel.
TEST(DemBondKernel, BondedDropIsTheSameRunWithEitherKernel) {
  if (!avx2_bond_kernel_available()) GTEST_SKIP() << "this CPU has no AVX2";
  const auto run = [](BondKernel kernel) {
    ModelSpec spec = test::ball_model({test::hertz(0.3), test::coulomb(0.5)}, 1.678512e-4,
                                      Vec3(0, 0, -9.81), true);
    // weak enough that the 1.5 m/s impact breaks some bonds
    spec.interactions[0].bond_law = test::bpm(1e6, 6e5, 2000.0, 2000.0);
    spec.thread_count = 2;
    spec.min_particles_per_thread = 1;
    spec.bond_kernel = kernel;
    Simulation sim(std::make_shared<Model>(spec));
    const std::vector<Vec3> positions = test::block_5x4x3_positions();
    const std::vector<BodyBond> bonds = test::block_bonds(positions, std::sqrt(3.0));
    const std::vector<double> radii(positions.size(), kRadius);
    const std::vector<std::uint8_t> types(positions.size(), 0);
    for (int body = 0; body < 2; ++body) {
      BodyPose pose;
      pose.position_m = Vec3(0.06 * body, 0.0, 0.02 + 0.03 * body);
      pose.orientation =
          Eigen::Quaterniond(Eigen::AngleAxisd(0.4 + body, Vec3(1, 2, 0).normalized()));
      pose.velocity_m_per_s = Vec3(-0.3 * body, 0.1, -1.5);
      pose.angular_velocity_rad_per_s = Vec3(3.0, -2.0, 5.0 * body);
      sim.add_body(positions, radii, types, bonds, pose);
    }
    sim.step(2000);
    return std::make_pair(sim.state(), sim.stats().broken_bonds);
  };
  const auto [scalar, scalar_broken] = run(BondKernel::kScalar);
  const auto [vector, vector_broken] = run(BondKernel::kAvx2Vector);
  EXPECT_GT(scalar_broken, 0U);
  EXPECT_LT(scalar_broken, scalar.bonds.size());
  EXPECT_EQ(scalar_broken, vector_broken);
  ASSERT_EQ(scalar.size(), vector.size());
  for (std::size_t k = 0; k < scalar.size(); ++k) {
    ASSERT_TRUE(same_bits(scalar.position_m[k], vector.position_m[k])) << k;
    ASSERT_TRUE(same_bits(scalar.velocity_m_per_s[k], vector.velocity_m_per_s[k])) << k;
    ASSERT_TRUE(
        same_bits(scalar.angular_velocity_rad_per_s[k], vector.angular_velocity_rad_per_s[k]))
        << k;
  }
}

// A fillet's sub-particles alternate two types, bonded only A-B (thesis 3.3), so its bonds go
// A-B and B-A in turn. Both orders are one law: a 5x4x3 checkerboard block's bonds are one run
// of one law per thread, which the vector kernel takes whole (they were runs of one or two).
TEST(DemBondKernel, AlternatingTypesBondAsOneRunPerThread) {
  ModelSpec spec = test::ball_model({test::hertz(0.3)}, 1.678512e-4);
  spec.types = {{"fillet_a", 0}, {"fillet_b", 0}};
  spec.interactions = {{0, 0, {test::hertz(0.3)}, std::nullopt, false},
                       {1, 1, {test::hertz(0.3)}, std::nullopt, false},
                       {0, 1, {test::hertz(0.3)}, test::bpm(1e6, 6e5), false}};
  spec.min_particles_per_thread = 1;
  std::vector<Vec3> positions;
  std::vector<std::uint8_t> types;
  const double pitch = 2.0 * kRadius;
  for (int x = 0; x < 5; ++x) {
    for (int y = 0; y < 4; ++y) {
      for (int z = 0; z < 3; ++z) {
        positions.emplace_back(x * pitch, y * pitch, z * pitch);
        types.push_back(static_cast<std::uint8_t>((x + y + z) % 2));
      }
    }
  }
  std::vector<BodyBond> bonds;
  std::size_t b_to_a = 0;
  for (std::uint32_t a = 0; a < positions.size(); ++a) {
    for (std::uint32_t b = a + 1; b < positions.size(); ++b) {
      if (types[a] != types[b] && (positions[a] - positions[b]).norm() < pitch * 1.5) {
        bonds.push_back({a, b, kAppendixBContactRadiusM});
        b_to_a += types[a] == 1 ? 1 : 0;
      }
    }
  }
  ASSERT_GT(b_to_a, 0U);  // both orders occur
  ASSERT_LT(b_to_a, bonds.size());
  const std::vector<double> radii(positions.size(), kRadius);
  for (const int threads : {1, 2}) {
    spec.thread_count = threads;
    Simulation sim(std::make_shared<Model>(spec));
    sim.add_body(positions, radii, types, bonds, BodyPose{});
    sim.step(1);
    EXPECT_EQ(sim.stats().bond_law_runs, static_cast<std::size_t>(threads)) << threads;
  }
}

}  // namespace
}  // namespace fl::dem
