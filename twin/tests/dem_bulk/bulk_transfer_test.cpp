// The bulk scene as the line's infeed (config/bulk_line.yaml): the level sensor's reading, the
// leveller unit's own belt, and the stop plate at the transfer onto the takt belt, where
// fillets wait until the line takes them one at a time.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>

#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem_bulk/bulk_scene.hpp"

namespace fl {
namespace {

using dem::Vec3;
namespace fs = std::filesystem;

const fs::path kLineConfig = fs::path(FL_SOURCE_DIR) / "config/bulk_line.yaml";

// The line's bulk end without fillets, its belts and rotor still, the stop plate in place.
BulkDemConfig empty_line_scene() {
  BulkDemConfig config = load_bulk_dem_config(kLineConfig);
  config.feeder.initial_fill = 0;
  config.feeder.rate_per_s = 0.0;
  config.belt.hold_at_discharge = true;
  return config;
}

Eigen::Quaterniond heading(double angle_rad, bool bone_up = false) {
  Eigen::Quaterniond q(Eigen::AngleAxisd(angle_rad, Vec3::UnitZ()));
  if (bone_up) q = q * Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX());
  return q;
}

TEST(BulkLineConfig, ShippedFileHasTheLevellersBeltBetweenGateAndRotor) {
  const BulkDemConfig config = load_bulk_dem_config(kLineConfig);
  ASSERT_TRUE(config.leveller_belt.present);
  EXPECT_GT(config.leveller_belt.from_mm, config.gate.x_mm);
  EXPECT_LT(config.leveller_belt.from_mm, config.leveller.x_mm - config.leveller.tip_radius_mm);
  EXPECT_DOUBLE_EQ(config.leveller_belt.rotor_rpm, 120.0);  // line.yaml leveller.speed_rpm
  EXPECT_FALSE(config.belt.hold_at_discharge);  // set by the plant, never read from a file
  // The other bulk files have one belt: the section is optional.
  EXPECT_FALSE(
      load_bulk_dem_config(fs::path(FL_SOURCE_DIR) / "config/bulk_dem.yaml").leveller_belt.present);
}

// bulk_line.yaml as `text`, beside the engine file it names: the loader's message, or "".
std::string load_error(const std::string& text) {
  const fs::path folder = fs::temp_directory_path() / "fl_bulk_line_cfg";
  fs::create_directories(folder);
  fs::copy_file(fs::path(FL_SOURCE_DIR) / "config/dem.yaml", folder / "dem.yaml",
                fs::copy_options::overwrite_existing);
  std::ofstream(folder / "bulk_line.yaml") << text;
  try {
    (void)load_bulk_dem_config(folder / "bulk_line.yaml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

TEST(BulkLineConfig, ALevellersBeltOutsideGateAndRotorIsRefused) {
  std::ifstream in(kLineConfig);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Under the rotor (its tip circle reaches back to 350 mm), and a key it does not know: the
  // unknown key stops the file, so the belt's place is judged once it is gone.
  text.replace(text.find("  from_mm: 150.0"), 15, "  from_mm: 400.0");
  text.replace(text.find("  rotor_rpm: 120.0"), 18, "  rotor_rpmm: 120.0");
  std::string error = load_error(text);
  EXPECT_NE(error.find("bulk_line.yaml:"), std::string::npos) << error;
  EXPECT_NE(error.find("leveller_belt.rotor_rpmm"), std::string::npos) << error;
  text.replace(text.find("  rotor_rpmm: 120.0"), 19, "  rotor_rpm: 120.0");
  error = load_error(text);
  EXPECT_NE(error.find("leveller_belt.from_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("between the gate and the rotor's tip circle"), std::string::npos) << error;
}

// A fillet placed whole in the window, one across its edge, and a bare stretch: the reading is
// the highest sphere top whose centre lies in the window, from the template itself.
TEST(BulkHeap, TheSensorReadsTheHighestSphereTopInItsWindow) {
  BulkScene scene(empty_line_scene());
  EXPECT_DOUBLE_EQ(scene.heap_height_mm(250.0, 330.0), 0.0);  // a bare belt
  const dem::FilletTemplate& t = scene.templates()[2];
  const Vec3 centre(0.240, 0.0, 0.050);  // lying along the travel, 50 mm up: not yet touching
  scene.add_fillet(2, centre, Eigen::Quaterniond::Identity());
  const auto expected_mm = [&](double from_mm, double to_mm) {
    double top = 0.0;
    for (std::size_t i = 0; i < t.positions_m.size(); ++i) {
      const Vec3 p = centre + t.positions_m[i];
      if (p.x() * 1e3 >= from_mm && p.x() * 1e3 <= to_mm) {
        top = std::max(top, (p.z() + t.radii_m[i]) * 1e3);
      }
    }
    return top;
  };
  // The whole fillet (176 mm: 152..328 mm), its front half, and a window past its tip.
  EXPECT_NEAR(scene.heap_height_mm(100.0, 400.0), expected_mm(100.0, 400.0), 1e-9);
  EXPECT_NEAR(scene.heap_height_mm(250.0, 330.0), expected_mm(250.0, 330.0), 1e-9);
  EXPECT_GT(scene.heap_height_mm(100.0, 400.0), 50.0);  // over the centroid's height
  EXPECT_DOUBLE_EQ(scene.heap_height_mm(340.0, 400.0), 0.0);
}

// The leveller unit's belt turns with its rotor, in proportion (one drive), whatever the bulk
// belt under the hopper does: a fillet behind the rotor is carried on with the bulk belt held.
TEST(BulkLevellerBelt, TurnsWithTheRotorWhileTheBulkBeltIsHeld) {
  BulkDemConfig config = empty_line_scene();
  BulkScene scene(config);
  const BulkLevellerBeltConfig& belt = config.leveller_belt;
  scene.set_leveller_rpm(60.0);
  EXPECT_NEAR(scene.leveller_belt_speed_mps(), belt.speed_mps * 60.0 / belt.rotor_rpm, 1e-12);
  scene.set_leveller_rpm(belt.rotor_rpm);
  EXPECT_NEAR(scene.leveller_belt_speed_mps(), belt.speed_mps, 1e-12);
  scene.set_belt_speed_mps(0.0);
  scene.add_fillet(0, Vec3(0.670, 0.0, 0.030), Eigen::Quaterniond::Identity());
  scene.step(0.5);  // 0.15 m/s: about 75 mm on, far from the stop plate (900 mm)
  const std::vector<BulkFilletView> fillets = scene.fillets();
  ASSERT_EQ(fillets.size(), 1U);
  // Friction 0.5 takes it to the belt's speed within 31 ms; 5 % for the soft contact's sway.
  EXPECT_NEAR(fillets[0].velocity_m_per_s.x(), belt.speed_mps, 0.05 * belt.speed_mps);
  EXPECT_GT(fillets[0].centroid_m.x(), 0.670 + 0.060);
}

// Fillets ride to the transfer and wait there on the stopped belt, as they lay; the one that
// came first leaves first, and only when taken; without the hold the same fillet leaves by
// itself.
TEST(BulkTransfer, FilletsWaitAtTheEdgeAsTheyLayAndLeaveOneAtATime) {
  BulkScene scene(empty_line_scene());
  scene.set_leveller_rpm(120.0);  // the leveller's belt at 0.15 m/s
  const std::uint32_t first = scene.add_fillet(1, Vec3(0.790, 0.05, 0.030), heading(0.3));
  const std::uint32_t second =
      scene.add_fillet(4, Vec3(0.600, -0.08, 0.030), heading(std::numbers::pi - 0.2, true));
  EXPECT_FALSE(scene.front_at_discharge().has_value());  // not at the edge yet
  EXPECT_NEAR(scene.leveller_belt_speed_mps(), 0.15, 1e-12);
  // The first one's front is 24 mm short of the edge: there after 0.16 s at 0.15 m/s. Then
  // the belt stops under both, and nothing leaves by itself.
  scene.step(2.0);
  EXPECT_EQ(scene.counters().discharged, 0U);
  EXPECT_TRUE(scene.transfer_waiting());
  EXPECT_DOUBLE_EQ(scene.leveller_belt_speed_mps(), 0.0);
  std::optional<BulkHandover> front = scene.front_at_discharge();
  ASSERT_TRUE(front.has_value());
  EXPECT_EQ(front->id, first);
  EXPECT_EQ(front->variant, 1);
  EXPECT_GE(front->upper_m.x(), 0.900 - BulkScene::kAtStopMm * 1e-3);
  EXPECT_LE(front->upper_m.x(), 0.900 + 0.001);     // stopped before the plate, not through it
  EXPECT_LT(front->velocity_m_per_s.norm(), 0.01);  // still on the stopped belt
  // As it lay: skin up, its heading 0.3 rad (a fillet is limp: 5 degrees), along the spheres'
  // long axis as well (found without the template).
  EXPECT_GT(front->rotation(2, 2), 0.9);
  const double fitted = std::atan2(front->rotation(1, 0), front->rotation(0, 0));
  EXPECT_NEAR(fitted, 0.3, 5.0 * std::numbers::pi / 180.0);
  // The second queues behind on the stopped belt, not at the edge.
  for (const BulkFilletView& f : scene.fillets()) {
    if (f.id == second) {
      EXPECT_LT(f.upper_m.x(), 0.900 - 0.010);
    }
  }

  const std::optional<BulkHandover> taken = scene.hand_over_front();
  ASSERT_TRUE(taken.has_value());
  EXPECT_EQ(taken->id, first);
  EXPECT_EQ(scene.counters().discharged, 1U);
  ASSERT_EQ(scene.fillets_in_scene(), 1U);
  EXPECT_FALSE(scene.transfer_waiting());  // the belt runs again
  scene.step(2.0);                         // the second's front had about 0.1 m to go
  front = scene.front_at_discharge();
  ASSERT_TRUE(front.has_value());
  EXPECT_EQ(front->id, second);
  EXPECT_EQ(front->variant, 4);
  EXPECT_LT(front->rotation(2, 2), -0.9);  // bone up
  EXPECT_EQ(scene.hand_over_front()->id, second);
  EXPECT_EQ(scene.fillets_in_scene(), 0U);
  EXPECT_FALSE(scene.hand_over_front().has_value());

  // Without the plate (bulk_dem.yaml's free edge) the first fillet leaves on its own.
  BulkDemConfig free_edge = empty_line_scene();
  free_edge.belt.hold_at_discharge = false;
  BulkScene free_scene(free_edge);
  free_scene.set_leveller_rpm(120.0);
  free_scene.add_fillet(1, Vec3(0.790, 0.05, 0.030), heading(0.3));
  free_scene.step(1.2);  // the centroid passes 900 mm after about 0.75 s
  EXPECT_EQ(free_scene.counters().discharged, 1U);
  EXPECT_EQ(free_scene.fillets_in_scene(), 0U);
  EXPECT_FALSE(free_scene.front_at_discharge().has_value());
}

}  // namespace
}  // namespace fl
