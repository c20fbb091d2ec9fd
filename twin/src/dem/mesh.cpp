#include "fl/twin/dem/mesh.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <stdexcept>
#include <unordered_map>

namespace fl::dem {
namespace {

std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  const auto low = std::min(a, b);
  const auto high = std::max(a, b);
  return (static_cast<std::uint64_t>(low) << 32U) | high;
}

void append_count(std::string& text, std::size_t count, const char* what) {
  if (count == 0) return;
  if (!text.empty()) text += ", ";
  text += std::to_string(count) + " " + what + (count == 1 ? "" : "s");
}

// Ericson, Real-Time Collision Detection 5.1.5: closest point on triangle abc to p.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                          const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp);
  const double d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp);
  const double d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  }
  const double denominator = 1.0 / (va + vb + vc);
  return a + ab * (vb * denominator) + ac * (vc * denominator);
}

}  // namespace

std::string MeshTopology::describe() const {
  std::string text;
  append_count(text, boundary_edges, "boundary edge");
  append_count(text, non_manifold_edges, "non-manifold edge");
  append_count(text, misoriented_edges, "misoriented edge");
  append_count(text, degenerate_triangles, "degenerate triangle");
  append_count(text, out_of_range_indices, "out-of-range vertex index");
  if (edge_count == 0) text = text.empty() ? "no triangles" : "no triangles, " + text;
  return text.empty() ? "closed manifold" : text;
}

MeshTopology check_topology(const TriangleMesh& mesh) {
  // Per undirected edge: how often it is traversed low->high and high->low.
  struct EdgeUse {
    std::uint32_t forward = 0;
    std::uint32_t backward = 0;
  };
  MeshTopology topology;
  std::unordered_map<std::uint64_t, EdgeUse> edges;
  edges.reserve(mesh.triangles.size() * 2);
  const auto vertex_count = mesh.vertices.size();
  for (const auto& triangle : mesh.triangles) {
    if (std::any_of(triangle.begin(), triangle.end(),
                    [&](std::uint32_t index) { return index >= vertex_count; })) {
      ++topology.out_of_range_indices;
      continue;
    }
    if (triangle[0] == triangle[1] || triangle[1] == triangle[2] || triangle[0] == triangle[2]) {
      ++topology.degenerate_triangles;
      continue;
    }
    for (int corner = 0; corner < 3; ++corner) {
      const auto from = triangle[static_cast<std::size_t>(corner)];
      const auto to = triangle[static_cast<std::size_t>((corner + 1) % 3)];
      auto& use = edges[edge_key(from, to)];
      if (from < to) {
        ++use.forward;
      } else {
        ++use.backward;
      }
    }
  }
  topology.edge_count = edges.size();
  for (const auto& [key, use] : edges) {
    const auto total = use.forward + use.backward;
    if (total == 1) {
      ++topology.boundary_edges;
    } else if (total > 2) {
      ++topology.non_manifold_edges;
    } else if (use.forward != 1) {
      ++topology.misoriented_edges;
    }
  }
  return topology;
}

double signed_volume(const TriangleMesh& mesh) {
  double six_volume = 0.0;
  for (const auto& t : mesh.triangles) {
    const auto& a = mesh.vertices[t[0]];
    const auto& b = mesh.vertices[t[1]];
    const auto& c = mesh.vertices[t[2]];
    six_volume += a.dot(b.cross(c));
  }
  return six_volume / 6.0;
}

double surface_area(const TriangleMesh& mesh) {
  double twice_area = 0.0;
  for (const auto& t : mesh.triangles) {
    const auto& a = mesh.vertices[t[0]];
    twice_area += (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a).norm();
  }
  return 0.5 * twice_area;
}

Aabb bounding_box(const TriangleMesh& mesh) {
  Aabb box;
  if (mesh.vertices.empty()) return box;
  box.min = box.max = mesh.vertices.front();
  for (const auto& v : mesh.vertices) {
    box.min = box.min.cwiseMin(v);
    box.max = box.max.cwiseMax(v);
  }
  return box;
}

Eigen::Vector3d volume_centroid(const TriangleMesh& mesh) {
  // Each triangle and the origin span a tetrahedron with signed volume det/6 and centroid
  // (a + b + c) / 4. Subtracting the box centre first keeps the sums well conditioned.
  const Eigen::Vector3d reference = bounding_box(mesh).center();
  double six_volume = 0.0;
  Eigen::Vector3d weighted = Eigen::Vector3d::Zero();
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]] - reference;
    const Eigen::Vector3d b = mesh.vertices[t[1]] - reference;
    const Eigen::Vector3d c = mesh.vertices[t[2]] - reference;
    const double det = a.dot(b.cross(c));
    six_volume += det;
    weighted += det * (a + b + c);
  }
  if (six_volume == 0.0) throw std::invalid_argument("volume_centroid: mesh encloses no volume");
  return reference + weighted / (4.0 * six_volume);
}

bool is_closed_outward(const TriangleMesh& mesh) {
  return check_topology(mesh).closed_manifold() && signed_volume(mesh) > 0.0;
}

