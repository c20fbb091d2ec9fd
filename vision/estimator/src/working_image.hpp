// The estimator's working image: row kernels for its luma and chroma, and the segmentation
// of the meat. Each gives the same bits as the OpenCV calls it replaces (tested), so estimates
// do not move; the kernels cost about a quarter less than cv::cvtColor plus a chroma loop on
// interleaved pixels, and the segmentation runs on the meat's box, not the frame. Internal to
// fl_vision.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace fl::vision::detail {

// One BGR row into planes.
void split_bgr_row(const std::uint8_t* bgr, int cols, std::uint8_t* blue, std::uint8_t* green,
                   std::uint8_t* red);

// Two BGR rows of 2 * `out_cols` pixels averaged 2 x 2 into planes of `out_cols`: each output
// is (a + b + c + d + 2) >> 2, as cv::resize(INTER_AREA) computes an exact halving, without
// the interleaved half-size image between.
// AVX2 where the CPU runs it (byte shuffles and pair sums: about 75 operations per 16 outputs
// against the portable 128-bit code's 130), chosen at run time; kPortable forces the portable
// code (tests).
enum class HalvingCode { kFastest, kPortable };
void halve_bgr_rows(const std::uint8_t* top, const std::uint8_t* bottom, int out_cols,
                    std::uint8_t* blue, std::uint8_t* green, std::uint8_t* red,
                    HalvingCode code = HalvingCode::kFastest);
// Whether kFastest runs the AVX2 code on this CPU.
bool halving_has_avx2();

// Luma as cv::cvtColor(COLOR_BGR2GRAY) computes it for 8-bit pixels: 15-bit fixed point,
// (3735 B + 19235 G + 9798 R + 2^14) >> 15.
void grey_row(const std::uint8_t* blue, const std::uint8_t* green, const std::uint8_t* red,
              int cols, std::uint8_t* grey);

// Chroma 128 + (R - B) / 2, rounded half to even and saturated at 255, as cv::transform with
// the float matrix (0.5, -0.5, 128) computes it.
void chroma_row(const std::uint8_t* blue, const std::uint8_t* red, int cols, std::uint8_t* chroma);

// The rectangle grown by `reach_px` on every side, clipped to the image: the region an
// operator of that reach can change or read around `rect`.
cv::Rect grown(const cv::Rect& rect, int reach_px, const cv::Size& image);

// The box of the pixels above `threshold`, from the largest value of each row and of each
// column (empty when there are none).
cv::Rect box_above(const std::vector<std::uint8_t>& row_max,
                   const std::vector<std::uint8_t>& column_max, int threshold);

// The meat mask of an 8-bit chroma image and its outer contours (every point, external only):
// chroma above `threshold`, opened by a 3 x 3 ellipse against specks, closed by a 5 x 5
// ellipse against cracks. Each step runs on `above` (box_above's box) grown by what the
// operator reads; outside it the mask is zero, so mask and contours are the whole frame's.
void segment_meat(const cv::Mat& chroma, int threshold, const cv::Rect& above, cv::Mat& mask,
                  cv::Mat& scratch, std::vector<std::vector<cv::Point>>& contours);

// Erosion by a structuring element whose rows are each one run of pixels centred on its middle
// column (an ellipse, a rectangle, a cross), with cv::erode's default border (the outside
// counts as 255): the same bits as cv::erode, in a few operations per pixel instead of one per
// element pixel. The minimum over each row's run comes from the next narrower run's and two
// more pixels; then the rows' minima are taken down the element.
//
// The element's row half widths, or empty when it is not of that kind (cv::erode then).
std::vector<int> centred_run_half_widths(const cv::Mat& element);
// `half_widths` from centred_run_half_widths, not empty; `padded` and `run_minima` are scratch.
void erode_by_centred_runs(const cv::Mat& src, const std::vector<int>& half_widths, cv::Mat& padded,
                           cv::Mat& run_minima, cv::Mat& dst);

}  // namespace fl::vision::detail
