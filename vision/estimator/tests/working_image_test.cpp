// The working image's row kernels against the OpenCV calls they replace: the estimator's
// results may only stay the same if every pixel does.
#include "working_image.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace {

using fl::vision::detail::box_above;
using fl::vision::detail::centred_run_half_widths;
using fl::vision::detail::chroma_row;
using fl::vision::detail::erode_by_centred_runs;
using fl::vision::detail::grey_row;
using fl::vision::detail::halve_bgr_rows;
using fl::vision::detail::halving_has_avx2;
using fl::vision::detail::HalvingCode;
using fl::vision::detail::segment_meat;
using fl::vision::detail::split_bgr_row;

// The kernels take 16 pixels at a time and finish with a scalar tail; a segment of this many
// pixels runs on the tail alone.
constexpr int kTailOnlyPixels = 15;

// Runs a row kernel over `cols` pixels in segments of kTailOnlyPixels, so the scalar code does
// every pixel.
template <typename Kernel>
void in_tail_segments(int cols, Kernel kernel) {
  for (int first = 0; first < cols; first += kTailOnlyPixels) {
    kernel(first, std::min(kTailOnlyPixels, cols - first));
  }
}

TEST(WorkingImage, SplitGivesTheChannelsAsPlanes) {
  cv::RNG rng(8);
  cv::Mat frame(1, 640 + 7, CV_8UC3);  // 40 blocks of 16 and a tail of 7
  rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
  cv::Mat planes(3, frame.cols, CV_8UC1);
  split_bgr_row(frame.ptr<std::uint8_t>(0), frame.cols, planes.ptr<std::uint8_t>(0),
                planes.ptr<std::uint8_t>(1), planes.ptr<std::uint8_t>(2));
  std::vector<cv::Mat> expected;
  cv::split(frame, expected);
  for (int channel = 0; channel < 3; ++channel) {
    EXPECT_EQ(
        cv::norm(expected[static_cast<std::size_t>(channel)], planes.row(channel), cv::NORM_INF),
        0.0)
        << "channel " << channel;
  }
}

// Halves `frame` pair of rows by pair of rows into planes; `segment` output pixels per call
// (kTailOnlyPixels for the scalar code alone).
std::vector<cv::Mat> halved_planes(const cv::Mat& frame, int segment, HalvingCode code) {
  std::vector<cv::Mat> planes(3);
  for (cv::Mat& plane : planes) plane.create(frame.rows / 2, frame.cols / 2, CV_8UC1);
  for (int row = 0; row < frame.rows / 2; ++row) {
    for (int first = 0; first < frame.cols / 2; first += segment) {
      const int count = std::min(segment, frame.cols / 2 - first);
      const auto offset = 6 * static_cast<std::ptrdiff_t>(first);
      halve_bgr_rows(
          frame.ptr<std::uint8_t>(2 * row) + offset, frame.ptr<std::uint8_t>(2 * row + 1) + offset,
          count, planes[0].ptr<std::uint8_t>(row) + first, planes[1].ptr<std::uint8_t>(row) + first,
          planes[2].ptr<std::uint8_t>(row) + first, code);
    }
  }
  return planes;
}

