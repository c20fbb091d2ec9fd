// Fillet and checkerboard rendering (fl/twin/render/fillet_renderer.hpp).
#include "fl/twin/render/fillet_renderer.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "fl/twin/dem/fillet_generator.hpp"
#include "imaging.hpp"

namespace fl::render {
namespace {

constexpr double kHeightCellMm = 0.25;  // height-map resolution, finer than any camera pixel
// A silhouette counts as wholly in view when its outline keeps this clearance from the image
// edge. With 1 px the evaluation counted a fillet missed whose broad side lay under 3 px from
// the edge: its mask reached the edge and the estimator rightly called it cut (docs/vision.md).
constexpr double kFullyVisibleMarginPx = 3.0;
constexpr double kTextureCellMm = 0.5;  // material texture resolution
constexpr int kSizeVariants = 3;

// One (size, hand, side) top view: height of the top surface above the belt, in the fillet's
// frame (u thick end -> tip, v left), sampled at cell centres.
struct Sprite {
  cv::Mat1f height_mm;
  double min_u_mm = 0.0;  // local position of cell (0, 0)'s centre
  double min_v_mm = 0.0;
  double max_height_mm = 0.0;
  double area_mm2 = 0.0;
  cv::Point2d area_centroid_mm;
  double radius_mm = 0.0;               // bounding circle about the origin
  std::vector<cv::Point2d> outline_mm;  // silhouette boundary
  // Centres of the silhouette's cells on a coarser grid (kInsideStepCells): the area a bent
  // fillet covers and its centroid are summed over them.
  std::vector<cv::Point2d> inside_mm;
  cv::Size2d size_mm;
};
constexpr int kInsideStepCells = 4;  // 1 mm: area and centroid to well under a pixel

// FilletInstance::bend_per_mm: the fillet's straight frame (u along the axis, v to its left,
// scaled mm) laid along a circular arc tangent to the u axis at the origin. A point keeps its
// distance from the axis and its arc length along it.
class Bend {
 public:
  explicit Bend(double curvature_per_mm)
      // Under 1e-7 / mm (a radius of 10 km) the arc differs from the line by under 1 nm.
      : curvature_(std::abs(curvature_per_mm) < 1e-7 ? 0.0 : curvature_per_mm) {}
  [[nodiscard]] bool straight() const { return curvature_ == 0.0; }
  // Straight frame -> bent.
  [[nodiscard]] cv::Point2d bend(cv::Point2d straight_mm) const {
    if (straight()) return straight_mm;
    const double radius = 1.0 / curvature_;
    const double turn = straight_mm.x * curvature_;
    const double from_centre = radius - straight_mm.y;
    return {from_centre * std::sin(turn), radius - from_centre * std::cos(turn)};
  }
  // Bent -> straight frame; `turn_rad` is how far the axis has turned at that point.
  [[nodiscard]] cv::Point2d unbend(cv::Point2d bent_mm, double& turn_rad) const {
    if (straight()) {
      turn_rad = 0.0;
      return bent_mm;
    }
    const double radius = 1.0 / curvature_;
    // From the arc's centre; for a negative curvature the centre lies on the right, where
    // (radius - v) is negative.
    const double sign = curvature_ > 0.0 ? 1.0 : -1.0;
    const double a = sign * bent_mm.x;
    const double b = sign * (radius - bent_mm.y);
    turn_rad = std::atan2(a, b);
    return {radius * turn_rad, radius - sign * std::hypot(a, b)};
  }
  // Area scale of the map at a point of the straight frame (the arc's Jacobian).
  [[nodiscard]] double area_factor(double v_mm) const { return 1.0 - curvature_ * v_mm; }

