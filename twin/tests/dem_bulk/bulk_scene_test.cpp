// Tests of the DEM bulk scene (twin/include/fl/twin/dem_bulk/bulk_scene.hpp): geometry of the
// gate and the leveller, the belt's drive, the gate's effect on the outflow, and the leveller
// knocking back a stacked fillet. 7 mm sub-particles (config/bulk_dem.yaml) and few fillets
// keep the whole executable within about a minute on two cores.
#include "fl/twin/dem_bulk/bulk_scene.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>

#include "fl/controller/yaml_reader.hpp"

namespace fl {
namespace {

using dem::Vec3;

const std::filesystem::path kConfig = std::filesystem::path(FL_SOURCE_DIR) / "config/bulk_dem.yaml";

// The shipped config with no fillets: geometry and single-body checks.
BulkDemConfig empty_scene_config() {
  BulkDemConfig config = load_bulk_dem_config(kConfig);
  config.feeder.initial_fill = 0;
  config.feeder.rate_per_s = 0.0;
  return config;
}

TEST(BulkConfig, ShippedFileLoadsWithTheThesisAndLineNumbers) {
  const BulkDemConfig config = load_bulk_dem_config(kConfig);
  EXPECT_EQ(config.leveller.blades, 8);                // thesis 5.3
  EXPECT_DOUBLE_EQ(config.gate.opening_mm, 60.0);      // line.yaml hopper_opening_mm
  EXPECT_DOUBLE_EQ(config.leveller.speed_rpm, 120.0);  // line.yaml leveller.speed_rpm
  EXPECT_DOUBLE_EQ(config.simulation.sub_particle_radius_mm, 7.0);
  EXPECT_EQ(config.engine.types.size(), 3U);  // dem.yaml: fillet_a, fillet_b, equipment
}

TEST(BulkConfig, ProblemsNameFileLineAndKeyPath) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() / "fl_bulk_cfg";
  std::filesystem::create_directories(folder);
  std::filesystem::copy_file(std::filesystem::path(FL_SOURCE_DIR) / "config/dem.yaml",
                             folder / "dem.yaml",
                             std::filesystem::copy_options::overwrite_existing);
  std::ifstream in(kConfig);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A typo in one key and a negative clearance in another: both reported in one pass.
  text.replace(text.find("  blades: 8"), 11, "  bladez: 8");
  text.replace(text.find("tip_clearance_mm: 55.0"), 22, "tip_clearance_mm: -5.0");
  std::ofstream(folder / "bulk_dem.yaml") << text;
  try {
    (void)load_bulk_dem_config(folder / "bulk_dem.yaml");
    FAIL() << "expected a ConfigError";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("bulk_dem.yaml:"), std::string::npos) << what;
    EXPECT_NE(what.find("leveller.bladez"), std::string::npos) << what;
    EXPECT_NE(what.find("leveller.tip_clearance_mm"), std::string::npos) << what;
  }
}

TEST(BulkGeometry, GateLowerEdgeFollowsTheOpeningAtTheCylinderSpeed) {
  BulkScene scene(empty_scene_config());
  EXPECT_NEAR(scene.gate_lower_edge_z_m(), 0.060, 1e-12);  // configured 60 mm
  scene.set_gate_opening_mm(80.0);
  // 20 mm at 50 mm/s takes 0.4 s: after 0.2 s the cylinder is half way (a moving plate, not a
  // jump into the pile), after 0.5 s it has arrived.
  scene.step(0.2);
  EXPECT_NEAR(scene.gate_lower_edge_z_m(), 0.070, 0.0005);
  scene.step(0.3);
  EXPECT_NEAR(scene.gate_lower_edge_z_m(), 0.080, 1e-9);
  EXPECT_NEAR(scene.gate_opening_mm(), 80.0, 1e-6);
  // Beyond the end stop (150 mm, plant_fast.yaml): clamped.
  scene.set_gate_opening_mm(400.0);
  scene.step(2.0);
  EXPECT_NEAR(scene.gate_lower_edge_z_m(), 0.150, 1e-9);
}

