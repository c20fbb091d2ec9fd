// The estimator on rendered frames: pose, thick end, hand, side and singulation on clean and
// disturbed frames. Tolerances: the 640 x 480 camera sees 0.47 mm per pixel; a 170 mm fillet's
// axis from silhouette moments is good to a fraction of a degree, and the shape model's
// corrections (axis bias, centroid offset) are fitted on the nominal mesh, so clean nominal
// fillets must come out within 1.5 mm and 1.5 degrees (a few pixels and well inside the line's
// 5 degree placement tolerance).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <opencv2/imgproc.hpp>
#include <string>

#include "render_support.hpp"

namespace fl::vision {
namespace {

using testing::angle_difference_rad;
using testing::camera_640;
using testing::camera_line;
using testing::exact_calibration;
using testing::nearest_fillet;
using testing::renderer;

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kCleanPositionToleranceMm = 1.5;
constexpr double kCleanAngleToleranceRad = 1.5 * kDeg;

render::Scene one_fillet(double x_mm, double y_mm, double angle_rad, Hand hand, SideUp side,
                         int size_variant = 1) {
  render::Scene scene;
  render::FilletInstance fillet;
  fillet.x_mm = x_mm;
  fillet.y_mm = y_mm;
  fillet.angle_rad = angle_rad;
  fillet.hand = hand;
  fillet.side = side;
  fillet.size_variant = size_variant;
  scene.fillets = {fillet};
  return scene;
}

void expect_matches(const FrameResult& result, const render::FilletTruth& truth,
                    double position_tolerance_mm, double angle_tolerance_rad) {
  ASSERT_EQ(result.status, FrameStatus::kOk) << result.message;
  const auto blob = nearest_fillet(result, {truth.fillet.x_mm, truth.fillet.y_mm});
  ASSERT_TRUE(blob.has_value()) << "no fillet near the truth";
  const FilletEstimate& e = blob->estimate;
  EXPECT_NEAR(e.x_mm, truth.fillet.x_mm, position_tolerance_mm);
  EXPECT_NEAR(e.y_mm, truth.fillet.y_mm, position_tolerance_mm);
  EXPECT_LT(angle_difference_rad(e.angle_rad, truth.fillet.angle_rad), angle_tolerance_rad)
      << "estimated " << e.angle_rad << " truth " << truth.fillet.angle_rad;
  EXPECT_GT(e.angle_rad, -std::numbers::pi);
  EXPECT_LE(e.angle_rad, std::numbers::pi);
  EXPECT_EQ(e.hand, truth.fillet.hand);
  EXPECT_EQ(e.side, truth.fillet.side);
  EXPECT_TRUE(e.singulated);
  EXPECT_GE(e.confidence, 0.6F);  // line.yaml's min_confidence: a clean frame must pass it
}

// Full circle in 10 degree steps, every hand and side: the thick end is found (an error below
// 90 degrees) and the angle within 1.5 degrees at every heading.
TEST(FilletEstimator, CleanSweepOverTheFullCircle) {
  const auto camera = camera_640();
  FilletEstimator estimator(exact_calibration(camera));
  for (const Hand hand : {Hand::kLeft, Hand::kRight}) {
    for (const SideUp side : {SideUp::kSkin, SideUp::kBone}) {
      for (int degrees = 0; degrees < 360; degrees += 10) {
        SCOPED_TRACE("hand " + std::to_string(static_cast<int>(hand)) + " side " +
                     std::to_string(static_cast<int>(side)) + " angle " + std::to_string(degrees));
        const auto frame = renderer().render(
            camera, one_fillet(6.0, -4.0, std::remainder(degrees * kDeg, 2 * std::numbers::pi),
                               hand, side));
        expect_matches(estimator.estimate(frame.bgr, 0, 0), frame.truth[0],
                       kCleanPositionToleranceMm, kCleanAngleToleranceRad);
      }
    }
  }
}

// Every table 3.1 size at the line cameras: binned 2 x 2 to 640 x 512 as mounted (measured as
// delivered), and the sensor read out in full at 1280 x 1024 (halved to the same working scale).
TEST(FilletEstimator, LineCameraResolutionAllSizes) {
  for (const bool binned : {true, false}) {
    const auto camera = binned ? camera_line() : testing::camera_line_full_readout();
    SCOPED_TRACE(binned ? "binned 640 x 512" : "full readout 1280 x 1024");
    FilletEstimator estimator(exact_calibration(camera));
    EXPECT_EQ(estimator.downscale_factor(), binned ? 1 : 2);  // 0.47 mm/px working either way
    for (int size = 0; size < 3; ++size) {
      const auto frame = renderer().render(
          camera, one_fillet(-20.0, 10.0, 2.5 - size, size % 2 ? Hand::kLeft : Hand::kRight,
                             size == 1 ? SideUp::kBone : SideUp::kSkin, size));
      expect_matches(estimator.estimate(frame.bgr, 0, 0), frame.truth[0], kCleanPositionToleranceMm,
                     kCleanAngleToleranceRad);
    }
  }
}

// The line camera's frames are halved in the colour pass, straight into planes; a frame of
// odd size, or one reduced by another factor, goes through cv::resize and the interleaved
// working image. The first must give what the second gives on the same working pixels: the
// same frame area-averaged by cv::resize and measured at that size with the calibration of
// its pixels (the full frame's times the halving's pixel map, the product the estimator forms
// itself). Outlines must agree to the bit; the rest to relative 1e-12: the two calibrations
// round the millimetres per pixel, and so the texture band's sigmas in pixels, apart in the
// last bits. Green and red read from the wrong place would move redness and side score by
// whole per cent.
TEST(FilletEstimator, HalvedInTheColourPassAsWhenResizedFirst) {
  const auto camera = testing::camera_line_full_readout();
  const BeltCalibration full_calibration = exact_calibration(camera);
  FilletEstimator halving(full_calibration);
  ASSERT_EQ(halving.downscale_factor(), 2);
  BeltCalibration half_calibration = full_calibration;
  half_calibration.image_width_px = camera.width_px / 2;
  half_calibration.image_height_px = camera.height_px / 2;
  half_calibration.image_to_belt =
      full_calibration.image_to_belt * cv::Matx33d(2, 0, 0.5, 0, 2, 0.5, 0, 0, 1);
  FilletEstimator resized(half_calibration);
  ASSERT_EQ(resized.downscale_factor(), 1);
  const auto near = [](double a, double b) {
    return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)});
  };
  // Singles, touching pairs and bent fillets with the evaluation's lighting and noise: the
  // colour means (redness, side score) and the gap check all read the planes.
  for (std::uint64_t seed = 0; seed < 12; ++seed) {
    testing::RandomSceneOptions options;
    options.touching_pair = seed % 3 == 1;
    options.bent = seed % 3 == 2;
    const auto frame =
        renderer().render(camera, testing::random_scene(camera, 930000 + seed, options)).bgr;
    cv::Mat half_frame;
    cv::resize(frame, half_frame, cv::Size(frame.cols / 2, frame.rows / 2), 0, 0, cv::INTER_AREA);
    const FrameResult a = halving.estimate(frame, 0, 1);
    const FrameResult b = resized.estimate(half_frame, 0, 1);
    SCOPED_TRACE("seed " + std::to_string(seed));
    ASSERT_EQ(a.status, b.status);
    ASSERT_EQ(a.blobs.size(), b.blobs.size());
    for (std::size_t i = 0; i < a.blobs.size(); ++i) {
      const BlobResult& x = a.blobs[i];
      const BlobResult& y = b.blobs[i];
      EXPECT_EQ(x.status, y.status) << "blob " << i;
      EXPECT_EQ(x.features.centroid_px, y.features.centroid_px) << "blob " << i;
      EXPECT_EQ(x.features.solidity, y.features.solidity) << "blob " << i;
      EXPECT_TRUE(near(x.features.redness, y.features.redness)) << "blob " << i;
      EXPECT_TRUE(near(x.features.texture, y.features.texture)) << "blob " << i;
      EXPECT_TRUE(near(x.features.side_score, y.features.side_score)) << "blob " << i;
      EXPECT_EQ(x.features.touches_other_blob, y.features.touches_other_blob) << "blob " << i;
      EXPECT_TRUE(near(x.features.area_mm2, y.features.area_mm2)) << "blob " << i;
      EXPECT_TRUE(near(x.estimate.x_mm, y.estimate.x_mm)) << "blob " << i;
      EXPECT_TRUE(near(x.estimate.y_mm, y.estimate.y_mm)) << "blob " << i;
      EXPECT_TRUE(near(x.estimate.angle_rad, y.estimate.angle_rad)) << "blob " << i;
      EXPECT_EQ(x.estimate.hand, y.estimate.hand) << "blob " << i;
      EXPECT_EQ(x.estimate.side, y.estimate.side) << "blob " << i;
      EXPECT_EQ(x.estimate.singulated, y.estimate.singulated) << "blob " << i;
    }
  }
}

