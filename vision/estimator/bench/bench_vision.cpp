// Estimator time per frame, single thread (cv::setNumThreads(1)), at 640 x 480, at the line
// cameras' 1280 x 1024 and at the recordings' 320 x 240, on rendered frames with one fillet (or a
// touching pair) and realistic noise. Run with repetitions to get the spread, e.g.
//   build/release/vision/estimator/bench_vision --benchmark_counters_tabular=true
// Each benchmark reports the median and p99 of the per-frame times as counters (ms).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <opencv2/core.hpp>
#include <vector>

#include "fl/twin/render/fillet_renderer.hpp"
#include "fl/vision/fillet_estimator.hpp"

namespace {

using fl::render::FilletRenderer;
using fl::render::RenderCamera;

fl::vision::BeltCalibration calibration_for(const RenderCamera& camera) {
  fl::vision::BeltCalibration calibration;
  calibration.camera_name = "bench";
  calibration.image_width_px = camera.width_px;
  calibration.image_height_px = camera.height_px;
  calibration.image_to_belt = camera.belt_to_image.inv();
  return calibration;
}

// Eight frames with different fillets, so that the benchmark does not time one lucky image.
std::vector<cv::Mat> frames_for(const RenderCamera& camera, bool pairs) {
  static const FilletRenderer renderer;
  std::vector<cv::Mat> frames;
  cv::RNG rng(99);
  for (int i = 0; i < 8; ++i) {
    fl::render::Scene scene;
    scene.seed = static_cast<std::uint64_t>(i + 1);
    scene.imaging.noise_sigma = 3.0;
    scene.imaging.lighting_gradient = 0.2;
    fl::render::FilletInstance fillet;
    fillet.x_mm = rng.uniform(-30.0, 30.0);
    fillet.y_mm = rng.uniform(-15.0, 15.0);
    fillet.angle_rad = rng.uniform(-3.1, 3.1);
    fillet.hand = i % 2 ? fl::Hand::kLeft : fl::Hand::kRight;
    fillet.side = i % 4 < 2 ? fl::SideUp::kSkin : fl::SideUp::kBone;
    if (pairs) {
      fillet.angle_rad = rng.uniform(-0.3, 0.3);
      fl::render::FilletInstance partner = fillet;
      partner =
          fl::render::make_touching_partner(renderer, fillet, partner, true, 0.1, 0.0, 1.0, 1);
      fillet.y_mm -= 40.0;
      partner.y_mm -= 40.0;
      scene.fillets = {fillet, partner};
    } else {
      scene.fillets = {fillet};
    }
    frames.push_back(renderer.render(camera, scene).bgr);
  }
  return frames;
}

void run(benchmark::State& state, const RenderCamera& camera, bool pairs) {
  cv::setNumThreads(1);
  const auto frames = frames_for(camera, pairs);
  fl::vision::FilletEstimator estimator(calibration_for(camera));
  std::vector<double> times_ms;
  std::size_t i = 0;
  std::uint32_t sequence = 0;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    auto result = estimator.estimate(frames[i++ % frames.size()], 0, ++sequence);
    const auto stop = std::chrono::steady_clock::now();
    benchmark::DoNotOptimize(result);
    times_ms.push_back(std::chrono::duration<double, std::milli>(stop - start).count());
  }
  std::sort(times_ms.begin(), times_ms.end());
  const auto at = [&](double share) {
    return times_ms[std::min(
        times_ms.size() - 1,
        static_cast<std::size_t>(share * static_cast<double>(times_ms.size())))];
  };
  state.counters["median_ms"] = at(0.5);
  state.counters["p99_ms"] = at(0.99);
  state.counters["max_ms"] = times_ms.back();
}

void BM_Estimate640x480(benchmark::State& state) {
  run(state, fl::render::make_top_down_camera(640, 480, 300.0 / 640.0), false);
}
void BM_EstimateLine1280x1024(benchmark::State& state) {
  run(state,
      fl::render::make_top_down_camera(
          fl::render::kLineCameraWidthPx, fl::render::kLineCameraHeightPx,
          fl::render::kLineCameraFieldAlongTravelMm / fl::render::kLineCameraWidthPx),
      false);
}
// The resolution of the twin's recordings and the CI replays (0.94 mm/px).
void BM_Estimate320x240(benchmark::State& state) {
  run(state, fl::render::make_top_down_camera(320, 240, 300.0 / 320.0), false);
}
void BM_EstimatePair640x480(benchmark::State& state) {
  run(state, fl::render::make_top_down_camera(640, 480, 300.0 / 640.0), true);
}

BENCHMARK(BM_Estimate640x480)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_EstimateLine1280x1024)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_EstimatePair640x480)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_Estimate320x240)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

}  // namespace

BENCHMARK_MAIN();
