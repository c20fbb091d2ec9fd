#include "fl/controller/cycle_stats.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>
#include <stdexcept>
#include <vector>

#include "scan_thread_probe.hpp"

namespace fl {
namespace {

constexpr std::int64_t kUs = 1'000;
constexpr std::int64_t kMs = 1'000'000;

TEST(DurationHistogram, EmptyReportsZeros) {
  const DurationHistogram histogram;
  const DistributionSummary summary = histogram.summary();
  EXPECT_EQ(summary.count, 0U);
  EXPECT_EQ(summary.min_ns, 0);
  EXPECT_EQ(summary.max_ns, 0);
  EXPECT_EQ(summary.mean_ns, 0.0);
  EXPECT_EQ(summary.p50_ns, 0);
  EXPECT_EQ(summary.p999_ns, 0);
}

TEST(DurationHistogram, DefaultIsOneMicrosecondBinsToTenMilliseconds) {
  const DurationHistogram histogram;
  EXPECT_EQ(histogram.bin_width_ns(), 1 * kUs);
  EXPECT_EQ(histogram.range_ns(), 10 * kMs);
  EXPECT_EQ(histogram.bins().size(), 10'001U);  // plus the overflow bin
}

// 1, 2, ..., 1000 us in shuffled order: the nearest-rank percentiles are known exactly.
TEST(DurationHistogram, PercentilesOfUniformDistributionAreExact) {
  std::vector<std::int64_t> samples_ns(1000);
  std::iota(samples_ns.begin(), samples_ns.end(), 1);
  for (auto& sample_ns : samples_ns) sample_ns *= kUs;
  std::shuffle(samples_ns.begin(), samples_ns.end(), std::mt19937(42));

  DurationHistogram histogram;
  for (const std::int64_t sample_ns : samples_ns) histogram.record(sample_ns);

  const DistributionSummary summary = histogram.summary();
  EXPECT_EQ(summary.count, 1000U);
  EXPECT_EQ(summary.overflow_count, 0U);
  EXPECT_EQ(summary.min_ns, 1 * kUs);
  EXPECT_EQ(summary.max_ns, 1000 * kUs);
  EXPECT_DOUBLE_EQ(summary.mean_ns, 500.5 * kUs);
  EXPECT_EQ(summary.p50_ns, 500 * kUs);
  EXPECT_EQ(summary.p99_ns, 990 * kUs);
  EXPECT_EQ(summary.p999_ns, 999 * kUs);  // rank 999, although 0.999 is inexact in binary
  EXPECT_EQ(histogram.quantile_ns(1.0), 1000 * kUs);
  EXPECT_EQ(histogram.quantile_ns(0.001), 1 * kUs);
  EXPECT_EQ(histogram.quantile_ns(0.0), 1 * kUs);  // rank is at least 1
}

// A latency distribution with a rare long tail: the tail must show in p99.9 but not in p99.
TEST(DurationHistogram, RareTailShowsOnlyAboveItsRank) {
  DurationHistogram histogram;
  for (int i = 0; i < 990; ++i) histogram.record(10 * kUs);
  for (int i = 0; i < 9; ++i) histogram.record(200 * kUs);
  histogram.record(5 * kMs);

  const DistributionSummary summary = histogram.summary();
  EXPECT_EQ(summary.p50_ns, 10 * kUs);
  EXPECT_EQ(summary.p99_ns, 10 * kUs);    // rank 990
  EXPECT_EQ(summary.p999_ns, 200 * kUs);  // rank 999
  EXPECT_EQ(histogram.quantile_ns(1.0), 5 * kMs);
  EXPECT_EQ(summary.max_ns, 5 * kMs);
}

TEST(DurationHistogram, PercentileIsLowerBinEdgeClampedToMinAndMax) {
  DurationHistogram histogram;
  histogram.record(1'500);  // bin [1 us, 2 us)
  histogram.record(1'700);
  histogram.record(3'900);                       // bin [3 us, 4 us)
  EXPECT_EQ(histogram.quantile_ns(0.3), 1'500);  // rank 1: lower edge 1000 clamped to the min
  EXPECT_EQ(histogram.quantile_ns(0.5), 1'500);  // rank 2 lies in the same bin
  EXPECT_EQ(histogram.quantile_ns(1.0), 3'000);  // truncated like cyclictest
  EXPECT_EQ(histogram.max_ns(), 3'900);          // the max stays exact
}

TEST(DurationHistogram, SamplesBeyondRangeGoToOverflowAndReportTheMax) {
  DurationHistogram histogram;
  for (int i = 0; i < 98; ++i) histogram.record(100 * kUs);
  histogram.record(10 * kMs);  // exactly the range: first overflow value
  histogram.record(25 * kMs);
  EXPECT_EQ(histogram.overflow_count(), 2U);
  EXPECT_EQ(histogram.quantile_ns(0.98), 100 * kUs);
  EXPECT_EQ(histogram.quantile_ns(0.99), 25 * kMs);  // rank 99 is in the overflow bin
  EXPECT_EQ(histogram.max_ns(), 25 * kMs);
  EXPECT_DOUBLE_EQ(histogram.mean_ns(), (98.0 * 100 * kUs + 10 * kMs + 25 * kMs) / 100.0);
}

TEST(DurationHistogram, NegativeSampleCountsAsZero) {
  DurationHistogram histogram;
  histogram.record(-5);
  EXPECT_EQ(histogram.count(), 1U);
  EXPECT_EQ(histogram.min_ns(), 0);
  EXPECT_EQ(histogram.bins()[0], 1U);
}

TEST(DurationHistogram, ClearKeepsTheBins) {
  DurationHistogram histogram(2 * kUs, 1 * kMs);
  histogram.record(7 * kUs);
  const auto* storage = histogram.bins().data();
  histogram.clear();
  EXPECT_EQ(histogram.count(), 0U);
  EXPECT_EQ(histogram.summary().max_ns, 0);
  EXPECT_EQ(histogram.bins().data(), storage);
  EXPECT_EQ(histogram.bins().size(), 501U);
  histogram.record(7 * kUs);
  EXPECT_EQ(histogram.quantile_ns(1.0), 7 * kUs);  // lower edge 6 us clamped to the min
}

TEST(DurationHistogram, RejectsInvalidGeometry) {
  EXPECT_THROW(DurationHistogram(0, kMs), std::invalid_argument);
  EXPECT_THROW(DurationHistogram(-1, kMs), std::invalid_argument);
  EXPECT_THROW(DurationHistogram(2 * kMs, kMs), std::invalid_argument);
}

TEST(CycleStats, CountsScansAndOverruns) {
  CycleStats stats;
  stats.record_scan(20 * kUs, 300 * kUs);
  stats.record_scan(40 * kUs, 500 * kUs);
  stats.record_overrun(1, 1);
  stats.record_overrun(3, 2);

  const CycleStatsSummary summary = stats.summary();
  EXPECT_EQ(summary.scans, 2U);
  EXPECT_EQ(summary.overruns, 2U);
  EXPECT_EQ(summary.missed_periods, 4U);
  EXPECT_EQ(summary.max_consecutive_overruns, 2U);
  EXPECT_EQ(summary.wakeup_latency.max_ns, 40 * kUs);
  EXPECT_DOUBLE_EQ(summary.wakeup_latency.mean_ns, 30.0 * kUs);
  EXPECT_EQ(summary.compute.min_ns, 300 * kUs);
  EXPECT_EQ(summary.compute.p50_ns, 300 * kUs);

  stats.clear();
  EXPECT_EQ(stats.summary().scans, 0U);
  EXPECT_EQ(stats.summary().overruns, 0U);
}

TEST(CycleStats, RecordingDoesNotAllocate) {
  CycleStats stats;
  test::reset_probe_counts();
  {
    test::ArmedProbeScope armed;
    for (std::int64_t i = 0; i < 20'000; ++i) {
      stats.record_scan(i * 997 % (12 * kMs), i * 31 % kMs);
      if (i % 100 == 0) stats.record_overrun(1, 1);
    }
  }
  EXPECT_EQ(test::probe_counts().allocations, 0U);
  EXPECT_EQ(test::probe_counts().deallocations, 0U);
  EXPECT_EQ(stats.scans(), 20'000U);
}

}  // namespace
}  // namespace fl