 private:
  double curvature_;
};

// Bilinear height at local (u, v); 0 outside.
double sample_height(const Sprite& sprite, double u_mm, double v_mm) {
  const double fx = (u_mm - sprite.min_u_mm) / kHeightCellMm;
  const double fy = (v_mm - sprite.min_v_mm) / kHeightCellMm;
  if (fx < 0.0 || fy < 0.0) return 0.0;
  const int x0 = static_cast<int>(fx);
  const int y0 = static_cast<int>(fy);
  if (x0 + 1 >= sprite.height_mm.cols || y0 + 1 >= sprite.height_mm.rows) return 0.0;
  const double ax = fx - x0;
  const double ay = fy - y0;
  const float* r0 = sprite.height_mm.ptr<float>(y0);
  const float* r1 = sprite.height_mm.ptr<float>(y0 + 1);
  const double h00 = r0[x0];
  const double h01 = r0[x0 + 1];
  const double h10 = r1[x0];
  const double h11 = r1[x0 + 1];
  // Any zero corner means the silhouette edge: keep the edge sharp at the mesh outline by
  // taking the nearest cell there instead of blending towards zero.
  if (h00 <= 0.0 || h01 <= 0.0 || h10 <= 0.0 || h11 <= 0.0) {
    const float* nearest = ay < 0.5 ? r0 : r1;
    return nearest[ax < 0.5 ? x0 : x0 + 1];
  }
  return (1 - ay) * ((1 - ax) * h00 + ax * h01) + ay * ((1 - ax) * h10 + ax * h11);
}

Sprite make_sprite(const dem::TriangleMesh& mesh_m) {
  std::vector<cv::Point3d> points;
  points.reserve(mesh_m.vertices.size());
  double min_u = 1e9, max_u = -1e9, min_v = 1e9, max_v = -1e9, min_z = 1e9;
  for (const auto& vertex : mesh_m.vertices) {
    const cv::Point3d p(vertex.x() * 1e3, vertex.y() * 1e3, vertex.z() * 1e3);
    points.push_back(p);
    min_u = std::min(min_u, p.x);
    max_u = std::max(max_u, p.x);
    min_v = std::min(min_v, p.y);
    max_v = std::max(max_v, p.y);
    min_z = std::min(min_z, p.z);
  }
  Sprite sprite;
  sprite.min_u_mm = std::floor(min_u) - 1.0;
  sprite.min_v_mm = std::floor(min_v) - 1.0;
  const int cols = static_cast<int>(std::ceil((max_u - sprite.min_u_mm + 1.0) / kHeightCellMm)) + 1;
  const int rows = static_cast<int>(std::ceil((max_v - sprite.min_v_mm + 1.0) / kHeightCellMm)) + 1;
  sprite.height_mm = cv::Mat1f::zeros(rows, cols);
  // Top-down z-buffer: the highest triangle over each cell centre.
  for (const auto& triangle : mesh_m.triangles) {
    const cv::Point3d& a = points[triangle[0]];
    const cv::Point3d& b = points[triangle[1]];
    const cv::Point3d& c = points[triangle[2]];
    const double det = (b.y - c.y) * (a.x - c.x) + (c.x - b.x) * (a.y - c.y);
    if (std::abs(det) < 1e-12) continue;  // seen edge-on from above
    const auto to_col = [&](double u) { return (u - sprite.min_u_mm) / kHeightCellMm; };
    const auto to_row = [&](double v) { return (v - sprite.min_v_mm) / kHeightCellMm; };
    const int c0 = std::max(0, static_cast<int>(std::floor(to_col(std::min({a.x, b.x, c.x})))));
    const int c1 =
        std::min(cols - 1, static_cast<int>(std::ceil(to_col(std::max({a.x, b.x, c.x})))));
    const int r0 = std::max(0, static_cast<int>(std::floor(to_row(std::min({a.y, b.y, c.y})))));
    const int r1 =
        std::min(rows - 1, static_cast<int>(std::ceil(to_row(std::max({a.y, b.y, c.y})))));
    for (int row = r0; row <= r1; ++row) {
      const double v = sprite.min_v_mm + row * kHeightCellMm;
      for (int col = c0; col <= c1; ++col) {
        const double u = sprite.min_u_mm + col * kHeightCellMm;
        const double w0 = ((b.y - c.y) * (u - c.x) + (c.x - b.x) * (v - c.y)) / det;
        const double w1 = ((c.y - a.y) * (u - c.x) + (a.x - c.x) * (v - c.y)) / det;
        const double w2 = 1.0 - w0 - w1;
        if (w0 < -1e-9 || w1 < -1e-9 || w2 < -1e-9) continue;
        const double height = w0 * a.z + w1 * b.z + w2 * c.z - min_z;
        float& cell = sprite.height_mm(row, col);
        // A tiny floor keeps cells inside the silhouette non-zero where the surface meets
        // the belt at the rim.
        cell = std::max(cell, static_cast<float>(std::max(height, 0.05)));
      }
    }
  }
  double area_cells = 0.0, sum_u = 0.0, sum_v = 0.0, max_height = 0.0, radius2 = 0.0;
  for (int row = 0; row < rows; ++row) {
    for (int col = 0; col < cols; ++col) {
      const double h = sprite.height_mm(row, col);
      if (h <= 0.0) continue;
      const double u = sprite.min_u_mm + col * kHeightCellMm;
      const double v = sprite.min_v_mm + row * kHeightCellMm;
      area_cells += 1.0;
      sum_u += u;
      sum_v += v;
      max_height = std::max(max_height, h);
      radius2 = std::max(radius2, u * u + v * v);
    }
  }
  sprite.area_mm2 = area_cells * kHeightCellMm * kHeightCellMm;
  sprite.area_centroid_mm = {sum_u / area_cells, sum_v / area_cells};
  sprite.max_height_mm = max_height;
  sprite.radius_mm = std::sqrt(radius2) + kHeightCellMm;
  sprite.size_mm = {max_u - min_u, max_v - min_v};
  for (int row = kInsideStepCells / 2; row < rows; row += kInsideStepCells) {
    for (int col = kInsideStepCells / 2; col < cols; col += kInsideStepCells) {
      if (sprite.height_mm(row, col) > 0.0) {
        sprite.inside_mm.emplace_back(sprite.min_u_mm + col * kHeightCellMm,
                                      sprite.min_v_mm + row * kHeightCellMm);
      }
    }
  }

  cv::Mat mask;
  cv::compare(sprite.height_mm, 0.0, mask, cv::CMP_GT);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  for (const auto& contour : contours) {
    for (const auto& p : contour) {
      sprite.outline_mm.emplace_back(sprite.min_u_mm + p.x * kHeightCellMm,
                                     sprite.min_v_mm + p.y * kHeightCellMm);
    }
  }
  return sprite;
}

std::size_t sprite_index(int shape_variant, int size_variant, Hand hand, SideUp side) {
  return static_cast<std::size_t>(shape_variant * kSizeVariants + size_variant) * 4 +
         (hand == Hand::kRight ? 2 : 0) + (side == SideUp::kBone ? 1 : 0);
}

std::size_t sprite_index(const FilletInstance& fillet) {
  return sprite_index(fillet.shape_variant, fillet.size_variant, fillet.hand, fillet.side);
}

void check_instance(const FilletInstance& fillet, int shape_variants) {
  if (fillet.shape_variant < 0 || fillet.shape_variant >= shape_variants) {
    throw std::invalid_argument("FilletRenderer: shape_variant out of range");
  }
  if (fillet.size_variant < 0 || fillet.size_variant >= kSizeVariants || !(fillet.scale > 0.2) ||
      !(fillet.scale < 5.0) || (fillet.hand != Hand::kLeft && fillet.hand != Hand::kRight) ||
      (fillet.side != SideUp::kSkin && fillet.side != SideUp::kBone) ||
      !std::isfinite(fillet.x_mm) || !std::isfinite(fillet.y_mm) ||
      !std::isfinite(fillet.angle_rad)) {
    throw std::invalid_argument("FilletRenderer: fillet with an invalid size, scale, hand or side");
  }
  if (!(fillet.lift_mm >= 0.0) || !(fillet.lift_mm < 200.0)) {
    throw std::invalid_argument("FilletRenderer: lift_mm must be in [0, 200) mm");
  }
  if (!(std::abs(fillet.bend_per_mm) <= kMaxBendPerMm)) {
    throw std::invalid_argument("FilletRenderer: bend_per_mm must be finite and at most 1/50 mm");
  }
}

// A point of the sprite's frame (unscaled local mm) where the fillet lays it on the belt.
cv::Point2d local_to_belt(const FilletInstance& fillet, double cos_a, double sin_a,
                          cv::Point2d local) {
  const cv::Point2d laid =
      Bend(fillet.bend_per_mm).bend({local.x * fillet.scale, local.y * fillet.scale});
  return {fillet.x_mm + cos_a * laid.x - sin_a * laid.y,
          fillet.y_mm + sin_a * laid.x + cos_a * laid.y};
}

// The sprite-frame point (unscaled local mm) the fillet lays at a belt point, and how far its
// axis has turned there.
cv::Point2d belt_to_local(const FilletInstance& fillet, double cos_a, double sin_a,
                          cv::Point2d belt_mm, double& turn_rad) {
  const double dx = belt_mm.x - fillet.x_mm;
  const double dy = belt_mm.y - fillet.y_mm;
  const cv::Point2d straight =
      Bend(fillet.bend_per_mm)
          .unbend({cos_a * dx + sin_a * dy, -sin_a * dx + cos_a * dy}, turn_rad);
  return {straight.x / fillet.scale, straight.y / fillet.scale};
}

// Deterministic per-cell hash in [-1, 1]: belt grain that moves with the belt.
double hash_noise(std::int64_t i, std::int64_t j, std::uint64_t seed) {
  std::uint64_t h = seed ^ (static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4FULL);
  h ^= h >> 33U;
  h *= 0xFF51AFD7ED558CCDULL;
  h ^= h >> 33U;
  return static_cast<double>(h >> 11U) * 0x1.0p-52 - 1.0;
}

cv::Vec3d belt_colour_at(const BeltAppearance& belt, cv::Point2d p_mm, std::uint64_t seed) {
  constexpr double kGrainMm = 0.5;
  const double x = p_mm.x + belt.travel_offset_mm;
  const auto gi = static_cast<std::int64_t>(std::floor(x / kGrainMm));
  const auto gj = static_cast<std::int64_t>(std::floor(p_mm.y / kGrainMm));
  double factor = 1.0;
  if (belt.hinge_pitch_mm > 0.0) {
    const double phase = x - belt.hinge_pitch_mm * std::floor(x / belt.hinge_pitch_mm);
    if (phase < belt.hinge_width_mm) factor -= belt.hinge_darkening;
  }
  const double grain = belt.grain_amplitude * hash_noise(gi, gj, seed);
  return belt.colour_bgr * factor + cv::Vec3d::all(grain);
}

// Zero-mean, unit-std Gaussian noise blurred with the given sigmas (texture cells).
cv::Mat1f blurred_noise(cv::RNG& rng, cv::Size size, double sigma_u, double sigma_v) {
  cv::Mat1f noise(size);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), sigma_u, sigma_v, cv::BORDER_REFLECT);
  cv::Scalar mean, stddev;
  cv::meanStdDev(noise, mean, stddev);
  noise = (noise - mean[0]) / std::max(stddev[0], 1e-9);
  return noise;
}

