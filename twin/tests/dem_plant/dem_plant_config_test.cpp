// config/plant_dem.yaml: the shipped file equals the defaults, and the plates' geometry is
// checked against itself (parsers are tested against malformed input).
#include "fl/twin/dem_plant/dem_plant_config.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "fl/controller/yaml_reader.hpp"

namespace fl::test {
namespace {

namespace fs = std::filesystem;
const fs::path kConfigDir = FL_SOURCE_DIR "/config";

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// plant_dem.yaml beside copies of the files it names, with one passage of `edited` (one of
// them) replaced.
fs::path variant_file(const std::string& name, const std::string& from, const std::string& to,
                      const std::string& edited = "plant_dem.yaml") {
  const fs::path dir = fs::temp_directory_path() / ("fl_plant_dem_config_" + name);
  fs::create_directories(dir);
  for (const char* file : {"plant_dem.yaml", "dem.yaml", "plant_fast.yaml", "bulk_line.yaml"}) {
    std::string text = read_text(kConfigDir / file);
    if (file == edited) {
      const std::size_t at = text.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) text.replace(at, from.size(), to);
    }
    std::ofstream(dir / file) << text;
  }
  return dir / "plant_dem.yaml";
}

std::string load_error(const fs::path& file) {
  try {
    (void)load_dem_plant_config(file);
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "";
}

TEST(DemPlantConfigFile, ShippedMachineryAndSimulationEqualTheDefaults) {
  const DemPlantConfig loaded = load_dem_plant_config(kConfigDir / "plant_dem.yaml");
  EXPECT_EQ(loaded.machinery, default_dem_plant_config().machinery);
  EXPECT_EQ(loaded.simulation, default_dem_plant_config().simulation);
  EXPECT_EQ(loaded.feeder, default_dem_plant_config().feeder);
  EXPECT_EQ(loaded.feeder.source, DemInfeedSource::kLevelledLayer);
  EXPECT_TRUE(loaded.bulk_end.leveller_belt.present);  // bulk_line.yaml, loaded either way
}

TEST(DemPlantConfigFile, UnknownInfeedSourceIsNamedWithTheChoices) {
  const std::string error =
      load_error(variant_file("source", "  source: levelled_layer", "  source: mailbox"));
  EXPECT_NE(error.find("feeder.source"), std::string::npos) << error;
  EXPECT_NE(error.find("dem_bulk_end"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, UnknownCentringUnitIsNamedWithTheChoices) {
  const std::string error =
      load_error(variant_file("centring", "  centring_unit: pusher", "  centring_unit: funnel"));
  EXPECT_NE(error.find("machinery.centring_unit"), std::string::npos) << error;
  EXPECT_NE(error.find("jaws"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, LevelSensorBehindTheLevellersBladesIsRefused) {
  // bulk_line.yaml's rotor reaches back to 500 - 150 = 350 mm.
  const std::string error = load_error(
      variant_file("sensor", "  level_sensor_to_mm: 330.0", "  level_sensor_to_mm: 420.0"));
  EXPECT_NE(error.find("feeder.level_sensor_from_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("in front of the leveller"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, BulkEndOfAnotherRasterIsRefused) {
  const std::string error =
      load_error(variant_file("raster", "  sub_particle_radius_mm: 7.0",
                              "  sub_particle_radius_mm: 4.0", "bulk_line.yaml"));
  EXPECT_NE(error.find("bulk_line.yaml"), std::string::npos) << error;
  EXPECT_NE(error.find("simulation.sub_particle_radius_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("must equal plant_dem.yaml"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, BulkEndStepBetweenThePlantsStepsIsRefused) {
  // 1.5 ms against the plant's 1 ms: the scene could not step whole steps with the line.
  const std::string error = load_error(variant_file("step", "  control_step_s: 0.002",
                                                    "  control_step_s: 0.0015", "bulk_line.yaml"));
  EXPECT_NE(error.find("simulation.control_step_s"), std::string::npos) << error;
  EXPECT_NE(error.find("whole multiple"), std::string::npos) << error;
}

// One belt under hopper and leveller: the level control would stop the levelled layer with the
// heap (a file the bulk scene itself reads: the section is optional there).
TEST(DemPlantConfigFile, BulkEndWithoutTheLevellersBeltIsRefused) {
  const std::string text = read_text(kConfigDir / "bulk_line.yaml");
  const std::size_t at = text.find("\nleveller_belt:");
  ASSERT_NE(at, std::string::npos);
  const std::string error =
      load_error(variant_file("one_belt", text.substr(at), "\n", "bulk_line.yaml"));
  EXPECT_NE(error.find("bulk_line.yaml: leveller_belt"), std::string::npos) << error;
  EXPECT_NE(error.find("the leveller's own belt"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, ZeroParticlesPerThreadIsRefused) {
  const std::string error = load_error(variant_file("per_thread", "  min_particles_per_thread: 256",
                                                    "  min_particles_per_thread: 0"));
  EXPECT_NE(error.find("simulation.min_particles_per_thread"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, GuideThatWouldStartBelowTheRejectBeltIsRefused) {
  // A 200 mm rise to a raised end 150 mm over the reject belt starts the guide 50 mm under it.
  const std::string error =
      load_error(variant_file("rise", "  guide_rise_mm: 50.0", "  guide_rise_mm: 200.0"));
  EXPECT_NE(error.find("machinery.guide_rise_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("below the reject belt"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, PlateThatWouldNotSlideDownIsRefused) {
  const std::string error = load_error(
      variant_file("end", "  plate1_end_height_mm: 50.0", "  plate1_end_height_mm: 150.0"));
  EXPECT_NE(error.find("machinery.plate1_end_height_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("slide down"), std::string::npos) << error;
}

TEST(DemPlantConfigFile, MissingPlateKeyIsNamed) {
  const std::string error =
      load_error(variant_file("missing", "  plate_swing_deg: 90.0", "  plate_swing: 90.0"));
  EXPECT_NE(error.find("plate_swing_deg"), std::string::npos) << error;
}

}  // namespace
}  // namespace fl::test
