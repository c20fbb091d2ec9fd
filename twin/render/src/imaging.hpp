// Internal: the imaging chain shared by fillet and checkerboard rendering.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "fl/twin/render/fillet_renderer.hpp"

namespace fl::render::detail {

// Radiance (CV_32FC3, 8-bit grey-level scale) -> camera frame (CV_8UC3): exposure, lighting
// gradient, vignetting, motion blur, Gaussian noise, rounding and clipping.
cv::Mat apply_imaging(const cv::Mat& radiance_bgr, const RenderCamera& camera,
                      const ImagingConditions& imaging, std::uint64_t seed);

}  // namespace fl::render::detail