TEST(BulkGeometry, BladeTipsSweepTheConfiguredClearance) {
  BulkDemConfig config = empty_scene_config();
  BulkScene scene(config);
  const double clearance_m = config.leveller.tip_clearance_mm * 1e-3;
  const double radius_m = config.leveller.tip_radius_mm * 1e-3;
  const double axis_z_m = clearance_m + radius_m;
  const double pitch_rad = 2.0 * std::numbers::pi / config.leveller.blades;
  EXPECT_NEAR(scene.leveller_lowest_tip_z_m(), clearance_m, 1e-12);  // one blade points down
  const double omega = config.leveller.speed_rpm * 2.0 * std::numbers::pi / 60.0;
  for (int k = 0; k < 20; ++k) {
    scene.step(0.006);  // 3 control steps: 0.75 rad at 120 rpm, not a multiple of the pitch
    // Lowest tip: the blade nearest to straight down, at the residual angle of the turn the
    // engine's clock gives (rotation = omega x time).
    const double turned = std::fmod(omega * scene.time_s(), pitch_rad);
    const double residual = std::min(turned, pitch_rad - turned);
    EXPECT_NEAR(scene.leveller_lowest_tip_z_m(), axis_z_m - radius_m * std::cos(residual), 1e-6)
        << "at " << scene.time_s() << " s";
    EXPECT_GE(scene.leveller_lowest_tip_z_m(), clearance_m - 1e-9);
  }
}

TEST(BulkBelt, SphereAndFilletAreCarriedByTheBelt) {
  BulkDemConfig config = empty_scene_config();
  config.belt.speed_mps = 0.2;
  BulkScene scene(config);
  const double r = config.simulation.sub_particle_radius_mm * 1e-3;
  // Between the gate (x = 0) and the blade circle (x >= 0.35 m): nothing but the belt touches.
  scene.add_sphere(Vec3(0.15, 0.0, r + 0.001), r);
  scene.add_fillet(2, Vec3(0.15, 0.1, 0.030), Eigen::Quaterniond::Identity());
  scene.step(0.3);  // friction 0.5: slip ends within 0.2 m/s / (0.5 g) = 41 ms
  const dem::State& s = scene.simulation().state();
  std::size_t sphere = s.size();
  // The loose sphere is the one whose body no other particle shares.
  for (std::size_t k = 0; k < s.size(); ++k) {
    const auto same = std::count(s.body.begin(), s.body.end(), s.body[k]);
    if (same == 1) sphere = k;
  }
  ASSERT_LT(sphere, s.size());
  // A free sphere on a belt rolls: friction at the contact conserves its angular momentum about
  // the contact line, m r v - I w = 0, and stops when the contact point moves with the belt,
  // v - w r = u: v = u I / (I + m r^2) = 2/7 u. Its contact point must run at the belt's speed.
  // 3 % of the belt speed: the Mindlin spring and JKR neck leave a small oscillation.
  const double u = 0.2;
  const Vec3 v = s.velocity_m_per_s[sphere];
  const Vec3 contact_v = v + s.angular_velocity_rad_per_s[sphere].cross(Vec3(0.0, 0.0, -r));
  EXPECT_NEAR(contact_v.x(), u, 0.03 * u);
  EXPECT_NEAR(v.x(), 2.0 / 7.0 * u, 0.03 * u);
  // A fillet cannot roll: it moves at the belt speed (same 3 %).
  const std::vector<BulkFilletView> fillets = scene.fillets();
  ASSERT_EQ(fillets.size(), 1U);
  EXPECT_NEAR(fillets[0].velocity_m_per_s.x(), u, 0.03 * u);
  EXPECT_NEAR(fillets[0].velocity_m_per_s.y(), 0.0, 0.03 * u);
}

// One sweep of the gate opening shared by the outflow tests (the expensive part). A narrower
// hopper (200 mm belt, 250 mm floor) holds 16 fillets four layers deep, so the opening and not
// the belt area limits what leaves: the shipped 400 x 400 mm floor lets 12 fillets spread to
// one layer that passes any opening over one fillet's thickness.
class BulkOutflow : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    BulkDemConfig config = load_bulk_dem_config(kConfig);
    config.belt.half_width_mm = 100.0;
    config.hopper.back_mm = -250.0;
    config.belt.start_mm = -400.0;
    config.feeder.initial_fill = 16;
    config.simulation.seed = 7;
    // 10 mm: under one sub-particle diameter (14 mm), so no sphere fits under the gate without
    // a 4 mm overlap (12 N Hertz force against about 1 N of belt drag per fillet); then the
    // openings 40 / 70 / 100 mm: under, about one and a half and over two fillet thicknesses
    // (a 7 mm raster fillet is 35 to 46 mm thick).
    const double openings[] = {10.0, 40.0, 70.0, 100.0};
    GateSweepOptions options;
    options.settle_s = 0.5;   // the pile falls 0.3 m and comes to rest in about 0.5 s
    options.measure_s = 1.5;  // 0.3 m of belt travel at 0.2 m/s: the floor's length
    points_ = sweep_gate_opening(config, openings, options);
    write_gate_sweep_csv(points_, std::filesystem::temp_directory_path() / "fl_bulk_sweep.csv");
  }
  static std::vector<GateSweepPoint> points_;
};
std::vector<GateSweepPoint> BulkOutflow::points_;