TEST(WorkingImage, HalvingIsCvResizeAreaSplitIntoPlanes) {
  // Both codes where the CPU has AVX2 (the fastest is AVX2 then), else the portable one twice.
  RecordProperty("avx2", halving_has_avx2() ? "yes" : "no");
  cv::RNG rng(9);
  // The line camera's frame; a width whose half is 3 blocks of 16 and a tail of 7; and pixels
  // at the extremes, where a sum of four 255s must not wrap and the rounding shows.
  std::vector<cv::Mat> frames;
  for (const cv::Size size : {cv::Size(1280, 1024), cv::Size(2 * (3 * 16 + 7), 10)}) {
    cv::Mat frame(size, CV_8UC3);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
    frames.push_back(frame);
    cv::Mat extremes(size, CV_8UC3);
    rng.fill(extremes, cv::RNG::UNIFORM, 0, 2);
    frames.push_back(extremes * 255);
    cv::Mat near_halves(size, CV_8UC3);  // small sums: 4k + 1, + 2 and + 3 round apart
    rng.fill(near_halves, cv::RNG::UNIFORM, 0, 4);
    frames.push_back(near_halves);
  }
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const cv::Mat& frame = frames[f];
    cv::Mat resized;
    cv::resize(frame, resized, cv::Size(frame.cols / 2, frame.rows / 2), 0, 0, cv::INTER_AREA);
    std::vector<cv::Mat> expected;
    cv::split(resized, expected);
    for (const HalvingCode code : {HalvingCode::kFastest, HalvingCode::kPortable}) {
      for (const int segment : {frame.cols / 2, kTailOnlyPixels}) {
        const std::vector<cv::Mat> planes = halved_planes(frame, segment, code);
        for (std::size_t channel = 0; channel < 3; ++channel) {
          EXPECT_EQ(cv::norm(expected[channel], planes[channel], cv::NORM_INF), 0.0)
              << "frame " << f << " (" << frame.cols << " x " << frame.rows << "), channel "
              << channel << ", " << segment << " pixels per call, "
              << (code == HalvingCode::kPortable ? "portable" : "fastest") << " code";
        }
      }
    }
  }
}

TEST(WorkingImage, GreyIsCvtColorForEveryColour) {
  // All 2^24 colours, one blue-green plane per red value.
  cv::Mat colours(256, 256 * 256, CV_8UC3);
  for (int red = 0; red < 256; ++red) {
    auto* pixel = colours.ptr<std::uint8_t>(red);
    for (int green = 0; green < 256; ++green) {
      for (int blue = 0; blue < 256; ++blue, pixel += 3) {
        pixel[0] = static_cast<std::uint8_t>(blue);
        pixel[1] = static_cast<std::uint8_t>(green);
        pixel[2] = static_cast<std::uint8_t>(red);
      }
    }
  }
  cv::Mat expected;
  cv::cvtColor(colours, expected, cv::COLOR_BGR2GRAY);
  const int cols = colours.cols;
  cv::Mat planes(3, cols, CV_8UC1), vector_grey(1, cols, CV_8UC1), scalar_grey(1, cols, CV_8UC1);
  int mismatches = 0;
  for (int row = 0; row < colours.rows; ++row) {
    split_bgr_row(colours.ptr<std::uint8_t>(row), cols, planes.ptr<std::uint8_t>(0),
                  planes.ptr<std::uint8_t>(1), planes.ptr<std::uint8_t>(2));
    const std::uint8_t* blue = planes.ptr<std::uint8_t>(0);
    const std::uint8_t* green = planes.ptr<std::uint8_t>(1);
    const std::uint8_t* red = planes.ptr<std::uint8_t>(2);
    grey_row(blue, green, red, cols, vector_grey.ptr<std::uint8_t>(0));
    in_tail_segments(cols, [&](int first, int count) {
      grey_row(blue + first, green + first, red + first, count,
               scalar_grey.ptr<std::uint8_t>(0) + first);
    });
    mismatches += cv::countNonZero(vector_grey != expected.row(row));
    mismatches += cv::countNonZero(scalar_grey != expected.row(row));
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(WorkingImage, ChromaIsCvTransformForEveryRedBluePair) {
  // Blue along the columns, red down the rows; green must not matter.
  cv::Mat colours(256, 256, CV_8UC3);
  cv::RNG rng(9);
  for (int red = 0; red < 256; ++red) {
    for (int blue = 0; blue < 256; ++blue) {
      colours.at<cv::Vec3b>(red, blue) =
          cv::Vec3b(static_cast<std::uint8_t>(blue), static_cast<std::uint8_t>(rng.uniform(0, 256)),
                    static_cast<std::uint8_t>(red));
    }
  }
  cv::Mat expected;
  cv::transform(colours, expected, cv::Matx14f(-0.5F, 0.0F, 0.5F, 128.0F));
  cv::Mat planes(3, 256, CV_8UC1), vector_chroma(1, 256, CV_8UC1), scalar_chroma(1, 256, CV_8UC1);
  int mismatches = 0;
  for (int row = 0; row < 256; ++row) {
    split_bgr_row(colours.ptr<std::uint8_t>(row), 256, planes.ptr<std::uint8_t>(0),
                  planes.ptr<std::uint8_t>(1), planes.ptr<std::uint8_t>(2));
    const std::uint8_t* blue = planes.ptr<std::uint8_t>(0);
    const std::uint8_t* red = planes.ptr<std::uint8_t>(2);
    chroma_row(blue, red, 256, vector_chroma.ptr<std::uint8_t>(0));
    in_tail_segments(256, [&](int first, int count) {
      chroma_row(blue + first, red + first, count, scalar_chroma.ptr<std::uint8_t>(0) + first);
    });
    mismatches += cv::countNonZero(vector_chroma != expected.row(row));
    mismatches += cv::countNonZero(scalar_chroma != expected.row(row));
  }
  EXPECT_EQ(mismatches, 0);
}

// The reference: the same operators on the whole frame.
void segment_whole_frame(const cv::Mat& chroma, int threshold, cv::Mat& mask,
                         std::vector<std::vector<cv::Point>>& contours) {
  cv::threshold(chroma, mask, threshold, 255, cv::THRESH_BINARY);
  cv::morphologyEx(mask, mask, cv::MORPH_OPEN,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5)));
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
}

