// Walls built from the engine config (config/dem.yaml's layout): boxes and triangle meshes
// from STL files beside it, as an EDEM or LIGGGHTS user imports geometry. They load where the
// file says and carry spheres; a bad box or a missing or broken STL is named with its key.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "dem_test_support.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/config.hpp"

namespace fl::dem {
namespace {

namespace fs = std::filesystem;

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A 100 x 100 mm square in z = 0, two facets, millimetres as CAD exports them.
constexpr const char* kSquareStl = R"(solid square
facet normal 0 0 1
 outer loop
  vertex 0 0 0
  vertex 100 0 0
  vertex 100 100 0
 endloop
endfacet
facet normal 0 0 1
 outer loop
  vertex 0 0 0
  vertex 100 100 0
  vertex 0 100 0
 endloop
endfacet
endsolid square
)";

// config/dem.yaml with `walls` appended, and square.stl (or `stl_text`) beside it.
fs::path config_with(const std::string& name, const std::string& walls,
                     const std::string& stl_text = kSquareStl) {
  const fs::path dir = fs::temp_directory_path() / ("fl_dem_config_walls_" + name);
  fs::create_directories(dir);
  std::ofstream(dir / "dem.yaml") << read_text(fs::path(FL_SOURCE_DIR) / "config/dem.yaml")
                                  << walls;
  std::ofstream(dir / "square.stl") << stl_text;
  return dir / "dem.yaml";
}

std::string load_error(const fs::path& file) {
  try {
    (void)load_model_spec(file);
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "";
}

constexpr const char* kWalls = R"(
boxes:
  - {name: block, type: equipment, min_m: [-0.05, -0.05, -0.02], max_m: [0.05, 0.05, 0.0]}
meshes:
  - {name: shelf, type: equipment, stl: square.stl, scale: 0.001, offset_m: [0.3, 0.0, 0.1]}
)";

// A box wall is 12 triangles spanning its corners.
TEST(DemConfigWalls, BoxWallHasTwelveTriangles) {
  const auto wall = box_mesh_wall("b", 2, Vec3(-1, -2, -3), Vec3(1, 2, 3));
  ASSERT_EQ(wall.triangles.size(), 12U);
  for (const auto& t : wall.triangles) {
    for (const auto& v : t.vertices_m) {
      EXPECT_EQ(std::abs(v.x()), 1.0);
      EXPECT_EQ(std::abs(v.z()), 3.0);
    }
  }
}

TEST(DemConfigWalls, BoxesAndStlMeshesLoadWhereTheFileSays) {
  const ModelSpec spec = load_model_spec(config_with("load", kWalls));
  ASSERT_EQ(spec.meshes.size(), 2U);
  const MeshWallSpec& block = spec.meshes[0];
  EXPECT_EQ(block.name, "block");
  EXPECT_EQ(block.triangles.size(), 12U);  // six faces of two triangles
  const MeshWallSpec& shelf = spec.meshes[1];
  EXPECT_EQ(shelf.name, "shelf");
  ASSERT_EQ(shelf.triangles.size(), 2U);
  // Millimetres times 0.001, then moved: the square spans x 0.3..0.4, y 0..0.1 at z 0.1.
  for (const Triangle& t : shelf.triangles) {
    for (const Vec3& v : t.vertices_m) {
      EXPECT_GE(v.x(), 0.3 - 1e-12);
      EXPECT_LE(v.x(), 0.4 + 1e-12);
      EXPECT_GE(v.y(), -1e-12);
      EXPECT_LE(v.y(), 0.1 + 1e-12);
      EXPECT_NEAR(v.z(), 0.1, 1e-12);
    }
  }
  const auto equipment = spec.types.size() - 1;  // config/dem.yaml: fillet_a, fillet_b, equipment
  EXPECT_EQ(spec.types[equipment].name, "equipment");
  EXPECT_EQ(block.type, equipment);
  EXPECT_EQ(shelf.type, equipment);
}

// A sphere dropped on each wall comes to rest on it: on the box's top (z = 0) and on the STL
// shelf (z = 0.1 m), its centre a radius above less the contact's small overlap (Hertz with
// JKR adhesion at appendix B's soft fillet: well under a fifth of the radius).
TEST(DemConfigWalls, SpheresComeToRestOnTheLoadedWalls) {
  ModelSpec spec = load_model_spec(config_with("rest", kWalls));
  spec.planes.clear();
  Simulation sim(std::make_shared<Model>(spec));
  const double radius = 0.004;
  sim.add_sphere({Vec3(0.0, 0.0, 0.02), radius, 0});
  sim.add_sphere({Vec3(0.35, 0.05, 0.12), radius, 0});
  sim.step(static_cast<std::size_t>(1.0 / spec.timestep_s));  // a second: dropped and settled
  const State& s = sim.state();
  for (const auto& [k, top_m] : {std::pair<std::size_t, double>{0, 0.0}, {1, 0.1}}) {
    const double gap = s.position_m[k].z() - top_m;
    EXPECT_GT(gap, 0.8 * radius) << "sphere " << k << " sank into or through its wall";
    EXPECT_LE(gap, radius) << "sphere " << k << " does not touch its wall";
    EXPECT_LT(s.velocity_m_per_s[k].norm(), 1e-3) << "sphere " << k << " is not at rest";
  }
}

TEST(DemConfigWalls, BadBoxesAndStlFilesAreNamedWithTheirKey) {
  const std::string inverted = load_error(config_with("inverted", R"(
boxes:
  - {name: block, type: equipment, min_m: [0.0, 0.0, 0.0], max_m: [0.1, -0.1, 0.1]}
)"));
  EXPECT_NE(inverted.find("max_m"), std::string::npos) << inverted;
  EXPECT_NE(inverted.find("above min_m on every axis"), std::string::npos) << inverted;

  const std::string cornerless = load_error(config_with("cornerless", R"(
boxes:
  - {name: block, type: equipment, max_m: [0.1, 0.1, 0.1]}
)"));
  EXPECT_NE(cornerless.find("min_m"), std::string::npos) << cornerless;

  const std::string missing = load_error(config_with("missing", R"(
meshes:
  - {name: shelf, type: equipment, stl: nowhere.stl}
)"));
  EXPECT_NE(missing.find("stl"), std::string::npos) << missing;
  EXPECT_NE(missing.find("nowhere.stl"), std::string::npos) << missing;

  const std::string broken = load_error(config_with("broken", R"(
meshes:
  - {name: shelf, type: equipment, stl: square.stl}
)",
                                                    "solid square\nfacet normal 0 0 1\n"));
  EXPECT_NE(broken.find("square.stl"), std::string::npos) << broken;

  const std::string untyped = load_error(config_with("untyped", R"(
meshes:
  - {name: shelf, type: steel_plate, stl: square.stl}
)"));
  EXPECT_NE(untyped.find("no type named 'steel_plate'"), std::string::npos) << untyped;
}

}  // namespace
}  // namespace fl::dem
