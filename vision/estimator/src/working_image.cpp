// Row kernels of the working image (working_image.hpp). Universal intrinsics where GCC leaves
// a loop scalar (3-channel strides, 32-bit products of 8-bit lanes); each loop has a scalar
// tail with the same arithmetic.
#include "working_image.hpp"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <opencv2/core/hal/intrin.hpp>
#include <opencv2/imgproc.hpp>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

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

// Sums of horizontally adjacent pixels of two rows: lane k of the result is
// top[2k] + top[2k + 1] + bottom[2k] + bottom[2k + 1].
inline cv::v_uint16x8 pair_sums(const cv::v_uint8x16& top, const cv::v_uint8x16& bottom) {
  const cv::v_uint16x8 low_byte = cv::v_setall_u16(0xFF);
  const cv::v_uint16x8 t = cv::v_reinterpret_as_u16(top);
  const cv::v_uint16x8 b = cv::v_reinterpret_as_u16(bottom);
  return (t & low_byte) + (t >> 8) + (b & low_byte) + (b >> 8);
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
  std::ptrdiff_t col = 0;  // a pointer offset: 3 * col must not overflow int
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

namespace {

// The scalar halving of output pixels [col, out_cols).
void halve_tail(const std::uint8_t* top, const std::uint8_t* bottom, std::ptrdiff_t col,
                int out_cols, std::uint8_t* blue, std::uint8_t* green, std::uint8_t* red) {
  for (; col < out_cols; ++col) {
    const std::uint8_t* t = top + 6 * col;
    const std::uint8_t* b = bottom + 6 * col;
    blue[col] = static_cast<std::uint8_t>((t[0] + t[3] + b[0] + b[3] + 2) >> 2);
    green[col] = static_cast<std::uint8_t>((t[1] + t[4] + b[1] + b[4] + 2) >> 2);
    red[col] = static_cast<std::uint8_t>((t[2] + t[5] + b[2] + b[5] + 2) >> 2);
  }
}

#if defined(__x86_64__)
// The AVX2 helpers below take and return 256-bit vectors but are all forced inline into the
// one AVX2 function, so the calling convention GCC warns about never applies.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

// Byte shuffles for the AVX2 halving. A 128-bit lane holds 16 of a group's 48 bytes (8 pixel
// pairs, BGR BGR); shuffle 3 * channel + part moves channel's bytes of pair k that lie in the
// group's part-th 16 bytes to bytes 2k and 2k + 1 of the lane, and zeroes the rest (index with
// the top bit set). Both lanes use the same table.
constexpr std::array<std::array<std::int8_t, 32>, 9> halving_shuffles() {
  std::array<std::array<std::int8_t, 32>, 9> shuffles{};
  for (std::size_t channel = 0; channel < 3; ++channel) {
    for (std::size_t part = 0; part < 3; ++part) {
      auto& shuffle = shuffles[3 * channel + part];
      for (std::size_t pair = 0; pair < 8; ++pair) {
        for (std::size_t pixel = 0; pixel < 2; ++pixel) {
          const std::size_t source = 6 * pair + 3 * pixel + channel;
          const auto index =
              static_cast<std::int8_t>(source / 16 == part ? static_cast<int>(source % 16) : -128);
          shuffle[2 * pair + pixel] = index;
          shuffle[16 + 2 * pair + pixel] = index;
        }
      }
    }
  }
  return shuffles;
}
constexpr auto kHalvingShuffles = halving_shuffles();

// A 16-byte part of both 48-byte groups of a row, the first group's in lane 0.
__attribute__((target("avx2"), always_inline)) inline __m256i group_parts(const std::uint8_t* row,
                                                                          std::size_t part) {
  const __m128i first = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + 16 * part));
  const __m128i second = _mm_loadu_si128(reinterpret_cast<const __m128i*>(row + 48 + 16 * part));
  return _mm256_inserti128_si256(_mm256_castsi128_si256(first), second, 1);
}

// One row's horizontal pair sums of 16 output pixels per channel, as 16-bit lanes: lane 0
// holds the group at bytes 0..47 (outputs 0..7), lane 1 the group at 48..95 (outputs 8..15).
__attribute__((target("avx2"), always_inline)) inline void row_pair_sums(const std::uint8_t* row,
                                                                         __m256i (&sums)[3]) {
  const __m256i parts[3] = {group_parts(row, 0), group_parts(row, 1), group_parts(row, 2)};
  const __m256i ones = _mm256_set1_epi8(1);
  for (std::size_t channel = 0; channel < 3; ++channel) {
    __m256i gathered = _mm256_setzero_si256();
    for (std::size_t part = 0; part < 3; ++part) {
      const __m256i shuffle = _mm256_loadu_si256(
          reinterpret_cast<const __m256i*>(kHalvingShuffles[3 * channel + part].data()));
      gathered = _mm256_or_si256(gathered, _mm256_shuffle_epi8(parts[part], shuffle));
    }
    sums[channel] = _mm256_maddubs_epi16(gathered, ones);  // byte pairs: 2 pixels, one channel
  }
}

