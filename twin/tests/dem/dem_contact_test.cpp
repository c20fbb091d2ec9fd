// Contact laws against analytic answers: Hertz impact, restitution, JKR pull-off, Coulomb.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "dem_test_support.hpp"
#include "fl/twin/dem/config.hpp"

namespace fl::dem {
namespace {

using test::kRadius;

// Hertz impact of a sphere on a plane of the same material without damping (e = 1).
// Theory (Johnson 1985, 11.1): contact duration t = 2.87 (m*^2 / (R* E*^2 v))^(1/5), maximum
// overlap d = (15 m* v^2 / (16 E* sqrt(R*)))^(2/5), peak force 4/3 E* sqrt(R*) d^1.5.
TEST(DemHertz, SphereOnPlaneContactDurationAndPeakForce) {
  const double dt = 1e-6;  // about 2,700 steps per contact: integration error far below 2%
  auto model =
      std::make_shared<Model>(test::ball_model({test::hertz(1.0)}, dt, Vec3::Zero(), true));
  Simulation sim(model);
  const double speed = 0.5;  // m/s, a fillet dropped about 13 mm
  sim.add_sphere({Vec3(0, 0, kRadius + 1e-5), kRadius, 0, Vec3(0, 0, -speed)});
  const double e_star = model->interaction(0, 1).material.effective_youngs_modulus_pa;
  const double m = test::sphere_mass();
  double first_touch = -1.0;
  double last_touch = -1.0;
  double peak_force = 0.0;
  for (int k = 0; k < 20000; ++k) {
    sim.step();
    const double force = sim.state().force_n[0].z();
    if (force > 0.0) {
      if (first_touch < 0.0) first_touch = sim.state().time_s - dt;
      last_touch = sim.state().time_s;
      peak_force = std::max(peak_force, force);
    }
  }
  const double duration = last_touch - first_touch;
  const double expected_duration =
      2.87 * std::pow(m * m / (kRadius * e_star * e_star * speed), 0.2);
  const double max_overlap =
      std::pow(15.0 * m * speed * speed / (16.0 * e_star * std::sqrt(kRadius)), 0.4);
  const double expected_peak = 4.0 / 3.0 * e_star * std::sqrt(kRadius) * std::pow(max_overlap, 1.5);
  EXPECT_NEAR(duration, expected_duration, 0.02 * expected_duration);
  EXPECT_NEAR(peak_force, expected_peak, 0.02 * expected_peak);
  EXPECT_NEAR(sim.state().velocity_m_per_s[0].z(), speed, 1e-3 * speed);  // elastic: e = 1
}

// Eq. 3.2 damping: head-on sphere-sphere impact returns the configured restitution.
class DemRestitution : public ::testing::TestWithParam<double> {};

TEST_P(DemRestitution, HeadOnSphereSphere) {
  const double restitution = GetParam();
  auto model = std::make_shared<Model>(test::ball_model({test::hertz(restitution)}, 1e-6));
  Simulation sim(model);
  const double speed = 0.25;  // each, towards the other
  sim.add_sphere({Vec3(-kRadius - 1e-5, 0, 0), kRadius, 0, Vec3(speed, 0, 0)});
  sim.add_sphere({Vec3(kRadius + 1e-5, 0, 0), kRadius, 0, Vec3(-speed, 0, 0)});
  sim.step(20000);  // contact lasts about 3.4 ms; 20 ms leaves them well apart
  const double separation_speed =
      sim.state().velocity_m_per_s[1].x() - sim.state().velocity_m_per_s[0].x();
  EXPECT_NEAR(separation_speed / (2.0 * speed), restitution, 0.02 * restitution);
}

INSTANTIATE_TEST_SUITE_P(SeveralCoefficients, DemRestitution, ::testing::Values(0.1, 0.5, 0.9));

// Two fillet sub-particles of appendix B with the thesis' surface energy of 0.055 J/m^2: the
// hertz law is contact_laws[0] and jkr, replacing its force while a neck holds, is [1].
class DemJkr : public ::testing::Test {
 protected:
  const ModelSpec spec = appendix_b_model_spec();
  const Model model{spec};
  const Interaction& fillets = model.interaction(0, 0);
  const double w = 0.055;
  const double r_star = kRadius / 2.0;
  const double e_star = fillets.material.effective_youngs_modulus_pa;
  const ContactLaw& jkr = *fillets.contact_laws[1];
  const double delta_c = jkr_break_overlap_m(w, r_star, e_star);
};

// JKR (laws.hpp): scanning the overlap, the most tensile force is the pull-off force
// 1.5 pi w R*, reached at a^3 = 9 pi w R*^2 / (8 E*); the neck holds down to delta_c and not
// beyond.
TEST_F(DemJkr, PullOffForceAndNeckBreak) {
  ASSERT_LT(delta_c, 0.0);
  EXPECT_NEAR(jkr.range_m(r_star), -delta_c, 1e-15);

  PairGeometry g;
  g.effective_radius_m = r_star;
  g.effective_mass_kg = test::sphere_mass() / 2.0;
  g.timestep_s = 1e-4;
  PairState state;
  double most_tensile = 0.0;
  const int samples = 20000;
  for (int k = 0; k <= samples; ++k) {  // unloading from 20 um overlap to delta_c
    g.overlap_m = 20e-6 + (delta_c * (1.0 - 1e-9) - 20e-6) * k / samples;
    ForceAccumulator f;
    for (const auto& law : fillets.contact_laws) law->compute(g, state, f);
    ASSERT_TRUE(f.touching) << "neck lost at overlap " << g.overlap_m;
    most_tensile = std::min(most_tensile, f.normal_force_n);
  }
  const double pull_off = jkr_pull_off_force_n(w, r_star);
  EXPECT_NEAR(pull_off, 1.5 * std::numbers::pi * w * r_star, 1e-15);
  EXPECT_NEAR(-most_tensile, pull_off, 1e-4 * pull_off);
  // Beyond delta_c the neck breaks: no force, and none on re-approach until touching.
  g.overlap_m = delta_c * 1.001;
  ForceAccumulator beyond;
  for (const auto& law : fillets.contact_laws) law->compute(g, state, beyond);
  EXPECT_FALSE(beyond.touching);
  g.overlap_m = delta_c * 0.5;
  ForceAccumulator gap;
  for (const auto& law : fillets.contact_laws) law->compute(g, state, gap);
  EXPECT_FALSE(gap.touching);
  // Independent check of the force formula at the pull-off contact radius.
  const double a = std::cbrt(9.0 * std::numbers::pi * w * r_star * r_star / (8.0 * e_star));
  EXPECT_NEAR(jkr_force_n(w, r_star, e_star, a), -pull_off, 1e-9 * pull_off);
  const double overlap_at_a = a * a / r_star - std::sqrt(2.0 * std::numbers::pi * w * a / e_star);
  EXPECT_NEAR(jkr_contact_radius_m(w, r_star, e_star, overlap_at_a), a, 1e-9 * a);
}

// The jkr law's force against the closed form (laws.hpp) for the contact radius solved to 1e-15:
// the law's warm-started Newton solve stops on its predicted next step, so a load sweep in small
// steps (as a contact sees it), one cold start at each overlap and the sweep back to delta_c all
// give the closed-form force less the Hertz force it replaces. 1e-9 of the pull-off force is
// 1e5 times the bits Newton leaves (1e-13 of the contact radius) and 1e4 times under any
// physical effect of the law.
TEST_F(DemJkr, LawMatchesTheClosedFormWarmAndCold) {
  const double tolerance_n = 1e-9 * jkr_pull_off_force_n(w, r_star);
  const auto expected_n = [&](double overlap_m) {
    const double a = jkr_contact_radius_m(w, r_star, e_star, overlap_m);
    const double hertz =
        overlap_m > 0.0 ? 4.0 / 3.0 * e_star * std::sqrt(r_star) * std::pow(overlap_m, 1.5) : 0.0;
    return jkr_force_n(w, r_star, e_star, a) - hertz;
  };
  PairGeometry g;
  g.effective_radius_m = r_star;
  g.effective_mass_kg = test::sphere_mass() / 2.0;
  g.timestep_s = 1e-4;
  PairState warm;
  const int samples = 4000;
  // from first touch loading to 200 um (5 % of the radius), then unloading to just above
  // delta_c, where the neck is about to break
  const double deepest_m = 200e-6;
  const double last_m = delta_c * (1.0 - 1e-6);
  for (int k = 1; k <= 2 * samples; ++k) {
    g.overlap_m = k <= samples ? deepest_m * k / samples
                               : deepest_m + (last_m - deepest_m) * (k - samples) / samples;
    ForceAccumulator f;
    jkr.compute(g, warm, f);
    ASSERT_TRUE(f.touching) << "neck lost at overlap " << g.overlap_m;
    ASSERT_NEAR(f.normal_force_n, expected_n(g.overlap_m), tolerance_n)
        << "warm start, overlap " << g.overlap_m;
    PairState cold;
    cold.flags = PairState::kFlagAdhesiveNeck;  // a neck, but no contact radius to start from
    ForceAccumulator f_cold;
    jkr.compute(g, cold, f_cold);
    ASSERT_NEAR(f_cold.normal_force_n, expected_n(g.overlap_m), tolerance_n)
        << "cold start, overlap " << g.overlap_m;
  }
}

// Mesh wall: a sphere resting on the shared edge of two coplanar triangles feels one contact,
// the same force as on a plane.
TEST(DemMesh, SharedEdgeCountsOnce) {
  ModelSpec spec = test::ball_model({test::hertz(1.0)}, 1e-5);
  const double half = 0.05;
  spec.meshes.push_back({"floor",
                         1,
                         {{{Vec3(-half, -half, 0), Vec3(half, -half, 0), Vec3(half, half, 0)}},
                          {{Vec3(-half, -half, 0), Vec3(half, half, 0), Vec3(-half, half, 0)}}}});
  Simulation sim(std::make_shared<Model>(spec));
  const double overlap = 1e-4;
  sim.add_sphere({Vec3(0.01, 0.01, kRadius - overlap), kRadius, 0});   // on the diagonal edge
  sim.add_sphere({Vec3(0.02, -0.01, kRadius - overlap), kRadius, 0});  // inside one face
  sim.prepare();
  const double e_star = sim.model().interaction(0, 1).material.effective_youngs_modulus_pa;
  const double hertz = 4.0 / 3.0 * e_star * std::sqrt(kRadius) * std::pow(overlap, 1.5);
  EXPECT_NEAR(sim.state().force_n[0].z(), hertz, 1e-9 * hertz);
  EXPECT_NEAR(sim.state().force_n[1].z(), hertz, 1e-9 * hertz);
}

// Wall list: between neighbour builds a particle searches only the triangles of an unmoved mesh
// that were within reach plus skin. A sphere falling from 12 mm (24 skin triggers on the way)
// onto a floor of 200 small triangles meets it as it meets a plane: the same peak overlap,
// and the same, found on the step the sphere reaches the floor. A list without the skin would
// find it up to half a skin late and deeper.
TEST(DemMesh, FallingSphereMeetsAMeshFloorAsItMeetsAPlane) {
  const double dt = 1e-6;
  const double speed = 0.5;  // m/s: 0.5 um per step, so a late find shows as a deeper overlap
  const auto peak_overlap = [&](bool mesh_floor) {
    ModelSpec spec = test::ball_model({test::hertz(1.0)}, dt, Vec3::Zero(), !mesh_floor);
    if (mesh_floor) {
      MeshWallSpec floor{"floor", 1, {}};
      const double cell = 0.01;  // 10 x 10 cells of two triangles over 0.1 m x 0.1 m
      for (int a = -5; a < 5; ++a) {
        for (int b = -5; b < 5; ++b) {
          const Vec3 p0(a * cell, b * cell, 0);
          const Vec3 p1((a + 1) * cell, b * cell, 0);
          const Vec3 p2((a + 1) * cell, (b + 1) * cell, 0);
          const Vec3 p3(a * cell, (b + 1) * cell, 0);
          floor.triangles.push_back({{p0, p1, p2}});
          floor.triangles.push_back({{p0, p2, p3}});
        }
      }
      spec.meshes.push_back(floor);
    }
    Simulation sim(std::make_shared<Model>(spec));
    sim.add_sphere({Vec3(0.0033, 0.0061, kRadius + 0.012), kRadius, 0, Vec3(0, 0, -speed)});
    double peak = 0.0;
    for (int k = 0; k < 30000; ++k) {
      sim.step();
      peak = std::max(peak, kRadius - sim.state().position_m[0].z());
    }
    return peak;
  };
  const double on_plane = peak_overlap(false);
  ASSERT_GT(on_plane, 0.0);
  EXPECT_NEAR(peak_overlap(true), on_plane, 1e-9 * on_plane);
}

// Conveyor: a sphere on a belt (plane with surface velocity) is dragged up to belt speed.
TEST(DemWalls, BeltDragsSphereAlong) {
  ModelSpec spec =
      test::ball_model({test::hertz(0.3), test::coulomb(0.5)}, 2e-5, Vec3(0, 0, -9.81), true);
  Simulation sim(std::make_shared<Model>(spec));
  sim.add_sphere({Vec3(0, 0, kRadius), kRadius, 0});
  sim.wall("floor").surface_velocity_m_per_s = Vec3(0.3, 0, 0);
  sim.step(50000);  // 1 s
  // Friction at the contact is the only horizontal force, so angular momentum about the
  // contact line is conserved (zero): m v r + I w = 0 with I = 2/5 m r^2; rolling without slip
  // on the belt (v - w r = v_belt) then gives v = 2/7 v_belt.
  EXPECT_NEAR(sim.state().velocity_m_per_s[0].x(), 0.3 * 2.0 / 7.0, 0.01 * 0.3 * 2.0 / 7.0);
}

// The reaction on a wall (EDEM's geometry force): three spheres of mass m at rest on the floor
// press it with their weight, 3 m g downwards, and its torque about the floor's pivot (the
// origin) is the sum of (x, y, 0) x (0, 0, -m g) = (-y m g, x m g, 0) over the contact points.
TEST(DemWalls, FloorCarriesTheRestingSpheresWeightAndItsMoment) {
  const double g = 9.81;
  ModelSpec spec =
      test::ball_model({test::hertz(0.3), test::coulomb(0.5)}, 2e-5, Vec3(0, 0, -g), true);
  Simulation sim(std::make_shared<Model>(spec));
  const std::array<Vec3, 3> spots{Vec3(0.05, 0.02, 0), Vec3(-0.03, 0.04, 0), Vec3(0.0, -0.06, 0)};
  for (const Vec3& spot : spots) sim.add_sphere({spot + Vec3(0, 0, kRadius), kRadius, 0});
  sim.step(25000);  // 0.5 s: the bounce of e = 0.3 has long died out
  const std::size_t floor = sim.wall_index("floor");
  const double weight = test::sphere_mass() * g;
  const Vec3& force = sim.state().wall_force_n[floor];
  EXPECT_NEAR(force.z(), -3.0 * weight, 1e-4 * weight);
  EXPECT_NEAR(force.x(), 0.0, 1e-6 * weight);
  EXPECT_NEAR(force.y(), 0.0, 1e-6 * weight);
  Vec3 moment = Vec3::Zero();
  for (const Vec3& spot : spots) moment += Vec3(-spot.y() * weight, spot.x() * weight, 0.0);
  const Vec3& torque = sim.state().wall_torque_nm[floor];
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_NEAR(torque[axis], moment[axis], 1e-4 * weight * 0.06) << "axis " << axis;
  }
  EXPECT_THROW((void)sim.wall_index("no_such_wall"), std::invalid_argument);