// Lighting and noise well beyond the evaluation's spread, one at a time: still right, within
// 2 mm and 2 degrees (noise and blur shift edge pixels by a fraction of a pixel).
TEST(FilletEstimator, RobustToLightingAndNoise) {
  const auto camera = camera_640();
  FilletEstimator estimator(exact_calibration(camera));
  std::vector<render::ImagingConditions> conditions(7);
  conditions[0].exposure_gain = 0.55;
  conditions[1].exposure_gain = 1.4;
  conditions[2].lighting_gradient = 0.5;
  conditions[2].lighting_gradient_direction_rad = 0.7;
  conditions[3].vignetting = 0.35;
  conditions[4].motion_blur_px = 6.0;
  conditions[5].noise_sigma = 10.0;
  conditions[6].light_direction = {0.6, -0.5, 1.0};
  for (std::size_t i = 0; i < conditions.size(); ++i) {
    SCOPED_TRACE("condition " + std::to_string(i));
    auto scene = one_fillet(-10.0, 8.0, -2.2, i % 2 ? Hand::kLeft : Hand::kRight,
                            i % 3 ? SideUp::kSkin : SideUp::kBone);
    scene.imaging = conditions[i];
    scene.seed = 40 + i;
    const auto frame = renderer().render(camera, scene);
    expect_matches(estimator.estimate(frame.bgr, 0, 0), frame.truth[0], 2.0, 2.0 * kDeg);
  }
}

