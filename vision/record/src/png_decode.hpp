// A fast path for the PNGs recordings carry. Replay spends most of its time decoding frames
// (perf: zlib inflate 39 %, libpng's unfiltering 24 %); libdeflate inflates about twice as
// fast as zlib. The path takes what the recorder writes (8-bit grey or RGB, not interlaced)
// and leaves every other PNG, and any it cannot read, to OpenCV, which stays the reference.
#pragma once

#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <span>

namespace fl::vision::record::detail {

// The image of an 8-bit grey (CV_8UC1) or RGB (CV_8UC3, in OpenCV's BGR order) PNG without
// interlacing, decoded bit-exactly with every chunk CRC and the zlib checksum verified.
// Nothing for any other PNG, for a corrupt one (bad signature, CRC, header or compressed
// data, wrong size, unknown row filter, more pixels than its data could hold) and for one
// above 2^26 pixels: the caller hands those
// to cv::imdecode, which decodes them or reports them undecodable.
std::optional<cv::Mat> decode_png_fast(std::span<const std::uint8_t> png);

}  // namespace fl::vision::record::detail