// The box_above of an image, from its row and column maxima.
cv::Rect box_above_of(const cv::Mat& chroma, int threshold) {
  std::vector<std::uint8_t> row_max(static_cast<std::size_t>(chroma.rows), 0);
  std::vector<std::uint8_t> column_max(static_cast<std::size_t>(chroma.cols), 0);
  for (int row = 0; row < chroma.rows; ++row) {
    for (int col = 0; col < chroma.cols; ++col) {
      const std::uint8_t value = chroma.at<std::uint8_t>(row, col);
      row_max[static_cast<std::size_t>(row)] =
          std::max(row_max[static_cast<std::size_t>(row)], value);
      column_max[static_cast<std::size_t>(col)] =
          std::max(column_max[static_cast<std::size_t>(col)], value);
    }
  }
  return box_above(row_max, column_max, threshold);
}

TEST(WorkingImage, BoxAboveBoundsThePixelsOverTheThreshold) {
  cv::Mat chroma(48, 64, CV_8UC1, cv::Scalar(120));
  EXPECT_TRUE(box_above_of(chroma, 120).empty()) << "equal to the threshold is not above it";
  chroma.at<std::uint8_t>(5, 60) = 121;
  chroma.at<std::uint8_t>(40, 3) = 200;
  EXPECT_EQ(box_above_of(chroma, 120), cv::Rect(3, 5, 58, 36));
  EXPECT_EQ(box_above_of(chroma, 121), cv::Rect(3, 40, 1, 1));
}

// Meat blobs anywhere, cut by every edge and corner, with specks the opening removes and
// cracks the closing fills: the mask and every contour point equal the whole frame's.
TEST(WorkingImage, SegmentationOnTheMeatBoxIsTheWholeFrames) {
  constexpr int kThreshold = 140;  // between the belt (100..130) and the meat (150..200)
  cv::RNG rng(11);
  cv::Mat mask, scratch, reference_mask;
  std::vector<std::vector<cv::Point>> contours, reference_contours;
  for (int scene = 0; scene < 200; ++scene) {
    cv::Mat chroma(120, 160, CV_8UC1);
    rng.fill(chroma, cv::RNG::UNIFORM, 100, 131);
    const int blobs = scene % 4;  // none, one, two or three
    for (int blob = 0; blob < blobs; ++blob) {
      // Centres up to 15 px beyond the frame, so that blobs are cut by edges and corners.
      const cv::Point centre(rng.uniform(-15, chroma.cols + 15),
                             rng.uniform(-15, chroma.rows + 15));
      const cv::Size axes(rng.uniform(4, 40), rng.uniform(3, 20));
      cv::ellipse(chroma, centre, axes, rng.uniform(0.0, 180.0), 0, 360,
                  cv::Scalar(rng.uniform(150, 201)), cv::FILLED);
      // A crack of belt colour through the blob, one pixel wide.
      cv::line(chroma, centre - cv::Point(axes.width, 0), centre + cv::Point(axes.width, 0),
               cv::Scalar(120), 1);
    }
    for (int speck = 0; speck < 6; ++speck) {
      chroma.at<std::uint8_t>(rng.uniform(0, chroma.rows), rng.uniform(0, chroma.cols)) = 190;
    }
    segment_meat(chroma, kThreshold, box_above_of(chroma, kThreshold), mask, scratch, contours);
    segment_whole_frame(chroma, kThreshold, reference_mask, reference_contours);
    ASSERT_EQ(cv::countNonZero(mask != reference_mask), 0) << "scene " << scene;
    ASSERT_EQ(contours, reference_contours) << "scene " << scene;
  }
}

