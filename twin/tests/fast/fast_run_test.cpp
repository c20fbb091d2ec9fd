// Long runs of the whole fast plant under a random open-loop operator: the ground-truth
// balance (fed = exits + on line), determinism (same seed, byte-equal input images;
// different seeds differ) and no allocation in step() after warm-up.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <new>
#include <set>
#include <vector>

#include "fast_test_support.hpp"

// Counts every allocation of this test binary, to check that step() makes none.
namespace {
std::atomic<std::size_t> g_allocations{0};
}  // namespace

// GCC sees free() on memory from operator new and warns; here that pairing is the point.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop

namespace fl::test {
namespace {

constexpr std::int64_t kScanNs = 10 * kMs;

// A crude line operator, deterministic from its own seed: belts at nominal speed (takt at a
// steady 0.2 m/s, about one fillet per second), the bulk belt on a P loop from the level,
// and every 100 ms random changes to the plates, reject reversals, air-knife pulses,
// centring strokes, the roller and the multilane differentials, so that every station and
// every exit is exercised.
class RandomOperator {
 public:
  RandomOperator(const LineConfig& line, std::uint64_t seed)
      : rng_(seed), out_(belts_running(line)) {
    out_.drives[index(DriveId::kTakt)].speed_mps = 0.2F;
    out_.drives[index(DriveId::kBulk)].enable = true;
    out_.leveller_speed_rpm = 120.0F;
    out_.hopper_opening_mm = 60.0F;
  }

  const OutputImage& update(const InputImage& in) {
    const float bulk = std::clamp(0.004F * (60.0F - in.level_mm), 0.0F, 0.15F);
    out_.drives[index(DriveId::kBulk)].speed_mps = bulk;
    if (in.time_ns < next_change_ns_) return out_;
    next_change_ns_ = in.time_ns + 100 * kMs;
    if (rng_.bernoulli(0.2)) out_.flip_plate1_flip = !out_.flip_plate1_flip;
    if (rng_.bernoulli(0.2)) out_.flip_plate2_flip = !out_.flip_plate2_flip;
    auto& reject = out_.drives[index(DriveId::kReject)];
    if (reject_until_ns_ > 0 && in.time_ns >= reject_until_ns_) {
      reject.speed_mps = 0.5F;
      reject_until_ns_ = 0;
    } else if (reject_until_ns_ == 0 && rng_.bernoulli(0.03)) {
      reject.speed_mps = -0.5F;
      reject_until_ns_ = in.time_ns + 800 * kMs;
    }
    out_.final_reject = rng_.bernoulli(0.05);
    if (rng_.bernoulli(0.3)) {
      out_.centring_stroke = !out_.centring_stroke;
      out_.centring_shift_mm = static_cast<float>(rng_.uniform(-40.0, 40.0));
    }
    if (rng_.bernoulli(0.3)) out_.squeeze_roller_down = !out_.squeeze_roller_down;
    for (auto [left, right] : {std::pair{DriveId::kMultilane1Left, DriveId::kMultilane1Right},
                               std::pair{DriveId::kMultilane2Left, DriveId::kMultilane2Right}}) {
      if (!rng_.bernoulli(0.3)) continue;
      const float diff = static_cast<float>(rng_.uniform(-0.3, 0.3));
      out_.drives[index(left)].speed_mps = 0.4F - 0.5F * diff;
      out_.drives[index(right)].speed_mps = 0.4F + 0.5F * diff;
    }
    return out_;
  }