double sample_texture(const cv::Mat1f& texture, double col, double row) {
  const int c = std::clamp(static_cast<int>(col), 0, texture.cols - 1);
  const int r = std::clamp(static_cast<int>(row), 0, texture.rows - 1);
  return texture(r, c);
}

// Everything a frame needs about one fillet: transforms, material and its textures.
struct PreparedFillet {
  const Sprite* sprite = nullptr;
  FilletInstance instance;
  double cos_a = 1.0, sin_a = 0.0;
  double reach_mm = 0.0;
  cv::Vec3d albedo_bgr;
  cv::Vec3d light_local;  // light direction in the fillet's frame
  bool skin = true;
  cv::Mat1f fibre, fat, mottle;  // texture cells over the sprite's extent (unscaled local mm)
  double fibre_cos = 1.0, fibre_sin = 0.0;
};

cv::Point2d outline_point_on_belt(const PreparedFillet& p, cv::Point2d local) {
  return local_to_belt(p.instance, p.cos_a, p.sin_a, local);
}

// Least distance between two closed outlines (0 where a vertex of one lies inside the other).
// Between two polygons that do not overlap it is reached at a vertex of one of them, so each
// one's vertices against the other's edges is exact. Two outlines that cross without a vertex
// inside the other give a gap under one outline step (0.5 mm) instead of 0.
double outline_gap_mm(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b) {
  if (a.size() < 3 || b.size() < 3) return std::numeric_limits<double>::infinity();
  double gap = std::numeric_limits<double>::infinity();
  for (const auto& [from, to] : {std::pair{&a, &b}, std::pair{&b, &a}}) {
    for (const cv::Point2f& vertex : *from) {
      // signed: positive inside, so a vertex inside the other outline gives no gap
      const double inside_mm = cv::pointPolygonTest(*to, vertex, true);
      gap = std::min(gap, std::max(0.0, -inside_mm));
      if (gap == 0.0) return 0.0;
    }
  }
  return gap;
}

