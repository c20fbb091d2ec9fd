// Fillet estimator for the line cameras (issue 4 item 1): one BGR frame in, one
// FilletEstimate per fillet in view out (camera-local belt frame, see process_image.hpp).
//
// Pipeline, per frame (all single-threaded, no allocation beyond OpenCV's buffers, which are
// reused between frames):
// 1. Checks: empty frame, wrong type, wrong size against the calibration -> an error status.
// 2. Working resolution: frames finer than `working_mm_per_px` are area-averaged down by an
//    integer factor (1280 x 1024 at 0.23 mm/px -> 640 x 512).
// 3. Segmentation: chroma c = 128 + (R - B) / 2 (meat is red, a blue or white belt is not;
//    a difference of channels cancels most of the exposure and lighting gradient). Otsu's
//    threshold on c separates belt and meat; a frame whose two Otsu classes differ by less than
//    `min_meat_contrast` has no meat (empty belt). "No belt": less than `min_belt_share` of
//    the frame looks like the belt (chroma within `belt_chroma_tolerance` of
//    `belt_chroma`, brightness at least `min_belt_brightness`) — a covered lens, a dark or
//    blown-out frame, a frame of something else.
// 4. Morphology: opening (removes speckle) and closing (fills fat streaks and highlights).
// 5. Blobs: external contours; blobs below `min_blob_area_mm2` are debris; blobs touching the
//    image border are reported as cut (no pose).
// 6. Geometry in belt millimetres: the contour is mapped through the calibration and its
//    polygon moments give area, centroid and the principal axis (exact under perspective).
// 6b. Bend: a limp fillet lies bent in the belt plane (the DEM twin's line bends them by 2 / m
//    in the median and up to 12 / m on the multilane). Its outline's midline is fitted over
//    slices along the axis as a + b u + k u^2 / 2 + beta w(u) / 2: the section centre sits a
//    share beta of the half-width w / 2 towards the bulging edge, and a bend adds the same
//    parabola to both edges while keeping the width. The outline is straightened along that
//    arc (repeated on the straightened outline) and items 7 to 11 read the straight shape;
//    the pose found there is laid back on the arc.
// 7. Thick end: the third moment along the principal axis. The tip tapers to a long point and
//    the thick end is blunt, so the area has its long tail towards the tip (skewness > 0
//    towards the tip). Direction = sign of the skewness.
// 8. Chirality: the third moment across the axis. The mesh-model fillet (and a real breast
//    fillet) has one straight long edge and one bulging edge; the bulge side has the longer
//    tail. Seen from above the bulge is on the left of the thick-to-tip direction for a left
//    fillet skin side up, and turning the fillet over mirrors it, so hand = bulge side XOR side.
// 9. Side: two exposure-invariant colour/texture features over the eroded blob: redness
//    (R - G) / R (the bone side is pinker) and relative band-pass texture energy (the bone side
//    has fibre and fat streaks; the skin side is smooth). A linear score with fixed weights
//    (fitted on rendered training frames, seeds disjoint from the evaluation; refit on real
//    labelled frames) decides.
// 10. Singulation: area within the single-fillet range, solidity (area / convex hull area) and
//    the deepest convexity defect. A blob failing any is reported not singulated, with its
//    centroid and principal axis, and unknown hand and side.
// 11. Axis bias: the principal axis of the asymmetric silhouette is turned against the
//    thick-to-tip line by a few degrees, towards the bulge; `axis_bias_rad` (signed by the
//    bulge side) corrects it. The centroid offset of area vs volume is not corrected.
// 12. Confidence: the smallest of the margins of thick end, chirality and side, each scaled to
//    0..1 by its "sure" margin, and of the singulation margins.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/calibration.hpp"

