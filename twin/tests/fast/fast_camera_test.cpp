// Cameras of the fast plant: frame period and latency, camera-local coordinates, noise and
// misclassification statistics for a fixed seed, touching pairs, and the injectable faults.
// Belts are stopped so that the bodies stay put and the truth is constant.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "fast_test_support.hpp"

namespace fl::test {
namespace {

constexpr std::int64_t kStepNs = 10 * kMs;  // the controller's scan

std::int64_t ns(float seconds) { return std::llround(static_cast<double>(seconds) * 1e9); }

BodySpawn still_at(double s_mm, double y_mm, double angle_rad) {
  BodySpawn spawn;
  spawn.s_mm = s_mm;
  spawn.y_mm = y_mm;
  spawn.angle_rad = angle_rad;
  spawn.hand = Hand::kLeft;
  spawn.side = SideUp::kBone;
  return spawn;
}

// No missed detections, so that every frame holds exactly the bodies in view.
FastPlantConfig no_miss_config() {
  FastPlantConfig config = quiet_config();
  for (auto& camera : config.cameras) camera.miss_prob = 0.0F;
  return config;
}

struct Stats {
  double sum = 0.0;
  double sum_sq = 0.0;
  std::size_t n = 0;
  void add(double x) {
    sum += x;
    sum_sq += x * x;
    ++n;
  }
  [[nodiscard]] double mean() const { return sum / static_cast<double>(n); }
  [[nodiscard]] double stddev() const {
    const double m = mean();
    return std::sqrt((sum_sq - static_cast<double>(n) * m * m) / static_cast<double>(n - 1));
  }
};

// Sample mean within 4 standard errors of 0 and sample sigma within 4 of its standard errors
// (sigma / sqrt(2n)) of the configured sigma.
void expect_noise(const Stats& stats, double sigma, const char* what) {
  const auto n = static_cast<double>(stats.n);
  EXPECT_NEAR(stats.mean(), 0.0, 4.0 * sigma / std::sqrt(n)) << what;
  EXPECT_NEAR(stats.stddev(), sigma, 4.0 * sigma / std::sqrt(2.0 * n)) << what;
}

TEST(FastCameras, FramesComeAtThePeriodAfterTheLatency) {
  Rig rig(no_miss_config());
  rig.out = OutputImage{};
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    ASSERT_TRUE(rig.plant->spawn_body(still_at(rig.line.cameras[c].s_mm, 0.0, 0.0)));
  }
  std::array<std::uint32_t, kCameraCount> last_sequence{};
  std::array<std::int64_t, kCameraCount> first_time{};
  std::array<std::int64_t, kCameraCount> last_time{};
  std::array<std::size_t, kCameraCount> frames{};
  for (int i = 0; i < 1000; ++i) {  // 10 s
    rig.step(kStepNs);
    for (std::size_t c = 0; c < kCameraCount; ++c) {
      const CameraFrame& frame = rig.in.cameras[c];
      if (frame.sequence == last_sequence[c]) continue;
      EXPECT_EQ(frame.sequence, last_sequence[c] + 1);  // one per published frame
      last_sequence[c] = frame.sequence;
      // Delivered at the first scan at or after exposure + latency.
      const std::int64_t age_ns = rig.in.time_ns - frame.frame_time_ns;
      const std::int64_t latency_ns = ns(rig.config.cameras[c].latency_s);
      EXPECT_GE(age_ns, latency_ns) << c;
      EXPECT_LT(age_ns, latency_ns + kStepNs) << c;
      const std::int64_t period_ns = ns(rig.line.cameras[c].period_s);
      if (frames[c] > 0) {
        // Jitter 0.5 ms sigma on each exposure, taken at the next 1 ms step: within 5 ms.
        EXPECT_NEAR(static_cast<double>(frame.frame_time_ns - last_time[c]),
                    static_cast<double>(period_ns), 5e6)
            << c;
      } else {
        first_time[c] = frame.frame_time_ns;
      }
      last_time[c] = frame.frame_time_ns;
      ++frames[c];
      // The one body under the camera, at the optical axis.
      ASSERT_GE(frame.count, 1U);
      EXPECT_NEAR(frame.estimates[0].x_mm, 0.0F, 10.0F);
    }
  }
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    const double period_s = rig.line.cameras[c].period_s;
    // 10 s of frames, give or take the first exposure phase and the latency.
    EXPECT_NEAR(static_cast<double>(frames[c]), 10.0 / period_s, 3.0) << c;
    // Mean interval: the jitter does not accumulate.
    const double mean_ns =
        static_cast<double>(last_time[c] - first_time[c]) / static_cast<double>(frames[c] - 1);
    EXPECT_NEAR(mean_ns, period_s * 1e9, 0.1e6) << c;
  }
}