  // On two threads (one sphere or two each) the per-thread reactions add up to the same.
  spec.thread_count = 2;
  spec.min_particles_per_thread = 1;
  Simulation threaded(std::make_shared<Model>(spec));
  for (const Vec3& spot : spots) threaded.add_sphere({spot + Vec3(0, 0, kRadius), kRadius, 0});
  threaded.step(25000);
  EXPECT_EQ(threaded.active_thread_count(), 2);
  EXPECT_NEAR(threaded.state().wall_force_n[floor].z(), force.z(), 1e-9 * weight);
  EXPECT_NEAR(threaded.state().wall_torque_nm[floor].x(), torque.x(), 1e-9 * weight * 0.06);
}

// Neighbour list (Verlet): a pair left out at the build was beyond reach plus skin, so the list
// holds while no pair's relative displacement exceeds the skin. Spheres carried along as one
// move no pair closer: 27 spheres 0.5 mm apart (within the 1 mm skin, so listed and kept)
// travel 20 mm at 1 m/s, 20 skins, without a rebuild. The half-skin rule on each sphere's own
// displacement rebuilt every 0.5 mm, 40 times.
TEST(DemNeighbourList, LoadCarriedAsAWholeKeepsItsList) {
  const double dt = 1e-5;
  Simulation sim(std::make_shared<Model>(test::ball_model({test::hertz(0.5)}, dt)));
  const double pitch = 2.0 * kRadius + 0.0005;
  const Vec3 velocity(1.0, 0.0, 0.0);
  for (int x = 0; x < 3; ++x) {
    for (int y = 0; y < 3; ++y) {
      for (int z = 0; z < 3; ++z) sim.add_sphere({pitch * Vec3(x, y, z), kRadius, 0, velocity});
    }
  }
  sim.step();
  const std::uint64_t after_first = sim.stats().neighbor_rebuilds;
  sim.step(2000);  // 20 mm; with the first step, 2001 steps at 1 m/s
  EXPECT_NEAR(sim.state().position_m[0].x(), velocity.x() * 2001 * dt, 1e-9);
  EXPECT_EQ(sim.stats().neighbor_rebuilds, after_first);
  EXPECT_EQ(sim.stats().touching_pairs, 0U);  // 0.5 mm apart all the way
}

// ...while what moves relative to the rest is still listed in time. Two spheres 3.5 mm apart (3.5
// skins, not listed) close at 0.1 m/s while both drift sideways at 2 m/s, 20 times as fast: the
// list must be rebuilt on their closing, not on the drift, and before they touch (at 0.5 mm
// apart; a rule that waited for twice the skin would rebuild at 1.5 mm and -0.5 mm). A late
// listing lets them pass into each other; a prompt one gives Hertz' maximum overlap for a central
// impact without damping (test::hertz_peak_overlap_m), 0.11 mm.
TEST(DemNeighbourList, PairClosingWithinACommonDriftMeetsAsHertzSays) {
  const double dt = 1e-5;  // 1 um of closing per step: the peak resolved to about 1 %
  Simulation sim(std::make_shared<Model>(test::ball_model({test::hertz(1.0)}, dt)));
  const double gap = 0.0035;
  const double closing_speed = 0.1;
  const Vec3 drift(0.0, 2.0, 0.0);
  sim.add_sphere(
      {Vec3(-kRadius - gap / 2, -0.15, 0), kRadius, 0, drift + Vec3(closing_speed / 2, 0, 0)});
  sim.add_sphere(
      {Vec3(kRadius + gap / 2, -0.15, 0), kRadius, 0, drift - Vec3(closing_speed / 2, 0, 0)});
  double max_overlap = 0.0;
  for (int step = 0; step < 5000; ++step) {  // they meet after 35 ms, 70 mm downstream
    sim.step();
    const double distance = (sim.state().position_m[1] - sim.state().position_m[0]).norm();
    max_overlap = std::max(max_overlap, 2.0 * kRadius - distance);
  }
  ASSERT_GT(max_overlap, 0.0);
  const double hertz_overlap = test::hertz_peak_overlap_m(closing_speed);
  EXPECT_NEAR(max_overlap, hertz_overlap, 0.02 * hertz_overlap);
  // the impact was elastic (e = 1): sphere 0 bounced back
  EXPECT_LT(sim.state().velocity_m_per_s[0].x(), 0.0);
}

}  // namespace
}  // namespace fl::dem