// The appearance constants (BGR, 8-bit scale under the nominal light). Chosen to look like
// raw chicken breast: the skin side pale pink-beige, the bone side pinker (R - G larger).
constexpr std::array<double, 3> kSkinBgr{150.0, 168.0, 222.0};
constexpr std::array<double, 3> kBoneBgr{128.0, 132.0, 218.0};
constexpr std::array<double, 3> kFatBgr{196.0, 218.0, 238.0};
constexpr double kColourJitterPerChannel = 0.03;  // relative std per fillet and channel
constexpr double kBrightnessJitter = 0.05;        // relative std per fillet
constexpr double kFibreContrast = 0.10;           // relative albedo change per unit fibre noise
constexpr double kMottleContrast = 0.04;
constexpr double kFatStreakBlend = 0.6;
constexpr double kTranslucencyMm = 2.0;  // meat this thin lets half the belt colour through

PreparedFillet prepare(const Sprite& sprite, const FilletInstance& fillet, const Scene& scene,
                       std::size_t index) {
  PreparedFillet p;
  p.sprite = &sprite;
  p.instance = fillet;
  p.cos_a = std::cos(fillet.angle_rad);
  p.sin_a = std::sin(fillet.angle_rad);
  p.reach_mm = sprite.radius_mm * fillet.scale;
  if (!Bend(fillet.bend_per_mm).straight()) {
    // The farthest point of a bent silhouette from the pose lies on its outline.
    double reach2 = 0.0;
    for (const cv::Point2d& local : sprite.outline_mm) {
      const cv::Point2d d =
          local_to_belt(fillet, 1.0, 0.0, local) - cv::Point2d(fillet.x_mm, fillet.y_mm);
      reach2 = std::max(reach2, d.dot(d));
    }
    p.reach_mm = std::sqrt(reach2) + kHeightCellMm * fillet.scale;
  }
  p.skin = fillet.side == SideUp::kSkin;
  cv::RNG rng(scene.seed * 7919ULL + index * 104729ULL + 17ULL);
  const auto& base = p.skin ? kSkinBgr : kBoneBgr;
  const double brightness = 1.0 + kBrightnessJitter * rng.gaussian(1.0);
  for (int c = 0; c < 3; ++c) {
    p.albedo_bgr[c] = base[static_cast<std::size_t>(c)] * brightness *
                      (1.0 + kColourJitterPerChannel * rng.gaussian(1.0));
  }
  // Light into the fillet frame (rotate by -angle).
  cv::Vec3d light = scene.imaging.light_direction;
  light /= cv::norm(light);
  p.light_local = {p.cos_a * light[0] + p.sin_a * light[1],
                   -p.sin_a * light[0] + p.cos_a * light[1], light[2]};
  const cv::Size cells(
      static_cast<int>(std::ceil(sprite.height_mm.cols * kHeightCellMm / kTextureCellMm)),
      static_cast<int>(std::ceil(sprite.height_mm.rows * kHeightCellMm / kTextureCellMm)));
  // Fibres: streaks ~12 mm long, ~1 mm wide, along the fillet within +-15 degrees.
  p.fibre = blurred_noise(rng, cells, 6.0 / kTextureCellMm * 0.5, 0.6 / kTextureCellMm);
  // Fat / connective tissue: sparse whitish streaks, the top few percent of smoother noise.
  p.fat = blurred_noise(rng, cells, 10.0 / kTextureCellMm * 0.5, 1.0 / kTextureCellMm);
  p.mottle = blurred_noise(rng, cells, 4.0 / kTextureCellMm, 4.0 / kTextureCellMm);
  const double fibre_angle = rng.uniform(-0.26, 0.26);
  p.fibre_cos = std::cos(fibre_angle);
  p.fibre_sin = std::sin(fibre_angle);
  return p;
}