TEST(FastCameras, NoiseAndMisclassificationStatistics) {
  Rig rig;
  rig.out = OutputImage{};
  const CameraId ids[] = {CameraId::kOrientation, CameraId::kPosition, CameraId::kFinal};
  // Truth per camera (the guide rails keep heading 0 and |y| < 40 mm as they are).
  const double ys[] = {10.0, -20.0, 5.0};
  const double angles[] = {0.0, 0.5, -2.0};
  for (std::size_t k = 0; k < 3; ++k) {
    ASSERT_TRUE(rig.plant->spawn_body(
        still_at(rig.line.cameras[index(ids[k])].s_mm + 20.0, ys[k], angles[k])));
  }
  std::array<Stats, 3> x{};
  std::array<Stats, 3> y{};
  std::array<Stats, 3> angle{};
  std::array<std::size_t, 3> hand_flips{};
  std::array<std::size_t, 3> side_flips{};
  std::array<std::size_t, 3> not_singulated{};
  std::array<std::uint32_t, 3> last_sequence{};
  for (int i = 0; i < 6000; ++i) {  // 60 s
    rig.step(kStepNs);
    for (std::size_t k = 0; k < 3; ++k) {
      const std::size_t c = index(ids[k]);
      const CameraFrame& frame = rig.in.cameras[c];
      if (frame.sequence == last_sequence[k]) continue;
      last_sequence[k] = frame.sequence;
      if (frame.count == 0) continue;  // a miss (0.5 %)
      ASSERT_EQ(frame.count, 1U);
      const FilletEstimate& e = frame.estimates[0];
      x[k].add(e.x_mm - 20.0);
      y[k].add(e.y_mm - ys[k]);
      angle[k].add(wrap_angle_rad(e.angle_rad - angles[k]));
      not_singulated[k] += e.singulated ? 0U : 1U;
      const bool flipped_hand = e.hand != Hand::kLeft;
      const bool flipped_side = e.side != SideUp::kBone;
      if (rig.config.cameras[c].classifies) {
        hand_flips[k] += flipped_hand ? 1U : 0U;
        side_flips[k] += flipped_side ? 1U : 0U;
        const auto& cfg = rig.config.cameras[c];
        if (flipped_hand || flipped_side) {
          EXPECT_GE(e.confidence, cfg.confidence_bad_min);
          EXPECT_LE(e.confidence, cfg.confidence_bad_max);
        } else {
          EXPECT_GE(e.confidence, cfg.confidence_ok_min);
          EXPECT_LE(e.confidence, cfg.confidence_ok_max);
        }
      } else {
        EXPECT_EQ(e.hand, Hand::kUnknown);
        EXPECT_EQ(e.side, SideUp::kUnknown);
      }
    }
  }
  for (std::size_t k = 0; k < 3; ++k) {
    const FastCameraConfig& cfg = rig.config.cameras[index(ids[k])];
    ASSERT_GT(x[k].n, 1000U);  // 60 s at 40 ms: 1500 frames less misses
    expect_noise(x[k], cfg.position_sigma_mm, "x");
    expect_noise(y[k], cfg.position_sigma_mm, "y");
    expect_noise(angle[k], cfg.angle_sigma_rad, "angle");
    // Binomial counts within 4 standard deviations.
    const auto n = static_cast<double>(x[k].n);
    const double p_hand = cfg.hand_flip_prob;
    const double p_side = cfg.side_flip_prob;
    EXPECT_NEAR(static_cast<double>(hand_flips[k]), n * p_hand,
                4.0 * std::sqrt(n * p_hand * (1.0 - p_hand)) + 1e-9);
    EXPECT_NEAR(static_cast<double>(side_flips[k]), n * p_side,
                4.0 * std::sqrt(n * p_side * (1.0 - p_side)) + 1e-9);
    const double p_sing = cfg.singulation_error_prob;
    EXPECT_NEAR(static_cast<double>(not_singulated[k]), n * p_sing,
                4.0 * std::sqrt(n * p_sing * (1.0 - p_sing)));
  }
}