// Blob interiors of every size the estimator erodes by (3 mm at 0.23 to 0.94 mm per working
// pixel: ellipses of 7 to 27 pixels), plus a rectangle and a cross, on masks cut by the box's
// edges and on noise: every pixel equals cv::erode's.
TEST(WorkingImage, CentredRunErosionIsCvErode) {
  std::vector<cv::Mat> elements;
  for (const int size : {1, 3, 5, 7, 9, 13, 15, 27}) {
    elements.push_back(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(size, size)));
  }
  elements.push_back(cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(9, 5)));
  elements.push_back(cv::getStructuringElement(cv::MORPH_RECT, cv::Size(5, 3)));
  elements.push_back(cv::getStructuringElement(cv::MORPH_CROSS, cv::Size(7, 7)));
  cv::RNG rng(12);
  cv::Mat eroded, expected, padded, run_minima;
  for (const cv::Mat& element : elements) {
    const std::vector<int> half_widths = centred_run_half_widths(element);
    ASSERT_EQ(half_widths.size(), static_cast<std::size_t>(element.rows)) << element;
    for (int trial = 0; trial < 20; ++trial) {
      cv::Mat mask(rng.uniform(1, 90), rng.uniform(1, 200), CV_8UC1, cv::Scalar(0));
      if (trial % 4 == 3) {
        rng.fill(mask, cv::RNG::UNIFORM, 0, 256);  // any values, not only 0 and 255
      } else {
        cv::ellipse(mask, cv::Point(mask.cols / 2, mask.rows / 2),
                    cv::Size(mask.cols / 2 + rng.uniform(0, 4), mask.rows / 2 + rng.uniform(0, 4)),
                    rng.uniform(0.0, 180.0), 0, 360, cv::Scalar(255), cv::FILLED);
      }
      erode_by_centred_runs(mask, half_widths, padded, run_minima, eroded);
      cv::erode(mask, expected, element);
      ASSERT_EQ(cv::norm(eroded, expected, cv::NORM_INF), 0.0)
          << element.size() << " element, " << mask.size() << " mask, trial " << trial;
    }
  }
}

TEST(WorkingImage, ElementsOfOtherShapesHaveNoCentredRuns) {
  cv::Mat off_centre = cv::Mat::zeros(3, 3, CV_8UC1);
  off_centre.at<std::uint8_t>(1, 1) = off_centre.at<std::uint8_t>(1, 2) = 1;
  cv::Mat two_runs = cv::Mat::ones(3, 5, CV_8UC1);
  two_runs.at<std::uint8_t>(1, 1) = 0;
  cv::Mat empty_row = cv::Mat::ones(3, 3, CV_8UC1);
  empty_row.row(0).setTo(0);
  const cv::Mat even_rows = cv::Mat::ones(2, 3, CV_8UC1);
  const cv::Mat not_8_bit = cv::Mat::ones(3, 3, CV_32FC1);
  for (const cv::Mat& element : {off_centre, two_runs, empty_row, even_rows, not_8_bit}) {
    EXPECT_TRUE(centred_run_half_widths(element).empty()) << element;
  }
}

}  // namespace
