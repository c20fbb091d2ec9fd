// The replay's fast PNG path against OpenCV's decoder (libpng), which stays the reference:
// every image it takes must come out bit-identical, and every other PNG must be left to
// OpenCV rather than guessed at.
#include "png_decode.hpp"

#include <gtest/gtest.h>
#include <libdeflate.h>

#include <cstdint>
#include <cstdlib>
#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

namespace fl::vision::record {
namespace {

using detail::decode_png_fast;
using Bytes = std::vector<std::uint8_t>;

// Noise over a gradient: rows that differ from their neighbours, so that every filter has
// work to do and a wrong predictor shows in many pixels.
cv::Mat test_image(int rows, int cols, int channels, std::uint64_t seed) {
  cv::Mat image(rows, cols, CV_8UC(channels));
  cv::RNG random(seed);
  for (int y = 0; y < rows; ++y) {
    auto* row = image.ptr<std::uint8_t>(y);
    for (int i = 0; i < cols * channels; ++i) {
      row[i] = static_cast<std::uint8_t>((3 * y + i) % 256 + random.uniform(0, 40));
    }
  }
  return image;
}

Bytes encode_with_opencv(const cv::Mat& image, const std::vector<int>& parameters = {}) {
  Bytes png;
  EXPECT_TRUE(cv::imencode(".png", image, png, parameters));
  return png;
}

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

void expect_same_as_opencv(const Bytes& png, const std::string& what) {
  const cv::Mat reference = cv::imdecode(png, cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(reference.empty()) << what;
  const std::optional<cv::Mat> fast = decode_png_fast(png);
  ASSERT_TRUE(fast.has_value()) << what << ": the fast path refused an image it should take";
  EXPECT_TRUE(identical(*fast, reference)) << what;
}

// A PNG written here, row by row with the filter chosen, as libpng would never be told to:
// each of the five filters of the specification must be undone exactly.
void append_chunk(Bytes& png, const char* type, const Bytes& data) {
  const auto length = static_cast<std::uint32_t>(data.size());
  for (int shift = 24; shift >= 0; shift -= 8) {
    png.push_back(static_cast<std::uint8_t>(length >> shift));
  }
  Bytes typed(type, type + 4);
  typed.insert(typed.end(), data.begin(), data.end());
  png.insert(png.end(), typed.begin(), typed.end());
  const std::uint32_t crc = libdeflate_crc32(0, typed.data(), typed.size());
  for (int shift = 24; shift >= 0; shift -= 8) {
    png.push_back(static_cast<std::uint8_t>(crc >> shift));
  }
}

int paeth_predictor(int left, int up, int up_left) {
  const int p = left + up - up_left;
  const int pa = std::abs(p - left);
  const int pb = std::abs(p - up);
  const int pc = std::abs(p - up_left);
  if (pa <= pb && pa <= pc) return left;
  return pb <= pc ? up : up_left;
}

// `image` in PNG's channel order (RGB for three channels); row y uses filter_of_row(y).
Bytes encode_with_filters(const cv::Mat& image, const std::function<int(int)>& filter_of_row) {
  const int channels = image.channels();
  const auto row_bytes = static_cast<std::size_t>(image.cols * channels);
  Bytes raw;
  for (int y = 0; y < image.rows; ++y) {
    const std::uint8_t* row = image.ptr<std::uint8_t>(y);
    const std::uint8_t* up_row = y > 0 ? image.ptr<std::uint8_t>(y - 1) : nullptr;
    const int filter = filter_of_row(y);
    raw.push_back(static_cast<std::uint8_t>(filter));
    for (std::size_t i = 0; i < row_bytes; ++i) {
      const int left = i >= static_cast<std::size_t>(channels) ? row[i - channels] : 0;
      const int up = up_row ? up_row[i] : 0;
      const int up_left =
          up_row && i >= static_cast<std::size_t>(channels) ? up_row[i - channels] : 0;
      const int predictions[] = {0, left, up, (left + up) / 2, paeth_predictor(left, up, up_left)};
      raw.push_back(static_cast<std::uint8_t>(row[i] - predictions[filter]));
    }
  }
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(6);
  Bytes compressed(libdeflate_zlib_compress_bound(compressor, raw.size()));
  compressed.resize(libdeflate_zlib_compress(compressor, raw.data(), raw.size(), compressed.data(),
                                             compressed.size()));
  libdeflate_free_compressor(compressor);

  Bytes png{0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  Bytes header;
  for (const int value : {image.cols, image.rows}) {
    for (int shift = 24; shift >= 0; shift -= 8) {
      header.push_back(static_cast<std::uint8_t>(value >> shift));
    }
  }
  header.insert(header.end(), {8, static_cast<std::uint8_t>(channels == 1 ? 0 : 2), 0, 0, 0});
  append_chunk(png, "IHDR", header);
  append_chunk(png, "tEXt", Bytes{'k', 0, 'v'});  // ancillary: skipped
  // Two IDAT chunks: the stream may be split anywhere.
  const std::size_t half = compressed.size() / 2;
  append_chunk(png, "IDAT",
               Bytes(compressed.begin(), compressed.begin() + static_cast<long>(half)));
  append_chunk(png, "IDAT", Bytes(compressed.begin() + static_cast<long>(half), compressed.end()));
  append_chunk(png, "IEND", {});
  return png;
}

TEST(PngFastPath, EveryRowFilterIsUndoneExactly) {
  for (const int channels : {1, 3}) {
    // 640 x 480 is the line camera's frame; 1 x 7 and 5 x 1 are the edges of the row loops.
    for (const cv::Size size : {cv::Size(640, 480), cv::Size(1, 7), cv::Size(5, 1)}) {
      const cv::Mat image = test_image(size.height, size.width, channels, 7);
      const std::string what = std::to_string(size.width) + "x" + std::to_string(size.height) +
                               "x" + std::to_string(channels);
      for (int filter = 0; filter <= 4; ++filter) {
        expect_same_as_opencv(encode_with_filters(image, [filter](int) { return filter; }),
                              what + " filter " + std::to_string(filter));
      }
      // All five in turn, so that every filter follows every other.
      expect_same_as_opencv(encode_with_filters(image, [](int y) { return (y * 3 + y / 5) % 5; }),
                            what + " mixed filters");
    }
  }
}

TEST(PngFastPath, WhatTheRecorderWritesDecodesAsOpenCvDecodesIt) {
  // The recorder writes with cv::imencode (libpng's adaptive filters) at a chosen zlib level;
  // every level and strategy must come out the same.
  for (const int channels : {1, 3}) {
    const cv::Mat image = test_image(480, 640, channels, 11);
    for (const int level : {0, 1, 3, 9}) {
      expect_same_as_opencv(encode_with_opencv(image, {cv::IMWRITE_PNG_COMPRESSION, level}),
                            "level " + std::to_string(level));
    }
    for (const int strategy :
         {cv::IMWRITE_PNG_STRATEGY_FILTERED, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY,
          cv::IMWRITE_PNG_STRATEGY_RLE, cv::IMWRITE_PNG_STRATEGY_FIXED}) {
      expect_same_as_opencv(encode_with_opencv(image, {cv::IMWRITE_PNG_STRATEGY, strategy}),
                            "strategy " + std::to_string(strategy));
    }
  }
}

TEST(PngFastPath, OtherPngsAreLeftToOpenCv) {
  // 16-bit, with alpha: valid PNGs outside the recorder's kind, which OpenCV decodes.
  cv::Mat deep(20, 30, CV_16UC1, cv::Scalar(40000));
  EXPECT_FALSE(decode_png_fast(encode_with_opencv(deep)).has_value());
  EXPECT_FALSE(decode_png_fast(encode_with_opencv(test_image(20, 30, 4, 3))).has_value());
  // Not a PNG at all.
  Bytes jpeg;
  ASSERT_TRUE(cv::imencode(".jpg", test_image(20, 30, 3, 3), jpeg));
  EXPECT_FALSE(decode_png_fast(jpeg).has_value());
  EXPECT_FALSE(decode_png_fast(Bytes{}).has_value());
}

TEST(PngFastPath, CorruptPngsAreRefusedNotGuessed) {
  const Bytes good = encode_with_opencv(test_image(48, 64, 3, 5));
  ASSERT_TRUE(decode_png_fast(good).has_value());
  // Every truncation: never a crash, never an image from part of the data.
  for (std::size_t length = 0; length < good.size(); length += 7) {
    EXPECT_FALSE(decode_png_fast(Bytes(good.begin(), good.begin() + static_cast<long>(length))))
        << "truncated to " << length << " bytes";
  }
  // One flipped bit anywhere after the signature: a chunk CRC no longer matches.
  for (std::size_t at = 8; at < good.size(); at += 13) {
    Bytes bad = good;
    bad[at] ^= 0x10;
    EXPECT_FALSE(decode_png_fast(bad).has_value()) << "bit flipped at byte " << at;
  }
}

// A one-pixel PNG whose header is rewritten to claim `width` x `height`, its CRC fixed so that
// only the size is wrong.
Bytes with_claimed_size(std::uint32_t width, std::uint32_t height) {
  Bytes png = encode_with_opencv(cv::Mat(1, 1, CV_8UC1, cv::Scalar(9)));
  for (int k = 0; k < 4; ++k) {
    png[16 + k] = static_cast<std::uint8_t>(width >> (24 - 8 * k));  // IHDR data at 16
    png[20 + k] = static_cast<std::uint8_t>(height >> (24 - 8 * k));
  }
  const std::uint32_t crc = libdeflate_crc32(0, png.data() + 12, 17);  // type and 13 bytes
  for (int k = 0; k < 4; ++k) png[29 + k] = static_cast<std::uint8_t>(crc >> (24 - 8 * k));
  return png;
}

TEST(PngFastPath, AHeaderClaimingAHugeImageIsRefusedBeforeAllocating) {
  // 2^20 x 2^20: beyond the 2^26-pixel limit.
  EXPECT_FALSE(decode_png_fast(with_claimed_size(1U << 20, 1U << 20)).has_value());
  // 4096 x 4096 is within the limit, but a few bytes of DEFLATE cannot expand to 16 MB
  // (1032:1 at most): refused (that it happens before the allocation, the fuzz target's
  // malloc limit watches).
  EXPECT_FALSE(decode_png_fast(with_claimed_size(4096, 4096)).has_value());
}

}  // namespace
}  // namespace fl::vision::record