double winding_number(const TriangleMesh& mesh, const Eigen::Vector3d& point) {
  // Van Oosterom and Strackee (1983): tan(omega / 2) of the solid angle of one triangle.
  double total_solid_angle = 0.0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]] - point;
    const Eigen::Vector3d b = mesh.vertices[t[1]] - point;
    const Eigen::Vector3d c = mesh.vertices[t[2]] - point;
    const double la = a.norm();
    const double lb = b.norm();
    const double lc = c.norm();
    const double numerator = a.dot(b.cross(c));
    const double denominator = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    total_solid_angle += 2.0 * std::atan2(numerator, denominator);
  }
  return total_solid_angle / (4.0 * std::numbers::pi);
}

bool contains_point(const TriangleMesh& mesh, const Eigen::Vector3d& point) {
  return winding_number(mesh, point) > 0.5;
}

double distance_to_surface(const TriangleMesh& mesh, const Eigen::Vector3d& point) {
  double best_squared = std::numeric_limits<double>::infinity();
  for (const auto& t : mesh.triangles) {
    const auto closest = closest_point_on_triangle(point, mesh.vertices[t[0]], mesh.vertices[t[1]],
                                                   mesh.vertices[t[2]]);
    best_squared = std::min(best_squared, (closest - point).squaredNorm());
  }
  return std::sqrt(best_squared);
}

TriangleMesh translated(const TriangleMesh& mesh, const Eigen::Vector3d& offset) {
  TriangleMesh result = mesh;
  for (auto& v : result.vertices) v += offset;
  return result;
}

TriangleMesh flipped(const TriangleMesh& mesh) {
  TriangleMesh result = mesh;
  for (auto& t : result.triangles) std::swap(t[1], t[2]);
  return result;
}

TriangleMesh scaled(const TriangleMesh& mesh, const Eigen::Vector3d& factors) {
  if (!factors.allFinite() || (factors.array() == 0.0).any()) {
    throw std::invalid_argument("scaled: factors must be finite and non-zero");
  }
  TriangleMesh result = mesh;
  for (auto& v : result.vertices) v = v.cwiseProduct(factors);
  const bool reflection = factors.prod() < 0.0;
  return reflection ? flipped(result) : result;
}

TriangleMesh mirrored(const TriangleMesh& mesh, int axis) {
  if (axis < 0 || axis > 2) throw std::invalid_argument("mirrored: axis must be 0, 1 or 2");
  Eigen::Vector3d factors = Eigen::Vector3d::Ones();
  factors[axis] = -1.0;
  return scaled(mesh, factors);
}

TriangleMesh make_box(const Eigen::Vector3d& min, const Eigen::Vector3d& max) {
  TriangleMesh mesh;
  for (int corner = 0; corner < 8; ++corner) {
    mesh.vertices.emplace_back((corner & 1) != 0 ? max.x() : min.x(),
                               (corner & 2) != 0 ? max.y() : min.y(),
                               (corner & 4) != 0 ? max.z() : min.z());
  }
  // Two triangles per face, counter-clockwise seen from outside (corner bit 0 = x, 1 = y, 2 = z).
  mesh.triangles = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6},   // z = min, z = max
                    {0, 1, 4}, {1, 5, 4}, {2, 6, 3}, {3, 6, 7},   // y = min, y = max
                    {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};  // x = min, x = max
  return mesh;
}

TriangleMesh make_icosphere(double radius, int subdivisions) {
  if (!(radius > 0.0) || subdivisions < 0) {
    throw std::invalid_argument("make_icosphere: radius must be > 0 and subdivisions >= 0");
  }
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  TriangleMesh mesh;
  mesh.vertices = {{-1, phi, 0}, {1, phi, 0}, {-1, -phi, 0}, {1, -phi, 0},
                   {0, -1, phi}, {0, 1, phi}, {0, -1, -phi}, {0, 1, -phi},
                   {phi, 0, -1}, {phi, 0, 1}, {-phi, 0, -1}, {-phi, 0, 1}};
  for (auto& v : mesh.vertices) v.normalize();
  mesh.triangles = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                    {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                    {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                    {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::uint64_t, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto [it, inserted] =
          midpoints.try_emplace(edge_key(a, b), static_cast<std::uint32_t>(mesh.vertices.size()));
      if (inserted) {
        mesh.vertices.push_back((mesh.vertices[a] + mesh.vertices[b]).normalized());
      }
      return it->second;
    };
    std::vector<IndexedTriangle> finer;
    finer.reserve(mesh.triangles.size() * 4);
    for (const auto& t : mesh.triangles) {
      const auto ab = midpoint(t[0], t[1]);
      const auto bc = midpoint(t[1], t[2]);
      const auto ca = midpoint(t[2], t[0]);
      finer.push_back({t[0], ab, ca});
      finer.push_back({t[1], bc, ab});
      finer.push_back({t[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    mesh.triangles = std::move(finer);
  }
  for (auto& v : mesh.vertices) v *= radius;
  return mesh;
}

}  // namespace fl::dem
