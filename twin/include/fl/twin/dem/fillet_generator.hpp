// The fillet meta-particles of the thesis (section 3.3 and appendix B): a fillet-shaped closed
// mesh, scaled to the three size variants of table 3.1 and mirrored (six types), filled with a
// cubic raster of equal spheres of two alternating types that are bonded A-B only.
//
// No scanned fillet mesh exists in this project, so the base shape is made procedurally
// (make_fillet_mesh) and written to twin/assets/fillet_nominal.stl (millimetres) for viewing
// and for tools that want a file; a test keeps the file equal to the procedure.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <string>
#include <vector>

#include "fl/twin/dem/fillet_template.hpp"
#include "fl/twin/dem/mesh.hpp"

namespace fl::dem {

// --- Shape -------------------------------------------------------------------------------

// A loft of super-ellipse cross-sections along x. Station t runs 0 (thick end, -x) to 1 (tip,
// +x). Profiles are shares of the maximum; the final mesh is scaled to the bounding box
// length x width x thickness exactly and moved so its volume centroid is the origin.
struct FilletShapeParams {
  double length_m = 0.172;  // table 3.1 variant 2, the nominal fillet
  double width_m = 0.072;
  double thickness_m = 0.032;
  // Thickness along the length: largest at `thickest_at` (the line config assumes 0.3 from
  // the thick end), falling to these shares at the ends before the ends are rounded off.
  double thickest_at = 0.30;
  double thick_end_thickness = 0.75;
  double tip_thickness = 0.15;
  // Width along the length, the same way.
  double widest_at = 0.38;
  double thick_end_width = 0.65;
  double tip_width = 0.12;
  // Length shares over which the ends round off (elliptic caps): a blunt thick end, a short
  // rounded point at the tip.
  double thick_end_cap = 0.16;
  double tip_cap = 0.05;
  // Left/right asymmetry: the section centre sits `edge_bias` x half-width towards +y, so the
  // -y edge (at -(1 - bias) x half-width) is straighter than the +y edge ((1 + bias) x).
  double edge_bias = 0.45;
  // Share of the thickness above the side edges, and the super-ellipse exponents: a domed
  // top (skin side, exponent ~2) and a flat-ish bottom (bone side, larger exponent).
  double top_share = 0.70;
  double top_exponent = 2.2;
  double bottom_exponent = 5.0;
  // Mesh resolution: rings along the length (clustered towards the ends) and points per ring.
  int stations = 72;
  int ring_points = 48;
};

// Closed, outward mesh in metres; centroid at the origin; bounding box exactly the params'.
TriangleMesh make_fillet_mesh(const FilletShapeParams& params = {});

// Left fillets are the base shape (straighter edge at -y), right fillets its mirror y -> -y.
enum class FilletSide { kLeft, kRight };

struct FilletVariant {
  std::string name;  // "s144x72x40_left"
  double length_m = 0.0;
  double width_m = 0.0;
  double thickness_m = 0.0;
  FilletSide side = FilletSide::kLeft;
};

// Table 3.1 sizes (144x72x40, 172x72x32, 176x72x40 mm), each left and right, in that order.
std::vector<FilletVariant> thesis_fillet_variants();

// The base mesh scaled non-uniformly to the variant's bounding box, mirrored for the right
// side, centroid moved to the origin. `base` is any closed outward mesh (the procedural one or
// a loaded STL).
TriangleMesh make_variant_mesh(const TriangleMesh& base, const FilletVariant& variant);

// --- Sub-particle raster -----------------------------------------------------------------

// Which raster points become spheres.
enum class RasterInclusion {
  // Centre inside the mesh (the default, as the thesis' "simple raster"): the spheres'
  // lattice cells tile the mesh volume on average, so the count is close to volume / pitch^3,
  // and spheres stick out of the surface by up to one radius.
  kCentreInside,
  // The whole sphere inside the mesh, up to `sphere_protrusion_m`: the shape shrinks by about
  // one radius all round, which for 4 mm spheres in a 32 mm fillet loses about half of them.
  kSphereInside,
};

// Whether a pair exactly at the bond limit (distance == 2 x contact radius) is bonded.
enum class BondLimit {
  // Bond only where the contact radii overlap (distance < 2 x contact radius, less a relative
  // 1e-9 for rounding), as the thesis' generation rule says. At the default contact radius
  // r x sqrt(3), the body diagonals sit exactly at the limit and stay unbonded: each interior
  // sphere has 6 bonds, to its face neighbours. This is the thesis' intent: R x sqrt(3) is
  // the largest contact radius that does not yet add the diagonal "truss" bonds (figures 3.4
  // and 3.5), and table B.1's 6.928 mm is 4 x sqrt(3) = 6.9282 mm rounded down.
  kExclusive,
  // Also bond pairs at the limit (distance <= 2 x contact radius, plus a relative 1e-9): at
  // r x sqrt(3) the 8 body diagonals join the 6 face neighbours, 14 bonds per interior sphere.
  kInclusive,
};

struct FilletGeneratorOptions {
  // Thesis: 4 mm chosen from 3..7 mm to balance shape, roughness and cost.
  double sub_particle_radius_m = 0.004;
  // Contact radius = factor x radius; sqrt(3) is the two-type limit (6.928 mm at 4 mm).
  double contact_radius_factor = std::sqrt(3.0);
  BondLimit bond_limit = BondLimit::kExclusive;
  RasterInclusion inclusion = RasterInclusion::kCentreInside;
  double sphere_protrusion_m = 0.0;  // only for RasterInclusion::kSphereInside
  double density_kg_m3 = 940.0;      // thesis table B.1
  // The spheres fill pi/6 = 52 % of their raster cells, so spheres of the material density
  // weigh about half the mesh volume x density. Set to scale the particle density so the
  // fillet weighs mesh volume x density instead.
  bool match_mesh_mass = false;
  // A raster point sits at the mesh's volume centroid plus this offset (the raster phase);
  // point (i, j, k) is type A when i + j + k is even. Same mesh + options = same template.
  Eigen::Vector3d raster_offset_m = Eigen::Vector3d::Zero();
};

// Fills a closed outward mesh (metres). Spheres are ordered by raster index (x fastest, then
// y, then z); bonds i < j sorted. Throws std::invalid_argument for a mesh that is not closed
// and outward or for bad options, std::runtime_error when no raster point falls inside.
FilletTemplate generate_fillet_template(const TriangleMesh& mesh_m, const std::string& name,
                                        const FilletGeneratorOptions& options = {});

// The six thesis types from one base mesh, in thesis_fillet_variants() order. A right
// variant's raster offset is the left one's mirrored (y -> -y), so left and right templates
// are exact mirror images.
std::vector<FilletTemplate> generate_thesis_fillets(const TriangleMesh& base_mesh_m,
                                                    const FilletGeneratorOptions& options = {});

// The six thesis types from the nominal mesh (make_fillet_mesh()) at one sub-particle radius,
// the other options at their defaults: the templates the DEM plant and the bulk scene use.
std::vector<FilletTemplate> thesis_fillet_templates(double sub_particle_radius_m);

}  // namespace fl::dem