TEST_F(BulkOutflow, ClosedGateHoldsEverythingAndAnOpenOneLetsThrough) {
  ASSERT_EQ(points_.size(), 4U);
  for (const GateSweepPoint& p : points_) {
    std::printf("opening %5.1f mm: %llu under the gate in 1.5 s (%.2f/s), %.2f kg/s out\n",
                p.opening_mm, static_cast<unsigned long long>(p.gate_passes), p.gate_passes_per_s,
                p.mass_flow_kg_per_s);
  }
  EXPECT_EQ(points_[0].gate_passes, 0U);
  EXPECT_GT(points_[3].gate_passes, 0U);
}

TEST_F(BulkOutflow, OutflowRisesWithTheOpening) {
  ASSERT_EQ(points_.size(), 4U);
  EXPECT_LE(points_[1].gate_passes, points_[2].gate_passes);
  EXPECT_LE(points_[2].gate_passes, points_[3].gate_passes);
  EXPECT_LT(points_[1].gate_passes, points_[3].gate_passes);
}

// A sweep that would measure something other than what was asked is refused before any scene
// is built: the shipped gate travels 0 to 150 mm and the control step is 2 ms, so 150.5 mm,
// NaN, 3 ms (one and a half steps) and 1 ms (under one step) are each refused, naming the value.
// A fillet under the belt plane (off the scene's side or through a gap) is taken out and
// counted as lost, not as discharged, so fed = in the scene + discharged + lost still holds.
TEST(BulkCounting, AFilletFallenUnderTheBeltIsCountedLost) {
  BulkScene scene(empty_scene_config());
  scene.add_fillet(0, Vec3(0.3, 0.0, -0.3), Eigen::Quaterniond::Identity());  // 0.3 m below
  scene.add_fillet(0, Vec3(0.3, 0.0, 0.03), Eigen::Quaterniond::Identity());  // on the belt
  scene.step(0.002);                                                          // one control step
  EXPECT_EQ(scene.counters().lost, 1U);
  EXPECT_EQ(scene.counters().discharged, 0U);
  EXPECT_EQ(scene.fillets_in_scene(), 1U);
  EXPECT_EQ(scene.counters().broken_bonds_removed, 0U);  // it left whole
}

// A sphere off the end of the belt falls on for as long as its fillet stays on the belt: in the
// thesis' bulk run such fragments fell 60 m and forced a neighbour rebuild at every step. From
// 0.3 m under the belt it is held still, so it no longer drives the rebuilds.
TEST(BulkCounting, ASphereFallenUnderTheSceneIsHeldStill) {
  BulkScene scene(empty_scene_config());
  scene.add_sphere(Vec3(1.2, 0.0, -0.25), 0.004);  // past the discharge edge (900 mm)
  scene.step(0.2);                                 // it reaches -0.3 m after 0.1 s, at 1 m/s
  EXPECT_EQ(scene.counters().fallen_spheres, 1U);
  const std::uint64_t rebuilds = scene.simulation().stats().neighbor_rebuilds;
  scene.step(0.5);
  // Held: in each 2 ms control step it regains only g h = 0.02 m/s and sinks g h^2 / 2 = 0.02 mm,
  // 5 mm in 0.5 s; falling on it would have gone 1.7 m (425 rebuilds at the 4 mm skin).
  EXPECT_LT(scene.simulation().state().velocity_m_per_s[0].norm(), 0.03);
  EXPECT_GT(scene.simulation().state().position_m[0].z(), -0.31);
  EXPECT_LE(scene.simulation().stats().neighbor_rebuilds - rebuilds, 3U);
  EXPECT_EQ(scene.counters().fallen_spheres, 1U);  // counted once
}

