// The fillet estimator (fl/vision/fillet_estimator.hpp); the pipeline is described there.
#include "fl/vision/fillet_estimator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "working_image.hpp"

namespace fl::vision {
namespace {

double clamp01(double value) { return std::clamp(value, 0.0, 1.0); }

float wrap_angle(double angle_rad) {
  double wrapped = std::remainder(angle_rad, 2.0 * std::numbers::pi);
  if (wrapped <= -std::numbers::pi) wrapped += 2.0 * std::numbers::pi;
  return static_cast<float>(wrapped);
}

struct Otsu {
  int threshold = 0;
  double low_mean = 0.0;
  double high_mean = 0.0;
};

// Otsu's threshold of an 8-bit histogram, with both class means.
Otsu otsu(const std::array<double, 256>& histogram) {
  double total = 0.0, total_sum = 0.0;
  for (int i = 0; i < 256; ++i) {
    total += histogram[static_cast<std::size_t>(i)];
    total_sum += i * histogram[static_cast<std::size_t>(i)];
  }
  Otsu best;
  double best_between = -1.0, low_count = 0.0, low_sum = 0.0;
  for (int t = 0; t < 255; ++t) {
    low_count += histogram[static_cast<std::size_t>(t)];
    low_sum += t * histogram[static_cast<std::size_t>(t)];
    const double high_count = total - low_count;
    if (low_count <= 0.0 || high_count <= 0.0) continue;
    const double low_mean = low_sum / low_count;
    const double high_mean = (total_sum - low_sum) / high_count;
    const double between = low_count * high_count * (low_mean - high_mean) * (low_mean - high_mean);
    if (between > best_between) {
      best_between = between;
      best = {t, low_mean, high_mean};
    }
  }
  return best;
}

// A point in the frame of an axis through `origin` at `axis_rad` (u along, v to its left).
cv::Point2d to_axis_frame(cv::Point2d p, cv::Point2d origin, double axis_rad) {
  const double c = std::cos(axis_rad), s = std::sin(axis_rad);
  const cv::Point2d d = p - origin;
  return {c * d.x + s * d.y, -s * d.x + c * d.y};
}

cv::Point2d from_axis_frame(cv::Point2d uv, cv::Point2d origin, double axis_rad) {
  const double c = std::cos(axis_rad), s = std::sin(axis_rad);
  return origin + cv::Point2d(c * uv.x - s * uv.y, s * uv.x + c * uv.y);
}

// The arc map of a bent fillet (EstimatorParams, item 6b): the straight frame laid along a
// circular arc of `curvature_per_mm` tangent to the u axis at the origin, each point keeping
// its arc length along the axis and its distance from it.
cv::Point2d lay_on_arc(cv::Point2d straight, double curvature_per_mm) {
  if (curvature_per_mm == 0.0) return straight;
  const double radius = 1.0 / curvature_per_mm;
  const double turn = straight.x * curvature_per_mm;
  const double from_centre = radius - straight.y;
  return {from_centre * std::sin(turn), radius - from_centre * std::cos(turn)};
}

cv::Point2d straighten(cv::Point2d bent, double curvature_per_mm) {
  if (curvature_per_mm == 0.0) return bent;
  const double radius = 1.0 / curvature_per_mm;
  const double sign = curvature_per_mm > 0.0 ? 1.0 : -1.0;  // the arc's centre is on that side
  const double a = sign * bent.x;
  const double b = sign * (radius - bent.y);
  return {radius * std::atan2(a, b), radius - sign * std::hypot(a, b)};
}

// Where a blob's fillet axis runs and how it is bent: the arc through `origin` tangent to
// `axis_rad` there, of `curvature_per_mm`. `contour` is the outline straightened along it, in
// that axis' frame.
struct AxisArc {
  cv::Point2d origin;
  double axis_rad = 0.0;
  double curvature_per_mm = 0.0;
  std::vector<cv::Point2d> contour;
};

// Fits the bend of a fillet outline (belt mm), starting from its area centroid and principal
// axis. A fillet's section centre sits a fixed share of its half-width to one side (the bulging
// edge, thesis figure 3.1; the twin's mesh, FilletShapeParams::edge_bias), so across the
// length its outline's midline follows m(u) = a + b u + beta w(u) / 2, with w(u) the width;
// a bend in the belt plane adds k u^2 / 2 to both edges and keeps the width. Least squares of
// the midline over slices along the axis gives k, beta and the axis (a, b); the outline is
// straightened with k and the fit repeated on it, as the first axis is the bent shape's.
// `passes` fits in all; with none the outline is only turned into the principal axis' frame.
AxisArc fit_axis_arc(const std::vector<cv::Point2f>& contour_mm, cv::Point2d centroid,
                     double principal_rad, int passes, const EstimatorParams& params,
                     double mm_per_px) {
  AxisArc arc;
  arc.origin = centroid;
  arc.axis_rad = principal_rad;
  arc.contour.resize(contour_mm.size());
  const double slice_mm = std::max(params.bend_slice_mm, 2.5 * mm_per_px);
  std::vector<double> high, low;
  for (int pass = 0; pass <= passes; ++pass) {
    double min_u = 1e300, max_u = -1e300;
    for (std::size_t i = 0; i < contour_mm.size(); ++i) {
      arc.contour[i] = straighten(
          to_axis_frame(cv::Point2d(contour_mm[i].x, contour_mm[i].y), arc.origin, arc.axis_rad),
          arc.curvature_per_mm);
      min_u = std::min(min_u, arc.contour[i].x);
      max_u = std::max(max_u, arc.contour[i].x);
    }
    if (pass == passes) break;
    const auto slices = static_cast<std::size_t>(std::ceil((max_u - min_u) / slice_mm)) + 1;
    high.assign(slices, -1e300);
    low.assign(slices, 1e300);
    for (const cv::Point2d& p : arc.contour) {
      const auto slice = static_cast<std::size_t>((p.x - min_u) / slice_mm);
      high[slice] = std::max(high[slice], p.y);
      low[slice] = std::min(low[slice], p.y);
    }
    // Normal equations of mid = a + b u + c u^2 + beta w / 2 over the slices wide enough to
    // have two edges (the rounded ends have one point or two).
    cv::Matx44d normal = cv::Matx44d::zeros();
    cv::Vec4d rhs(0, 0, 0, 0);
    int rows = 0;
    for (std::size_t slice = 0; slice < slices; ++slice) {
      const double width = high[slice] - low[slice];
      if (!(width >= params.bend_min_slice_width_mm)) continue;
      const double u = min_u + (static_cast<double>(slice) + 0.5) * slice_mm;
      const cv::Vec4d row(1.0, u, u * u, 0.5 * width);
      const double mid = 0.5 * (high[slice] + low[slice]);
      normal += row * row.t();
      rhs += mid * row;
      ++rows;
    }
    if (rows < 8) break;  // too short a blob to tell a bend: keep what is fitted
    cv::Vec4d coefficients;
    if (!cv::solve(normal, rhs, coefficients, cv::DECOMP_SVD)) break;
    // The residual bend and axis, in the straightened frame; re-anchored on the fitted
    // midline at u = 0 (on the arc, as laid). Not on the intercept a alone: where the width
    // changes little along the length, a and beta trade off against each other, while their
    // sum, the midline, is what the slices measure.
    const double curvature = std::clamp(arc.curvature_per_mm + 2.0 * coefficients[2],
                                        -params.max_bend_per_mm, params.max_bend_per_mm);
    if (!std::isfinite(curvature)) break;
    const auto centre_slice = static_cast<std::size_t>(std::max(0.0, -min_u) / slice_mm);
    const double centre_width =
        centre_slice < slices ? std::max(0.0, high[centre_slice] - low[centre_slice]) : 0.0;
    const double midline_at_zero = coefficients[0] + 0.5 * coefficients[3] * centre_width;
    arc.origin = from_axis_frame(lay_on_arc({0.0, midline_at_zero}, arc.curvature_per_mm),
                                 arc.origin, arc.axis_rad);
    arc.axis_rad += std::atan(coefficients[1]);
    arc.curvature_per_mm = curvature;
  }
  return arc;
}

// Deepest point of a closed outline inside its convex hull (the hull's vertex indices in
// outline order), from each hull edge to the outline points between its ends.
double deepest_defect(const std::vector<cv::Point2d>& outline, std::vector<int> hull) {
  if (hull.size() < 3) return 0.0;
  std::sort(hull.begin(), hull.end());
  double deepest = 0.0;
  const std::size_t n = outline.size();
  for (std::size_t h = 0; h < hull.size(); ++h) {
    const auto from = static_cast<std::size_t>(hull[h]);
    const auto to = static_cast<std::size_t>(hull[(h + 1) % hull.size()]);
    const cv::Point2d edge = outline[to] - outline[from];
    const double length = std::hypot(edge.x, edge.y);
    if (length <= 0.0) continue;
    for (std::size_t i = (from + 1) % n; i != to; i = (i + 1) % n) {
      const cv::Point2d d = outline[i] - outline[from];
      deepest = std::max(deepest, std::abs(edge.x * d.y - edge.y * d.x) / length);
    }
  }
  return deepest;
}

}  // namespace

std::string_view to_string(FrameStatus status) {
  switch (status) {
    case FrameStatus::kOk:
      return "ok";
    case FrameStatus::kEmptyFrame:
      return "empty frame";
    case FrameStatus::kWrongType:
      return "wrong pixel type";
    case FrameStatus::kWrongResolution:
      return "wrong resolution";
    case FrameStatus::kNoBelt:
      return "no belt in view";
  }
  return "?";
}

std::string_view to_string(BlobStatus status) {
  switch (status) {
    case BlobStatus::kFillet:
      return "fillet";
    case BlobStatus::kCutByBorder:
      return "cut by the image border";
    case BlobStatus::kTooSmall:
      return "too small for a fillet";
    case BlobStatus::kOverCapacity:
      return "more fillets than a camera frame holds";
  }
  return "?";
}

CameraFrame FrameResult::to_camera_frame() const {
  CameraFrame frame;
  frame.frame_time_ns = frame_time_ns;
  frame.sequence = sequence;
  if (status != FrameStatus::kOk) return frame;
  for (const auto& blob : blobs) {
    if (blob.status != BlobStatus::kFillet || frame.count >= kMaxEstimatesPerFrame) continue;
    frame.estimates[frame.count++] = blob.estimate;
  }
  return frame;
}

FilletEstimator::FilletEstimator(BeltCalibration calibration, EstimatorParams params)
    : calibration_(std::move(calibration)), params_(params) {
  if (calibration_.image_width_px <= 0 || calibration_.image_height_px <= 0) {
    throw std::invalid_argument("FilletEstimator: calibration without an image size");
  }
  const double mm_per_px = calibration_.mm_per_px_at_centre();
  if (!(mm_per_px > 0.0) || !std::isfinite(mm_per_px)) {
    throw std::invalid_argument("FilletEstimator: calibration homography is degenerate");
  }
  downscale_ = std::max(1, static_cast<int>(std::lround(params_.working_mm_per_px / mm_per_px)));
  // Working pixel centre x' covers full pixels [x' k, x' k + k): its centre is x' k + (k-1)/2.
  const double k = downscale_;
  const cv::Matx33d work_to_full(k, 0, 0.5 * (k - 1), 0, k, 0.5 * (k - 1), 0, 0, 1);
  work_to_belt_ = calibration_.image_to_belt * work_to_full;
  // Structuring elements depend only on the working scale: built once, not per frame.
  const double work_mm_per_px = mm_per_px * downscale_;
  const int erode_px = std::max(1, static_cast<int>(std::lround(3.0 / work_mm_per_px)));
  interior_erosion_ =
      cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * erode_px + 1, 2 * erode_px + 1));
  interior_erosion_runs_ = detail::centred_run_half_widths(interior_erosion_);
  gap_radius_px_ =
      std::max(1, static_cast<int>(std::lround(0.5 * params_.min_gap_mm / work_mm_per_px)));
  gap_dilation_ = cv::getStructuringElement(
      cv::MORPH_ELLIPSE, cv::Size(2 * gap_radius_px_ + 1, 2 * gap_radius_px_ + 1));
  const double fine_mm = params_.texture_fine_sigma_mm;
  const double coarse_mm = params_.texture_coarse_sigma_mm;
  if (!(fine_mm > 0.0) || !(coarse_mm > fine_mm) || !std::isfinite(coarse_mm)) {
    throw std::invalid_argument(
        "FilletEstimator: the texture band needs 0 < texture_fine_sigma_mm (" +
        std::to_string(fine_mm) + ") < texture_coarse_sigma_mm (" + std::to_string(coarse_mm) +
        ")");
  }
  if (!(params_.texture_mm_per_px > 0.0) || !std::isfinite(params_.texture_mm_per_px)) {
    throw std::invalid_argument("FilletEstimator: texture_mm_per_px (" +
                                std::to_string(params_.texture_mm_per_px) +
                                ") must be a positive pixel size");
  }
  // The bend fit (item 6b): slices of some length, a width that leaves the rounded ends out,
  // and a largest bend whose arc keeps a fillet's half width (36 mm) off its centre.
  if (!(params_.bend_slice_mm > 0.0) || !(params_.bend_slice_mm < 50.0) ||
      !(params_.bend_min_slice_width_mm >= 0.0) || !(params_.bend_min_slice_width_mm < 100.0) ||
      !(params_.max_bend_per_mm >= 0.0) || !(params_.max_bend_per_mm < 1.0 / 36.0) ||
      params_.bend_fit_passes < 0 || params_.bend_fit_passes > 10) {
    throw std::invalid_argument(
        "FilletEstimator: the bend fit needs 0 < bend_slice_mm (" +
        std::to_string(params_.bend_slice_mm) + ") < 50, 0 <= bend_min_slice_width_mm (" +
        std::to_string(params_.bend_min_slice_width_mm) + ") < 100, 0 <= max_bend_per_mm (" +
        std::to_string(params_.max_bend_per_mm) + ") < 1/36 and 0 <= bend_fit_passes (" +
        std::to_string(params_.bend_fit_passes) + ") <= 10");
  }
  texture_downscale_ =
      std::max(1, static_cast<int>(std::lround(params_.texture_mm_per_px / work_mm_per_px)));
  const double texture_px_mm = work_mm_per_px * texture_downscale_;
  texture_fine_sigma_px_ = fine_mm / texture_px_mm;
  texture_coarse_sigma_px_ = coarse_mm / texture_px_mm;
}

