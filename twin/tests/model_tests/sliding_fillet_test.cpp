// A fillet sliding over steel: how far it goes before friction stops it, against the rigid
// Coulomb answer v0^2 / (2 mu g). The slide test (thesis 4.1.4) calibrates mu on the angle at
// which a resting fillet starts to slide; this is the other half of friction, the sliding
// itself, which decides how far a pushed fillet runs on after the plate stops (the centring
// unit, docs/twin.md "Why a pushed fillet slides on").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>

#include "fl/twin/dem/config.hpp"
#include "fl/twin/model_tests/fixtures.hpp"

namespace fl::model_tests {
namespace {

constexpr double kGravityMps2 = 9.81;
constexpr double kLaunchMps = 0.5;  // the centring pusher's top speed (60 mm in 0.12 s)

struct SlideOut {
  double distance_m = 0.0;
  bool stopped = false;
};

// A fillet of thesis_fillet_variants() `variant` (7 mm spheres) settled on a steel floor, then
// launched at kLaunchMps along its length (heading 0) or across it (pi/2); the centroid's
// travel until it moves under 1 mm/s, or after 0.5 s (over 4x the rigid stop, 0.1 s).
// `spin_locked` makes every sphere's rotational inertia infinite, as the slide test's solid
// fillet.
SlideOut slide_after_launch(std::size_t variant, double surface_energy_j_per_m2, bool spin_locked,
                            double heading_rad) {
  CommonParams common;
  common.base_spec = dem::load_model_spec(FL_SOURCE_DIR "/config/dem.yaml");
  common.sub_particle_radius_m = 0.007;
  common.variant = variant;
  dem::ModelSpec spec = make_spec(common);
  const std::uint32_t equipment = equipment_type(spec);
  set_contact_parameter(spec, "jkr", "surface_energy_j_per_m2", surface_energy_j_per_m2, equipment);
  spec.planes.push_back(floor_plane(equipment));
  spec.domain.lower_m = Vec3(-0.3, -0.3, -0.05);
  spec.domain.upper_m = Vec3(0.3, 0.3, 0.2);
  const dem::FilletTemplate fillet = make_fillet(common);
  spec.timestep_s = choose_timestep_s(common, spec, fillet);
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  add_fillet(sim, fillet, Eigen::Quaterniond::Identity(), 0.0, 0.0, 0.0005);
  dem::State& state = sim.mutable_state();
  if (spin_locked) {
    for (double& inverse : state.inverse_inertia_per_kg_m2) inverse = 0.0;
  }
  const auto steps_for = [&](double seconds) {
    return static_cast<std::size_t>(std::ceil(seconds / spec.timestep_s));
  };
  sim.step(steps_for(0.3));  // settled: lying still, its contacts and adhesion necks loaded
  const Vec3 launch(kLaunchMps * std::cos(heading_rad), kLaunchMps * std::sin(heading_rad), 0.0);
  for (Vec3& velocity : state.velocity_m_per_s) velocity = launch;
  for (Vec3& spin : state.angular_velocity_rad_per_s) spin.setZero();
  const Vec3 start_m = centroid_m(state);
  constexpr double kSampleS = 0.002;
  constexpr double kStillMps = 0.001;  // from here the rest of the slide is under a micrometre
  SlideOut out;
  for (int sample = 0; sample < 250; ++sample) {
    sim.step(steps_for(kSampleS));
    const double distance_m = (centroid_m(state) - start_m).norm();
    const bool still = distance_m - out.distance_m < kStillMps * kSampleS;
    out.distance_m = distance_m;
    if (still && sample > 10) {  // not in the first 20 ms, while the launch still rings
      out.stopped = true;
      break;
    }
  }
  return out;
}

double rigid_coulomb_distance_m(double mu) {
  return kLaunchMps * kLaunchMps / (2.0 * mu * kGravityMps2);
}
double deceleration_mps2(double distance_m) { return kLaunchMps * kLaunchMps / (2.0 * distance_m); }

// Without adhesion, the fillet whose spheres cannot spin stops where a rigid block would:
// v0^2 / (2 mu g) = 25.5 mm at mu 0.5. The appendix-B fillet, whose spheres turn freely
// against bonds that carry no moment, goes further: its bottom spheres roll (bonded neighbours
// counter-rotate like gears, see DemFriction), so part of its contacts stick instead of
// sliding. The nominal fillet, along its length, slides on as if mu were 0.35 (36 mm).
TEST(ModelTestsSliding, SpheresThatRollLetTheFilletSlideFurtherThanCoulomb) {
  constexpr double kMu = 0.5;          // config/dem.yaml, fillet-equipment
  constexpr std::size_t kNominal = 2;  // 172 x 72 x 32 mm, left
  const double rigid_m = rigid_coulomb_distance_m(kMu);
  const SlideOut locked = slide_after_launch(kNominal, 0.0, true, 0.0);
  const SlideOut free = slide_after_launch(kNominal, 0.0, false, 0.0);
  std::cout << "rigid Coulomb " << rigid_m * 1e3 << " mm; spin locked " << locked.distance_m * 1e3
            << " mm; free spheres " << free.distance_m * 1e3 << " mm (sliding mu "
            << deceleration_mps2(free.distance_m) / kGravityMps2 << ")\n";
  ASSERT_TRUE(locked.stopped);
  ASSERT_TRUE(free.stopped);
  // Within 5 %: the launch leaves the contacts' tangential springs unloaded, and the soft body
  // rings for the first millimetres (0.5 % measured).
  EXPECT_NEAR(locked.distance_m, rigid_m, 0.05 * rigid_m);
  // The rolling spheres: at least a fifth further than Coulomb (mu at most 0.42), and less than
  // twice as far (the bottom is not a bed of free rollers: mu over 0.25).
  EXPECT_GT(free.distance_m, 1.2 * rigid_m);
  EXPECT_LT(free.distance_m, 2.0 * rigid_m);
}

// The shipped model (adhesion 0.055 J/m^2 raises the friction load to |F + 2 F_c|, as LAMMPS'
// jkr) decelerates a sliding fillet at 3.2 to 4.8 m/s^2 by size and direction; the 40 mm thick
// fillets roll most. A centring pusher that brakes harder than the least of these leaves the
// fillet sliding on past the shift: config/plant_dem.yaml's 4 m/s^2 does, under the rigid
// mu g of 4.9; 2.5 does not (DemPlantStations).
TEST(ModelTestsSliding, ThickFilletsSlideOnPastAPlateBrakingUnderMuG) {
  constexpr double kGentleBrakeMps2 = 2.5;   // stops every size with the plate
  constexpr double kShippedBrakeMps2 = 4.0;  // config/plant_dem.yaml pusher_brake_mps2
  double least_mps2 = 1e9;
  for (const std::size_t variant : {0U, 2U, 4U}) {  // table 3.1's three sizes (left hand)
    for (const double heading_rad : {0.0, 0.5 * std::numbers::pi}) {
      const SlideOut out = slide_after_launch(variant, 0.055, false, heading_rad);
      // Stopped, so v0^2 / (2 d) is its mean deceleration, not a bound on it.
      EXPECT_TRUE(out.stopped) << "variant " << variant << " heading " << heading_rad;
      const double deceleration = deceleration_mps2(out.distance_m);
      std::cout << "variant " << variant << " heading " << heading_rad << ": "
                << out.distance_m * 1e3 << " mm, " << deceleration << " m/s^2\n";
      least_mps2 = std::min(least_mps2, deceleration);
    }
  }
  EXPECT_GT(least_mps2, kGentleBrakeMps2);
  EXPECT_LT(least_mps2, kShippedBrakeMps2);
}

}  // namespace
}  // namespace fl::model_tests
