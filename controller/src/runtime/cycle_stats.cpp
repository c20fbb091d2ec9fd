#include "fl/controller/cycle_stats.hpp"

#include <algorithm>
#include <stdexcept>

namespace fl {

namespace {

std::size_t overflow_bin_index(std::int64_t bin_width_ns, std::int64_t range_ns) {
  if (bin_width_ns <= 0 || range_ns < bin_width_ns) {
    throw std::invalid_argument("DurationHistogram needs 0 < bin_width_ns <= range_ns");
  }
  // A range that is not a multiple of the bin width is rounded up to whole bins.
  return static_cast<std::size_t>((range_ns + bin_width_ns - 1) / bin_width_ns);
}

// Nearest rank ceil(quantile * count), at least 1. The tolerance keeps 0.999 * 1000 at rank
// 999 although 0.999 has no exact binary representation.
std::uint64_t nearest_rank(double quantile, std::uint64_t count) {
  const double exact_rank = quantile * static_cast<double>(count);
  auto rank = static_cast<std::uint64_t>(exact_rank);
  if (exact_rank - static_cast<double>(rank) > 1e-9 * std::max(1.0, exact_rank)) ++rank;
  return std::clamp<std::uint64_t>(rank, 1, count);
}

}  // namespace

DurationHistogram::DurationHistogram(std::int64_t bin_width_ns, std::int64_t range_ns)
    : bin_width_ns_(bin_width_ns),
      overflow_bin_(overflow_bin_index(bin_width_ns, range_ns)),
      bins_(overflow_bin_ + 1, 0) {}

void DurationHistogram::clear() noexcept {
  std::fill(bins_.begin(), bins_.end(), 0);
  count_ = 0;
  sum_ns_ = 0;
  min_ns_ = std::numeric_limits<std::int64_t>::max();
  max_ns_ = 0;
}

double DurationHistogram::mean_ns() const noexcept {
  return count_ == 0 ? 0.0 : static_cast<double>(sum_ns_) / static_cast<double>(count_);
}

std::int64_t DurationHistogram::quantile_ns(double quantile) const noexcept {
  if (count_ == 0) return 0;
  const std::uint64_t rank = nearest_rank(quantile, count_);
  std::uint64_t seen = 0;
  for (std::size_t bin = 0; bin < overflow_bin_; ++bin) {
    seen += bins_[bin];
    if (seen >= rank) {
      const auto lower_edge_ns = static_cast<std::int64_t>(bin) * bin_width_ns_;
      return std::clamp(lower_edge_ns, min_ns_, max_ns_);
    }
  }
  return max_ns_;  // the rank lies in the overflow bin, whose only known value is the max
}

DistributionSummary DurationHistogram::summary() const noexcept {
  DistributionSummary summary;
  summary.count = count_;
  summary.overflow_count = overflow_count();
  summary.min_ns = min_ns();
  summary.max_ns = max_ns();
  summary.mean_ns = mean_ns();
  summary.p50_ns = quantile_ns(0.5);
  summary.p99_ns = quantile_ns(0.99);
  summary.p999_ns = quantile_ns(0.999);
  return summary;
}

CycleStats::CycleStats(std::int64_t bin_width_ns, std::int64_t range_ns)
    : wakeup_latency_(bin_width_ns, range_ns), compute_(bin_width_ns, range_ns) {}

void CycleStats::clear() noexcept {
  wakeup_latency_.clear();
  compute_.clear();
  scans_ = 0;
  overruns_ = 0;
  missed_periods_ = 0;
  max_consecutive_overruns_ = 0;
}

CycleStatsSummary CycleStats::summary() const noexcept {
  CycleStatsSummary summary;
  summary.scans = scans_;
  summary.overruns = overruns_;
  summary.missed_periods = missed_periods_;
  summary.max_consecutive_overruns = max_consecutive_overruns_;
  summary.wakeup_latency = wakeup_latency_.summary();
  summary.compute = compute_.summary();
  return summary;
}

}  // namespace fl