FrameResult FilletEstimator::estimate(const cv::Mat& bgr, std::int64_t frame_time_ns,
                                      std::uint32_t sequence) {
  FrameResult result;
  result.frame_time_ns = frame_time_ns;
  result.sequence = sequence;
  if (bgr.empty()) {
    result.status = FrameStatus::kEmptyFrame;
    result.message = "frame has no pixels";
    return result;
  }
  if (bgr.type() != CV_8UC3) {
    result.status = FrameStatus::kWrongType;
    result.message = "frame must be 8-bit BGR (CV_8UC3), got type " + std::to_string(bgr.type());
    return result;
  }
  if (bgr.cols != calibration_.image_width_px || bgr.rows != calibration_.image_height_px) {
    result.status = FrameStatus::kWrongResolution;
    result.message = "frame is " + std::to_string(bgr.cols) + " x " + std::to_string(bgr.rows) +
                     " px, calibration '" + calibration_.camera_name + "' is for " +
                     std::to_string(calibration_.image_width_px) + " x " +
                     std::to_string(calibration_.image_height_px);
    return result;
  }
  // An exact 2 x 2 reduction (a 1280 x 1024 camera to the 640 x 512 working scale) is done in
  // the colour pass below, row pair by row pair into planes; other reductions go through
  // cv::resize first. Both give the same bits.
  halved_in_colour_pass_ = downscale_ == 2 && bgr.cols % 2 == 0 && bgr.rows % 2 == 0;
  const cv::Size work_size(bgr.cols / downscale_, bgr.rows / downscale_);
  if (halved_in_colour_pass_) {
    work_bgr_.release();
    work_green_.create(work_size, CV_8UC1);
    work_red_.create(work_size, CV_8UC1);
  } else if (downscale_ > 1) {
    cv::resize(bgr, work_bgr_, work_size, 0, 0, cv::INTER_AREA);
  } else {
    work_bgr_ = bgr;
  }
  // Luma, chroma 128 + (R - B) / 2, the belt count and the histogram in one pass, row by row
  // from colour planes in cache (working_image.hpp). The histogram counts in integers into
  // four tables, so that equal neighbouring pixels do not wait on each other's increment.
  grey_.create(work_size, CV_8UC1);
  chroma_.create(work_size, CV_8UC1);
  planes_.create(3, work_size.width, CV_8UC1);
  std::uint8_t* const blue = planes_.ptr<std::uint8_t>(0);
  std::array<std::array<std::uint32_t, 256>, 4> counts{};
  std::size_t belt_like = 0;
  // The largest chroma per row and per column: once the threshold is known they bound the
  // mask, and the segmentation below runs on that box only.
  row_max_chroma_.assign(static_cast<std::size_t>(work_size.height), 0);
  column_max_chroma_.assign(static_cast<std::size_t>(work_size.width), 0);
  std::uint8_t* const column_max = column_max_chroma_.data();
  const int belt_low = static_cast<int>(params_.belt_chroma - params_.belt_chroma_tolerance);
  const int belt_high = static_cast<int>(params_.belt_chroma + params_.belt_chroma_tolerance);
  const auto min_brightness = static_cast<int>(params_.min_belt_brightness);
  // Locals, not members: the uint8_t stores below may alias anything, so member reads in the
  // loops would be reloaded per pixel and block vectorisation.
  const int cols = chroma_.cols;
  for (int row = 0; row < chroma_.rows; ++row) {
    std::uint8_t* green = planes_.ptr<std::uint8_t>(1);
    std::uint8_t* red = planes_.ptr<std::uint8_t>(2);
    if (halved_in_colour_pass_) {
      green = work_green_.ptr<std::uint8_t>(row);
      red = work_red_.ptr<std::uint8_t>(row);
      detail::halve_bgr_rows(bgr.ptr<std::uint8_t>(2 * row), bgr.ptr<std::uint8_t>(2 * row + 1),
                             cols, blue, green, red);
    } else {
      detail::split_bgr_row(work_bgr_.ptr<std::uint8_t>(row), cols, blue, green, red);
    }
    std::uint8_t* g = grey_.ptr<std::uint8_t>(row);
    std::uint8_t* c = chroma_.ptr<std::uint8_t>(row);
    detail::grey_row(blue, green, red, cols, g);
    detail::chroma_row(blue, red, cols, c);
    std::uint8_t row_max = 0;
    for (int col = 0; col < cols; ++col) {
      row_max = std::max(row_max, c[col]);
      column_max[col] = std::max(column_max[col], c[col]);
    }
    row_max_chroma_[static_cast<std::size_t>(row)] = row_max;
    std::uint32_t belt_in_row = 0;
    for (int col = 0; col < cols; ++col) {
      belt_in_row += static_cast<std::uint32_t>((c[col] >= belt_low) & (c[col] <= belt_high) &
                                                (g[col] >= min_brightness));
    }
    belt_like += belt_in_row;
    int col = 0;
    for (; col + 4 <= cols; col += 4) {
      ++counts[0][c[col]];
      ++counts[1][c[col + 1]];
      ++counts[2][c[col + 2]];
      ++counts[3][c[col + 3]];
    }
    for (; col < cols; ++col) ++counts[0][c[col]];
  }
  std::array<double, 256> histogram{};
  for (std::size_t level = 0; level < histogram.size(); ++level) {
    histogram[level] = static_cast<double>(counts[0][level] + counts[1][level] + counts[2][level] +
                                           counts[3][level]);
  }
  const double belt_share = static_cast<double>(belt_like) / static_cast<double>(chroma_.total());
  if (belt_share < params_.min_belt_share) {
    result.status = FrameStatus::kNoBelt;
    result.message = "only " + std::to_string(static_cast<int>(100.0 * belt_share)) +
                     " % of the frame looks like the belt (needs " +
                     std::to_string(static_cast<int>(100.0 * params_.min_belt_share)) +
                     " %): covered, dark, blown out or not the belt";
    return result;
  }
  const Otsu split = otsu(histogram);
  if (split.high_mean - split.low_mean < params_.min_meat_contrast) return result;  // empty belt

  // Threshold, opening, closing and contours on the box of the pixels above the threshold
  // only (the same result as on the whole frame, at a fraction of its cost).
  std::vector<std::vector<cv::Point>> contours;
  detail::segment_meat(chroma_, split.threshold,
                       detail::box_above(row_max_chroma_, column_max_chroma_, split.threshold),
                       mask_, scratch_, contours);
  const double work_mm_per_px = calibration_.mm_per_px_at_centre() * downscale_;
  const double min_area_px = params_.min_blob_area_mm2 / (work_mm_per_px * work_mm_per_px);
  const int margin = params_.border_margin_px;
  std::size_t fillets = 0;
  cv::Rect foreground;  // all mask pixels, debris included (the gap check's extent)
  for (const auto& contour : contours) {
    BlobResult blob;
    const cv::Rect box = cv::boundingRect(contour);
    foreground |= box;
    const double area_px = cv::contourArea(contour);
    // A generous pre-filter in pixels (the mm area below decides): debris costs nothing.
    if (area_px < 0.5 * min_area_px) continue;
    const cv::Moments m = cv::moments(contour);
    blob.features.centroid_px = {m.m10 / m.m00, m.m01 / m.m00};
    if (box.x <= margin || box.y <= margin || box.x + box.width >= mask_.cols - margin ||
        box.y + box.height >= mask_.rows - margin) {
      blob.status = BlobStatus::kCutByBorder;
      blob.contact_label = contour.front();
      blob.features.area_mm2 = area_px * work_mm_per_px * work_mm_per_px;
      result.blobs.push_back(blob);
      continue;
    }
    blob = measure_blob(contour);
    blob.contact_label = contour.front();  // a pixel of the blob, for the gap check below
    if (blob.status == BlobStatus::kFillet && ++fillets > kMaxEstimatesPerFrame) {
      blob.status = BlobStatus::kOverCapacity;
    }
    result.blobs.push_back(blob);
  }
  flag_close_blobs(result, foreground);
  return result;
}

