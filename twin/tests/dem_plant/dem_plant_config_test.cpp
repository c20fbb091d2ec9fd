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

// plant_dem.yaml with one line replaced, beside copies of the two files it names.
fs::path variant_file(const std::string& name, const std::string& from, const std::string& to) {
  const fs::path dir = fs::temp_directory_path() / ("fl_plant_dem_config_" + name);
  fs::create_directories(dir);
  for (const char* other : {"dem.yaml", "plant_fast.yaml"}) {
    fs::copy_file(kConfigDir / other, dir / other, fs::copy_options::overwrite_existing);
  }
  std::string text = read_text(kConfigDir / "plant_dem.yaml");
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  std::ofstream(dir / "plant_dem.yaml") << text;
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