namespace fl::vision {

struct EstimatorParams {
  double working_mm_per_px = 0.45;  // finer frames are downscaled to at least this
  // Belt appearance (chroma c = 128 + (R - B) / 2, brightness = mean of B, G, R).
  double belt_chroma = 63.0;  // food-grade blue belt (B ~ 165, R ~ 35)
  double belt_chroma_tolerance = 30.0;
  double min_belt_brightness = 25.0;
  double min_belt_share = 0.3;
  double min_meat_contrast = 20.0;  // chroma levels between the two Otsu classes
  // Blobs (areas in belt mm^2; single fillets of table 3.1 are 7 500 .. 9 800 mm^2 at +-5 %).
  double min_blob_area_mm2 = 1500.0;
  double min_single_area_mm2 = 5000.0;
  double max_single_area_mm2 = 12000.0;
  double min_solidity = 0.90;
  double max_defect_depth_mm = 7.0;
  int border_margin_px = 1;  // a blob within this of the image edge is cut
  // Blobs closer than this count as touching (thin rims where two fillets meet may segment as
  // belt); both are reported not singulated. Also the least gap the flip plates can handle.
  double min_gap_mm = 4.0;
  // Shape model (see items 7, 8, 11), fitted on the nominal mesh shape (tests/explore): the
  // principal axis is turned 2.3 degrees away from the bulge, and the area centroid lies
  // 5.6 mm towards the tip and 0.74 mm towards the straight edge from the volume centroid (the
  // rigid-body centre the twin and the tracker use). Zero offsets report the area centroid.
  double axis_bias_rad = 0.0405;
  double pose_offset_along_mm = -5.6;
  double pose_offset_toward_bulge_mm = 0.74;
  // Bend fit (item 6b): slices along the axis of this length (at least 2.5 working pixels),
  // only slices at least this wide (two edges, not a rounded end), this many fits, each on
  // the outline straightened by the one before, and the largest bend believed (a tighter one
  // is a folded or doubled fillet, not a bent one).
  double bend_slice_mm = 2.0;
  double bend_min_slice_width_mm = 6.0;
  int bend_fit_passes = 3;
  double max_bend_per_mm = 1.0 / 40.0;
  double sure_thick_end_skewness = 0.10;  // |skewness| at which the thick end counts as sure
  double sure_bulge_skewness = 0.08;
  // Texture band-pass, in belt millimetres so that every camera resolution measures the same
  // detail: the difference of two Gaussian blurs of these sigmas. The band keys on the fibre
  // and fat streaks (~1 mm wide, ~12 mm long). It is measured on the blob area-averaged by an
  // integer factor to about `texture_mm_per_px` (640 x 480 and 1280 x 1024 by 2, 320 x 240 as
  // it is), so every camera sees it on pixels of the same size. The band once set in pixels
  // (0.7 and 2.5 px, ~0.33 to 1.17 mm at 640 x 480) read pixel noise and aliasing as texture
  // at 320 x 240: skin reached 0.016 there, against 0.009 at 640 x 480.
  double texture_mm_per_px = 0.9;
  double texture_fine_sigma_mm = 0.7;
  double texture_coarse_sigma_mm = 2.3;
  // Side classifier: score = w_redness * (redness - redness_mid) / redness_scale +
  //                          w_texture * (texture - texture_mid) / texture_scale; > 0 = bone.
  // Fitted on 200 rendered training frames (seeds 100000..100199) at 320 x 240, 640 x 480
  // and 1280 x 1024: skin redness 0.09..0.27, bone 0.22..0.41; skin texture 0.0071..0.0121,
  // bone 0.022..0.039 at every resolution. Texture separates, redness only supports it; the
  // midpoint is the geometric middle of the gap.
  double redness_mid = 0.255;
  double redness_scale = 0.05;
  double texture_mid = 0.0165;
  double texture_scale = 0.0035;
  double w_redness = 0.5;
  double w_texture = 1.0;
  double sure_side_score = 1.0;
};

enum class FrameStatus : std::uint8_t {
  kOk,               // estimates (possibly none: an empty belt) are valid
  kEmptyFrame,       // no pixels
  kWrongType,        // not 8-bit BGR
  kWrongResolution,  // size differs from the calibration's
  kNoBelt,           // the frame does not show the belt (see the pipeline, item 3)
};
std::string_view to_string(FrameStatus status);

enum class BlobStatus : std::uint8_t {
  kFillet,        // a fully visible fillet or touching group: has an estimate
  kCutByBorder,   // touches the image edge: no pose (it is reported when fully in view)
  kTooSmall,      // debris or a splash, ignored
  kOverCapacity,  // more fillets than CameraFrame holds (kMaxEstimatesPerFrame)
};
std::string_view to_string(BlobStatus status);

// Features behind one estimate, for diagnostics, tests and refitting thresholds.
struct BlobFeatures {
  double area_mm2 = 0.0;
  double solidity = 0.0;
  double max_defect_depth_mm = 0.0;
  double bend_per_mm = 0.0;     // fitted in-plane bend (item 6b), + = anticlockwise to the tip
  double axis_skewness = 0.0;   // along the principal axis, oriented thick -> tip: > 0
  double bulge_skewness = 0.0;  // across it, + = bulge on the left of thick -> tip
  double redness = 0.0;
  double texture = 0.0;
  double side_score = 0.0;          // > 0 bone
  bool touches_other_blob = false;  // within min_gap_mm of another blob
  cv::Point2d centroid_px;          // working image
};

struct BlobResult {
  BlobStatus status = BlobStatus::kTooSmall;
  FilletEstimate estimate;  // valid for kFillet only
  BlobFeatures features;
  cv::Point contact_label;  // a working-image pixel of the blob (internal: gap check)
};

struct FrameResult {
  FrameStatus status = FrameStatus::kOk;
  std::string message;  // why, for a status other than kOk
  std::int64_t frame_time_ns = 0;
  std::uint32_t sequence = 0;
  std::vector<BlobResult> blobs;  // every blob found, in image order

