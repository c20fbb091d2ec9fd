// The procedural fillet mesh, its table 3.1 variants and the STL asset made from it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <map>

#include "fl/twin/dem/fillet_generator.hpp"
#include "fl/twin/dem/stl.hpp"

namespace fl::dem {
namespace {

const std::filesystem::path kAsset =
    std::filesystem::path(FL_SOURCE_DIR) / "twin/assets/fillet_nominal.stl";

// One cross-section ring of the loft: every ring's vertices share one x exactly (same
// arithmetic per ring), so grouping by x recovers the rings.
struct Section {
  double y_min = 1e9, y_max = -1e9, z_min = 1e9, z_max = -1e9;
  std::vector<Eigen::Vector3d> points;
  double thickness() const { return z_max - z_min; }
};

std::map<double, Section> sections_of(const TriangleMesh& mesh) {
  std::map<double, Section> sections;
  for (const auto& v : mesh.vertices) {
    auto& s = sections[v.x()];
    s.y_min = std::min(s.y_min, v.y());
    s.y_max = std::max(s.y_max, v.y());
    s.z_min = std::min(s.z_min, v.z());
    s.z_max = std::max(s.z_max, v.z());
    s.points.push_back(v);
  }
  return sections;
}

// The section nearest to a length share from the thick end (-x).
const Section& section_at(const std::map<double, Section>& sections, double share) {
  const double x_min = sections.begin()->first;
  const double x_max = sections.rbegin()->first;
  const double x = x_min + share * (x_max - x_min);
  auto best = sections.begin();
  for (auto it = sections.begin(); it != sections.end(); ++it) {
    if (std::abs(it->first - x) < std::abs(best->first - x)) best = it;
  }
  return best->second;
}

// How far an edge (y_min or y_max of each section, 15 %..85 % of the length) bows away from
// the straight chord between its ends: a measure of the edge's curvature.
double edge_bow(const std::map<double, Section>& sections, bool plus_edge) {
  const auto edge = [&](const Section& s) { return plus_edge ? s.y_max : s.y_min; };
  const double x_min = sections.begin()->first;
  const double length = sections.rbegin()->first - x_min;
  const double x0 = x_min + 0.15 * length;
  const double x1 = x_min + 0.85 * length;
  const double y0 = edge(section_at(sections, 0.15));
  const double y1 = edge(section_at(sections, 0.85));
  double bow = 0.0;
  for (const auto& [x, s] : sections) {
    if (x < x0 || x > x1) continue;
    const double chord = y0 + (y1 - y0) * (x - x0) / (x1 - x0);
    bow = std::max(bow, std::abs(edge(s) - chord));
  }
  return bow;
}

TEST(FilletShape, NominalIsClosedOutwardWithTable31Box) {
  const auto mesh = make_fillet_mesh();
  EXPECT_TRUE(check_topology(mesh).closed_manifold()) << check_topology(mesh).describe();
  EXPECT_GT(signed_volume(mesh), 0.0);
  // Fitted to the box by construction; 1e-12 m covers rounding of the scale factors.
  const auto size = bounding_box(mesh).size();
  EXPECT_NEAR(size.x(), 0.172, 1e-12);
  EXPECT_NEAR(size.y(), 0.072, 1e-12);
  EXPECT_NEAR(size.z(), 0.032, 1e-12);
  EXPECT_LT(volume_centroid(mesh).norm(), 1e-12);  // body frame origin at the centroid
  // A fillet fills about half its bounding box (an ellipsoid fills pi/6 = 0.52): 0.4..0.6.
  const double fill = signed_volume(mesh) / size.prod();
  EXPECT_GT(fill, 0.4);
  EXPECT_LT(fill, 0.6);
}

TEST(FilletShape, ThickEndAtMinusXThickestAtThirtyPercentThinTip) {
  const auto sections = sections_of(make_fillet_mesh());
  const double length = sections.rbegin()->first - sections.begin()->first;
  auto thickest = sections.begin();
  for (auto it = sections.begin(); it != sections.end(); ++it) {
    if (it->second.thickness() > thickest->second.thickness()) thickest = it;
  }
  // Rings are ~1/70 of the length apart near 30 %: +-0.03 holds the nearest ring.
  EXPECT_NEAR((thickest->first - sections.begin()->first) / length, 0.30, 0.03);
  // Thick rounded end, thin tip: 10 % in from each end the thick end is over twice as thick
  // (profiles: 0.81 vs 0.34 of the peak).
  EXPECT_GT(section_at(sections, 0.10).thickness(), 2.0 * section_at(sections, 0.90).thickness());
  // The thick end is blunt: 5 % in it already has over half the peak thickness.
  EXPECT_GT(section_at(sections, 0.05).thickness(), 0.5 * thickest->second.thickness());
}

TEST(FilletShape, MinusYEdgeIsStraighterThanPlusYEdge) {
  const auto sections = sections_of(make_fillet_mesh());
  // The section centre sits 0.45 half-widths towards +y: the -y edge bows 0.55 / 1.45 = 0.38
  // as much as the +y edge. Below 0.5 is a clear asymmetry.
  EXPECT_LT(edge_bow(sections, false), 0.5 * edge_bow(sections, true));
}

TEST(FilletShape, FlatBottomDomedTop) {
  const auto sections = sections_of(make_fillet_mesh());
  const auto& s = section_at(sections, 0.30);
  // Share of the section's width over which the bottom (top) stays within 10 % of the
  // thickness of its lowest (highest) point. Bottom super-ellipse exponent 5: 0.97 of the
  // width; top exponent 2.2: 0.57.
  const double tolerance = 0.1 * s.thickness();
  double bottom_lo = 1e9, bottom_hi = -1e9, top_lo = 1e9, top_hi = -1e9;
  for (const auto& p : s.points) {
    if (p.z() <= s.z_min + tolerance) {
      bottom_lo = std::min(bottom_lo, p.y());
      bottom_hi = std::max(bottom_hi, p.y());
    }
    if (p.z() >= s.z_max - tolerance) {
      top_lo = std::min(top_lo, p.y());
      top_hi = std::max(top_hi, p.y());
    }
  }
  const double width = s.y_max - s.y_min;
  EXPECT_GT((bottom_hi - bottom_lo) / width, 0.85);
  EXPECT_LT((top_hi - top_lo) / width, 0.70);
  // More of the thickness is above the side edge (z of the widest point) than below it:
  // 0.7 vs 0.3 of the thickness by construction.
  const auto widest = std::max_element(s.points.begin(), s.points.end(),
                                       [](const auto& a, const auto& b) { return a.y() < b.y(); });
  EXPECT_GT(s.z_max - widest->z(), 1.5 * (widest->z() - s.z_min));
}

TEST(FilletShape, SixVariantsHaveTable31BoxesAndNames) {
  const auto base = make_fillet_mesh();
  const auto variants = thesis_fillet_variants();
  const std::vector<std::string> names = {"s144x72x40_left", "s144x72x40_right",
                                          "s172x72x32_left", "s172x72x32_right",
                                          "s176x72x40_left", "s176x72x40_right"};
  ASSERT_EQ(variants.size(), names.size());
  const double table31_mm[3][3] = {{144, 72, 40}, {172, 72, 32}, {176, 72, 40}};
  for (std::size_t n = 0; n < variants.size(); ++n) {
    const auto& variant = variants[n];
    EXPECT_EQ(variant.name, names[n]);
    EXPECT_EQ(variant.side, n % 2 == 0 ? FilletSide::kLeft : FilletSide::kRight);
    const auto mesh = make_variant_mesh(base, variant);
    EXPECT_TRUE(is_closed_outward(mesh)) << variant.name;
    const auto size = bounding_box(mesh).size();
    for (Eigen::Index axis = 0; axis < 3; ++axis) {
      EXPECT_NEAR(size[axis], table31_mm[n / 2][axis] * 1e-3, 1e-12) << variant.name;
    }
    EXPECT_LT(volume_centroid(mesh).norm(), 1e-12) << variant.name;
  }
}

TEST(FilletShape, RightVariantMirrorsLeft) {
  const auto base = make_fillet_mesh();
  const auto variants = thesis_fillet_variants();
  const auto left = make_variant_mesh(base, variants[2]);
  const auto right = make_variant_mesh(base, variants[3]);
  // Mirroring keeps the volume (to rounding of the reordered sum).
  EXPECT_NEAR(signed_volume(right), signed_volume(left), signed_volume(left) * 1e-12);
  // Vertex by vertex: right = left with y negated (centroid shifts are ~1e-18 m).
  ASSERT_EQ(left.vertices.size(), right.vertices.size());
  for (std::size_t n = 0; n < left.vertices.size(); ++n) {
    const auto& l = left.vertices[n];
    ASSERT_TRUE(right.vertices[n].isApprox(Eigen::Vector3d(l.x(), -l.y(), l.z()), 1e-12));
  }
  // The asymmetry flips: the straighter edge moves from -y to +y.
  const auto left_sections = sections_of(left);
  const auto right_sections = sections_of(right);
  EXPECT_LT(edge_bow(left_sections, false), 0.5 * edge_bow(left_sections, true));
  EXPECT_LT(edge_bow(right_sections, true), 0.5 * edge_bow(right_sections, false));
}

TEST(FilletShape, PointInMeshOnKnownPoints) {
  const auto mesh = make_fillet_mesh();
  EXPECT_TRUE(contains_point(mesh, Eigen::Vector3d::Zero()));  // centroid of a convex-ish body
  // Inside near the thick end and the tip, along the body's own axis.
  const auto box = bounding_box(mesh);
  EXPECT_TRUE(contains_point(mesh, Eigen::Vector3d(box.min.x() + 0.01, 0.0, 0.0)));
  EXPECT_FALSE(contains_point(mesh, Eigen::Vector3d(box.min.x() - 1e-4, 0.0, 0.0)));
  EXPECT_FALSE(contains_point(mesh, Eigen::Vector3d(0.0, 0.0, box.max.z() + 1e-4)));
  EXPECT_FALSE(contains_point(mesh, Eigen::Vector3d(0.0, 0.0, box.min.z() - 1e-4)));
  // The bounding box corners are outside a rounded body.
  EXPECT_FALSE(contains_point(mesh, box.min + Eigen::Vector3d::Constant(1e-3)));
  EXPECT_FALSE(contains_point(mesh, box.max - Eigen::Vector3d::Constant(1e-3)));
}

TEST(FilletShape, AssetEqualsProceduralMesh) {
  const auto mesh = make_fillet_mesh();
  if (std::getenv("FL_REGENERATE_ASSETS") != nullptr) {
    write_stl(kAsset, mesh, StlWriteOptions{StlFormat::kBinary, 1e3, "fillet_nominal mm"});
  }
  StlReadOptions millimetres;
  millimetres.scale = 1e-3;
  const auto asset = read_stl(kAsset, millimetres);
  ASSERT_EQ(asset.mesh.triangles.size(), mesh.triangles.size())
      << "regenerate with FL_REGENERATE_ASSETS=1 after changing the shape";
  ASSERT_EQ(asset.mesh.vertices.size(), mesh.vertices.size());
  // float32 millimetres: relative 6e-8 of at most 90 mm is 5e-6 mm = 5e-9 m; 1e-8 m bound.
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (std::size_t corner = 0; corner < 3; ++corner) {
      const auto& expected = mesh.vertices[mesh.triangles[t][corner]];
      const auto& actual = asset.mesh.vertices[asset.mesh.triangles[t][corner]];
      ASSERT_LT((expected - actual).norm(), 1e-8) << "facet " << t;
    }
  }
}

}  // namespace
}  // namespace fl::dem