TEST(FastCameras, OnlyBodiesInTheFieldOfViewAndAtMostEightPerFrame) {
  Rig rig;
  rig.out = OutputImage{};
  const CameraMount& mount = rig.line.cameras[index(CameraId::kPosition)];
  // Three lanes (y = -180, 0, 180) of four sideways bodies 75 mm apart in the 300 mm view:
  // twelve in view, none touching.
  for (double y_mm : {-180.0, 0.0, 180.0}) {
    for (int k = 0; k < 4; ++k) {
      ASSERT_TRUE(rig.plant->spawn_body(
          still_at(mount.s_mm - 112.5 + 75.0 * k, y_mm, 0.5 * std::numbers::pi)));
    }
  }
  // One just outside the view.
  ASSERT_TRUE(rig.plant->spawn_body(still_at(mount.s_mm + 0.5 * 300.0 + 40.0, 0.0, 0.0)));
  rig.run(0.5, kStepNs);
  const CameraFrame& frame = rig.in.cameras[index(CameraId::kPosition)];
  EXPECT_EQ(frame.count, kMaxEstimatesPerFrame);
  EXPECT_GT(rig.plant->cameras().counters().detections_truncated[index(CameraId::kPosition)], 0U);
  for (std::size_t i = 0; i < frame.count; ++i) {
    EXPECT_LE(std::abs(frame.estimates[i].x_mm), 0.5F * mount.field_of_view_mm + 10.0F);
  }
}

TEST(FastCameras, TouchingPairIsOneBlobNotSingulated) {
  Rig rig;
  rig.out = OutputImage{};
  BodySpawn pair = still_at(rig.line.cameras[index(CameraId::kFinal)].s_mm, 0.0, 0.0);
  pair.touching_pair = true;
  ASSERT_TRUE(rig.plant->spawn_body(pair));
  std::size_t frames = 0;
  std::size_t singulated = 0;
  std::uint32_t last = 0;
  for (int i = 0; i < 2000; ++i) {
    rig.step(kStepNs);
    const CameraFrame& frame = rig.in.cameras[index(CameraId::kFinal)];
    if (frame.sequence == last || frame.count == 0) continue;
    last = frame.sequence;
    ASSERT_EQ(frame.count, 1U);
    ++frames;
    singulated += frame.estimates[0].singulated ? 1U : 0U;
    EXPECT_LE(frame.estimates[0].confidence,
              rig.config.cameras[index(CameraId::kFinal)].confidence_bad_max);
  }
  // 1 % wrong singulation flags: 500 frames, expected 5, within 4 sigma (2.2).
  ASSERT_GT(frames, 400U);
  EXPECT_LE(static_cast<double>(singulated), 0.01 * static_cast<double>(frames) + 4.0 * 2.23 + 1);
  EXPECT_EQ(rig.plant->bodies()[0].member_count, 2U);
}

// ---------------------------------------------------------------- faults

struct FaultRig {
  FaultRig() : rig(no_miss_config()) {
    rig.out = OutputImage{};
    EXPECT_TRUE(rig.plant->spawn_body(still_at(mount().s_mm, 0.0, 0.3)));
    rig.run(0.5, kStepNs);
  }
  const CameraMount& mount() const { return rig.line.cameras[index(CameraId::kPosition)]; }
  FastCameraFaults& faults() { return rig.plant->faults().cameras[index(CameraId::kPosition)]; }
  const CameraFrame& frame() const { return rig.in.cameras[index(CameraId::kPosition)]; }
  // Calls `check` on each new frame for `seconds`; returns how many. Frames exposed before a
  // fault was set (at most the 20 ms latency old) are skipped first.
  int each_new_frame(double seconds, const std::function<void(const CameraFrame&)>& check) {
    rig.run(0.03, kStepNs);
    int count = 0;
    std::uint32_t last = frame().sequence;
    const auto steps = static_cast<int>(seconds / 0.01);
    for (int i = 0; i < steps; ++i) {
      rig.step(kStepNs);
      if (frame().sequence == last) continue;
      last = frame().sequence;
      check(frame());
      ++count;
    }
    return count;
  }
  Rig rig;
};

