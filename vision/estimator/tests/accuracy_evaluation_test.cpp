// Accuracy evaluation over rendered frames with realistic imaging spreads (render_support:
// exposure 0.75..1.25, lighting gradient up to 30 %, vignetting up to 20 %, motion blur up to
// 3 px, noise 1..5 grey levels, light direction up to ~22 degrees off vertical), random size,
// +-5 % scale, one of 8 shapes (the nominal and 7 random ones), hand, side, heading and
// position, and partial neighbours at the frame ends. Seeds 200000.. are disjoint from the
// 100000.. frames the side thresholds and shape corrections were read from.
//
// Targets of issue 4: angle error p95 < 2 degrees, hand and side >= 99.5 %, touching pairs
// flagged >= 99 %; position p95 < 3 mm is this suite's own (the centring tolerance is 20 mm).
// The figures are printed for docs/benchmarks.md (vision).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numbers>

#include "render_support.hpp"

namespace fl::vision {
namespace {

using testing::camera_640;
using testing::camera_line;
using testing::exact_calibration;
using testing::nearest_fillet;
using testing::random_scene;
using testing::renderer;

double percentile(std::vector<double> values, double share) {
  if (values.empty()) return 0.0;
  std::sort(values.begin(), values.end());
  const auto index = static_cast<std::size_t>(share * static_cast<double>(values.size() - 1) + 0.5);
  return values[std::min(index, values.size() - 1)];
}

struct Figures {
  int singles = 0, detected = 0, hand_ok = 0, side_ok = 0, thick_end_ok = 0, singulated_ok = 0;
  int confident = 0;
  int pairs = 0, pairs_flagged = 0;
  std::vector<double> angle_error_deg, position_error_mm;
};

Figures evaluate(const render::RenderCamera& camera, std::uint64_t first_seed, int singles,
                 int pairs) {
  FilletEstimator estimator(exact_calibration(camera));
  Figures f;
  for (int i = 0; i < singles + pairs; ++i) {
    const bool pair = i >= singles;
    const auto scene = random_scene(
        camera, first_seed + static_cast<std::uint64_t>(i),
        {.touching_pair = pair, .neighbours = true, .realistic = true, .nominal_shape = false});
    const auto frame = renderer().render(camera, scene);
    const auto result = estimator.estimate(frame.bgr, 0, 0);
    if (pair) {
      ++f.pairs;
      // Flagged: every fillet blob within 100 mm of the pair's members is not singulated, and
      // there is at least one.
      bool seen = false, all_flagged = true;
      for (const auto& blob : result.blobs) {
        if (blob.status != BlobStatus::kFillet) continue;
        for (int m = 0; m < 2; ++m) {
          const auto& t = frame.truth[static_cast<std::size_t>(m)].fillet;
          if (std::hypot(blob.estimate.x_mm - t.x_mm, blob.estimate.y_mm - t.y_mm) < 100.0) {
            seen = true;
            all_flagged = all_flagged && !blob.estimate.singulated;
          }
        }
      }
      f.pairs_flagged += seen && all_flagged ? 1 : 0;
      continue;
    }
    ++f.singles;
    const auto& truth = frame.truth[0];
    const auto blob = nearest_fillet(result, {truth.fillet.x_mm, truth.fillet.y_mm});
    if (!blob) continue;
    ++f.detected;
    const auto& e = blob->estimate;
    const double error = testing::angle_difference_rad(e.angle_rad, truth.fillet.angle_rad);
    f.angle_error_deg.push_back(error * 180.0 / std::numbers::pi);
    f.position_error_mm.push_back(
        std::hypot(e.x_mm - truth.fillet.x_mm, e.y_mm - truth.fillet.y_mm));
    f.thick_end_ok += error < std::numbers::pi / 2 ? 1 : 0;
    f.hand_ok += e.hand == truth.fillet.hand ? 1 : 0;
    f.side_ok += e.side == truth.fillet.side ? 1 : 0;
    f.singulated_ok += e.singulated ? 1 : 0;
    f.confident += e.confidence >= 0.6F ? 1 : 0;
  }
  return f;
}

void report_and_check(const char* name, const Figures& f) {
  const double n = f.singles;
  std::printf(
      "[%s] singles %d: detected %.1f %%, thick end %.1f %%, hand %.1f %%, side %.1f %%, "
      "singulated %.1f %%, confidence >= 0.6 %.1f %%\n"
      "[%s] angle error median %.2f p95 %.2f max %.2f deg; position error median %.2f p95 %.2f "
      "max %.2f mm\n[%s] touching pairs %d: flagged %.1f %%\n",
      name, f.singles, 100.0 * f.detected / n, 100.0 * f.thick_end_ok / n, 100.0 * f.hand_ok / n,
      100.0 * f.side_ok / n, 100.0 * f.singulated_ok / n, 100.0 * f.confident / n, name,
      percentile(f.angle_error_deg, 0.5), percentile(f.angle_error_deg, 0.95),
      percentile(f.angle_error_deg, 1.0), percentile(f.position_error_mm, 0.5),
      percentile(f.position_error_mm, 0.95), percentile(f.position_error_mm, 1.0), name, f.pairs,
      100.0 * f.pairs_flagged / f.pairs);
  EXPECT_EQ(f.detected, f.singles);
  EXPECT_LT(percentile(f.angle_error_deg, 0.95), 2.0);
  EXPECT_LT(percentile(f.position_error_mm, 0.95), 3.0);
  EXPECT_GE(f.hand_ok, 0.995 * n);
  EXPECT_GE(f.side_ok, 0.995 * n);
  EXPECT_GE(f.singulated_ok, 0.995 * n);
  EXPECT_GE(f.pairs_flagged, 0.99 * f.pairs);
}

TEST(AccuracyEvaluation, Camera640x480) {
  report_and_check("640x480", evaluate(camera_640(), 200000, 300, 100));
}

TEST(AccuracyEvaluation, LineCamera1280x1024) {
  report_and_check("1280x1024", evaluate(camera_line(), 210000, 60, 20));
}

}  // namespace
}  // namespace fl::vision