// Meat radiance at local (u, v) (unscaled mm) with height h_mm (scaled), given the belt under it,
// where the fillet's axis has turned by turn_rad from its heading (a bent fillet).
cv::Vec3d shade(const PreparedFillet& p, double u, double v, double h_scaled_mm, double turn_rad,
                const cv::Vec3d& belt_under) {
  const Sprite& s = *p.sprite;
  const double scale = p.instance.scale;
  // Normal from central differences of the (unscaled) height map; the height scales with the
  // fillet as its footprint does, so slopes stay the same.
  constexpr double kStep = 0.75;
  const double hu = sample_height(s, u + kStep, v) - sample_height(s, u - kStep, v);
  const double hv = sample_height(s, u, v + kStep) - sample_height(s, u, v - kStep);
  const double slope_u = -hu / (2 * kStep);
  const double slope_v = -hv / (2 * kStep);
  // The surface turns with the axis: the normal into the heading's frame, where the light is.
  const double cos_t = std::cos(turn_rad);
  const double sin_t = std::sin(turn_rad);
  cv::Vec3d normal(cos_t * slope_u - sin_t * slope_v, sin_t * slope_u + cos_t * slope_v, 1.0);
  normal /= cv::norm(normal);
  const cv::Vec3d& light = p.light_local;
  const double lambert = std::max(0.0, normal.dot(light)) / light[2];
  const double thickness_share = std::clamp(h_scaled_mm / (s.max_height_mm * scale), 0.0, 1.0);
  const double brightness = (0.55 + 0.45 * lambert) * (0.88 + 0.17 * thickness_share);

  const double tc = (u - s.min_u_mm) / kTextureCellMm;
  const double tr = (v - s.min_v_mm) / kTextureCellMm;
  cv::Vec3d albedo = p.albedo_bgr;
  if (p.skin) {
    albedo *= 1.0 + kMottleContrast * sample_texture(p.mottle, tc, tr);
  } else {
    // Fibres follow a direction turned by the fillet's fibre angle.
    const double mid_u = s.min_u_mm + 0.5 * s.height_mm.cols * kHeightCellMm;
    const double mid_v = s.min_v_mm + 0.5 * s.height_mm.rows * kHeightCellMm;
    const double fu = mid_u + p.fibre_cos * (u - mid_u) + p.fibre_sin * (v - mid_v);
    const double fv = mid_v - p.fibre_sin * (u - mid_u) + p.fibre_cos * (v - mid_v);
    albedo *= 1.0 + kFibreContrast * sample_texture(p.fibre, (fu - s.min_u_mm) / kTextureCellMm,
                                                    (fv - s.min_v_mm) / kTextureCellMm);
    const double fat_value = sample_texture(p.fat, tc, tr);
    const double fat_share = kFatStreakBlend * std::clamp((fat_value - 1.8) / 0.6, 0.0, 1.0);
    albedo = (1.0 - fat_share) * albedo + fat_share * cv::Vec3d(kFatBgr[0], kFatBgr[1], kFatBgr[2]);
  }
  cv::Vec3d colour = albedo * brightness;
  const double opacity = 1.0 - std::exp(-h_scaled_mm / kTranslucencyMm * std::numbers::ln2);
  colour = opacity * colour + (1.0 - opacity) * belt_under;

  // Blinn-Phong highlight, camera straight above: skin glossy and tight, bone weak and broad.
  cv::Vec3d half_vector = light + cv::Vec3d(0.0, 0.0, 1.0);
  half_vector /= cv::norm(half_vector);
  const double n_dot_h = std::max(0.0, normal.dot(half_vector));
  const double specular = p.skin ? 70.0 * std::pow(n_dot_h, 30.0) : 18.0 * std::pow(n_dot_h, 6.0);
  return colour + cv::Vec3d::all(specular * opacity);
}

}  // namespace

struct FilletRenderer::Sprites {
  int shape_variants = 1;
  std::vector<Sprite> by_index;
};

dem::FilletShapeParams random_shape(std::uint64_t seed) {
  cv::RNG rng(seed);
  dem::FilletShapeParams shape;
  shape.thickest_at = rng.uniform(0.25, 0.35);
  shape.thick_end_thickness = rng.uniform(0.65, 0.85);
  shape.tip_thickness = rng.uniform(0.10, 0.20);
  shape.widest_at = rng.uniform(0.32, 0.44);
  shape.thick_end_width = rng.uniform(0.55, 0.75);
  shape.tip_width = rng.uniform(0.08, 0.16);
  shape.thick_end_cap = rng.uniform(0.12, 0.20);
  shape.tip_cap = rng.uniform(0.03, 0.07);
  shape.edge_bias = rng.uniform(0.30, 0.60);
  shape.top_share = rng.uniform(0.62, 0.78);
  return shape;
}