  // The controller's view: the kFillet blobs (at most kMaxEstimatesPerFrame), time and
  // sequence passed through; count 0 for a frame that is not kOk.
  [[nodiscard]] CameraFrame to_camera_frame() const;
  // Whether the frame goes to the controller at all: only when kOk. A refused frame (no
  // belt in view, wrong size or type) says nothing about what is on the belt, so it is not
  // passed on as "no fillet": its sequence stays a gap, and a camera that keeps refusing
  // falls silent, which the controller faults as kCameraSilent (docs/vision.md).
  [[nodiscard]] bool deliverable() const { return status == FrameStatus::kOk; }
};

class FilletEstimator {
 public:
  FilletEstimator(BeltCalibration calibration, EstimatorParams params = {});

  // Never throws for bad image content; the status says what was wrong.
  FrameResult estimate(const cv::Mat& bgr, std::int64_t frame_time_ns, std::uint32_t sequence);

  [[nodiscard]] const BeltCalibration& calibration() const { return calibration_; }
  [[nodiscard]] const EstimatorParams& params() const { return params_; }
  [[nodiscard]] int downscale_factor() const { return downscale_; }

 private:
  BlobResult measure_blob(const std::vector<cv::Point>& contour);
  void flag_close_blobs(FrameResult& result, const cv::Rect& foreground);

  BeltCalibration calibration_;
  EstimatorParams params_;
  int downscale_ = 1;
  cv::Matx33d work_to_belt_;  // working-image pixel -> belt mm (no distortion case)
  // Structuring elements, built once for the working scale.
  cv::Mat interior_erosion_;                // ~3 mm ellipse
  std::vector<int> interior_erosion_runs_;  // its rows' half widths (centred runs)
  cv::Mat gap_dilation_;                    // min_gap_mm / 2 ellipse
  int gap_radius_px_ = 1;
  // The texture band: integer reduction from the working scale, and its sigmas there.
  int texture_downscale_ = 1;
  double texture_fine_sigma_px_ = 0.75;
  double texture_coarse_sigma_px_ = 2.45;
  // Reused buffers.
  // The working image: interleaved (the frame itself, or cv::resize's result), or, when the
  // colour pass halves the frame itself, only its green and red planes (for the colour means).
  bool halved_in_colour_pass_ = false;
  cv::Mat work_bgr_;
  cv::Mat work_green_;
  cv::Mat work_red_;
  cv::Mat chroma_;
  cv::Mat grey_;
  cv::Mat planes_;  // one working row's planes (only blue when the pass halves the frame)
  std::vector<std::uint8_t> row_max_chroma_;
  std::vector<std::uint8_t> column_max_chroma_;
  cv::Mat mask_;
  cv::Mat scratch_;
  cv::Mat labels_;
  cv::Mat interior_;
  cv::Mat eroded_;
  cv::Mat erosion_padded_;
  cv::Mat erosion_run_minima_;
  cv::Mat grey_box_;
  cv::Mat texture_grey_;
  cv::Mat texture_inside_;
  cv::Mat fine_;
  cv::Mat coarse_;
};

}  // namespace fl::vision