TEST(BulkSweep, RefusesWhatTheSceneCannotMeasureAsAsked) {
  const BulkDemConfig config = load_bulk_dem_config(kConfig);
  const auto refusal = [&](double opening_mm, double settle_s, double measure_s) {
    const double openings[] = {opening_mm};
    try {
      (void)sweep_gate_opening(config, openings, GateSweepOptions{settle_s, measure_s});
    } catch (const std::runtime_error& error) {
      return std::string(error.what());
    }
    return std::string("ran");
  };
  EXPECT_NE(refusal(150.5, 0.5, 2.0).find("not 150.5 mm"), std::string::npos);
  EXPECT_NE(refusal(std::nan(""), 0.5, 2.0).find("not nan mm"), std::string::npos);
  EXPECT_NE(refusal(60.0, 0.5, 0.003).find("measuring time 0.003"), std::string::npos);
  EXPECT_NE(refusal(60.0, 0.5, 0.001).find("measuring time 0.001"), std::string::npos);
  EXPECT_NE(refusal(60.0, std::nan(""), 2.0).find("settling time nan"), std::string::npos);
}

TEST(BulkLeveller, KnocksBackTheTopFilletOfAStack) {
  BulkDemConfig config = empty_scene_config();
  config.belt.speed_mps = 0.3;
  BulkScene scene(config);
  // Two 144 x 72 x 40 mm fillets (variant 0; 42 mm thick as three layers of 7 mm spheres)
  // stacked: the bottom one passes under the 55 mm tip clearance, the top one spans about
  // 43..85 mm and meets the blades. The stack starts with its front 0.41 m downstream, where
  // the blade circle (axis 0.5 m, 205 mm up, 150 mm radius) comes down to 85 mm: with the
  // fillet-fillet friction of 0.1 a stack slides apart on its own within about 0.3 s (seen in
  // this scene), so the blades must meet it before.
  const double half_z = scene.templates()[0].half_extent_m.z();
  const double half_x = scene.templates()[0].half_extent_m.x();
  const double x0 = 0.41 - half_x;
  const Vec3 v(0.3, 0.0, 0.0);
  const std::uint32_t bottom =
      scene.add_fillet(0, Vec3(x0, 0.0, half_z + 0.001), Eigen::Quaterniond::Identity(), v);
  const std::uint32_t top =
      scene.add_fillet(0, Vec3(x0, 0.0, 3.0 * half_z + 0.002), Eigen::Quaterniond::Identity(), v);
  const double axis_x = config.leveller.x_mm * 1e-3;
  double bottom_cross_s = -1.0;
  double top_cross_s = -1.0;
  double top_x_when_bottom_crossed = 0.0;
  double peak_torque_nm = 0.0;
  for (int k = 0; k < 125 && (bottom_cross_s < 0.0 || top_cross_s < 0.0); ++k) {
    scene.step(0.02);
    peak_torque_nm = std::max(peak_torque_nm, scene.leveller_load_mean().torque_nm);
    for (const BulkFilletView& f : scene.fillets()) {
      if (f.id == bottom && bottom_cross_s < 0.0 && f.centroid_m.x() > axis_x) {
        bottom_cross_s = scene.time_s();
        for (const BulkFilletView& g : scene.fillets()) {
          if (g.id == top) top_x_when_bottom_crossed = g.centroid_m.x();
        }
      }
      if (f.id == top && top_cross_s < 0.0 && f.centroid_m.x() > axis_x) {
        top_cross_s = scene.time_s();
      }
    }
  }
  // The bottom one passes: (0.5 - 0.15) m at 0.3 m/s is 1.2 s; 2.5 s allows for the drag of the
  // pile on it.
  ASSERT_GT(bottom_cross_s, 0.0) << "bottom fillet did not pass under the rotor";
  // The top one was held back upstream of the rotor's axis when the bottom one passed it, by
  // more than half a fillet length (86 mm): knocked back, not merely lagging.
  EXPECT_LT(top_x_when_bottom_crossed, axis_x - 0.086);
  if (top_cross_s > 0.0) {
    EXPECT_GT(top_cross_s, bottom_cross_s);
  }
  // The blades did work against it: a load resisting the rotation.
  EXPECT_GT(peak_torque_nm, 0.0);
}

}  // namespace
}  // namespace fl
