// The effect library's laws (issue 6): each against its analytic answer.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "dem_test_support.hpp"
#include "fl/twin/dem/config.hpp"

namespace fl::dem {
namespace {

using test::kRadius;
constexpr double kG = 9.81;

// ---------------------------------------------------------------- bonds, at the law level

PairMaterial fillet_material() {
  const Material m{"fillet", test::kYoungs, test::kPoisson, test::kDensity};
  return make_pair_material(m, m, false);
}

// k = 1e6 N/m^3 on a 4 mm disk: k A = 50.3 N/m (appendix B's normal stiffness)
constexpr double kStiffness = 1e6;
const double kArea = 3.14159265358979323846 * kRadius * kRadius;

// A bond of rest length 8 mm driven through `distance(t)`; returns the normal force at the end.
template <typename Distance>
double drive_bond(const BondLaw& law, BondState& state, Distance distance, double from_s,
                  double to_s, double dt, double thickness_m = 0.0) {
  BondForce force;
  for (double t = from_s; t < to_s - 0.5 * dt; t += dt) {
    BondGeometry g;
    g.normal = Vec3::UnitX();
    g.distance_m = distance(t + dt);
    g.relative_velocity_m_per_s = Vec3((distance(t + dt) - distance(t)) / dt, 0, 0);
    g.rest_length_m = 0.008;
    g.bond_radius_m = kRadius;
    g.break_distance_m = 0.016;
    g.thickness_m = thickness_m;
    g.timestep_s = dt;
    force = BondForce{};
    law.compute(g, state, force);
  }
  return force.normal_force_n;
}

TEST(DemEffects, ViscoelasticBondRelaxesWithItsTimeConstant) {
  const double arm = 2e6;     // Maxwell arm twice the bpm spring: easy to see
  const double tau_s = 0.05;  // relaxation time
  auto law = LawRegistry::builtin().create_bond_law("bpm_viscoelastic",
                                                    {{"normal_stiffness_n_per_m3", kStiffness},
                                                     {"shear_stiffness_n_per_m3", kStiffness},
                                                     {"relaxation_stiffness_n_per_m3", arm},
                                                     {"relaxation_time_s", tau_s}},
                                                    fillet_material());
  const double stretch = 1e-4;  // 0.1 mm, reached in 1 ms (tau / 50: nearly a step)
  const double ramp_s = 1e-3;
  const auto distance = [&](double t) { return 0.008 + stretch * std::min(t / ramp_s, 1.0); };
  const double dt = 1e-5;
  BondState state;
  const double at_peak = drive_bond(*law, state, distance, 0.0, ramp_s, dt);
  // the ramp relaxes the arm by about ramp/(2 tau) = 1%: instant stiffness (k + k_m) A
  EXPECT_NEAR(at_peak, -(kStiffness + arm) * kArea * stretch,
              0.011 * (kStiffness + arm) * kArea * stretch);
  // hold for one tau: arm force falls by e
  const double held = drive_bond(*law, state, distance, ramp_s, ramp_s + tau_s, dt);
  const double relaxed = -kStiffness * kArea * stretch;
  EXPECT_NEAR((held - relaxed) / (at_peak - relaxed), std::exp(-1.0), 0.002);
  // long hold: only the bpm spring is left
  const double late = drive_bond(*law, state, distance, ramp_s + tau_s, ramp_s + 10 * tau_s, dt);
  EXPECT_NEAR(late, relaxed, 1e-4 * std::abs(relaxed));
}

TEST(DemEffects, PlasticBondKeepsAPermanentSet) {
  const double yield_pa = 20.0;  // yield stretch = sigma_y / k = 20 um
  auto law = LawRegistry::builtin().create_bond_law("bpm_plastic",
                                                    {{"normal_stiffness_n_per_m3", kStiffness},
                                                     {"shear_stiffness_n_per_m3", kStiffness},
                                                     {"normal_yield_strength_pa", yield_pa}},
                                                    fillet_material());
  const double yield_stretch = yield_pa / kStiffness;
  BondState state;
  // stretch to three yield stretches: force capped at sigma_y A (tension: negative)
  const auto out = [&](double t) { return 0.008 + 3.0 * yield_stretch * std::min(t, 1.0); };
  EXPECT_NEAR(drive_bond(*law, state, out, 0.0, 1.0, 1e-3), -yield_pa * kArea, 1e-12);
  // back to where the force is zero: rest length moved by two yield stretches
  const double set_distance = 0.008 + 2.0 * yield_stretch;
  const auto back = [&](double t) {
    return 0.008 + 3.0 * yield_stretch - yield_stretch * std::min(t - 1.0, 1.0);
  };
  EXPECT_NEAR(drive_bond(*law, state, back, 1.0, 2.0, 1e-3), 0.0, 1e-12);
  EXPECT_NEAR(back(2.0), set_distance, 1e-15);
  // the plain bpm at the same point would still pull with 2 k A yield_stretch
  auto elastic = LawRegistry::builtin().create_bond_law(
      "bpm", {{"normal_stiffness_n_per_m3", kStiffness}, {"shear_stiffness_n_per_m3", kStiffness}},
      fillet_material());
  BondState elastic_state;
  EXPECT_NEAR(drive_bond(*elastic, elastic_state, back, 1.0, 2.0, 1e-3),
              -2.0 * kStiffness * kArea * yield_stretch, 1e-12);
}

TEST(DemEffects, GradedBondStiffnessFollowsThePowerOfTheThickness) {
  // k(t) = k (t / 20 mm)^1.5: a 10 mm thin tip at 0.354 k, the reference at k, a 40 mm rear
  // at 2.83 k, in force, in the reported spring constant and in the stored energy.
  constexpr double kReferenceM = 0.020;
  constexpr double kExponent = 1.5;
  auto law = LawRegistry::builtin().create_bond_law("bpm_graded",
                                                    {{"normal_stiffness_n_per_m3", kStiffness},
                                                     {"shear_stiffness_n_per_m3", kStiffness},
                                                     {"reference_thickness_m", kReferenceM},
                                                     {"thickness_exponent", kExponent}},
                                                    fillet_material());
  EXPECT_TRUE(law->needs_bond_thickness());
  const double stretch = 1e-5;
  const auto distance = [&](double t) { return 0.008 + stretch * std::min(t, 1.0); };
  for (const double thickness_m : {0.010, 0.020, 0.040}) {
    const double scale = std::pow(thickness_m / kReferenceM, kExponent);
    BondState state;
    EXPECT_NEAR(drive_bond(*law, state, distance, 0.0, 1.0, 1e-2, thickness_m),
                -scale * kStiffness * kArea * stretch, 1e-12 * kStiffness * kArea * stretch)
        << thickness_m;
    Bond bond;
    bond.bond_radius_m = kRadius;
    bond.thickness_m = thickness_m;
    EXPECT_NEAR(law->normal_stiffness_n_per_m(bond), scale * kStiffness * kArea, 1e-9);
    EXPECT_NEAR(law->shear_stiffness_n_per_m(bond), scale * kStiffness * kArea, 1e-9);
    const double force_n = scale * kStiffness * kArea * stretch;
    EXPECT_NEAR(law->elastic_energy_j(state, bond),
                force_n * force_n / (2.0 * scale * kStiffness * kArea), 1e-18);
  }
  // The plain bpm ignores a thickness.
  auto plain = LawRegistry::builtin().create_bond_law(
      "bpm", {{"normal_stiffness_n_per_m3", kStiffness}, {"shear_stiffness_n_per_m3", kStiffness}},
      fillet_material());
  EXPECT_FALSE(plain->needs_bond_thickness());
  BondState plain_state;
  EXPECT_NEAR(drive_bond(*plain, plain_state, distance, 0.0, 1.0, 1e-2, 0.040),
              -kStiffness * kArea * stretch, 1e-12 * kStiffness * kArea * stretch);
}

// In the engine: a bonded pair at twice the reference thickness with exponent 2 has 4 times
// the spring, so it oscillates twice as fast and the timestep check halves its bond step; a
// body whose bonds carry no thickness is refused, naming the bond.
TEST(DemEffects, GradedBondInTheEngineUsesEachBondsThickness) {
  ModelSpec spec = test::ball_model({test::hertz(1.0)}, 1e-5, Vec3::Zero(), false);
  spec.interactions[0].bond_law = LawSpec{"bpm_graded",
                                          {{"normal_stiffness_n_per_m3", kStiffness},
                                           {"shear_stiffness_n_per_m3", kStiffness},
                                           {"reference_thickness_m", 0.010},
                                           {"thickness_exponent", 2.0}}};
  const auto model = std::make_shared<Model>(spec);
  const std::vector<Vec3> positions = {Vec3(-kRadius, 0, 0), Vec3(kRadius, 0, 0)};
  const std::vector<double> radii = {kRadius, kRadius};
  const std::vector<std::uint8_t> types = {0, 0};
  {
    Simulation sim(model);
    const std::vector<BodyBond> no_thickness = {{0, 1, kAppendixBContactRadiusM}};
    try {
      sim.add_body(positions, radii, types, no_thickness, BodyPose{});
      ADD_FAILURE() << "a graded bond without a thickness was accepted";
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find("bond 0-1"), std::string::npos) << error.what();
      EXPECT_NE(std::string(error.what()).find("thickness"), std::string::npos) << error.what();
    }
  }
  Simulation sim(model);
  const std::vector<BodyBond> bonds = {{0, 1, kAppendixBContactRadiusM, 0.020}};
  sim.add_body(positions, radii, types, bonds, BodyPose{});
  const double k = 4.0 * kStiffness * kArea;
  EXPECT_NEAR(sim.check_timestep().bond_critical_step_s, 2.0 / std::sqrt(k / test::sphere_mass()),
              1e-12);
  // Released from a small stretch speed, it passes back through its rest length after half
  // a period of the stiffer spring: omega = sqrt(k / (m / 2)).
  const double omega = std::sqrt(k / (test::sphere_mass() / 2.0));
  sim.mutable_state().velocity_m_per_s[0] = Vec3(-1e-4, 0, 0);
  sim.mutable_state().velocity_m_per_s[1] = Vec3(1e-4, 0, 0);
  double previous = 0.0;
  double crossed_s = -1.0;
  while (sim.state().time_s < 2.0 * std::numbers::pi / omega && crossed_s < 0.0) {
    sim.step();
    const double stretch =
        (sim.state().position_m[1] - sim.state().position_m[0]).norm() - 2.0 * kRadius;
    if (previous > 0.0 && stretch <= 0.0) crossed_s = sim.state().time_s;
    previous = stretch;
  }
  EXPECT_NEAR(crossed_s, std::numbers::pi / omega, 0.01 * std::numbers::pi / omega);
}

// ---------------------------------------------------------------- contacts, in the engine

// One sphere on the floor; gravity tilted by theta about y (the floor is an incline down +x).
// Rotation frozen when `slider`: a rigid block that can only slide.
struct Incline {
  Simulation sim;
  Incline(std::vector<LawSpec> laws, double tan_theta, bool slider, double dt)
      : sim(std::make_shared<Model>(test::ball_model(
            std::move(laws), dt,
            kG * Vec3(std::sin(std::atan(tan_theta)), 0, -std::cos(std::atan(tan_theta))), true))) {
    sim.add_sphere({Vec3(0, 0, kRadius), kRadius, 0});
    if (slider) sim.mutable_state().inverse_inertia_per_kg_m2[0] = 0.0;
  }
  [[nodiscard]] double x() const { return sim.state().position_m[0].x(); }
  [[nodiscard]] double speed() const { return sim.state().velocity_m_per_s[0].x(); }
};

constexpr double kDt = 2e-5;  // Hertz contact of a 4 mm sphere: ~1 ms, 50 steps

// Distance slid in `seconds` after `settle_s` at rest on the incline.
double slide_m(std::vector<LawSpec> laws, double tan_theta, double settle_s, double seconds) {
  Incline incline(std::move(laws), tan_theta, true, kDt);
  incline.sim.step(static_cast<std::size_t>(settle_s / kDt));
  const double x0 = incline.x();
  incline.sim.step(static_cast<std::size_t>(seconds / kDt));
  return incline.x() - x0;
}

LawSpec static_kinetic(double mu_s, double mu_k) {
  return {"static_kinetic_friction",
          {{"static_friction_coefficient", mu_s}, {"kinetic_friction_coefficient", mu_k}}};
}

TEST(DemEffects, StaticFrictionHoldsBetweenTheTwoAngles) {
  // tan theta 0.5 lies between mu_k 0.4 and mu_s 0.6: at rest it stays (Coulomb 0.4 would slide)
  const double held = slide_m({test::hertz(0.3), static_kinetic(0.6, 0.4)}, 0.5, 0.02, 0.2);
  EXPECT_LT(std::abs(held), 1e-5);  // spring creep only
  const double coulomb = slide_m({test::hertz(0.3), test::coulomb(0.4)}, 0.5, 0.02, 0.2);
  EXPECT_GT(coulomb, 0.01);
}

TEST(DemEffects, KineticFrictionSetsTheSlidingAcceleration) {
  const double tan_theta = 0.7;  // above mu_s 0.6: it slips, then slides with mu_k 0.4
  const double theta = std::atan(tan_theta);
  const double a = kG * (std::sin(theta) - 0.4 * std::cos(theta));
  Incline incline({test::hertz(0.3), static_kinetic(0.6, 0.4)}, tan_theta, true, kDt);
  incline.sim.step(static_cast<std::size_t>(0.02 / kDt));
  const double v0 = incline.speed();
  incline.sim.step(static_cast<std::size_t>(0.2 / kDt));
  EXPECT_NEAR((incline.speed() - v0) / 0.2, a, 0.01 * a);
}

TEST(DemEffects, WetFilmLowersTheSlideAngle) {
  // dry mu 0.5 holds at tan theta 0.35; a film with lubrication 0.5 leaves mu 0.25: it slides
  // at g (sin - 0.25 cos)
  const std::vector<LawSpec> dry = {test::hertz(0.3), test::coulomb(0.5)};
  EXPECT_LT(std::abs(slide_m(dry, 0.35, 0.02, 0.2)), 1e-5);
  const std::vector<LawSpec> wet = {
      test::hertz(0.3), {"wet_film", {{"lubrication", 0.5}}}, test::coulomb(0.5)};
  const double theta = std::atan(0.35);
  Incline incline(wet, 0.35, true, kDt);
  incline.sim.step(static_cast<std::size_t>(0.02 / kDt));
  const double v0 = incline.speed();
  incline.sim.step(static_cast<std::size_t>(0.2 / kDt));
  const double a = kG * (std::sin(theta) - 0.25 * std::cos(theta));
  EXPECT_NEAR((incline.speed() - v0) / 0.2, a, 0.01 * a);
}

TEST(DemEffects, RollingResistanceDeceleratesABallAtFiveSeventhsMuRG) {
  const double mu_r = 0.05;
  const std::vector<LawSpec> laws = {
      test::hertz(0.3), {"rolling_resistance", {{"rolling_friction", mu_r}}}, test::coulomb(0.5)};
  Incline ball(laws, 0.0, false, kDt);  // flat floor
  const double v_start = 0.3;
  ball.sim.mutable_state().velocity_m_per_s[0] = Vec3(v_start, 0, 0);
  ball.sim.mutable_state().angular_velocity_rad_per_s[0] = Vec3(0, v_start / kRadius, 0);
  ball.sim.step(static_cast<std::size_t>(0.02 / kDt));  // contact settles
  const double v0 = ball.speed();
  ball.sim.step(static_cast<std::size_t>(0.2 / kDt));
  // solid sphere rolling without slip: (m + I / R^2) a = mu_r N
  const double a = 5.0 / 7.0 * mu_r * kG;
  EXPECT_NEAR((v0 - ball.speed()) / 0.2, a, 0.02 * a);
  // without the law it keeps rolling (no loss beyond the contact's tiny damping)
  Incline free({test::hertz(0.3), test::coulomb(0.5)}, 0.0, false, kDt);
  free.sim.mutable_state().velocity_m_per_s[0] = Vec3(v_start, 0, 0);
  free.sim.mutable_state().angular_velocity_rad_per_s[0] = Vec3(0, v_start / kRadius, 0);
  free.sim.step(static_cast<std::size_t>(0.22 / kDt));
  EXPECT_GT(free.speed(), 0.99 * v_start);
}

TEST(DemEffects, KineticAboveStaticIsRejected) {
  EXPECT_THROW((void)LawRegistry::builtin().create_contact_law(
                   "static_kinetic_friction",
                   {{"static_friction_coefficient", 0.3}, {"kinetic_friction_coefficient", 0.5}},
                   fillet_material()),
               std::invalid_argument);
}

}  // namespace
}  // namespace fl::dem