FilletRenderer::FilletRenderer(int shape_variants, std::uint64_t shape_seed)
    : sprites_(std::make_unique<Sprites>()) {
  if (shape_variants < 1) throw std::invalid_argument("FilletRenderer: shape_variants < 1");
  sprites_->shape_variants = shape_variants;
  sprites_->by_index.resize(static_cast<std::size_t>(shape_variants * kSizeVariants * 4));
  const auto variants = dem::thesis_fillet_variants();
  for (int shape = 0; shape < shape_variants; ++shape) {
    const dem::TriangleMesh base = dem::make_fillet_mesh(
        shape == 0 ? dem::FilletShapeParams{}
                   : random_shape(shape_seed * 1000003ULL + static_cast<std::uint64_t>(shape)));
    for (const auto& variant : variants) {
      const int size = static_cast<int>(&variant - variants.data()) / 2;
      const Hand hand = variant.side == dem::FilletSide::kLeft ? Hand::kLeft : Hand::kRight;
      const dem::TriangleMesh skin_up = dem::make_variant_mesh(base, variant);
      // Bone side up: turned over about the long axis (a half turn: y -> -y and z -> -z).
      dem::TriangleMesh bone_up = skin_up;
      for (auto& vertex : bone_up.vertices) {
        vertex = Eigen::Vector3d(vertex.x(), -vertex.y(), -vertex.z());
      }
      sprites_->by_index[sprite_index(shape, size, hand, SideUp::kSkin)] = make_sprite(skin_up);
      sprites_->by_index[sprite_index(shape, size, hand, SideUp::kBone)] = make_sprite(bone_up);
    }
  }
}

int FilletRenderer::shape_variants() const { return sprites_->shape_variants; }

FilletRenderer::~FilletRenderer() = default;
FilletRenderer::FilletRenderer(FilletRenderer&&) noexcept = default;
FilletRenderer& FilletRenderer::operator=(FilletRenderer&&) noexcept = default;

double FilletRenderer::silhouette_area_mm2(int size_variant) const {
  if (size_variant < 0 || size_variant >= kSizeVariants) throw std::out_of_range("size_variant");
  return sprites_->by_index[sprite_index(0, size_variant, Hand::kLeft, SideUp::kSkin)].area_mm2;
}

cv::Size2d FilletRenderer::silhouette_size_mm(int size_variant) const {
  if (size_variant < 0 || size_variant >= kSizeVariants) throw std::out_of_range("size_variant");
  return sprites_->by_index[sprite_index(0, size_variant, Hand::kLeft, SideUp::kSkin)].size_mm;
}

RenderedFrame FilletRenderer::render(const RenderCamera& camera, const Scene& scene) const {
  if (camera.width_px <= 0 || camera.height_px <= 0 || scene.supersampling < 1) {
    throw std::invalid_argument("FilletRenderer::render: empty camera or supersampling < 1");
  }
  std::vector<PreparedFillet> prepared;
  prepared.reserve(scene.fillets.size());
  for (std::size_t i = 0; i < scene.fillets.size(); ++i) {
    const auto& fillet = scene.fillets[i];
    check_instance(fillet, sprites_->shape_variants);
    prepared.push_back(prepare(sprites_->by_index[sprite_index(fillet)], fillet, scene, i));
  }

  // Light is imaged on the sensor's pixels; apply_imaging bins them to the delivered image.
  const RenderCamera sensor = sensor_of(camera);
  const cv::Matx33d image_to_belt = sensor.belt_to_image.inv();
  const int n = scene.supersampling;
  cv::Mat radiance(sensor.height_px, sensor.width_px, CV_32FC3);
  for (int row = 0; row < sensor.height_px; ++row) {
    auto* out = radiance.ptr<cv::Vec3f>(row);
    for (int col = 0; col < sensor.width_px; ++col) {
      cv::Vec3d sum(0, 0, 0);
      for (int sy = 0; sy < n; ++sy) {
        for (int sx = 0; sx < n; ++sx) {
          const double pu = col - 0.5 + (sx + 0.5) / n;
          const double pv = row - 0.5 + (sy + 0.5) / n;
          const cv::Vec3d b = image_to_belt * cv::Vec3d(pu, pv, 1.0);
          const cv::Point2d belt_mm(b[0] / b[2], b[1] / b[2]);
          const cv::Vec3d belt = belt_colour_at(scene.belt, belt_mm, scene.seed);
          // The highest fillet surface over this point is the one seen: its own thickness
          // plus its lift where it lies on another. Shading uses the thickness.
          const PreparedFillet* top = nullptr;
          double top_surface = 0.0, top_height = 0.0, top_turn = 0.0;
          cv::Point2d top_local;
          for (const auto& p : prepared) {
            if (std::abs(belt_mm.x - p.instance.x_mm) > p.reach_mm ||
                std::abs(belt_mm.y - p.instance.y_mm) > p.reach_mm) {
              continue;
            }
            double turn = 0.0;
            const cv::Point2d local = belt_to_local(p.instance, p.cos_a, p.sin_a, belt_mm, turn);
            const double h = sample_height(*p.sprite, local.x, local.y) * p.instance.scale;
            const double surface = h > 0.0 ? h + p.instance.lift_mm : 0.0;
            if (surface > top_surface) {
              top_surface = surface;
              top_height = h;
              top = &p;
              top_local = local;
              top_turn = turn;
            }
          }
          sum += top == nullptr ? belt
                                : shade(*top, top_local.x, top_local.y, top_height, top_turn, belt);
        }
      }
      out[col] = cv::Vec3f(sum * (1.0 / (n * n)));
    }
  }

  RenderedFrame frame;
  frame.bgr = detail::apply_imaging(radiance, camera, scene.imaging, scene.seed);
  // Every silhouette's outline on the belt (double for the visibility test, float for OpenCV's
  // polygon distance), and each fillet's least gap to another: the gap is symmetric, so each
  // pair is measured once.
  std::vector<std::vector<cv::Point2d>> outlines_mm(prepared.size());
  std::vector<std::vector<cv::Point2f>> outlines_f_mm(prepared.size());
  for (std::size_t k = 0; k < prepared.size(); ++k) {
    for (const auto& local : prepared[k].sprite->outline_mm) {
      const cv::Point2d belt = outline_point_on_belt(prepared[k], local);
      outlines_mm[k].push_back(belt);
      outlines_f_mm[k].emplace_back(static_cast<float>(belt.x), static_cast<float>(belt.y));
    }
  }
  std::vector<double> gap_mm(prepared.size(), std::numeric_limits<double>::infinity());
  for (std::size_t k = 0; k < prepared.size(); ++k) {
    for (std::size_t other = k + 1; other < prepared.size(); ++other) {
      const double gap = outline_gap_mm(outlines_f_mm[k], outlines_f_mm[other]);
      gap_mm[k] = std::min(gap_mm[k], gap);
      gap_mm[other] = std::min(gap_mm[other], gap);
    }
  }
  for (std::size_t k = 0; k < prepared.size(); ++k) {
    const auto& p = prepared[k];
    FilletTruth truth;
    truth.fillet = p.instance;
    truth.gap_to_nearest_mm = gap_mm[k];
    truth.fully_visible = true;
    for (const cv::Point2d& belt : outlines_mm[k]) {
      const cv::Point2d px = belt_to_pixel(camera, belt);
      const double m = kFullyVisibleMarginPx;
      if (px.x < m || px.y < m || px.x > camera.width_px - 1.0 - m ||
          px.y > camera.height_px - 1.0 - m) {
        truth.fully_visible = false;
        break;
      }
    }
    truth.singulated =
        p.instance.group_id < 0 ||
        std::count_if(scene.fillets.begin(), scene.fillets.end(), [&](const FilletInstance& other) {
          return other.group_id == p.instance.group_id;
        }) == 1;
    truth.centre_px = belt_to_pixel(camera, {p.instance.x_mm, p.instance.y_mm});
    truth.silhouette_area_mm2 = p.sprite->area_mm2 * p.instance.scale * p.instance.scale;
    truth.silhouette_centroid_mm = outline_point_on_belt(p, p.sprite->area_centroid_mm);
    const Bend bend(p.instance.bend_per_mm);
    if (!bend.straight()) {
      // Bent, the area centroid is not the bent straight centroid (the arc moves the ends
      // sideways more than the middle): sum the cells where they lie, weighted by how the
      // arc stretches them.
      double weight = 0.0;
      cv::Point2d moment;
      for (const cv::Point2d& local : p.sprite->inside_mm) {
        const double w = bend.area_factor(local.y * p.instance.scale);
        weight += w;
        moment += w * outline_point_on_belt(p, local);
      }
      const double cell_mm2 = std::pow(kInsideStepCells * kHeightCellMm * p.instance.scale, 2);
      truth.silhouette_area_mm2 = weight * cell_mm2;
      truth.silhouette_centroid_mm = moment / weight;
    }
    frame.truth.push_back(truth);
  }
  return frame;
}

