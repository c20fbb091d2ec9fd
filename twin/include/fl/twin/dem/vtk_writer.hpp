// Runs as VTK files for ParaView: particles and walls as legacy PolyData (ASCII), and a series
// as a ParaView collection (.pvd) that opens every frame with its simulated time.
//
// Particles: points with radius, velocity, type, body and id arrays (use the Glyph filter with
// a sphere scaled by "radius_m"). Walls: the mesh walls' triangles where the walls are now
// (flip plates turned, roller lowered) with a "wall" index array; a plane wall as a square of
// `plane_half_size_m` around its point.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "fl/twin/dem/simulation.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {

// Both throw std::runtime_error naming the file when it cannot be written. `offset_m` moves
// every point: a scene of its own (the DEM line's bulk end) placed where it stands in another's
// frame, so that both series open together in ParaView.
void write_vtk_particles(const State& state, const std::filesystem::path& file,
                         const Vec3& offset_m = Vec3::Zero());
void write_vtk_walls(const Model& model, const State& state, const std::filesystem::path& file,
                     double plane_half_size_m = 0.5, const Vec3& offset_m = Vec3::Zero());

// Writes DIR/particles_NNNNNN.vtk and DIR/walls_NNNNNN.vtk per frame and rewrites DIR/run.pvd
// after each frame, so the collection is valid even if the run stops early.
class VtkSeriesWriter {
 public:
  explicit VtkSeriesWriter(std::filesystem::path directory);  // creates it
  void write(const Simulation& simulation, const Vec3& offset_m = Vec3::Zero());
  [[nodiscard]] std::size_t frames() const { return times_s_.size(); }
  [[nodiscard]] std::filesystem::path collection_file() const { return directory_ / "run.pvd"; }

 private:
  std::filesystem::path directory_;
  std::vector<double> times_s_;
};

}  // namespace fl::dem
