// The estimator's accuracy against ground truth (issue 4 item 5, `linectl vision eval`): each
// frame's blobs are matched with the true fillets in view, and a tally collects the angle and
// position errors, the left/right and side-up confusion matrices, and how well touching
// fillets are told apart from single ones (singulation precision and recall, "touching" being
// the positive class: it is what must never be placed).
//
// Matching rules, per frame:
//  - a single fillet (no other touches it) wholly in view is matched with the nearest fillet
//    blob within `match_gate_mm` of its pose; no blob there: missed;
//  - a touching group wholly in view counts once; it is flagged when at least one fillet blob lies
//  within
//    `group_gate_mm` of a member and every such blob says "not singulated";
//  - a fillet blob with no true fillet (in view or not) within `group_gate_mm`: a phantom.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "fl/controller/process_image.hpp"
#include "fl/vision/fillet_estimator.hpp"

namespace fl::vision {

// A fillet as it truly lies in a frame, in the camera's belt frame (the estimates' frame).
struct TrueFillet {
  double x_mm = 0.0;
  double y_mm = 0.0;
  double angle_rad = 0.0;  // thick end to tip, counter-clockwise from travel
  Hand hand = Hand::kUnknown;
  SideUp side = SideUp::kUnknown;
  int group_id = -1;          // >= 0: the fillets sharing it touch
  bool singulated = true;     // no other fillet shares its group
  bool fully_visible = true;  // the whole silhouette is inside the image
  // Least distance from its silhouette to another fillet's (infinity: none, or not recorded).
  double gap_mm = std::numeric_limits<double>::infinity();
};

struct AccuracyOptions {
  // The estimate's position is the blob's centroid, a few mm from the pose; 30 mm is a sixth
  // of the shortest fillet (144 mm), so a neighbour is never taken for it.
  double match_gate_mm = 30.0;
  // A touching group's blob centre can lie half a fillet length from any member's pose.
  double group_gate_mm = 100.0;
  // A single closer than this to another fillet is a near pair: the estimator reports such a
  // pair not singulated by design (EstimatorParams::min_gap_mm, the least gap the flip
  // plates handle), so it is tallied apart from the singles. 0: every single is a single.
  double near_gap_mm = 0.0;
  // Singles whose gap lies within this above near_gap_mm are borderline: the estimator
  // measures the gap on its working pixels, each blob's edge to within half a pixel, so it
  // may rightly call them either way. They are tallied apart, scored neither as singles nor
  // as near pairs.
  double near_gap_band_mm = 0.0;
};

// Confusion matrix: rows the truth (left/right or skin/bone), columns the estimate
// (the two classes, then unknown).
using Confusion = std::array<std::array<std::uint64_t, 3>, 2>;

struct AccuracySummary {
  std::uint64_t frames = 0;
  std::uint64_t frames_not_ok = 0;  // the estimator refused the frame (status other than kOk)
  std::uint64_t singles = 0;        // single fillets wholly in view
  std::uint64_t detected = 0;       // of them, matched with a blob
  std::uint64_t phantoms = 0;
  // Over the detected singles.
  double angle_error_p50_deg = 0.0;
  double angle_error_p95_deg = 0.0;
  double angle_error_max_deg = 0.0;
  double position_error_p50_mm = 0.0;
  double position_error_p95_mm = 0.0;
  double position_error_max_mm = 0.0;
  std::uint64_t thick_end_right = 0;  // angle error under 90 degrees
  Confusion hand{};
  Confusion side{};
  double hand_correct_share = 0.0;  // of detected singles
  double side_correct_share = 0.0;
  // Singulation, "touching" positive.
  std::uint64_t groups = 0;           // touching groups in view
  std::uint64_t groups_flagged = 0;   // true positives
  std::uint64_t singles_flagged = 0;  // false positives: a single called touching
  double singulation_precision = 1.0;
  double singulation_recall = 1.0;
  // Near pairs: singles wholly in view closer than near_gap_mm to another fillet, and how many
  // of them were reported not singulated (a flagged blob, or one blob with the neighbour).
  std::uint64_t near_singles = 0;
  std::uint64_t near_reported_not_singulated = 0;
  // Borderline: within near_gap_band_mm above the least gap (either answer is right).
  std::uint64_t borderline_singles = 0;
  std::uint64_t borderline_reported_not_singulated = 0;
};

// A single fillet wholly in view that no fillet blob matched, and what the estimator saw
// instead (for finding the frame and the cause of a miss).
struct MissedSingle {
  std::uint32_t sequence = 0;  // the frame's sequence number
  double x_mm = 0.0;           // the true pose
  double y_mm = 0.0;
  double angle_rad = 0.0;
  // The frame's status when it was refused; else the nearest fillet blob's distance (beyond
  // the gate) and the statuses of the frame's blobs without a pose; "no blob" when neither.
  std::string why;
};

// A detected single fillet whose hand or side the estimator got wrong or left unknown (the
// pose it was matched at, for drawing the frame).
struct MisjudgedSingle {
  std::uint32_t sequence = 0;
  double x_mm = 0.0;  // the true pose
  double y_mm = 0.0;
  double angle_rad = 0.0;
  Hand true_hand = Hand::kUnknown;
  Hand seen_hand = Hand::kUnknown;
  SideUp true_side = SideUp::kUnknown;
  SideUp seen_side = SideUp::kUnknown;
  float confidence = 0.0F;  // the estimate's
};

class AccuracyTally {
 public:
  explicit AccuracyTally(AccuracyOptions options = {}) : options_(options) {}

  void add_frame(const FrameResult& result, const std::vector<TrueFillet>& truth);
  [[nodiscard]] AccuracySummary summary() const;

  // Every detected single's errors, in the order they were added (for plots).
  [[nodiscard]] const std::vector<double>& angle_errors_deg() const { return angle_errors_deg_; }
  [[nodiscard]] const std::vector<double>& position_errors_mm() const {
    return position_errors_mm_;
  }
  [[nodiscard]] const std::vector<MissedSingle>& missed_singles() const { return missed_; }
  [[nodiscard]] const std::vector<MisjudgedSingle>& misjudged_singles() const { return misjudged_; }

 private:
  AccuracyOptions options_;
  AccuracySummary counts_;
  std::vector<double> angle_errors_deg_;
  std::vector<double> position_errors_mm_;
  std::vector<MissedSingle> missed_;
  std::vector<MisjudgedSingle> misjudged_;
};

// The smallest angle between two directions, in [0, pi].
double angle_between_rad(double a_rad, double b_rad);

// Nearest-rank percentile of `values` (share in [0, 1]); 0 for none.
double percentile(std::vector<double> values, double share);

}  // namespace fl::vision
