#include "png_decode.hpp"

#include <libdeflate.h>

#include <array>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace fl::vision::record::detail {
namespace {

constexpr std::array<std::uint8_t, 8> kSignature{0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 26;  // 8192 x 8192
constexpr std::size_t kMaxDeflateRatio = 1032;

std::uint32_t read_be32(const std::uint8_t* bytes) {
  return (std::uint32_t{bytes[0]} << 24) | (std::uint32_t{bytes[1]} << 16) |
         (std::uint32_t{bytes[2]} << 8) | std::uint32_t{bytes[3]};
}

struct DecompressorDeleter {
  void operator()(libdeflate_decompressor* decompressor) const {
    libdeflate_free_decompressor(decompressor);
  }
};

// One per thread: replay decodes frames on every core.
libdeflate_decompressor* thread_decompressor() {
  thread_local const std::unique_ptr<libdeflate_decompressor, DecompressorDeleter> decompressor(
      libdeflate_alloc_decompressor());
  return decompressor.get();
}

std::uint8_t paeth(int left, int up, int up_left) {
  const int estimate = left + up - up_left;
  const int to_left = std::abs(estimate - left);
  const int to_up = std::abs(estimate - up);
  const int to_up_left = std::abs(estimate - up_left);
  if (to_left <= to_up && to_left <= to_up_left) return static_cast<std::uint8_t>(left);
  if (to_up <= to_up_left) return static_cast<std::uint8_t>(up);
  return static_cast<std::uint8_t>(up_left);
}

// Reverses one row's filter (PNG specification, section 9) in place; `previous` is the row
// above, already unfiltered (zeros for the first row). False for an unknown filter type.
bool unfilter_row(std::uint8_t filter, std::uint8_t* row, const std::uint8_t* previous,
                  std::size_t length, std::size_t pixel_bytes) {
  switch (filter) {
    case 0:  // None
      return true;
    case 1:  // Sub
      for (std::size_t i = pixel_bytes; i < length; ++i) {
        row[i] = static_cast<std::uint8_t>(row[i] + row[i - pixel_bytes]);
      }
      return true;
    case 2:  // Up
      for (std::size_t i = 0; i < length; ++i) {
        row[i] = static_cast<std::uint8_t>(row[i] + previous[i]);
      }
      return true;
    case 3:  // Average
      for (std::size_t i = 0; i < length; ++i) {
        const int left = i >= pixel_bytes ? row[i - pixel_bytes] : 0;
        row[i] = static_cast<std::uint8_t>(row[i] + ((left + previous[i]) >> 1));
      }
      return true;
    case 4:  // Paeth
      for (std::size_t i = 0; i < pixel_bytes && i < length; ++i) {
        row[i] = static_cast<std::uint8_t>(row[i] + previous[i]);  // paeth(0, up, 0) is up
      }
      for (std::size_t i = pixel_bytes; i < length; ++i) {
        row[i] = static_cast<std::uint8_t>(
            row[i] + paeth(row[i - pixel_bytes], previous[i], previous[i - pixel_bytes]));
      }
      return true;
    default:
      return false;
  }
}

}  // namespace

std::optional<cv::Mat> decode_png_fast(std::span<const std::uint8_t> png) {
  if (png.size() < kSignature.size() ||
      std::memcmp(png.data(), kSignature.data(), kSignature.size()) != 0) {
    return std::nullopt;
  }
  std::size_t width = 0;
  std::size_t height = 0;
  std::size_t channels = 0;
  std::vector<std::uint8_t> compressed;
  bool have_header = false;
  bool ended = false;
  std::size_t at = kSignature.size();
  while (!ended) {
    if (png.size() - at < 12) return std::nullopt;  // length, type and CRC at least
    const std::size_t length = read_be32(png.data() + at);
    if (length > png.size() - at - 12) return std::nullopt;
    const std::uint8_t* type = png.data() + at + 4;
    const std::uint8_t* data = type + 4;
    const std::uint32_t stored_crc = read_be32(data + length);
    if (libdeflate_crc32(0, type, length + 4) != stored_crc) return std::nullopt;
    at += length + 12;
    if (std::memcmp(type, "IHDR", 4) == 0) {
      if (have_header || length != 13) return std::nullopt;
      width = read_be32(data);
      height = read_be32(data + 4);
      const std::uint8_t bit_depth = data[8];
      const std::uint8_t colour_type = data[9];
      // compression 0, filter method 0, no interlacing; 8-bit grey (0) or RGB (2).
      if (bit_depth != 8 || (colour_type != 0 && colour_type != 2) || data[10] != 0 ||
          data[11] != 0 || data[12] != 0) {
        return std::nullopt;
      }
      if (width == 0 || height == 0 || std::uint64_t{width} * height > kMaxPixels) {
        return std::nullopt;
      }
      channels = colour_type == 0 ? 1 : 3;
      have_header = true;
      continue;
    }
    if (!have_header) return std::nullopt;  // IHDR must come first
    if (std::memcmp(type, "IDAT", 4) == 0) {
      compressed.insert(compressed.end(), data, data + length);
    } else if (std::memcmp(type, "IEND", 4) == 0) {
      ended = true;
    } else if ((type[0] & 0x20) == 0) {
      return std::nullopt;  // a critical chunk this path does not know (PLTE, ...)
    }                       // ancillary chunks (text, gamma, ...) do not change the pixels
  }
  if (compressed.empty()) return std::nullopt;

  const std::size_t row_bytes = width * channels;
  const std::size_t filtered_bytes = height * (row_bytes + 1);
  // DEFLATE expands at most 1032-fold: a header promising more than the data can hold is
  // refused before its buffer is allocated.
  if (filtered_bytes / kMaxDeflateRatio > compressed.size()) return std::nullopt;
  std::vector<std::uint8_t> filtered(filtered_bytes);
  std::size_t produced = 0;
  if (libdeflate_zlib_decompress(thread_decompressor(), compressed.data(), compressed.size(),
                                 filtered.data(), filtered.size(),
                                 &produced) != LIBDEFLATE_SUCCESS ||
      produced != filtered_bytes) {
    return std::nullopt;
  }

  cv::Mat image(static_cast<int>(height), static_cast<int>(width),
                CV_8UC(static_cast<int>(channels)));
  const std::vector<std::uint8_t> zeros(row_bytes, 0);
  const std::uint8_t* previous = zeros.data();
  for (std::size_t y = 0; y < height; ++y) {
    const std::uint8_t* source = filtered.data() + y * (row_bytes + 1);
    std::uint8_t* row = image.ptr<std::uint8_t>(static_cast<int>(y));
    std::memcpy(row, source + 1, row_bytes);
    if (!unfilter_row(source[0], row, previous, row_bytes, channels)) return std::nullopt;
    previous = row;
  }
  if (channels == 3) cv::cvtColor(image, image, cv::COLOR_RGB2BGR);
  return image;
}

}  // namespace fl::vision::record::detail
