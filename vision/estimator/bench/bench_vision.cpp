// Estimator time per frame, single thread (cv::setNumThreads(1)), at 640 x 480, at the line
// cameras' 640 x 512 (their 1280 x 1024 sensor binned 2 x 2, as mounted) and full 1280 x 1024
// readout, and at the recordings' 320 x 240, on rendered frames with one fillet (or a touching
// pair) and realistic noise. Run with repetitions to get the spread, e.g.
//   build/release/vision/estimator/bench_vision --benchmark_counters_tabular=true
// Each estimate benchmark reports the median and p99 of the per-frame times as counters (ms);
// the stage benchmark (BM_WorkingPlanesFrom1280x1024) the mean only.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "fl/twin/render/fillet_renderer.hpp"
#include "fl/vision/fillet_estimator.hpp"
#include "working_image.hpp"

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
    scene.seed = static_cast<std::uint64_t>(i) + 1;
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
void BM_EstimateLineBinned640x512(benchmark::State& state) {
  run(state, fl::render::make_line_camera(), false);
}
void BM_EstimateLine1280x1024(benchmark::State& state) {
  run(state, fl::render::make_line_camera(false), false);
}
// The resolution of the twin's recordings and the CI replays (0.94 mm/px).
void BM_Estimate320x240(benchmark::State& state) {
  run(state, fl::render::make_top_down_camera(320, 240, 300.0 / 320.0), false);
}
void BM_EstimatePair640x480(benchmark::State& state) {
  run(state, fl::render::make_top_down_camera(640, 480, 300.0 / 640.0), true);
}

// The first stage at the line cameras' 1280 x 1024: the frame to the 640 x 512 working planes.
// Sixteen different frames of noise in turn (63 MB, twice this VM's 32 MB L3), as a camera's
// frames arrive in memory that is not in cache. Mean time per frame only (no percentiles). Argument
// 0: cv::resize(INTER_AREA) then the split into planes (the estimator before 2026-11-29); 1:
// halve_bgr_rows' portable code; 2: its fastest code (AVX2 where the CPU has it), as the estimator
// runs it.
void BM_WorkingPlanesFrom1280x1024(benchmark::State& state) {
  cv::setNumThreads(1);
  constexpr int kFrames = 16;
  std::vector<cv::Mat> frames(kFrames);
  cv::RNG rng(1);
  for (cv::Mat& frame : frames) {
    frame.create(fl::render::kLineSensorHeightPx, fl::render::kLineSensorWidthPx, CV_8UC3);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
  }
  const cv::Size work(frames[0].cols / 2, frames[0].rows / 2);
  cv::Mat work_bgr;
  cv::Mat row_planes(3, work.width, CV_8UC1);
  cv::Mat green(work, CV_8UC1);
  cv::Mat red(work, CV_8UC1);
  const auto code = state.range(0) == 1 ? fl::vision::detail::HalvingCode::kPortable
                                        : fl::vision::detail::HalvingCode::kFastest;
  std::size_t i = 0;
  for (auto _ : state) {
    const cv::Mat& frame = frames[i++ % frames.size()];
    if (state.range(0) == 0) {
      cv::resize(frame, work_bgr, work, 0, 0, cv::INTER_AREA);
      for (int row = 0; row < work.height; ++row) {
        fl::vision::detail::split_bgr_row(
            work_bgr.ptr<std::uint8_t>(row), work.width, row_planes.ptr<std::uint8_t>(0),
            row_planes.ptr<std::uint8_t>(1), row_planes.ptr<std::uint8_t>(2));
      }
    } else {
      for (int row = 0; row < work.height; ++row) {
        fl::vision::detail::halve_bgr_rows(
            frame.ptr<std::uint8_t>(2 * row), frame.ptr<std::uint8_t>(2 * row + 1), work.width,
            row_planes.ptr<std::uint8_t>(0), green.ptr<std::uint8_t>(row),
            red.ptr<std::uint8_t>(row), code);
      }
    }
    benchmark::ClobberMemory();
  }
  state.SetLabel(state.range(0) == 0                      ? "cv::resize + split"
                 : state.range(0) == 1                    ? "halve_bgr_rows, portable"
                 : fl::vision::detail::halving_has_avx2() ? "halve_bgr_rows, AVX2"
                                                          : "halve_bgr_rows, portable (no AVX2)");
}

BENCHMARK(BM_Estimate640x480)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_EstimateLineBinned640x512)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_EstimateLine1280x1024)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_EstimatePair640x480)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_Estimate320x240)->Unit(benchmark::kMicrosecond)->MinTime(2.0);
BENCHMARK(BM_WorkingPlanesFrom1280x1024)
    ->Unit(benchmark::kMicrosecond)
    ->MinTime(1.0)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2);

}  // namespace

BENCHMARK_MAIN();