TEST(FastCameraFaults, DroppedFramesAndStaleCameraStopTheSequence) {
  FaultRig drop;
  drop.faults().drop_frame_prob = 1.0F;
  EXPECT_EQ(drop.each_new_frame(1.0, [](const CameraFrame&) {}), 0);
  drop.faults().drop_frame_prob = 0.0F;
  EXPECT_GT(drop.each_new_frame(1.0, [](const CameraFrame&) {}), 20);

  FaultRig stale;
  const CameraFrame before = stale.frame();
  stale.faults().stale = true;
  EXPECT_EQ(stale.each_new_frame(1.0, [](const CameraFrame&) {}), 0);
  EXPECT_EQ(stale.frame().frame_time_ns, before.frame_time_ns);
  EXPECT_GT(stale.rig.plant->cameras().counters().frames_dropped[index(CameraId::kPosition)], 20U);
}

TEST(FastCameraFaults, NanFieldsDuplicatesPhantomsAndOutOfOrderTimes) {
  FaultRig nan;
  nan.faults().nan_prob = 1.0F;
  EXPECT_GT(nan.each_new_frame(1.0,
                               [](const CameraFrame& f) {
                                 ASSERT_EQ(f.count, 1U);
                                 const FilletEstimate& e = f.estimates[0];
                                 EXPECT_TRUE(std::isnan(e.x_mm) || std::isnan(e.y_mm) ||
                                             std::isnan(e.angle_rad) || std::isnan(e.confidence));
                               }),
            20);

  FaultRig duplicate;
  duplicate.faults().duplicate_prob = 1.0F;
  EXPECT_GT(duplicate.each_new_frame(1.0,
                                     [](const CameraFrame& f) {
                                       ASSERT_EQ(f.count, 2U);
                                       EXPECT_NEAR(f.estimates[0].x_mm, f.estimates[1].x_mm, 6.0F);
                                     }),
            20);

  FaultRig phantom;
  phantom.faults().phantom_prob = 1.0F;
  EXPECT_GT(phantom.each_new_frame(1.0, [](const CameraFrame& f) { EXPECT_EQ(f.count, 2U); }), 20);

  FaultRig order;
  order.faults().out_of_order_prob = 1.0F;
  order.rig.run(0.03, kStepNs);
  std::int64_t previous = order.frame().frame_time_ns;
  EXPECT_GT(order.each_new_frame(1.0,
                                 [&](const CameraFrame& f) {
                                   EXPECT_LT(f.frame_time_ns, previous);
                                   previous = f.frame_time_ns;
                                 }),
            20);
}

TEST(FastCameraFaults, FaultsDoNotShiftTheOtherRandomStreams) {
  // A camera fault changes that camera's frames only: the bodies fed are the same.
  auto run = [](bool faulty) {
    Rig rig(quiet_config(), default_line_config(), 7);
    rig.out.leveller_speed_rpm = 120.0F;
    rig.out.hopper_opening_mm = 60.0F;
    rig.out.drives[index(DriveId::kBulk)].speed_mps = 0.05F;
    rig.out.drives[index(DriveId::kTakt)].speed_mps = 0.2F;
    if (faulty) rig.plant->faults().cameras[index(CameraId::kOrientation)].phantom_prob = 0.5F;
    rig.run(20.0, kStepNs);
    std::vector<double> positions;
    for (const FilletBody& body : rig.plant->bodies()) positions.push_back(body.s_mm);
    return positions;
  };
  EXPECT_EQ(run(false), run(true));
}

}  // namespace
}  // namespace fl::test
