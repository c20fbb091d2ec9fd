// The procedural fillet shape and the table 3.1 variants (fl/twin/dem/fillet_generator.hpp).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "fl/twin/dem/fillet_generator.hpp"

namespace fl::dem {
namespace {

// Signed power keeping the sign: the super-ellipse parametrisation.
double signed_power(double value, double exponent) {
  return std::copysign(std::pow(std::abs(value), exponent), value);
}

// Profile with a smooth maximum 1 at `peak`, `start_share` at t = 0 and `end_share` at t = 1.
// A quarter sine up to the peak, a quarter cosine down after it: the fall towards the tip is
// steepest at the tip itself, a tapering wedge.
double profile(double t, double peak, double start_share, double end_share) {
  constexpr double kQuarter = std::numbers::pi / 2.0;
  if (t <= peak) return start_share + (1.0 - start_share) * std::sin(kQuarter * t / peak);
  return end_share + (1.0 - end_share) * std::cos(kQuarter * (t - peak) / (1.0 - peak));
}

// Elliptic rounding of an end: 0 at the end, 1 from `cap` on (distance as length share).
double end_rounding(double distance, double cap) {
  if (distance >= cap) return 1.0;
  const double u = std::max(distance, 0.0) / cap;
  return std::sqrt(u * (2.0 - u));
}

void check_params(const FilletShapeParams& p) {
  const auto share = [](double value) { return value > 0.0 && value < 1.0; };
  if (!(p.length_m > 0.0 && p.width_m > 0.0 && p.thickness_m > 0.0) || !share(p.thickest_at) ||
      !share(p.widest_at) || !share(p.thick_end_cap) || !share(p.tip_cap) ||
      !(p.thick_end_cap + p.tip_cap < 1.0) || !share(p.top_share) || !(p.edge_bias >= 0.0) ||
      !(p.edge_bias < 1.0) || !(p.top_exponent > 0.0) || !(p.bottom_exponent > 0.0) ||
      !(p.thick_end_thickness > 0.0) || !(p.tip_thickness > 0.0) || !(p.thick_end_width > 0.0) ||
      !(p.tip_width > 0.0) || p.stations < 2 || p.ring_points < 4) {
    throw std::invalid_argument("FilletShapeParams out of range");
  }
}

TriangleMesh fit_to_box(const TriangleMesh& mesh, const Eigen::Vector3d& size) {
  const auto box = bounding_box(mesh);
  const auto centred = translated(mesh, -box.center());
  const auto fitted = scaled(centred, size.cwiseQuotient(box.size()));
  return translated(fitted, -volume_centroid(fitted));
}

}  // namespace

TriangleMesh make_fillet_mesh(const FilletShapeParams& p) {
  check_params(p);
  const auto stations = static_cast<std::uint32_t>(p.stations);
  const auto ring = static_cast<std::uint32_t>(p.ring_points);
  TriangleMesh mesh;
  mesh.vertices.reserve(stations * ring + 2);

  // Built in "share" units (length 1, width 1, thickness 1 at the peaks), then fitted.
  mesh.vertices.emplace_back(0.0, 0.0, 0.0);  // apex of the thick end
  for (std::uint32_t station = 1; station <= stations; ++station) {
    // Cosine spacing: rings crowd towards the ends, where the elliptic caps curve fastest.
    const double t = 0.5 * (1.0 - std::cos(std::numbers::pi * station / (stations + 1.0)));
    const double rounding = end_rounding(t, p.thick_end_cap) * end_rounding(1.0 - t, p.tip_cap);
    const double half_width =
        0.5 * profile(t, p.widest_at, p.thick_end_width, p.tip_width) * rounding;
    const double thickness =
        profile(t, p.thickest_at, p.thick_end_thickness, p.tip_thickness) * rounding;
    const double centre_y = p.edge_bias * half_width;
    const double top_height = p.top_share * thickness;
    const double bottom_depth = (1.0 - p.top_share) * thickness;
    for (std::uint32_t point = 0; point < ring; ++point) {
      // Counter-clockwise seen from +x: +y edge, top, -y edge, bottom.
      const double angle = 2.0 * std::numbers::pi * point / ring;
      const double c = std::cos(angle);
      const double s = std::sin(angle);
      const bool upper = s >= 0.0;
      const double exponent = 2.0 / (upper ? p.top_exponent : p.bottom_exponent);
      const double y = centre_y + half_width * signed_power(c, exponent);
      const double z =
          upper ? top_height * signed_power(s, exponent) : bottom_depth * signed_power(s, exponent);
      mesh.vertices.emplace_back(t, y, z);
    }
  }
  const auto tip_apex = static_cast<std::uint32_t>(mesh.vertices.size());
  mesh.vertices.emplace_back(1.0, 0.0, 0.0);

  const auto at = [&](std::uint32_t station, std::uint32_t point) {
    return 1 + station * ring + point % ring;
  };
  for (std::uint32_t point = 0; point < ring; ++point) {
    mesh.triangles.push_back({0, at(0, point + 1), at(0, point)});
  }
  for (std::uint32_t station = 0; station + 1 < stations; ++station) {
    for (std::uint32_t point = 0; point < ring; ++point) {
      const auto a0 = at(station, point);
      const auto a1 = at(station, point + 1);
      const auto b0 = at(station + 1, point);
      const auto b1 = at(station + 1, point + 1);
      mesh.triangles.push_back({a0, a1, b0});
      mesh.triangles.push_back({a1, b1, b0});
    }
  }
  for (std::uint32_t point = 0; point < ring; ++point) {
    mesh.triangles.push_back({tip_apex, at(stations - 1, point), at(stations - 1, point + 1)});
  }
  return fit_to_box(mesh, Eigen::Vector3d(p.length_m, p.width_m, p.thickness_m));
}

std::vector<FilletVariant> thesis_fillet_variants() {
  struct Size {
    int length_mm, width_mm, thickness_mm;
  };
  constexpr Size kTable31[] = {{144, 72, 40}, {172, 72, 32}, {176, 72, 40}};
  std::vector<FilletVariant> variants;
  for (const auto& size : kTable31) {
    for (const auto side : {FilletSide::kLeft, FilletSide::kRight}) {
      FilletVariant variant;
      variant.name = "s" + std::to_string(size.length_mm) + "x" + std::to_string(size.width_mm) +
                     "x" + std::to_string(size.thickness_mm) +
                     (side == FilletSide::kLeft ? "_left" : "_right");
      variant.length_m = size.length_mm * 1e-3;
      variant.width_m = size.width_mm * 1e-3;
      variant.thickness_m = size.thickness_mm * 1e-3;
      variant.side = side;
      variants.push_back(variant);
    }
  }
  return variants;
}

TriangleMesh make_variant_mesh(const TriangleMesh& base, const FilletVariant& variant) {
  if (!is_closed_outward(base)) {
    throw std::invalid_argument("make_variant_mesh: base mesh is not closed and outward");
  }
  auto mesh =
      fit_to_box(base, Eigen::Vector3d(variant.length_m, variant.width_m, variant.thickness_m));
  if (variant.side == FilletSide::kRight) mesh = mirrored(mesh, 1);
  return translated(mesh, -volume_centroid(mesh));
}

}  // namespace fl::dem