void FilletEstimator::flag_close_blobs(FrameResult& result, const cv::Rect& foreground) {
  // Blobs closer than min_gap_mm touch or nearly touch (their thin translucent rims may not
  // segment as meat where they meet): dilating the mask by half the gap joins them.
  std::size_t candidates = 0;
  for (const auto& blob : result.blobs) candidates += blob.status == BlobStatus::kFillet ? 1 : 0;
  if (candidates == 0 || result.blobs.size() < 2) return;
  // Only the mask's foreground box grown by the dilation can be non-zero after it, so the
  // components there are those of the full frame, at a fraction of its cost.
  const cv::Rect roi = detail::grown(foreground, gap_radius_px_ + 1, mask_.size());
  cv::dilate(mask_(roi), scratch_, gap_dilation_);
  cv::connectedComponents(scratch_, labels_, 8, CV_32S);
  const auto label_at = [&](const cv::Point& pixel) { return labels_.at<int>(pixel - roi.tl()); };
  for (auto& blob : result.blobs) {
    if (blob.status != BlobStatus::kFillet && blob.status != BlobStatus::kCutByBorder) continue;
    const int label = label_at(blob.contact_label);
    for (const auto& other : result.blobs) {
      if (&other == &blob ||
          (other.status != BlobStatus::kFillet && other.status != BlobStatus::kCutByBorder)) {
        continue;
      }
      if (label_at(other.contact_label) == label && blob.status == BlobStatus::kFillet &&
          blob.estimate.singulated) {
        blob.estimate.singulated = false;
        blob.estimate.hand = Hand::kUnknown;
        blob.estimate.side = SideUp::kUnknown;
        blob.features.touches_other_blob = true;
        blob.estimate.confidence = 1.0F;  // a visible second blob within the gap is certain
      }
    }
  }
}

