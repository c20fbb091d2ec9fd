// Test support: rendered frames for the estimator (links the twin renderer; fl_vision does not).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>

#include "fl/twin/render/fillet_renderer.hpp"
#include "fl/vision/calibration.hpp"
#include "fl/vision/fillet_estimator.hpp"

namespace fl::vision::testing {

// Shapes of the shared renderer: 0 is the nominal mesh, 1..7 random (FilletRenderer).
inline constexpr int kShapeVariants = 8;
// One renderer for the whole test binary (building its height maps takes a few seconds).
const render::FilletRenderer& renderer();

// 640 x 480 and the line cameras, all over the line's 300 mm field along travel: as mounted,
// 640 x 512 binned 2 x 2 from the 1280 x 1024 sensor (render::make_line_camera), and the same
// sensor read out in full.
render::RenderCamera camera_640();
render::RenderCamera camera_line();
render::RenderCamera camera_line_full_readout();

// The calibration a perfect checkerboard procedure would give for a renderer camera.
BeltCalibration exact_calibration(const render::RenderCamera& camera);

// Imaging with realistic spreads, drawn from `rng`: exposure 0.75..1.25, a lighting gradient
// up to 30 % across the frame, vignetting up to 20 %, motion blur up to 3 px, noise 1..5 grey
// levels (documented in docs/benchmarks.md (vision)).
render::ImagingConditions realistic_imaging(cv::RNG& rng);

struct RandomSceneOptions {
  bool touching_pair = false;     // a touching pair instead of one fillet in the middle
  bool overlapping_pair = false;  // or a pair with one lying partly on the other
  bool neighbours = true;         // fillets cut by the frame edges before and after
  bool realistic = true;          // realistic_imaging(); otherwise clean
  bool nominal_shape = false;     // only the nominal mesh shape (else any of kShapeVariants)
  bool bent = false;              // bent in the belt plane as the DEM line bends them
};
// An in-plane bend (render::FilletInstance::bend_per_mm) drawn from the spread the DEM twin's
// line gave (dem::InPlaneBendFit, `linectl record --plant dem`, seed 2, 30 s, every camera:
// 2953 views, median 2.0 / m, 90th percentile 6.7 / m, 99.9th 12 / m; the two above that, 23
// and 36 / m at camera 1, were folded, not bent flat).
double dem_line_bend_per_mm(cv::RNG& rng);
// A random scene: one fully visible fillet (or pair) anywhere in view at any angle, random
// size, scale (+-5 %), hand and side, plus partial neighbours. Retries placements until the
// middle fillet(s) are fully visible.
render::Scene random_scene(const render::RenderCamera& camera, std::uint64_t seed,
                           const RandomSceneOptions& options);

// Smallest absolute difference of two angles, radians.
double angle_difference_rad(double a, double b);

// The estimate whose position is nearest `belt_mm` within `gate_mm`.
std::optional<BlobResult> nearest_fillet(const FrameResult& result, cv::Point2d belt_mm,
                                         double gate_mm = 40.0);

}  // namespace fl::vision::testing
