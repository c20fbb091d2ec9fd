// Row kernels of the working image (working_image.hpp). Universal intrinsics where GCC leaves
// a loop scalar (3-channel strides, 32-bit products of 8-bit lanes); each loop has a scalar
// tail with the same arithmetic.
#include "working_image.hpp"

#include <algorithm>
#include <cstdlib>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

namespace fl::vision::detail {
namespace {

// cv::cvtColor's 8-bit luma weights (15-bit fixed point; they sum to 2^15).
constexpr int kBlueWeight = 3735;
constexpr int kGreenWeight = 19235;
constexpr int kRedWeight = 9798;
constexpr int kLumaShift = 15;

#if CV_SIMD128
// Luma of eight pixels given as 16-bit lanes.
inline cv::v_int16x8 luma8(const cv::v_uint16x8& blue, const cv::v_uint16x8& green,
                           const cv::v_uint16x8& red) {
  const cv::v_int16x8 blue_green_weights(kBlueWeight, kGreenWeight, kBlueWeight, kGreenWeight,
                                         kBlueWeight, kGreenWeight, kBlueWeight, kGreenWeight);
  const cv::v_int16x8 red_round_weights(kRedWeight, 1 << (kLumaShift - 1), kRedWeight,
                                        1 << (kLumaShift - 1), kRedWeight, 1 << (kLumaShift - 1),
                                        kRedWeight, 1 << (kLumaShift - 1));
  cv::v_int16x8 blue_green_low, blue_green_high, red_one_low, red_one_high;
  cv::v_zip(cv::v_reinterpret_as_s16(blue), cv::v_reinterpret_as_s16(green), blue_green_low,
            blue_green_high);
  cv::v_zip(cv::v_reinterpret_as_s16(red), cv::v_setall_s16(1), red_one_low, red_one_high);
  const cv::v_int32x4 low = cv::v_dotprod(blue_green_low, blue_green_weights) +
                            cv::v_dotprod(red_one_low, red_round_weights);
  const cv::v_int32x4 high = cv::v_dotprod(blue_green_high, blue_green_weights) +
                             cv::v_dotprod(red_one_high, red_round_weights);
  return cv::v_pack(low >> kLumaShift, high >> kLumaShift);
}

// 2 * chroma = 256 + R - B in 16-bit lanes, halved with ties to the even neighbour.
inline cv::v_int16x8 chroma8(const cv::v_uint16x8& red, const cv::v_uint16x8& blue) {
  const cv::v_int16x8 twice =
      cv::v_reinterpret_as_s16(red) - cv::v_reinterpret_as_s16(blue) + cv::v_setall_s16(256);
  return (twice + ((twice >> 1) & cv::v_setall_s16(1))) >> 1;
}
#endif

}  // namespace

cv::Rect grown(const cv::Rect& rect, int reach_px, const cv::Size& image) {
  return cv::Rect(rect.x - reach_px, rect.y - reach_px, rect.width + 2 * reach_px,
                  rect.height + 2 * reach_px) &
         cv::Rect(0, 0, image.width, image.height);
}

void split_bgr_row(const std::uint8_t* bgr, int cols, std::uint8_t* blue, std::uint8_t* green,
                   std::uint8_t* red) {
  int col = 0;
#if CV_SIMD128
  for (; col + 16 <= cols; col += 16) {
    cv::v_uint8x16 b, g, r;
    cv::v_load_deinterleave(bgr + 3 * col, b, g, r);
    cv::v_store(blue + col, b);
    cv::v_store(green + col, g);
    cv::v_store(red + col, r);
  }
#endif
  for (; col < cols; ++col) {
    blue[col] = bgr[3 * col];
    green[col] = bgr[3 * col + 1];
    red[col] = bgr[3 * col + 2];
  }
}

void grey_row(const std::uint8_t* blue, const std::uint8_t* green, const std::uint8_t* red,
              int cols, std::uint8_t* grey) {
  int col = 0;
#if CV_SIMD128
  for (; col + 16 <= cols; col += 16) {
    cv::v_uint16x8 b[2], g[2], r[2];
    cv::v_expand(cv::v_load(blue + col), b[0], b[1]);
    cv::v_expand(cv::v_load(green + col), g[0], g[1]);
    cv::v_expand(cv::v_load(red + col), r[0], r[1]);
    cv::v_store(grey + col, cv::v_pack_u(luma8(b[0], g[0], r[0]), luma8(b[1], g[1], r[1])));
  }
#endif
  for (; col < cols; ++col) {
    grey[col] = static_cast<std::uint8_t>((kBlueWeight * blue[col] + kGreenWeight * green[col] +
                                           kRedWeight * red[col] + (1 << (kLumaShift - 1))) >>
                                          kLumaShift);
  }
}

void chroma_row(const std::uint8_t* blue, const std::uint8_t* red, int cols, std::uint8_t* chroma) {
  int col = 0;
#if CV_SIMD128
  for (; col + 16 <= cols; col += 16) {
    cv::v_uint16x8 b[2], r[2];
    cv::v_expand(cv::v_load(blue + col), b[0], b[1]);
    cv::v_expand(cv::v_load(red + col), r[0], r[1]);
    cv::v_store(chroma + col, cv::v_pack_u(chroma8(r[0], b[0]), chroma8(r[1], b[1])));
  }
#endif
  for (; col < cols; ++col) {
    // twice_chroma = 256 + R - B in 1..511; half of it, ties to the even neighbour.
    const int twice_chroma = 256 + red[col] - blue[col];
    const int value = (twice_chroma + ((twice_chroma >> 1) & 1)) >> 1;
    chroma[col] = static_cast<std::uint8_t>(value > 255 ? 255 : value);
  }
}

cv::Rect box_above(const std::vector<std::uint8_t>& row_max,
                   const std::vector<std::uint8_t>& column_max, int threshold) {
  const auto above = [threshold](std::uint8_t value) { return value > threshold; };
  const auto first_row = std::find_if(row_max.begin(), row_max.end(), above);
  const auto first_col = std::find_if(column_max.begin(), column_max.end(), above);
  if (first_row == row_max.end() || first_col == column_max.end()) return {};
  const auto last_row = std::find_if(row_max.rbegin(), row_max.rend(), above);
  const auto last_col = std::find_if(column_max.rbegin(), column_max.rend(), above);
  const auto top = static_cast<int>(first_row - row_max.begin());
  const auto bottom = static_cast<int>(row_max.rend() - last_row);  // one past the last
  const auto left = static_cast<int>(first_col - column_max.begin());
  const auto right = static_cast<int>(column_max.rend() - last_col);
  return {left, top, right - left, bottom - top};
}

void segment_meat(const cv::Mat& chroma, int threshold, const cv::Rect& above, cv::Mat& mask,
                  cv::Mat& scratch, std::vector<std::vector<cv::Point>>& contours) {
  static const cv::Mat kOpen = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  static const cv::Mat kClose = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  mask.create(chroma.size(), CV_8UC1);
  mask.setTo(0);
  contours.clear();
  // The opening reads one pixel around each pixel it keeps: two rows and columns of zeros
  // around the thresholded box make it the whole frame's.
  const cv::Rect open_roi =
      grown(above & cv::Rect(0, 0, chroma.cols, chroma.rows), kOpen.cols - 1, mask.size());
  if (open_roi.empty()) return;
  cv::threshold(chroma(open_roi), mask(open_roi), threshold, 255, cv::THRESH_BINARY);
  cv::morphologyEx(mask(open_roi), mask(open_roi), cv::MORPH_OPEN, kOpen);
  const cv::Rect opened = cv::boundingRect(mask(open_roi)) + open_roi.tl();
  if (opened.empty()) return;
  // Closing only adds pixels within its radius of the foreground, and reads 2 radii around
  // them: on the foreground's box grown by twice the radius the result is the full frame's.
  const cv::Rect close_roi = grown(opened, kClose.cols - 1, mask.size());
  cv::morphologyEx(mask(close_roi), scratch, cv::MORPH_CLOSE, kClose);
  scratch.copyTo(mask(close_roi));
  // The closed mask lies within the closing's radius of the opened box (outside it only at the
  // frame's edges, where the erosion takes the outside for meat), so the contours traced on
  // the closing's box, with zeros or the frame's edge around them, are the whole frame's.
  cv::findContours(mask(close_roi), contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE,
                   close_roi.tl());
}

std::vector<int> centred_run_half_widths(const cv::Mat& element) {
  if (element.empty() || element.type() != CV_8UC1 || element.rows % 2 == 0 ||
      element.cols % 2 == 0) {
    return {};
  }
  const int centre = element.cols / 2;
  std::vector<int> half_widths;
  for (int row = 0; row < element.rows; ++row) {
    const auto* pixels = element.ptr<std::uint8_t>(row);
    int half_width = -1;
    while (half_width < centre && pixels[centre + half_width + 1] != 0 &&
           pixels[centre - half_width - 1] != 0) {
      ++half_width;
    }
    // The run must not be empty, and every pixel of the row must be inside it.
    if (half_width < 0) return {};
    for (int col = 0; col < element.cols; ++col) {
      const bool in_run = half_width >= 0 && std::abs(col - centre) <= half_width;
      if ((pixels[col] != 0) != in_run) return {};
    }
    half_widths.push_back(half_width);
  }
  return half_widths;
}

void erode_by_centred_runs(const cv::Mat& src, const std::vector<int>& half_widths, cv::Mat& padded,
                           cv::Mat& run_minima, cv::Mat& dst) {
  CV_Assert(src.type() == CV_8UC1 && !half_widths.empty() && half_widths.size() % 2 == 1);
  const int reach_rows = static_cast<int>(half_widths.size()) / 2;
  const int reach_cols = *std::max_element(half_widths.begin(), half_widths.end());
  const int cols = src.cols;
  // Rows above and below the image are all 255 and change no minimum, so only the columns are
  // padded.
  padded.create(src.rows, cols + 2 * reach_cols, CV_8UC1);
  padded.setTo(255);
  src.copyTo(padded(cv::Rect(reach_cols, 0, cols, src.rows)));
  run_minima.create(reach_cols + 1, cols, CV_8UC1);  // one image row's, per half width
  dst.create(src.size(), CV_8UC1);
  dst.setTo(255);
  for (int row = 0; row < src.rows; ++row) {
    const std::uint8_t* in = padded.ptr<std::uint8_t>(row) + reach_cols;
    std::copy(in, in + cols, run_minima.ptr<std::uint8_t>(0));
    for (int k = 1; k <= reach_cols; ++k) {
      const std::uint8_t* narrower = run_minima.ptr<std::uint8_t>(k - 1);
      std::uint8_t* wider = run_minima.ptr<std::uint8_t>(k);
      for (int col = 0; col < cols; ++col) {
        wider[col] = std::min(narrower[col], std::min(in[col - k], in[col + k]));
      }
    }
    // This image row is element row e of output row (row + reach_rows - e).
    for (std::size_t element_row = 0; element_row < half_widths.size(); ++element_row) {
      const int out_row = row + reach_rows - static_cast<int>(element_row);
      if (out_row < 0 || out_row >= src.rows) continue;
      std::uint8_t* out = dst.ptr<std::uint8_t>(out_row);
      const std::uint8_t* minima = run_minima.ptr<std::uint8_t>(half_widths[element_row]);
      for (int col = 0; col < cols; ++col) out[col] = std::min(out[col], minima[col]);
    }
  }
}

}  // namespace fl::vision::detail
