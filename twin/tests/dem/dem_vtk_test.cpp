// VTK output: what ParaView reads back, parsed here from the legacy ASCII files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>

#include "dem_test_support.hpp"
#include "fl/twin/dem/vtk_writer.hpp"

namespace fl::dem {
namespace {

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The numbers after `keyword` on its line, then the following `count` lines' numbers.
std::vector<double> section(const std::string& text, const std::string& keyword, int lines) {
  const auto at = text.find("\n" + keyword + " ");
  if (at == std::string::npos) return {};
  std::istringstream in(text.substr(text.find('\n', at + 1) + 1));
  std::vector<double> values;
  std::string line;
  for (int k = 0; k < lines && std::getline(in, line); ++k) {
    std::istringstream numbers(line);
    for (double value = 0.0; numbers >> value;) values.push_back(value);
  }
  return values;
}

ModelSpec model_with_mesh() {
  ModelSpec spec = test::ball_model({test::hertz(0.5)}, 1e-5, Vec3::Zero(), true);
  MeshWallSpec plate{"plate", 1, {Triangle{{Vec3(0, 0, 0), Vec3(0.1, 0, 0), Vec3(0, 0.05, 0)}}}};
  spec.meshes.push_back(plate);
  return spec;
}

class DemVtkOutput : public ::testing::Test {
 protected:
  std::filesystem::path dir_ = std::filesystem::temp_directory_path() /
                               ("fl_dem_vtk_" + std::to_string(::getpid()) + "_" +
                                ::testing::UnitTest::GetInstance()->current_test_info()->name());
  void TearDown() override { std::filesystem::remove_all(dir_); }
};

TEST_F(DemVtkOutput, WallsAreWrittenWhereTheyAreNow) {
  Simulation sim(std::make_shared<Model>(model_with_mesh()));
  // the plate turned by 90 degrees about z around its first vertex: (0.1, 0, 0) -> (0, 0.1, 0)
  WallState& plate = sim.wall("plate");
  plate.rotation = Eigen::Quaterniond(Eigen::AngleAxisd(std::numbers::pi / 2, Vec3::UnitZ()));
  plate.translation_m = Vec3(0, 0, 0.02);  // and lifted by 20 mm
  std::filesystem::create_directories(dir_);
  write_vtk_walls(sim.model(), sim.state(), dir_ / "walls.vtk", 0.5);
  const std::string text = read_text(dir_ / "walls.vtk");
  // 4 corners of the floor square + 3 triangle vertices
  ASSERT_NE(text.find("POINTS 7 double"), std::string::npos) << text;
  const std::vector<double> points = section(text, "POINTS", 7);
  ASSERT_EQ(points.size(), 21U);
  // floor: z = 0 everywhere, corners 0.5 m from the centre along both in-plane axes
  for (int corner = 0; corner < 4; ++corner) EXPECT_DOUBLE_EQ(points[corner * 3 + 2], 0.0);
  EXPECT_NEAR(std::abs(points[0]), 0.5, 1e-12);
  // the plate's second vertex: turned onto +y, lifted
  EXPECT_NEAR(points[15], 0.0, 1e-12);
  EXPECT_NEAR(points[16], 0.1, 1e-12);
  EXPECT_NEAR(points[17], 0.02, 1e-12);
  ASSERT_NE(text.find("POLYGONS 2 9"), std::string::npos);  // (4 + 1) + (3 + 1) entries
  const std::vector<double> wall = section(text, "LOOKUP_TABLE", 2);
  EXPECT_EQ(wall, (std::vector<double>{0, 1}));  // the plane is wall 0, the mesh wall 1
}

TEST_F(DemVtkOutput, SeriesListsEveryFrameWithItsTime) {
  Simulation sim(std::make_shared<Model>(model_with_mesh()));
  sim.add_sphere({Vec3(0.05, 0.01, 0.1), test::kRadius, 0});
  sim.add_sphere({Vec3(-0.05, 0.01, 0.1), test::kRadius, 0});
  VtkSeriesWriter series(dir_);
  series.write(sim);
  sim.step(10);  // 10 steps of 10 us: t = 1e-4 s
  series.write(sim);
  EXPECT_EQ(series.frames(), 2U);
  const std::string pvd = read_text(series.collection_file());
  EXPECT_NE(pvd.find("timestep=\"0\" part=\"0\" file=\"particles_000000.vtk\""), std::string::npos)
      << pvd;
  EXPECT_NE(pvd.find("timestep=\"0.0001\" part=\"1\" file=\"walls_000001.vtk\""), std::string::npos)
      << pvd;
  const std::string particles = read_text(dir_ / "particles_000001.vtk");
  ASSERT_NE(particles.find("POINTS 2 double"), std::string::npos);
  const std::vector<double> points = section(particles, "POINTS", 2);
  ASSERT_EQ(points.size(), 6U);
  // no gravity, no contact: the spheres stay put (the engine may have re-ordered them)
  EXPECT_NEAR(std::abs(points[0]), 0.05, 1e-9);
  EXPECT_NEAR(points[0] + points[3], 0.0, 1e-9);
}

// A scene placed in another's frame (the DEM line's bulk end): every particle and wall point
// moved by the offset, nothing else changed.
TEST_F(DemVtkOutput, AnOffsetMovesEveryPointOfTheSeries) {
  Simulation sim(std::make_shared<Model>(model_with_mesh()));
  sim.add_sphere({Vec3(0.05, 0.01, 0.1), test::kRadius, 0});
  const Vec3 offset(-1.5, 0.02, 0.1);
  VtkSeriesWriter series(dir_);
  series.write(sim, offset);
  const std::vector<double> particle =
      section(read_text(dir_ / "particles_000000.vtk"), "POINTS", 1);
  ASSERT_EQ(particle.size(), 3U);
  EXPECT_NEAR(particle[0], 0.05 - 1.5, 1e-12);
  EXPECT_NEAR(particle[1], 0.01 + 0.02, 1e-12);
  EXPECT_NEAR(particle[2], 0.1 + 0.1, 1e-12);
  // The plate's second vertex (0.1, 0, 0), after the floor's 4 corners.
  const std::vector<double> walls = section(read_text(dir_ / "walls_000000.vtk"), "POINTS", 7);
  ASSERT_EQ(walls.size(), 21U);
  EXPECT_NEAR(walls[15], 0.1 - 1.5, 1e-12);
  EXPECT_NEAR(walls[16], 0.02, 1e-12);
  EXPECT_NEAR(walls[17], 0.1, 1e-12);
  for (int corner = 0; corner < 4; ++corner) EXPECT_NEAR(walls[corner * 3 + 2], 0.1, 1e-12);
}

TEST_F(DemVtkOutput, UnwritableDirectoryIsAClearError) {
  const std::filesystem::path file = dir_ / "not_a_dir";
  std::filesystem::create_directories(dir_);
  std::ofstream(file) << "x";
  try {
    VtkSeriesWriter series(file / "frames");
    FAIL() << "expected an error";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("not_a_dir"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace fl::dem