// Touching pairs (side by side, same way or head to tail, contact overlap 0.5 .. 3 mm) are one
// blob, or two blobs closer than the gap: every member is reported not singulated, with
// unknown hand and side.
// Every fillet blob of 20 random scenes with a pair in the middle (no neighbours) says "not
// singulated", and claims no hand or side: a pair's outline tells neither.
void expect_every_pair_flagged(std::uint64_t first_seed,
                               const testing::RandomSceneOptions& options) {
  const auto camera = camera_640();
  FilletEstimator estimator(exact_calibration(camera));
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto scene = testing::random_scene(camera, first_seed + seed, options);
    ASSERT_EQ(scene.fillets.size(), 2U);
    const auto frame = renderer().render(camera, scene);
    const auto result = estimator.estimate(frame.bgr, 0, 0);
    ASSERT_EQ(result.status, FrameStatus::kOk);
    int fillet_blobs = 0;
    for (const auto& blob : result.blobs) {
      if (blob.status != BlobStatus::kFillet) continue;
      ++fillet_blobs;
      EXPECT_FALSE(blob.estimate.singulated) << "area " << blob.features.area_mm2;
      EXPECT_EQ(blob.estimate.hand, Hand::kUnknown);
      EXPECT_EQ(blob.estimate.side, SideUp::kUnknown);
    }
    EXPECT_GE(fillet_blobs, 1);
  }
}

TEST(FilletEstimator, TouchingPairsAreFlagged) {
  expect_every_pair_flagged(
      300000,
      {.touching_pair = true, .neighbours = false, .realistic = true, .nominal_shape = false});
}

TEST(FilletEstimator, OverlappingPairsAreFlagged) {
  expect_every_pair_flagged(
      310000,
      {.overlapping_pair = true, .neighbours = false, .realistic = true, .nominal_shape = false});
}

