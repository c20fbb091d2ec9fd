// Scan-cycle statistics with fixed memory: every buffer is allocated in the constructor, so
// recording a sample in the cycle is a few integer operations and never allocates, locks or
// blocks. Percentiles come from a fixed-bin histogram (1 us bins up to 10 ms by default, plus
// one overflow bin) and are computed outside the cycle.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

namespace fl {

// Count, min, max, mean and percentiles of one quantity (a latency or a duration), in ns.
// Plain fields so that the app can serialise it (JSON, CSV, log line) as it likes.
struct DistributionSummary {
  std::uint64_t count = 0;
  std::uint64_t overflow_count = 0;  // samples at or beyond the histogram's range
  std::int64_t min_ns = 0;
  std::int64_t max_ns = 0;
  double mean_ns = 0.0;
  // Nearest-rank percentiles at the histogram's resolution: the lower edge of the bin that
  // holds the sample of that rank (the way cyclictest truncates to whole microseconds),
  // clamped to [min_ns, max_ns]. A rank that falls into the overflow bin reports max_ns.
  std::int64_t p50_ns = 0;
  std::int64_t p99_ns = 0;
  std::int64_t p999_ns = 0;
};

// Histogram of non-negative durations with equal-width bins and one overflow bin.
class DurationHistogram {
 public:
  static constexpr std::int64_t kDefaultBinWidthNs = 1'000;    // 1 us
  static constexpr std::int64_t kDefaultRangeNs = 10'000'000;  // 10 ms

  // Allocates range_ns / bin_width_ns bins plus the overflow bin. Throws
  // std::invalid_argument unless 0 < bin_width_ns <= range_ns.
  explicit DurationHistogram(std::int64_t bin_width_ns = kDefaultBinWidthNs,
                             std::int64_t range_ns = kDefaultRangeNs);

  // Real-time safe. A negative sample counts as 0 (a clock cannot run backwards, but a
  // caller's subtraction might).
  void record(std::int64_t value_ns) noexcept {
    const std::int64_t clamped_ns = value_ns < 0 ? 0 : value_ns;
    const auto bin = static_cast<std::size_t>(clamped_ns / bin_width_ns_);
    ++bins_[bin < overflow_bin_ ? bin : overflow_bin_];
    ++count_;
    sum_ns_ += clamped_ns;
    if (clamped_ns < min_ns_) min_ns_ = clamped_ns;
    if (clamped_ns > max_ns_) max_ns_ = clamped_ns;
  }

  // Empties the histogram without releasing memory (real-time safe).
  void clear() noexcept;

  // The value of nearest rank ceil(quantile * count), quantile in (0, 1]; 0 when empty.
  // O(bins): call it outside the cycle.
  [[nodiscard]] std::int64_t quantile_ns(double quantile) const noexcept;
  [[nodiscard]] DistributionSummary summary() const noexcept;

  [[nodiscard]] std::uint64_t count() const noexcept { return count_; }
  [[nodiscard]] std::int64_t min_ns() const noexcept { return count_ == 0 ? 0 : min_ns_; }
  [[nodiscard]] std::int64_t max_ns() const noexcept { return count_ == 0 ? 0 : max_ns_; }
  [[nodiscard]] double mean_ns() const noexcept;
  [[nodiscard]] std::uint64_t overflow_count() const noexcept { return bins_[overflow_bin_]; }
  [[nodiscard]] std::int64_t bin_width_ns() const noexcept { return bin_width_ns_; }
  [[nodiscard]] std::int64_t range_ns() const noexcept {
    return static_cast<std::int64_t>(overflow_bin_) * bin_width_ns_;
  }
  // Sample counts per bin, the last entry being the overflow bin.
  [[nodiscard]] const std::vector<std::uint64_t>& bins() const noexcept { return bins_; }

 private:
  std::int64_t bin_width_ns_;
  std::size_t overflow_bin_;
  std::vector<std::uint64_t> bins_;
  std::uint64_t count_ = 0;
  std::int64_t sum_ns_ = 0;  // 2^63 ns is 292 years of samples
  std::int64_t min_ns_ = std::numeric_limits<std::int64_t>::max();
  std::int64_t max_ns_ = 0;
};

// Everything a commissioning engineer wants to know about the scan timing of a run.
struct CycleStatsSummary {
  std::uint64_t scans = 0;
  std::uint64_t overruns = 0;        // scans that finished after the next deadline
  std::uint64_t missed_periods = 0;  // scheduled scans skipped because of overruns
  std::uint32_t max_consecutive_overruns = 0;
  DistributionSummary wakeup_latency;  // actual wake-up minus scheduled wake-up
  DistributionSummary compute;         // read + update + write
};

// What the runtime measured of one scan, as it hands it to ScanLogic::after_scan.
struct ScanTimingSample {
  std::int64_t period_ns = 0;
  std::int64_t wakeup_latency_ns = 0;  // actual minus scheduled wake-up
  std::int64_t compute_ns = 0;         // read + update + write
  std::uint64_t scans = 0;             // since start, this one included
  std::uint64_t overruns = 0;
};

class CycleStats {
 public:
  explicit CycleStats(std::int64_t bin_width_ns = DurationHistogram::kDefaultBinWidthNs,
                      std::int64_t range_ns = DurationHistogram::kDefaultRangeNs);

  // Real-time safe.
  void record_scan(std::int64_t wakeup_latency_ns, std::int64_t compute_ns) noexcept {
    wakeup_latency_.record(wakeup_latency_ns);
    compute_.record(compute_ns);
    ++scans_;
  }
  // One overrunning scan that made the schedule skip `missed_periods` wake-ups.
  void record_overrun(std::uint64_t missed_periods, std::uint32_t consecutive) noexcept {
    ++overruns_;
    missed_periods_ += missed_periods;
    if (consecutive > max_consecutive_overruns_) max_consecutive_overruns_ = consecutive;
  }
  void clear() noexcept;

  [[nodiscard]] CycleStatsSummary summary() const noexcept;
  [[nodiscard]] const DurationHistogram& wakeup_latency() const noexcept { return wakeup_latency_; }
  [[nodiscard]] const DurationHistogram& compute() const noexcept { return compute_; }
  [[nodiscard]] std::uint64_t scans() const noexcept { return scans_; }
  [[nodiscard]] std::uint64_t overruns() const noexcept { return overruns_; }
  [[nodiscard]] std::uint64_t missed_periods() const noexcept { return missed_periods_; }

 private:
  DurationHistogram wakeup_latency_;
  DurationHistogram compute_;
  std::uint64_t scans_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint64_t missed_periods_ = 0;
  std::uint32_t max_consecutive_overruns_ = 0;
};

}  // namespace fl