__attribute__((target("avx2"))) void halve_avx2(const std::uint8_t* top, const std::uint8_t* bottom,
                                                int out_cols, std::uint8_t* blue,
                                                std::uint8_t* green, std::uint8_t* red) {
  std::uint8_t* const planes[3] = {blue, green, red};
  const __m256i rounding = _mm256_set1_epi16(2);
  std::ptrdiff_t col = 0;
  for (; col + 16 <= out_cols; col += 16) {
    __m256i top_sums[3], bottom_sums[3];
    row_pair_sums(top + 6 * col, top_sums);
    row_pair_sums(bottom + 6 * col, bottom_sums);
    for (int channel = 0; channel < 3; ++channel) {
      const __m256i mean = _mm256_srli_epi16(
          _mm256_add_epi16(_mm256_add_epi16(top_sums[channel], bottom_sums[channel]), rounding), 2);
      _mm_storeu_si128(
          reinterpret_cast<__m128i*>(planes[channel] + col),
          _mm_packus_epi16(_mm256_castsi256_si128(mean), _mm256_extracti128_si256(mean, 1)));
    }
  }
  halve_tail(top, bottom, col, out_cols, blue, green, red);
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

bool cpu_runs_avx2() {
  static const bool runs = __builtin_cpu_supports("avx2") != 0;
  return runs;
}
#endif

void halve_portable(const std::uint8_t* top, const std::uint8_t* bottom, int out_cols,
                    std::uint8_t* blue, std::uint8_t* green, std::uint8_t* red) {
  std::ptrdiff_t col = 0;
#if CV_SIMD128
  // 16 outputs from 96 bytes of each row.
  for (; col + 16 <= out_cols; col += 16) {
    cv::v_uint8x16 top_b[2], top_g[2], top_r[2], bottom_b[2], bottom_g[2], bottom_r[2];
    for (std::ptrdiff_t half = 0; half < 2; ++half) {
      cv::v_load_deinterleave(top + 6 * col + 48 * half, top_b[half], top_g[half], top_r[half]);
      cv::v_load_deinterleave(bottom + 6 * col + 48 * half, bottom_b[half], bottom_g[half],
                              bottom_r[half]);
    }
    cv::v_store(blue + col, cv::v_rshr_pack<2>(pair_sums(top_b[0], bottom_b[0]),
                                               pair_sums(top_b[1], bottom_b[1])));
    cv::v_store(green + col, cv::v_rshr_pack<2>(pair_sums(top_g[0], bottom_g[0]),
                                                pair_sums(top_g[1], bottom_g[1])));
    cv::v_store(red + col, cv::v_rshr_pack<2>(pair_sums(top_r[0], bottom_r[0]),
                                              pair_sums(top_r[1], bottom_r[1])));
  }
#endif
  halve_tail(top, bottom, col, out_cols, blue, green, red);
}

}  // namespace

bool halving_has_avx2() {
#if defined(__x86_64__)
  return cpu_runs_avx2();
#else
  return false;
#endif
}

void halve_bgr_rows(const std::uint8_t* top, const std::uint8_t* bottom, int out_cols,
                    std::uint8_t* blue, std::uint8_t* green, std::uint8_t* red, HalvingCode code) {
#if defined(__x86_64__)
  if (code != HalvingCode::kPortable && cpu_runs_avx2()) {
    halve_avx2(top, bottom, out_cols, blue, green, red);
    return;
  }
#endif
  halve_portable(top, bottom, out_cols, blue, green, red);
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
  static const cv::Mat open_element = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  static const cv::Mat close_element = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  mask.create(chroma.size(), CV_8UC1);
  mask.setTo(0);
  contours.clear();
  // The opening reads one pixel around each pixel it keeps: two rows and columns of zeros
  // around the thresholded box make it the whole frame's.
  const cv::Rect open_roi =
      grown(above & cv::Rect(0, 0, chroma.cols, chroma.rows), open_element.cols - 1, mask.size());
  if (open_roi.empty()) return;
  cv::threshold(chroma(open_roi), mask(open_roi), threshold, 255, cv::THRESH_BINARY);
  cv::morphologyEx(mask(open_roi), mask(open_roi), cv::MORPH_OPEN, open_element);
  const cv::Rect opened = cv::boundingRect(mask(open_roi)) + open_roi.tl();
  if (opened.empty()) return;
  // Closing only adds pixels within its radius of the foreground, and reads 2 radii around
  // them: on the foreground's box grown by twice the radius the result is the full frame's.
  const cv::Rect close_roi = grown(opened, close_element.cols - 1, mask.size());
  cv::morphologyEx(mask(close_roi), scratch, cv::MORPH_CLOSE, close_element);
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
