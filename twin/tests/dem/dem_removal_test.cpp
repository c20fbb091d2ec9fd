// Simulation::remove_bodies: what leaves, what stays, and that the survivors do not notice.
#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "dem_test_support.hpp"

namespace fl::dem {
namespace {

using test::kRadius;

constexpr double kDt = 2e-5;  // 50 steps per Hertz contact of a 4 mm sphere

// A pair of spheres bonded along x, placed at `x_m`.
std::uint32_t add_pair(Simulation& sim, double x_m) {
  const std::array<Vec3, 2> positions{Vec3(0, 0, 0), Vec3(2.0 * kRadius, 0, 0)};
  const std::array<double, 2> radii{kRadius, kRadius};
  const std::array<std::uint8_t, 2> types{0, 0};
  const std::array<BodyBond, 1> bonds{BodyBond{0, 1, 1.5 * kRadius}};
  BodyPose pose;
  pose.position_m = Vec3(x_m, 0, 0.1);
  return sim.add_body(positions, radii, types, bonds, pose);
}

ModelSpec bonded_model() {
  ModelSpec spec = test::ball_model({test::hertz(0.3)}, kDt);
  spec.interactions[0].bond_law = test::bpm(1e9, 5e8);
  return spec;
}

TEST(DemRemoval, RemovesTheBodiesParticlesAndBondsAndKeepsTheRest) {
  Simulation sim(std::make_shared<Model>(bonded_model()));
  const std::uint32_t first = add_pair(sim, -0.1);
  const std::uint32_t middle = add_pair(sim, 0.0);
  const std::uint32_t last = add_pair(sim, 0.1);
  sim.prepare();
  const State& s = sim.state();
  const std::uint32_t middle_id = s.id[2];
  const Vec3 last_position = s.position_m[4];

  const std::array<std::uint32_t, 2> gone{middle, 999};  // 999: no such body, ignored
  EXPECT_EQ(sim.remove_bodies(gone), 2U);

  ASSERT_EQ(s.size(), 4U);
  ASSERT_EQ(s.bonds.size(), 2U);
  for (std::size_t k = 0; k < s.size(); ++k) {
    EXPECT_NE(s.body[k], middle);
    EXPECT_NE(s.id[k], middle_id);
  }
  // Body numbers and ids stay; the bonds point at the survivors' new indices.
  EXPECT_EQ(s.body[s.bonds[0].i], first);
  EXPECT_EQ(s.body[s.bonds[0].j], first);
  EXPECT_EQ(s.body[s.bonds[1].i], last);
  EXPECT_EQ(s.body[s.bonds[1].j], last);
  EXPECT_EQ(s.position_m[2], last_position);
  const std::array<std::uint32_t, 1> none{middle};
  EXPECT_EQ(sim.remove_bodies(none), 0U);  // already gone
  sim.step(10);                            // and the run goes on
  EXPECT_EQ(sim.stats().broken_bonds, 0U);
}

// A sphere held on an incline by static friction carries a loaded tangential spring. Taking
// another body out must keep that history: the sphere then stays exactly where it would have
// been without the removal. Restarting its history would unload the spring and let the
// sphere creep down by about the spring's stretch (micrometres), far above the 1e-12 m here.
TEST(DemRemoval, SurvivorsKeepTheirContactHistory) {
  const double tan_theta = 0.3;  // below the friction coefficient 0.5: held
  const double theta = std::atan(tan_theta);
  const Vec3 gravity = 9.81 * Vec3(std::sin(theta), 0, -std::cos(theta));
  const ModelSpec spec =
      test::ball_model({test::hertz(0.3), test::coulomb(0.5)}, kDt, gravity, true);
  const auto run = [&](bool remove_other) {
    Simulation sim(std::make_shared<Model>(spec));
    sim.add_sphere({Vec3(0, 0, kRadius), kRadius, 0});
    sim.mutable_state().inverse_inertia_per_kg_m2[0] = 0.0;  // slides, cannot roll
    const std::uint32_t other_index = sim.add_sphere({Vec3(0.1, 0.1, kRadius), kRadius, 0});
    const std::uint32_t other = sim.state().body[other_index];
    sim.step(10000);  // 0.2 s: settled, the spring loaded
    if (remove_other) {
      const std::array<std::uint32_t, 1> bodies{other};
      sim.remove_bodies(bodies);
    }
    sim.step(10000);
    for (std::size_t k = 0; k < sim.state().size(); ++k) {
      if (sim.state().id[k] == 0) return sim.state().position_m[k];
    }
    return Vec3(Vec3::Constant(std::nan("")));
  };
  const Vec3 kept = run(false);
  const Vec3 after_removal = run(true);
  EXPECT_NEAR((after_removal - kept).norm(), 0.0, 1e-12);
}

}  // namespace
}  // namespace fl::dem
