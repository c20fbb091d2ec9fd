// Accuracy evaluation over rendered frames with realistic imaging spreads (render_support:
// exposure 0.75..1.25, lighting gradient up to 30 %, vignetting up to 20 %, motion blur up to
// 3 px, noise 1..5 grey levels, light direction up to ~22 degrees off vertical), random size,
// +-5 % scale, one of 8 shapes (the nominal and 7 random ones), hand, side, heading and
// position, and partial neighbours at the frame ends. Seeds 200000.. are disjoint from the
// 100000.. frames the side thresholds and shape corrections were read from.
//
// The frames are scored by AccuracyTally, the tally of `linectl vision eval`, against the
// renderer's truth (the partial neighbours are not wholly in view, so only the fillet or pair
// in the middle is scored).
//
// Targets of issue 4: angle error p95 < 2 degrees, hand and side >= 99.5 %, touching pairs
// flagged >= 99 %; position p95 < 3 mm is this suite's own (the centring tolerance is 20 mm).
// The figures are printed for docs/benchmarks.md (vision).
#include <gtest/gtest.h>

#include <cstdio>

#include "fl/vision/accuracy.hpp"
#include "fl/vision/record/twin_frame_source.hpp"
#include "render_support.hpp"

namespace fl::vision {
namespace {

using record::true_fillets;
using testing::camera_640;
using testing::camera_line;
using testing::exact_calibration;
using testing::nearest_fillet;
using testing::random_scene;
using testing::renderer;

// A single is matched with the nearest fillet blob within 40 mm (nearest_fillet's gate, which
// this suite has always used); a pair is flagged when every fillet blob within 100 mm of a
// member says "not singulated" (the tally's default group gate).
constexpr AccuracyOptions kOptions{.match_gate_mm = 40.0, .group_gate_mm = 100.0};

struct Figures {
  AccuracySummary summary;
  std::uint64_t singles = 0;    // scenes made with one fillet in the middle
  std::uint64_t pairs = 0;      // scenes made with a touching pair in the middle
  std::uint64_t confident = 0;  // detected singles with confidence >= 0.6 (the tally keeps none)
};

Figures evaluate(const render::RenderCamera& camera, std::uint64_t first_seed, int singles,
                 int pairs, bool bent = false) {
  FilletEstimator estimator(exact_calibration(camera));
  AccuracyTally tally(kOptions);
  Figures f;
  for (int i = 0; i < singles + pairs; ++i) {
    const bool pair = i >= singles;
    const auto scene = random_scene(camera, first_seed + static_cast<std::uint64_t>(i),
                                    {.touching_pair = pair,
                                     .neighbours = true,
                                     .realistic = true,
                                     .nominal_shape = false,
                                     .bent = bent});
    const auto frame = renderer().render(camera, scene);
    const auto result = estimator.estimate(frame.bgr, 0, 0);
    tally.add_frame(result, true_fillets(frame));
    if (pair) {
      ++f.pairs;
      continue;
    }
    ++f.singles;
    const auto& truth = frame.truth[0].fillet;
    const auto blob = nearest_fillet(result, {truth.x_mm, truth.y_mm}, kOptions.match_gate_mm);
    f.confident += blob && blob->estimate.confidence >= 0.6F ? 1 : 0;
  }
  f.summary = tally.summary();
  return f;
}

double percent(std::uint64_t part, std::uint64_t whole) {
  return 100.0 * static_cast<double>(part) / static_cast<double>(whole);
}

void report_and_check(const char* name, const Figures& f) {
  const AccuracySummary& s = f.summary;
  // The tally scored exactly the scenes made: every middle fillet and pair wholly in view.
  ASSERT_EQ(s.singles, f.singles);
  ASSERT_EQ(s.groups, f.pairs);
  const std::uint64_t hand_ok = s.hand[0][0] + s.hand[1][1];
  const std::uint64_t side_ok = s.side[0][0] + s.side[1][1];
  const std::uint64_t singulated_ok = s.detected - s.singles_flagged;
  const double n = static_cast<double>(s.singles);
  std::printf(
      "[%s] singles %llu: detected %.1f %%, thick end %.1f %%, hand %.1f %%, side %.1f %%, "
      "singulated %.1f %%, confidence >= 0.6 %.1f %%\n"
      "[%s] angle error median %.2f p95 %.2f max %.2f deg; position error median %.2f p95 %.2f "
      "max %.2f mm\n[%s] touching pairs %llu: flagged %.1f %%; phantoms %llu, frames not ok "
      "%llu\n",
      name, static_cast<unsigned long long>(s.singles), percent(s.detected, s.singles),
      percent(s.thick_end_right, s.singles), percent(hand_ok, s.singles),
      percent(side_ok, s.singles), percent(singulated_ok, s.singles),
      percent(f.confident, s.singles), name, s.angle_error_p50_deg, s.angle_error_p95_deg,
      s.angle_error_max_deg, s.position_error_p50_mm, s.position_error_p95_mm,
      s.position_error_max_mm, name, static_cast<unsigned long long>(s.groups),
      percent(s.groups_flagged, s.groups), static_cast<unsigned long long>(s.phantoms),
      static_cast<unsigned long long>(s.frames_not_ok));
  EXPECT_EQ(s.detected, s.singles);
  EXPECT_LT(s.angle_error_p95_deg, 2.0);
  EXPECT_LT(s.position_error_p95_mm, 3.0);
  EXPECT_GE(static_cast<double>(hand_ok), 0.995 * n);
  EXPECT_GE(static_cast<double>(side_ok), 0.995 * n);
  EXPECT_GE(static_cast<double>(singulated_ok), 0.995 * n);
  EXPECT_GE(static_cast<double>(s.groups_flagged), 0.99 * static_cast<double>(s.groups));
}

TEST(AccuracyEvaluation, Camera640x480) {
  report_and_check("640x480", evaluate(camera_640(), 200000, 300, 100));
}

// The line cameras as mounted: the 1280 x 1024 sensor binned 2 x 2 to 640 x 512. A full
// readout measures the same as its binned frame (FilletEstimator.HalvedInTheColourPassAs
// WhenResizedFirst with BinnedCamera.FrameIsTheFullReadoutAveragedInBlocks), so this also
// stands for 1280 x 1024 frames.
TEST(AccuracyEvaluation, LineCameraBinned640x512) {
  report_and_check("line 640x512 binned", evaluate(camera_line(), 210000, 60, 20));
}

// The twin's recordings and the CI replays use 320 x 240 (0.94 mm/px): coarser than the
// resolution the side features were fitted at, so this guards the texture band being set in
// millimetres, not pixels (at 0.7 and 2.5 px it called skin sides bone here).
TEST(AccuracyEvaluation, Camera320x240) {
  const auto camera =
      render::make_top_down_camera(320, 240, render::kLineCameraFieldAlongTravelMm / 320.0);
  report_and_check("320x240", evaluate(camera, 230000, 200, 40));
}

// Limp fillets lie bent on the belt: the DEM twin's line bends them by 2 / m in the median and
// up to 12 / m on the multilane (render_support, dem_line_bend_per_mm). The same targets hold
// with every fillet bent so, against the heading at the fillet's centroid (the DEM's rigid fit
// of its template), at the 640 x 480 camera and the 320 x 240 of the recordings.
TEST(AccuracyEvaluation, BentFillets640x480) {
  report_and_check("bent 640x480", evaluate(camera_640(), 240000, 200, 40, /*bent=*/true));
}

TEST(AccuracyEvaluation, BentFillets320x240) {
  const auto camera =
      render::make_top_down_camera(320, 240, render::kLineCameraFieldAlongTravelMm / 320.0);
  report_and_check("bent 320x240", evaluate(camera, 250000, 200, 40, /*bent=*/true));
}

// Issue 4: "touching or overlapping fillets detected as such". A fillet that slid partly onto
// its neighbour makes one blob whose outline can be nearly as convex as a single's, so it is
// scored on its own: every overlapping pair must come out "not singulated" (the touching
// pairs' 99 %).
TEST(AccuracyEvaluation, OverlappingPairsAreFlaggedNotSingulated) {
  const render::RenderCamera camera = camera_640();
  FilletEstimator estimator(exact_calibration(camera));
  AccuracyTally tally(kOptions);
  constexpr int kPairs = 100;
  for (int i = 0; i < kPairs; ++i) {
    const auto scene = random_scene(
        camera, 220000 + static_cast<std::uint64_t>(i),
        {.overlapping_pair = true, .neighbours = true, .realistic = true, .nominal_shape = false});
    const auto frame = renderer().render(camera, scene);
    tally.add_frame(estimator.estimate(frame.bgr, 0, 0), true_fillets(frame));
  }
  const AccuracySummary s = tally.summary();
  std::printf("[640x480] overlapping pairs %llu: flagged %.1f %%; phantoms %llu\n",
              static_cast<unsigned long long>(s.groups), percent(s.groups_flagged, s.groups),
              static_cast<unsigned long long>(s.phantoms));
  ASSERT_EQ(s.groups, static_cast<std::uint64_t>(kPairs));
  EXPECT_GE(static_cast<double>(s.groups_flagged), 0.99 * static_cast<double>(s.groups));
}

}  // namespace
}  // namespace fl::vision
