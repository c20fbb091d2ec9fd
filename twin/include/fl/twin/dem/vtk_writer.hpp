// Particles as a VTK legacy PolyData file (ASCII) for ParaView: points with radius, velocity,
// type, body and id arrays (use the Glyph filter with a sphere scaled by "radius_m").
#pragma once

#include <filesystem>

#include "fl/twin/dem/state.hpp"

namespace fl::dem {

// Throws std::runtime_error when the file cannot be written.
void write_vtk_particles(const State& state, const std::filesystem::path& file);

}  // namespace fl::dem