BlobResult FilletEstimator::measure_blob(const std::vector<cv::Point>& contour) {
  BlobResult blob;
  BlobFeatures& f = blob.features;
  const double work_mm_per_px = calibration_.mm_per_px_at_centre() * downscale_;

  // Contour to belt millimetres.
  std::vector<cv::Point2f> contour_px(contour.begin(), contour.end());
  std::vector<cv::Point2f> contour_mm;
  if (calibration_.has_intrinsics) {
    const double k = downscale_;
    for (auto& p : contour_px) {
      p = cv::Point2f(static_cast<float>(p.x * k + 0.5 * (k - 1)),
                      static_cast<float>(p.y * k + 0.5 * (k - 1)));
    }
    std::vector<cv::Point2f> ideal;
    cv::undistortPoints(contour_px, ideal, calibration_.camera_matrix, calibration_.distortion,
                        cv::noArray(), calibration_.camera_matrix);
    cv::perspectiveTransform(ideal, contour_mm, calibration_.image_to_belt);
  } else {
    cv::perspectiveTransform(contour_px, contour_mm, work_to_belt_);
  }
  const cv::Moments m = cv::moments(contour_mm);
  f.area_mm2 = std::abs(m.m00);
  const cv::Moments m_px = cv::moments(contour);
  f.centroid_px = {m_px.m10 / m_px.m00, m_px.m01 / m_px.m00};
  if (f.area_mm2 < params_.min_blob_area_mm2) {
    blob.status = BlobStatus::kTooSmall;
    return blob;
  }
  const double cx = m.m10 / m.m00;
  const double cy = m.m01 / m.m00;
  // Central moments normalised by the area (OpenCV's mu are sums over the polygon): the
  // principal axis, turned so that the third moment along it (the long tail) points at the
  // tip, and the third moment across it.
  struct Shape {
    double axis_rad = 0.0;
    double along = 0.0;   // skewness along the axis, > 0 after turning
    double across = 0.0;  // skewness across it, + = the long tail on the left
  };
  const auto shape_of = [](const cv::Moments& mo) {
    const double area = std::abs(mo.m00);
    const double mu20 = mo.mu20 / area, mu11 = mo.mu11 / area, mu02 = mo.mu02 / area;
    const double mu30 = mo.mu30 / area, mu21 = mo.mu21 / area, mu12 = mo.mu12 / area;
    const double mu03 = mo.mu03 / area;
    Shape shape;
    shape.axis_rad = 0.5 * std::atan2(2.0 * mu11, mu20 - mu02);
    const double c = std::cos(shape.axis_rad), s = std::sin(shape.axis_rad);
    const double var_u = c * c * mu20 + 2 * c * s * mu11 + s * s * mu02;
    const double var_v = s * s * mu20 - 2 * c * s * mu11 + c * c * mu02;
    const double m_uuu =
        c * c * c * mu30 + 3 * c * c * s * mu21 + 3 * c * s * s * mu12 + s * s * s * mu03;
    const double m_vvv =
        -s * s * s * mu30 + 3 * s * s * c * mu21 - 3 * s * c * c * mu12 + c * c * c * mu03;
    shape.along = m_uuu / std::pow(std::max(var_u, 1e-12), 1.5);
    shape.across = m_vvv / std::pow(std::max(var_v, 1e-12), 1.5);
    if (shape.along < 0.0) {  // the long tail points at the tip
      shape.axis_rad += std::numbers::pi;
      shape.along = -shape.along;
      shape.across = -shape.across;
    }
    return shape;
  };
  const Shape raw = shape_of(m);

  // The outline straightened along its fitted arc (item 6b): a limp fillet lies bent, and the
  // thick end, the bulge, the singulation and the pose are read on its straight shape.
  AxisArc arc = fit_axis_arc(contour_mm, {cx, cy}, raw.axis_rad, params_.bend_fit_passes, params_,
                             work_mm_per_px);
  std::vector<cv::Point2f> straight(arc.contour.begin(), arc.contour.end());
  cv::Moments ms = cv::moments(straight);
  if (!(std::abs(std::abs(ms.m00) - f.area_mm2) <= 0.05 * f.area_mm2)) {
    // A fit that folds the outline over itself (not a single bent fillet): read it unbent.
    arc = fit_axis_arc(contour_mm, {cx, cy}, raw.axis_rad, 0, params_, work_mm_per_px);
    straight.assign(arc.contour.begin(), arc.contour.end());
    ms = cv::moments(straight);
  }
  f.bend_per_mm = arc.curvature_per_mm;
  const Shape shape = shape_of(ms);
  f.axis_skewness = shape.along;
  f.bulge_skewness = shape.across;
  const bool bulge_left = shape.across > 0.0;

  // Singulation, on the straightened outline: a bent single is as convex as a straight one.
  std::vector<int> hull_indices;
  cv::convexHull(straight, hull_indices, false, false);
  std::vector<cv::Point2f> hull;
  hull.reserve(hull_indices.size());
  for (int i : hull_indices) hull.push_back(straight[static_cast<std::size_t>(i)]);
  const double hull_area = cv::contourArea(hull);
  f.solidity = hull_area > 0.0 ? std::abs(ms.m00) / hull_area : 0.0;
  f.max_defect_depth_mm = deepest_defect(arc.contour, hull_indices);
  const double area_margin =
      std::min((f.area_mm2 - params_.min_single_area_mm2) / (0.1 * params_.min_single_area_mm2),
               (params_.max_single_area_mm2 - f.area_mm2) / (0.1 * params_.max_single_area_mm2));
  const double solidity_margin = (f.solidity - params_.min_solidity) / 0.03;
  const double defect_margin =
      (params_.max_defect_depth_mm - f.max_defect_depth_mm) / (0.3 * params_.max_defect_depth_mm);
  const double singulation_margin = std::min({area_margin, solidity_margin, defect_margin});
  const bool singulated = singulation_margin > 0.0;

  // Side: colour and texture over the blob's interior (eroded ~3 mm from the edge, where the
  // translucent rim mixes in the belt colour).
  const cv::Rect box = cv::boundingRect(contour);
  interior_.create(box.size(), CV_8UC1);
  interior_.setTo(0);
  cv::drawContours(interior_, std::vector<std::vector<cv::Point>>{contour}, 0, cv::Scalar(255),
                   cv::FILLED, cv::LINE_8, cv::noArray(), 0, -box.tl());
  if (interior_erosion_runs_.empty()) {
    cv::erode(interior_, eroded_, interior_erosion_);
  } else {
    detail::erode_by_centred_runs(interior_, interior_erosion_runs_, erosion_padded_,
                                  erosion_run_minima_, eroded_);
  }
  // Colour and brightness means over the interior in one pass instead of masked cv::mean
  // calls: integer sums as cv::mean keeps them, and the mean is the sum times 1 / count as
  // there.
  std::int64_t sum_green = 0, sum_red = 0, sum_grey = 0, count = 0;
  for (int row = 0; row < box.height; ++row) {
    const auto* inside = eroded_.ptr<std::uint8_t>(row);
    const auto* grey = grey_.ptr<std::uint8_t>(box.y + row) + box.x;
    // Green and red from their planes (a frame halved in the colour pass) or from the
    // interleaved working image.
    const std::uint8_t* green = nullptr;
    const std::uint8_t* red = nullptr;
    int pixel_step = 1;
    if (halved_in_colour_pass_) {
      green = work_green_.ptr<std::uint8_t>(box.y + row) + box.x;
      red = work_red_.ptr<std::uint8_t>(box.y + row) + box.x;
    } else {
      const auto* bgr = work_bgr_.ptr<std::uint8_t>(box.y + row) + 3 * box.x;
      green = bgr + 1;
      red = bgr + 2;
      pixel_step = 3;
    }
    for (int col = 0; col < box.width; ++col) {
      if (inside[col] == 0) continue;
      sum_green += green[pixel_step * col];
      sum_red += red[pixel_step * col];
      sum_grey += grey[col];
      ++count;
    }
  }
  // Texture: a band-pass in belt millimetres (EstimatorParams) on the box area-averaged to the
  // texture scale, so that every camera measures it on pixels of about the same size (and the
  // blurs run on a quarter of the pixels at 640 x 480). Only texture pixels wholly inside the
  // eroded interior count. The fine blur suppresses per-pixel noise.
  grey_(box).convertTo(grey_box_, CV_32F);
  const cv::Mat* texture_grey = &grey_box_;
  const cv::Mat* texture_inside = &eroded_;
  if (texture_downscale_ > 1) {
    // Whole blocks only (the box's last row or column may be dropped), so each texture pixel
    // is the mean of exactly t x t working pixels.
    const int t = texture_downscale_;
    const cv::Size reduced(std::max(1, box.width / t), std::max(1, box.height / t));
    const cv::Rect blocks(0, 0, std::min(box.width, reduced.width * t),
                          std::min(box.height, reduced.height * t));
    cv::resize(grey_box_(blocks), texture_grey_, reduced, 0, 0, cv::INTER_AREA);
    cv::resize(eroded_(blocks), texture_inside_, reduced, 0, 0, cv::INTER_AREA);
    texture_grey = &texture_grey_;
    texture_inside = &texture_inside_;
  }
  cv::GaussianBlur(*texture_grey, fine_, cv::Size(0, 0), texture_fine_sigma_px_);
  cv::GaussianBlur(*texture_grey, coarse_, cv::Size(0, 0), texture_coarse_sigma_px_);
  double sum_detail = 0.0;
  std::int64_t texture_count = 0;
  for (int row = 0; row < texture_grey->rows; ++row) {
    const auto* inside = texture_inside->ptr<std::uint8_t>(row);
    const auto* fine = fine_.ptr<float>(row);
    const auto* coarse = coarse_.ptr<float>(row);
    for (int col = 0; col < texture_grey->cols; ++col) {
      if (inside[col] != 255) continue;
      sum_detail += static_cast<double>(std::abs(fine[col] - coarse[col]));
      ++texture_count;
    }
  }
  const double per_pixel = count > 0 ? 1.0 / static_cast<double>(count) : 0.0;
  const double mean_green = static_cast<double>(sum_green) * per_pixel;
  const double mean_red = static_cast<double>(sum_red) * per_pixel;
  f.redness = mean_red > 1.0 ? (mean_red - mean_green) / mean_red : 0.0;
  const double mean_grey = static_cast<double>(sum_grey) * per_pixel;
  f.texture = mean_grey > 1.0 && texture_count > 0
                  ? sum_detail / static_cast<double>(texture_count) / mean_grey
                  : 0.0;
  f.side_score = params_.w_redness * (f.redness - params_.redness_mid) / params_.redness_scale +
                 params_.w_texture * (f.texture - params_.texture_mid) / params_.texture_scale;
  const bool bone_up = f.side_score > 0.0;

  FilletEstimate& e = blob.estimate;
  e.x_mm = static_cast<float>(cx);
  e.y_mm = static_cast<float>(cy);
  e.singulated = singulated;
  if (singulated) {
    // The pose in the straightened frame, then laid back on the arc: the heading there is the
    // straight heading turned by the arc up to that point.
    const double bulge_sign = bulge_left ? 1.0 : -1.0;
    const double corrected = shape.axis_rad + bulge_sign * params_.axis_bias_rad;
    // From the silhouette's area centroid to the fillet's volume centroid (shape model).
    const double c = std::cos(corrected), s = std::sin(corrected);
    const double offset_along = params_.pose_offset_along_mm;
    const double toward_bulge = bulge_sign * params_.pose_offset_toward_bulge_mm;
    const cv::Point2d pose_straight(ms.m10 / ms.m00 + c * offset_along - s * toward_bulge,
                                    ms.m01 / ms.m00 + s * offset_along + c * toward_bulge);
    const cv::Point2d pose =
        from_axis_frame(lay_on_arc(pose_straight, arc.curvature_per_mm), arc.origin, arc.axis_rad);
    e.angle_rad = wrap_angle(arc.axis_rad + corrected + arc.curvature_per_mm * pose_straight.x);
    e.x_mm = static_cast<float>(pose.x);
    e.y_mm = static_cast<float>(pose.y);
    e.side = bone_up ? SideUp::kBone : SideUp::kSkin;
    e.hand = (bulge_left != bone_up) ? Hand::kLeft : Hand::kRight;
    e.confidence = static_cast<float>(std::min(
        {clamp01(shape.along / params_.sure_thick_end_skewness),
         clamp01(std::abs(shape.across) / params_.sure_bulge_skewness),
         clamp01(std::abs(f.side_score) / params_.sure_side_score), clamp01(singulation_margin)}));
  } else {
    e.angle_rad = wrap_angle(raw.axis_rad);
    e.confidence = static_cast<float>(clamp01(-singulation_margin));
  }
  blob.status = BlobStatus::kFillet;
  return blob;
}

}  // namespace fl::vision
