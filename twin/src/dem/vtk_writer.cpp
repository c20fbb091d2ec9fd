#include "fl/twin/dem/vtk_writer.hpp"

#include <array>
#include <cstdio>
#include <fstream>
#include <stdexcept>

namespace fl::dem {
namespace {

std::ofstream open_for_writing(const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) throw std::runtime_error("dem vtk: cannot write " + file.string());
  out.precision(9);
  return out;
}

void finish(std::ofstream& out, const std::filesystem::path& file) {
  out.flush();
  if (!out) throw std::runtime_error("dem vtk: write failed for " + file.string());
}

std::string frame_name(const char* prefix, std::size_t frame) {
  char name[48];
  std::snprintf(name, sizeof name, "%s_%06zu.vtk", prefix, frame);
  return name;
}

}  // namespace

void write_vtk_particles(const State& state, const std::filesystem::path& file,
                         const Vec3& offset_m) {
  std::ofstream out = open_for_writing(file);
  const std::size_t n = state.size();
  out << "# vtk DataFile Version 3.0\nfl dem particles t=" << state.time_s
      << " s\nASCII\nDATASET POLYDATA\nPOINTS " << n << " double\n";
  for (const Vec3& position : state.position_m) {
    const Vec3 x = position + offset_m;
    out << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
  }
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
  finish(out, file);
}

void write_vtk_walls(const Model& model, const State& state, const std::filesystem::path& file,
                     double plane_half_size_m, const Vec3& offset_m) {
  const ModelSpec& spec = model.spec();
  std::vector<Vec3> points;
  std::vector<std::size_t> polygon_sizes;
  std::vector<std::size_t> polygon_wall;
  for (std::size_t w = 0; w < spec.planes.size(); ++w) {
    const WallState& ws = state.walls[w];
    const Vec3 normal = (ws.rotation * spec.planes[w].normal).normalized();
    const Vec3 centre = ws.place(spec.planes[w].point_m);
    // two in-plane directions: any vector not parallel to the normal, crossed
    const Vec3 helper = std::abs(normal.z()) < 0.9 ? Vec3::UnitZ() : Vec3::UnitX();
    const Vec3 u = normal.cross(helper).normalized() * plane_half_size_m;
    const Vec3 v = normal.cross(u);
    const std::array<Vec3, 4> corners = {centre - u - v, centre + u - v, centre + u + v,
                                         centre - u + v};
    for (const Vec3& corner : corners) {
      points.push_back(corner);
    }
    polygon_sizes.push_back(4);
    polygon_wall.push_back(w);
  }
  for (std::size_t m = 0; m < spec.meshes.size(); ++m) {
    const std::size_t w = spec.planes.size() + m;
    for (const Triangle& triangle : spec.meshes[m].triangles) {
      for (const Vec3& vertex : triangle.vertices_m) points.push_back(state.walls[w].place(vertex));
      polygon_sizes.push_back(3);
      polygon_wall.push_back(w);
    }
  }
  std::ofstream out = open_for_writing(file);
  out << "# vtk DataFile Version 3.0\nfl dem walls t=" << state.time_s
      << " s\nASCII\nDATASET POLYDATA\nPOINTS " << points.size() << " double\n";
  for (const Vec3& point : points) {
    const Vec3 x = point + offset_m;
    out << x.x() << ' ' << x.y() << ' ' << x.z() << '\n';
  }
  std::size_t entries = 0;
  for (const std::size_t size : polygon_sizes) entries += size + 1;
  out << "POLYGONS " << polygon_sizes.size() << ' ' << entries << '\n';
  std::size_t next = 0;
  for (const std::size_t size : polygon_sizes) {
    out << size;
    for (std::size_t k = 0; k < size; ++k) out << ' ' << next++;
    out << '\n';
  }
  out << "CELL_DATA " << polygon_sizes.size() << "\nSCALARS wall int 1\nLOOKUP_TABLE default\n";
  for (const std::size_t w : polygon_wall) out << w << '\n';
  finish(out, file);
}

VtkSeriesWriter::VtkSeriesWriter(std::filesystem::path directory)
    : directory_(std::move(directory)) {
  std::error_code error;
  std::filesystem::create_directories(directory_, error);
  if (error) {
    throw std::runtime_error("dem vtk: cannot create " + directory_.string() + ": " +
                             error.message());
  }
}

void VtkSeriesWriter::write(const Simulation& simulation, const Vec3& offset_m) {
  const std::size_t frame = times_s_.size();
  write_vtk_particles(simulation.state(), directory_ / frame_name("particles", frame), offset_m);
  write_vtk_walls(simulation.model(), simulation.state(), directory_ / frame_name("walls", frame),
                  0.5, offset_m);
  times_s_.push_back(simulation.state().time_s);
  // ParaView collection: one DataSet per frame and part, rewritten whole (small).
  const std::filesystem::path pvd = collection_file();
  std::ofstream out = open_for_writing(pvd);
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (std::size_t k = 0; k < times_s_.size(); ++k) {
    out << "  <DataSet timestep=\"" << times_s_[k] << "\" part=\"0\" file=\""
        << frame_name("particles", k) << "\"/>\n";
    out << "  <DataSet timestep=\"" << times_s_[k] << "\" part=\"1\" file=\""
        << frame_name("walls", k) << "\"/>\n";
  }
  out << "</Collection>\n</VTKFile>\n";
  finish(out, pvd);
}

}  // namespace fl::dem