// The renderer's truth gives each fillet its least gap to another, so that an evaluation can
// tell a pair closer than the estimator's least gap (reported not singulated by design) from a
// single. A left fillet and its mirror image (the right fillet) across a line parallel to the
// travel are nearest at their outermost points: the gap is twice the distance from the left
// fillet's outermost point to the line, whatever the outline's shape.
TEST(FilletRenderer, TruthGivesTheGapBetweenSilhouettes) {
  const auto camera = camera_640();
  render::FilletInstance left;
  left.x_mm = 10.0;
  left.y_mm = -40.0;
  left.hand = Hand::kLeft;
  double outermost_y_mm = -1e9;
  for (const cv::Point2d& point : renderer().silhouette_outline_mm(left)) {
    outermost_y_mm = std::max(outermost_y_mm, point.y);
  }
  constexpr double kGapMm = 3.0;  // under the estimator's least gap (4 mm): the case that matters
  const double mirror_y_mm = outermost_y_mm + 0.5 * kGapMm;
  render::FilletInstance right = left;
  right.hand = Hand::kRight;
  right.y_mm = 2.0 * mirror_y_mm - left.y_mm;
  render::Scene pair;
  pair.fillets = {left, right};
  const auto frame = renderer().render(camera, pair);
  ASSERT_EQ(frame.truth.size(), 2U);
  // The right fillet's outline polygon is the left one's mirrored, so the polygons' gap is
  // exact; the outlines are held in float (7 digits of ~100 mm): 1 um.
  EXPECT_NEAR(frame.truth[0].gap_to_nearest_mm, kGapMm, 1e-3);
  EXPECT_DOUBLE_EQ(frame.truth[1].gap_to_nearest_mm, frame.truth[0].gap_to_nearest_mm);

  // Alone: no neighbour at all.
  render::Scene alone;
  alone.fillets = {left};
  EXPECT_TRUE(std::isinf(renderer().render(camera, alone).truth.at(0).gap_to_nearest_mm));

  // A touching pair (2 mm pressed together) has no gap.
  render::FilletInstance first = left;
  first.y_mm = 0.0;
  render::FilletInstance partner;
  partner = render::make_touching_partner(renderer(), first, partner, true, 0.4, 20.0, 2.0, 1);
  render::Scene touching;
  touching.fillets = {first, partner};
  const auto touching_frame = renderer().render(camera, touching);
  EXPECT_EQ(touching_frame.truth.at(0).gap_to_nearest_mm, 0.0);
  EXPECT_EQ(touching_frame.truth.at(1).gap_to_nearest_mm, 0.0);
}

// The renderer's overlap: the fillet lying on the other is the one seen where they overlap.
// Rendered cleanly (no blur or noise), a pixel inside both silhouettes is the same with the
// lower fillet present as without it; the upper one rests on the lower one's thickness, no
// more than the thickest variant's 40 mm (+5 % scale) and more than nothing.
TEST(FilletRenderer, AFilletLyingOnAnotherIsTheOneSeenWhereTheyOverlap) {
  const auto camera = camera_640();
  render::FilletInstance lower;
  lower.angle_rad = 0.3;
  render::FilletInstance upper;
  upper.side = SideUp::kBone;  // a different surface, so a wrong winner would show
  upper = render::make_overlapping_partner(renderer(), lower, upper, true, 1.2, 10.0, 30.0, 1);
  EXPECT_GT(upper.lift_mm, 0.0);
  EXPECT_LE(upper.lift_mm, 42.0);
  EXPECT_EQ(lower.lift_mm, 0.0);
  render::Scene both;
  both.fillets = {upper, lower};  // the upper first: colour jitter goes by index
  render::Scene alone;
  alone.fillets = {upper};
  const auto frame_both = renderer().render(camera, both);
  const auto frame_alone = renderer().render(camera, alone);
  int overlap_pixels = 0;
  int differing = 0;
  for (int row = 0; row < camera.height_px; row += 2) {
    for (int col = 0; col < camera.width_px; col += 2) {
      const cv::Point2d belt = render::pixel_to_belt(camera, {col + 0.0, row + 0.0});
      // 1 mm inside both silhouettes, clear of anti-aliased edges.
      bool inside = true;
      for (const cv::Point2d offset :
           {cv::Point2d(1, 0), cv::Point2d(-1, 0), cv::Point2d(0, 1), cv::Point2d(0, -1)}) {
        inside = inside && renderer().silhouette_height_mm(upper, belt + offset) > 0.0 &&
                 renderer().silhouette_height_mm(lower, belt + offset) > 0.0;
      }
      if (!inside) continue;
      ++overlap_pixels;
      if (frame_both.bgr.at<cv::Vec3b>(row, col) != frame_alone.bgr.at<cv::Vec3b>(row, col)) {
        ++differing;
      }
    }
  }
  EXPECT_GT(overlap_pixels, 100);  // 30 mm of overlap: thousands of square millimetres
  EXPECT_EQ(differing, 0);
}

