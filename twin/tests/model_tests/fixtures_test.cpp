// Building blocks of the model tests: levels, sampling, walls, blocks, timestep choice and the
// parallel loop.
#include "fl/twin/model_tests/fixtures.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <stdexcept>

#include "fl/twin/dem/config.hpp"

namespace fl::model_tests {
namespace {

// Appendix C: 1..9 x 10^k over three decades plus the end value = 28 levels.
TEST(ModelTestsFixtures, AppendixCLevels) {
  const auto levels = log_levels(1e4, 3, {1, 2, 3, 4, 5, 6, 7, 8, 9});
  ASSERT_EQ(levels.size(), 28U);
  EXPECT_DOUBLE_EQ(levels[0], 1e4);
  EXPECT_DOUBLE_EQ(levels[9], 1e5);
  EXPECT_DOUBLE_EQ(levels[10], 2e5);
  EXPECT_DOUBLE_EQ(levels.back(), 1e7);
}

// Hammersley: first coordinate k/n, second the base-2 radical inverse (0, 1/2, 1/4, 3/4).
TEST(ModelTestsFixtures, HammersleyPoints) {
  EXPECT_DOUBLE_EQ(hammersley3(1, 4)[1], 0.5);
  EXPECT_DOUBLE_EQ(hammersley3(2, 4)[1], 0.25);
  EXPECT_DOUBLE_EQ(hammersley3(3, 4)[1], 0.75);
  EXPECT_DOUBLE_EQ(hammersley3(3, 4)[0], 0.75);
  EXPECT_DOUBLE_EQ(hammersley3(1, 4)[2], 1.0 / 3.0);
}

// A 3x3x2 block: 18 spheres, face bonds 2*3*2 (x) + 3*2*2 (y) + 9 (z) = 33, all A-B.
TEST(ModelTestsFixtures, BlockHasFaceBondsBetweenTypes) {
  const auto block = make_block(0.004, 3, 3, 2);
  EXPECT_EQ(block.positions_m.size(), 18U);
  EXPECT_EQ(block.bonds.size(), 33U);
  for (const auto& b : block.bonds) {
    EXPECT_NE(block.types[b.i], block.types[b.j]);
    EXPECT_NEAR((block.positions_m[b.i] - block.positions_m[b.j]).norm(), 0.008, 1e-12);
  }
}

// The bond critical step matches the engine's check_timestep for the same body.
TEST(ModelTestsFixtures, BondCriticalStepMatchesEngine) {
  CommonParams common;
  const dem::ModelSpec spec = make_spec(common);
  const auto block = make_block(0.007, 3, 3, 3);
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  const auto bonds = body_bonds(block);
  sim.add_body(block.positions_m, block.radii_m, block.types, bonds, dem::BodyPose{});
  sim.prepare();
  EXPECT_NEAR(bond_critical_step_s(spec, block), sim.check_timestep().bond_critical_step_s, 1e-12);
}

// A box wall is 12 triangles spanning its corners.
TEST(ModelTestsFixtures, BoxWallHasTwelveTriangles) {
  const auto wall = box_wall("b", 2, Vec3(-1, -2, -3), Vec3(1, 2, 3));
  ASSERT_EQ(wall.triangles.size(), 12U);
  for (const auto& t : wall.triangles) {
    for (const auto& v : t.vertices_m) {
      EXPECT_EQ(std::abs(v.x()), 1.0);
      EXPECT_EQ(std::abs(v.z()), 3.0);
    }
  }
}

TEST(ModelTestsFixtures, ParallelForRunsEveryItemAndRethrows) {
  std::atomic<int> sum{0};
  parallel_for(100, 3, [&](std::size_t k) { sum += static_cast<int>(k); });
  EXPECT_EQ(sum.load(), 4950);
  EXPECT_THROW(parallel_for(10, 2,
                            [](std::size_t k) {
                              if (k == 3) throw std::runtime_error("item 3");
                            }),
               std::runtime_error);
}

TEST(ModelTestsFixtures, BadVariantAndRadiusAreRejected) {
  CommonParams common;
  common.variant = 6;  // table 3.1 has six variants, 0..5
  EXPECT_THROW((void)make_fillet(common), std::invalid_argument);
  common.variant = 0;
  common.sub_particle_radius_m = 0.0;
  EXPECT_THROW((void)make_fillet(common), std::invalid_argument);
}

}  // namespace
}  // namespace fl::model_tests