cv::Point2d checkerboard_corner_mm(const CheckerboardOnBelt& board, int i, int j) {
  const double c = std::cos(board.yaw_rad);
  const double s = std::sin(board.yaw_rad);
  const double bx = i * board.square_mm;
  const double by = j * board.square_mm;
  return {board.origin_x_mm + c * bx - s * by, board.origin_y_mm + s * bx + c * by};
}

cv::Mat FilletRenderer::render_checkerboard(const RenderCamera& camera,
                                            const CheckerboardOnBelt& board,
                                            const BeltAppearance& belt,
                                            const ImagingConditions& imaging,
                                            std::uint64_t seed) const {
  if (board.inner_corners_x < 2 || board.inner_corners_y < 2 || !(board.square_mm > 0.0)) {
    throw std::invalid_argument(
        "render_checkerboard: board needs >= 2 x 2 corners and squares > 0");
  }
  constexpr double kWhite = 225.0;
  constexpr double kBlack = 30.0;
  constexpr int kSamples = 4;  // per axis: anti-aliased square edges for sub-pixel corners
  const RenderCamera sensor = sensor_of(camera);
  const cv::Matx33d image_to_belt = sensor.belt_to_image.inv();
  const double c = std::cos(board.yaw_rad);
  const double s = std::sin(board.yaw_rad);
  const double sq = board.square_mm;
  // Squares span board coordinates [-sq, inner * sq] on each axis.
  const double min_x = -sq, max_x = board.inner_corners_x * sq;
  const double min_y = -sq, max_y = board.inner_corners_y * sq;
  cv::Mat radiance(sensor.height_px, sensor.width_px, CV_32FC3);
  for (int row = 0; row < sensor.height_px; ++row) {
    auto* out = radiance.ptr<cv::Vec3f>(row);
    for (int col = 0; col < sensor.width_px; ++col) {
      cv::Vec3d sum(0, 0, 0);
      for (int sy = 0; sy < kSamples; ++sy) {
        for (int sx = 0; sx < kSamples; ++sx) {
          const double pu = col - 0.5 + (sx + 0.5) / kSamples;
          const double pv = row - 0.5 + (sy + 0.5) / kSamples;
          const cv::Vec3d b = image_to_belt * cv::Vec3d(pu, pv, 1.0);
          const cv::Point2d p(b[0] / b[2], b[1] / b[2]);
          const double dx = p.x - board.origin_x_mm;
          const double dy = p.y - board.origin_y_mm;
          const double bx = c * dx + s * dy;
          const double by = -s * dx + c * dy;
          if (bx >= min_x && bx < max_x && by >= min_y && by < max_y) {
            const auto cell_x = static_cast<long>(std::floor(bx / sq)) + 1;
            const auto cell_y = static_cast<long>(std::floor(by / sq)) + 1;
            sum += cv::Vec3d::all((cell_x + cell_y) % 2 == 0 ? kBlack : kWhite);
          } else if (bx >= min_x - board.margin_mm && bx < max_x + board.margin_mm &&
                     by >= min_y - board.margin_mm && by < max_y + board.margin_mm) {
            sum += cv::Vec3d::all(kWhite);
          } else {
            sum += belt_colour_at(belt, p, seed);
          }
        }
      }
      out[col] = cv::Vec3f(sum * (1.0 / (kSamples * kSamples)));
    }
  }
  return detail::apply_imaging(radiance, camera, imaging, seed);
}