// The belt points (pixel centres, mm) of a cleanly rendered fillet on the blue belt, in the
// frame of the pose (u along `heading_rad`, v to its left, from `origin`): the meat's red
// channel is above 200 where the belt's is 35, so half way between splits them. Thin meat lets
// the belt through, so the mask ends where the fillet is about 2 mm thick, inside the outline.
std::vector<cv::Point2d> meat_pixels(const render::RenderCamera& camera, const cv::Mat& bgr,
                                     cv::Point2d origin, double heading_rad) {
  const double c = std::cos(heading_rad);
  const double s = std::sin(heading_rad);
  std::vector<cv::Point2d> points;
  for (int row = 0; row < bgr.rows; ++row) {
    for (int col = 0; col < bgr.cols; ++col) {
      if (bgr.at<cv::Vec3b>(row, col)[2] < 128) continue;
      const cv::Point2d d = render::pixel_to_belt(camera, {col + 0.0, row + 0.0}) - origin;
      points.emplace_back(c * d.x + s * d.y, -s * d.x + c * d.y);
    }
  }
  return points;
}

cv::Point2d mean_of(const std::vector<cv::Point2d>& points) {
  cv::Point2d sum;
  for (const cv::Point2d& p : points) sum += p;
  return sum / static_cast<double>(points.size());
}

// A bent fillet is its straight shape laid along the arc: each point keeps its arc length along
// the axis and its distance from it, so the area at distance v from the axis is stretched by
// (1 - k v). The straight picture's meat pixels, carried along the arc with that weight, must
// predict the bent picture's: same area within 1 % (edge pixels) and the same centroid within
// 0.3 mm (two thirds of a 0.47 mm pixel). Checked at the DEM line's tightest bends
// (dem::InPlaneBendFit on the multilane: up to about 1/90 mm), both ways, at two headings.
TEST(FilletRenderer, BentFilletIsItsStraightShapeLaidAlongTheArc) {
  const auto camera = camera_640();
  const double pixel_mm2 = std::abs(cv::determinant(cv::Mat(camera.belt_to_image.inv())));
  for (const double heading : {0.3, -2.4}) {
    render::FilletInstance fillet;
    fillet.x_mm = 5.0;
    fillet.y_mm = -3.0;
    fillet.angle_rad = heading;
    render::Scene scene;
    scene.fillets = {fillet};
    const cv::Point2d pose(fillet.x_mm, fillet.y_mm);
    const auto straight_frame = renderer().render(camera, scene);
    const auto straight = meat_pixels(camera, straight_frame.bgr, pose, heading);
    for (const double bend : {1.0 / 90.0, -1.0 / 150.0}) {
      SCOPED_TRACE("heading " + std::to_string(heading) + " bend " + std::to_string(bend));
      const double radius = 1.0 / bend;
      double predicted_area = 0.0;
      cv::Point2d predicted_moment;
      for (const cv::Point2d& p : straight) {
        const double weight = 1.0 - bend * p.y;
        const cv::Point2d laid((radius - p.y) * std::sin(p.x * bend),
                               radius - (radius - p.y) * std::cos(p.x * bend));
        predicted_area += weight;
        predicted_moment += weight * laid;
      }
      const cv::Point2d predicted_centroid = predicted_moment / predicted_area;
      predicted_area *= pixel_mm2;

      scene.fillets[0].bend_per_mm = bend;
      const auto frame = renderer().render(camera, scene);
      const auto bent = meat_pixels(camera, frame.bgr, pose, heading);
      const cv::Point2d bent_centroid = mean_of(bent);
      const double bent_area = static_cast<double>(bent.size()) * pixel_mm2;
      EXPECT_NEAR(bent_area, predicted_area, 0.01 * predicted_area);
      EXPECT_NEAR(bent_centroid.x, predicted_centroid.x, 0.3);
      EXPECT_NEAR(bent_centroid.y, predicted_centroid.y, 0.3);
      // The case is a real bend: the centroid moved sideways by several pixels.
      EXPECT_GT(std::abs(bent_centroid.y - mean_of(straight).y), 3.0);

      // The truth moves as the pixels do (its silhouette is the whole outline, the mask ends
      // at 2 mm of meat, so compare the changes from straight to bent).
      const render::FilletTruth& truth = frame.truth.at(0);
      const render::FilletTruth& flat = straight_frame.truth.at(0);
      const double c = std::cos(heading), s = std::sin(heading);
      const cv::Point2d moved = truth.silhouette_centroid_mm - flat.silhouette_centroid_mm;
      const cv::Point2d pixels_moved = bent_centroid - mean_of(straight);
      EXPECT_NEAR(c * moved.x + s * moved.y, pixels_moved.x, 0.3);
      EXPECT_NEAR(-s * moved.x + c * moved.y, pixels_moved.y, 0.3);
      EXPECT_NEAR(truth.silhouette_area_mm2 / flat.silhouette_area_mm2,
                  static_cast<double>(bent.size()) / static_cast<double>(straight.size()), 0.01);

      // The outline the truth and make_touching_partner use (laid forward along the arc)
      // agrees with the height the picture is drawn from (taken back off the arc): each outline
      // point lies on the silhouette. Outline points are the silhouette's edge cells, and a
      // rounding in the two maps can put a few a cell outside.
      int outside = 0;
      const auto outline = renderer().silhouette_outline_mm(scene.fillets[0]);
      for (const cv::Point2d& point : outline) {
        outside += renderer().silhouette_height_mm(scene.fillets[0], point) > 0.0 ? 0 : 1;
      }
      EXPECT_LE(outside, static_cast<int>(outline.size() / 100)) << outline.size();
    }
  }
}

