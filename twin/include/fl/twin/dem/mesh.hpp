// Indexed triangle mesh for the DEM twin: the closed surface a fillet's sub-particle raster is
// cut from (thesis 3.3). The type is plain data; the free functions measure and transform it.
// Units are whatever the vertices are in (the fillet code uses metres, STL assets millimetres).
// A "closed" mesh here is a closed 2-manifold: every edge is shared by exactly two triangles
// that traverse it in opposite directions, so the surface has a consistent orientation and
// the divergence-theorem volume is meaningful. Outward orientation = counter-clockwise seen from
// outside = positive signed volume.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace fl::dem {

// Vertex indices of one triangle (the engine's wall triangle, model.hpp, holds coordinates).
using IndexedTriangle = std::array<std::uint32_t, 3>;

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<IndexedTriangle> triangles;  // vertex indices, counter-clockwise seen from outside
};

struct Aabb {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  Eigen::Vector3d size() const { return max - min; }
  Eigen::Vector3d center() const { return 0.5 * (min + max); }
};

// Result of the topology check. Counts are of undirected edges unless stated.
struct MeshTopology {
  std::size_t edge_count = 0;
  std::size_t boundary_edges = 0;        // used by one triangle only: a hole
  std::size_t non_manifold_edges = 0;    // used by three or more triangles
  std::size_t misoriented_edges = 0;     // two triangles traverse it in the same direction
  std::size_t degenerate_triangles = 0;  // repeated vertex index
  std::size_t out_of_range_indices = 0;  // triangle index >= vertex count
  // Closed, manifold and consistently oriented (says nothing about inward/outward).
  bool closed_manifold() const {
    return edge_count > 0 && boundary_edges == 0 && non_manifold_edges == 0 &&
           misoriented_edges == 0 && degenerate_triangles == 0 && out_of_range_indices == 0;
  }
  // One line for error messages, e.g. "3 boundary edges, 1 misoriented edge".
  std::string describe() const;
};

MeshTopology check_topology(const TriangleMesh& mesh);

// Divergence theorem over the triangles: sum of det(a, b, c) / 6. Positive for a closed mesh
// whose triangles face outward; meaningless for an open mesh.
double signed_volume(const TriangleMesh& mesh);
double surface_area(const TriangleMesh& mesh);
Aabb bounding_box(const TriangleMesh& mesh);  // of the vertices; zero box for an empty mesh
// Centroid of the enclosed solid (uniform density), from the same tetrahedron decomposition
// as signed_volume. Requires a closed mesh with non-zero volume.
Eigen::Vector3d volume_centroid(const TriangleMesh& mesh);
// Closed manifold and positive signed volume.
bool is_closed_outward(const TriangleMesh& mesh);

// Point-in-solid test by the generalized winding number (sum of the triangles' signed solid
// angles over 4 pi): 1 inside, 0 outside for a closed outward mesh, independent of any ray
// direction, so there are no ray-through-vertex or ray-along-edge ties to break. The threshold
// is 0.5; a point on the surface itself (within rounding) is classified either way.
double winding_number(const TriangleMesh& mesh, const Eigen::Vector3d& point);
bool contains_point(const TriangleMesh& mesh, const Eigen::Vector3d& point);
// Unsigned distance from the point to the nearest point of the surface.
double distance_to_surface(const TriangleMesh& mesh, const Eigen::Vector3d& point);

// Transforms return a new mesh. scaled() with an odd number of negative factors is a
// reflection and flips the triangle winding so an outward mesh stays outward.
TriangleMesh translated(const TriangleMesh& mesh, const Eigen::Vector3d& offset);
TriangleMesh scaled(const TriangleMesh& mesh, const Eigen::Vector3d& factors);
// Mirror in the plane through the origin normal to `axis` (0 = x, 1 = y, 2 = z).
TriangleMesh mirrored(const TriangleMesh& mesh, int axis);
// Reverses every triangle's winding (inward <-> outward).
TriangleMesh flipped(const TriangleMesh& mesh);

// Reference shapes for tests and for anything that needs a known solid.
TriangleMesh make_box(const Eigen::Vector3d& min, const Eigen::Vector3d& max);
// Icosahedron subdivided `subdivisions` times with vertices projected on the sphere.
TriangleMesh make_icosphere(double radius, int subdivisions);

}  // namespace fl::dem
