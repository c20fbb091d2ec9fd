// Replay's fast PNG decoder (vision/record/src/png_decode.cpp) on arbitrary bytes, against
// OpenCV's decoder as the reference. The fast path may refuse anything (OpenCV then decides),
// but it must never crash or read out of bounds, and an image it returns must be the one
// OpenCV decodes from the same bytes, pixel for pixel. A mutated chunk almost never keeps its
// CRC, so the input's chunk CRCs are made right first: the mutations then reach the header,
// the zlib stream and the row filters.
#include <libdeflate.h>

#include <cstdint>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <vector>

#include "png_decode.hpp"

namespace {

void fix_chunk_crcs(std::vector<std::uint8_t>& png) {
  std::size_t at = 8;  // after the signature
  while (png.size() >= at + 12) {
    const std::size_t length = (std::size_t{png[at]} << 24) | (std::size_t{png[at + 1]} << 16) |
                               (std::size_t{png[at + 2]} << 8) | std::size_t{png[at + 3]};
    if (length > png.size() - at - 12) return;
    const std::uint32_t crc = libdeflate_crc32(0, png.data() + at + 4, length + 4);
    for (std::size_t k = 0; k < 4; ++k) {
      png[at + 8 + length + k] = static_cast<std::uint8_t>(crc >> (24 - 8 * k));
    }
    at += length + 12;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::uint8_t> copy(data, data + size);
  fix_chunk_crcs(copy);
  const std::optional<cv::Mat> fast = fl::vision::record::detail::decode_png_fast(copy);
  if (!fast) return 0;
  cv::Mat reference;
  try {
    reference = cv::imdecode(copy, cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception&) {
    return 0;  // libpng is stricter about some ancillary data; the pixels are what counts
  }
  if (reference.empty()) return 0;
  if (reference.size() != fast->size() || reference.type() != fast->type() ||
      cv::norm(reference, *fast, cv::NORM_INF) != 0.0) {
    std::abort();  // both decoded the bytes, to different images
  }
  return 0;
}
