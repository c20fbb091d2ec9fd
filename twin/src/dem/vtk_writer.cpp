#include "fl/twin/dem/vtk_writer.hpp"

#include <fstream>
#include <stdexcept>

namespace fl::dem {

void write_vtk_particles(const State& state, const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) {
    throw std::runtime_error("dem vtk: cannot write " + file.string());
  }
  out.precision(9);
  const std::size_t n = state.size();
  out << "# vtk DataFile Version 3.0\nfl dem particles t=" << state.time_s
      << " s\nASCII\nDATASET POLYDATA\nPOINTS " << n << " double\n";
  for (const Vec3& x : state.position_m) out << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
  out << "VERTICES " << n << ' ' << 2 * n << '\n';
  for (std::size_t k = 0; k < n; ++k) out << "1 " << k << '\n';
  out << "POINT_DATA " << n << "\nSCALARS radius_m double 1\nLOOKUP_TABLE default\n";
  for (const double r : state.radius_m) out << r << '\n';
  out << "VECTORS velocity_m_per_s double\n";
  for (const Vec3& v : state.velocity_m_per_s) out << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  out << "SCALARS type int 1\nLOOKUP_TABLE default\n";
  for (const auto t : state.type) out << t << '\n';
  out << "SCALARS body int 1\nLOOKUP_TABLE default\n";
  for (const auto b : state.body) out << b << '\n';
  out << "SCALARS id int 1\nLOOKUP_TABLE default\n";
  for (const auto id : state.id) out << id << '\n';
  if (!out) {
    throw std::runtime_error("dem vtk: write failed for " + file.string());
  }
}

}  // namespace fl::dem