 private:
  FastRng rng_;
  OutputImage out_;
  std::int64_t next_change_ns_ = 0;
  std::int64_t reject_until_ns_ = 0;
};

// Moderate camera faults everywhere, to exercise those paths in the determinism check.
void inject_camera_faults(FastPlant& plant) {
  for (auto& camera : plant.faults().cameras) {
    camera.drop_frame_prob = 0.02F;
    camera.nan_prob = 0.01F;
    camera.duplicate_prob = 0.02F;
    camera.out_of_order_prob = 0.01F;
    camera.phantom_prob = 0.02F;
  }
}

TEST(FastRun, GroundTruthBalancesOverALongRandomRun) {
  const LineConfig line = default_line_config();
  FastPlant plant(line, FastPlantConfig{});
  InputImage in{};
  plant.reset(42, in);
  RandomOperator op(line, 4242);
  std::vector<TrueFilletExit> exits;
  exits.reserve(1000);
  for (int i = 0; i < 18000; ++i) {  // 180 s
    plant.step(op.update(in), kScanNs, in);
    for (const TrueFilletExit& exit : plant.drain_exits()) exits.push_back(exit);
    ASSERT_EQ(plant.fillets_fed(), exits.size() + plant.fillets_on_line()) << i;
  }
  // About one fillet a second crosses the barrier.
  EXPECT_GT(plant.fillets_fed(), 120U);
  std::array<std::size_t, 4> by_exit{};
  std::set<std::uint32_t> ids;
  std::size_t in_pairs = 0;
  for (const TrueFilletExit& exit : exits) {
    ++by_exit[static_cast<std::size_t>(exit.exit)];
    EXPECT_TRUE(ids.insert(exit.plant_id).second) << "fillet " << exit.plant_id << " left twice";
    if (!exit.singulated) ++in_pairs;
  }
  EXPECT_GT(by_exit[static_cast<std::size_t>(TrueExit::kOutfeed)], 20U);
  EXPECT_GT(by_exit[static_cast<std::size_t>(TrueExit::kRejectCrate)], 0U);
  EXPECT_GT(by_exit[static_cast<std::size_t>(TrueExit::kFinalReject)], 0U);
  EXPECT_EQ(in_pairs % 2, 0U);  // touching pairs leave together
  const FastPlantCounters& counters = plant.counters();
  EXPECT_EQ(counters.exits_not_recorded, 0U);
  EXPECT_EQ(counters.pool_full_refusals, 0U);
  EXPECT_GT(counters.groups_spawned, 0U);
  EXPECT_GT(counters.misflips, 0U);
  EXPECT_GT(counters.roller_stuck, 0U);
}

TEST(FastRun, SameSeedGivesByteEqualImagesDifferentSeedsDiffer) {
  const LineConfig line = default_line_config();
  auto run = [&](std::uint64_t seed, std::vector<InputImage>& images) {
    FastPlant plant(line, FastPlantConfig{});
    InputImage in{};
    plant.reset(seed, in);
    inject_camera_faults(plant);
    RandomOperator op(line, 99);
    images.push_back(in);
    for (int i = 0; i < 5000; ++i) {  // 50 s
      plant.step(op.update(in), kScanNs, in);
      images.push_back(in);
      (void)plant.drain_exits();
    }
  };
  std::vector<InputImage> a;
  std::vector<InputImage> b;
  std::vector<InputImage> c;
  a.reserve(5001);
  b.reserve(5001);
  c.reserve(5001);
  run(5, a);
  run(5, b);
  run(6, c);
  ASSERT_EQ(a.size(), b.size());
  // Bit for bit: the injected camera faults put NaNs in the images, which == never matches.
  // Every image starts value-initialised (zero padding) and is copied whole, so the padding
  // bytes compare equal too.
  for (std::size_t i = 0; i < a.size(); ++i) {
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison)
    ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(InputImage)), 0) << "image " << i;
  }
  std::size_t differing = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    // NOLINTNEXTLINE(bugprone-suspicious-memory-comparison)
    differing += std::memcmp(&a[i], &c[i], sizeof(InputImage)) != 0 ? 1U : 0U;
  }
  EXPECT_GT(differing, a.size() / 2);
}

TEST(FastRun, ResetRestartsTheSameSequence) {
  const LineConfig line = default_line_config();
  FastPlant plant(line, FastPlantConfig{});
  std::vector<InputImage> first;
  first.reserve(1001);
  for (int pass = 0; pass < 2; ++pass) {
    InputImage in{};
    plant.reset(11, in);
    RandomOperator op(line, 3);
    for (int i = 0; i < 1000; ++i) {
      plant.step(op.update(in), kScanNs, in);
      if (pass == 0) {
        first.push_back(in);
      } else {
        ASSERT_TRUE(first[static_cast<std::size_t>(i)] == in) << i;
      }
    }
    EXPECT_EQ(in.time_ns, 1000 * kScanNs);
  }
}

TEST(FastRun, StepDoesNotAllocateAfterWarmUp) {
  const LineConfig line = default_line_config();
  FastPlant plant(line, FastPlantConfig{});
  InputImage in{};
  plant.reset(8, in);
  inject_camera_faults(plant);
  RandomOperator op(line, 8);
  for (int i = 0; i < 500; ++i) {
    plant.step(op.update(in), kScanNs, in);
    (void)plant.drain_exits();
  }
  const std::size_t before = g_allocations.load();
  std::uint64_t exits = 0;
  for (int i = 0; i < 6000; ++i) {  // 60 s with the line full
    plant.step(op.update(in), kScanNs, in);
    exits += plant.drain_exits().size();
  }
  EXPECT_EQ(g_allocations.load(), before);
  EXPECT_GT(exits, 20U);
}

}  // namespace
}  // namespace fl::test