double FilletRenderer::silhouette_height_mm(const FilletInstance& fillet,
                                            cv::Point2d belt_mm) const {
  check_instance(fillet, sprites_->shape_variants);
  const Sprite& sprite = sprites_->by_index[sprite_index(fillet)];
  double turn_rad = 0.0;
  const cv::Point2d local = belt_to_local(fillet, std::cos(fillet.angle_rad),
                                          std::sin(fillet.angle_rad), belt_mm, turn_rad);
  return sample_height(sprite, local.x, local.y) * fillet.scale;
}

std::vector<cv::Point2d> FilletRenderer::silhouette_outline_mm(const FilletInstance& fillet) const {
  check_instance(fillet, sprites_->shape_variants);
  const Sprite& sprite = sprites_->by_index[sprite_index(fillet)];
  const double c = std::cos(fillet.angle_rad);
  const double s = std::sin(fillet.angle_rad);
  std::vector<cv::Point2d> outline;
  outline.reserve(sprite.outline_mm.size());
  for (const auto& local : sprite.outline_mm) outline.push_back(local_to_belt(fillet, c, s, local));
  return outline;
}

FilletInstance make_touching_partner(const FilletRenderer& renderer, FilletInstance& first,
                                     FilletInstance partner, bool to_the_left,
                                     double relative_angle_rad, double along_offset_mm,
                                     double overlap_mm, int group_id) {
  const double c = std::cos(first.angle_rad);
  const double s = std::sin(first.angle_rad);
  const double side = to_the_left ? 1.0 : -1.0;
  partner.angle_rad = first.angle_rad + relative_angle_rad;
  partner.group_id = group_id;
  first.group_id = group_id;
  const auto place = [&](double lateral_mm) {
    partner.x_mm = first.x_mm + c * along_offset_mm - s * side * lateral_mm;
    partner.y_mm = first.y_mm + s * along_offset_mm + c * side * lateral_mm;
  };
  const auto touching = [&] {
    for (const auto& point : renderer.silhouette_outline_mm(partner)) {
      if (renderer.silhouette_height_mm(first, point) > 0.0) return true;
    }
    return false;
  };
  // Come in from well apart (two widths) until the silhouettes first meet.
  constexpr double kStepMm = 0.25;
  double lateral = 2.5 * (first.scale + partner.scale) * 72.0;
  place(lateral);
  while (lateral > 0.0 && !touching()) {
    lateral -= kStepMm;
    place(lateral);
  }
  place(lateral - overlap_mm);
  return partner;
}

FilletInstance make_overlapping_partner(const FilletRenderer& renderer, FilletInstance& first,
                                        FilletInstance partner, bool to_the_left,
                                        double relative_angle_rad, double along_offset_mm,
                                        double overlap_mm, int group_id) {
  partner = make_touching_partner(renderer, first, partner, to_the_left, relative_angle_rad,
                                  along_offset_mm, overlap_mm, group_id);
  // It rests on the highest point of `first` under it: sample its silhouette's outline and a
  // grid inside its bounding box.
  const std::vector<cv::Point2d> outline = renderer.silhouette_outline_mm(partner);
  cv::Point2d low = outline.front();
  cv::Point2d high = outline.front();
  for (const cv::Point2d& point : outline) {
    low = {std::min(low.x, point.x), std::min(low.y, point.y)};
    high = {std::max(high.x, point.x), std::max(high.y, point.y)};
  }
  constexpr int kGrid = 40;
  double rest_mm = 0.0;
  for (int i = 0; i <= kGrid; ++i) {
    for (int j = 0; j <= kGrid; ++j) {
      const cv::Point2d point(low.x + (high.x - low.x) * i / kGrid,
                              low.y + (high.y - low.y) * j / kGrid);
      if (renderer.silhouette_height_mm(partner, point) > 0.0) {
        rest_mm = std::max(rest_mm, renderer.silhouette_height_mm(first, point));
      }
    }
  }
  partner.lift_mm = first.lift_mm + rest_mm;
  return partner;
}

}  // namespace fl::render