// Bent tighter than the renderer can lay in the plane, or not a number: refused, not drawn.
TEST(FilletRenderer, BendBeyondTheDrawableIsRefused) {
  render::Scene scene;
  scene.fillets.emplace_back();
  for (const double bend : {1.05 * render::kMaxBendPerMm, -1.05 * render::kMaxBendPerMm,
                            std::numeric_limits<double>::quiet_NaN()}) {
    scene.fillets[0].bend_per_mm = bend;
    EXPECT_THROW((void)renderer().render(camera_640(), scene), std::invalid_argument) << bend;
  }
  scene.fillets[0].bend_per_mm = render::kMaxBendPerMm;
  EXPECT_NO_THROW((void)renderer().render(camera_640(), scene));
}

// A camera tilted 5 and 3 degrees (perspective) with its exact homography: the polygon moments
// in belt millimetres keep the pose within 2 mm and 2 degrees.
TEST(FilletEstimator, PerspectiveCamera) {
  const cv::Matx33d k(900, 0, 320, 0, 900, 240, 0, 0, 1);
  const auto camera = render::make_tilted_camera(640, 480, k, 700.0, 5.0 * kDeg, -3.0 * kDeg);
  FilletEstimator estimator(exact_calibration(camera));
  const auto frame =
      renderer().render(camera, one_fillet(5.0, 0.0, 0.8, Hand::kRight, SideUp::kSkin));
  ASSERT_TRUE(frame.truth[0].fully_visible);
  expect_matches(estimator.estimate(frame.bgr, 0, 0), frame.truth[0], 2.0, 2.0 * kDeg);
}

// A white belt: the same chroma channel separates, with the belt chroma set for white.
TEST(FilletEstimator, WhiteBelt) {
  const auto camera = camera_640();
  EstimatorParams params;
  params.belt_chroma = 128.0;  // R == B
  FilletEstimator estimator(exact_calibration(camera), params);
  auto scene = one_fillet(0.0, 0.0, -0.4, Hand::kLeft, SideUp::kBone);
  scene.belt.colour_bgr = {215.0, 215.0, 212.0};
  scene.imaging.noise_sigma = 3.0;
  const auto frame = renderer().render(camera, scene);
  expect_matches(estimator.estimate(frame.bgr, 0, 0), frame.truth[0], 2.0, 2.0 * kDeg);
}

TEST(FilletEstimator, TimeAndSequencePassThrough) {
  const auto camera = camera_640();
  FilletEstimator estimator(exact_calibration(camera));
  const auto frame =
      renderer().render(camera, one_fillet(0.0, 0.0, 1.0, Hand::kLeft, SideUp::kSkin));
  const auto result = estimator.estimate(frame.bgr, 123'456'789'000LL, 77U);
  const CameraFrame camera_frame = result.to_camera_frame();
  EXPECT_EQ(camera_frame.frame_time_ns, 123'456'789'000LL);
  EXPECT_EQ(camera_frame.sequence, 77U);
  ASSERT_EQ(camera_frame.count, 1);
  EXPECT_TRUE(camera_frame.estimates[0].singulated);
}

}  // namespace
}  // namespace fl::vision
