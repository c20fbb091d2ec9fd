// What a soak (a long closed-loop run on the real-time schedule) is judged by: memory that
// stays flat after a warm-up, no scan woken late beyond a bound (under SCHED_FIFO), and no
// fillet lost. The run samples a timeline; evaluate_soak() turns the timeline and the run's
// totals into a verdict with every figure it used, so the report shows why it passed or not.
#pragma once

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fl/apps/closed_loop.hpp"
#include "fl/controller/cycle_stats.hpp"

namespace fl::apps {

// One point of the timeline, taken every few seconds of the run.
struct SoakSample {
  double elapsed_s = 0.0;
  std::uint64_t resident_kib = 0;  // the process's resident set
  // Maxima over the scans since the previous sample.
  std::int64_t max_wakeup_latency_ns = 0;
  std::int64_t max_compute_ns = 0;
  // The machine's own worst wake-up in the interval (LatencyProbe beside the scan); 0 when
  // no probe ran.
  std::int64_t probe_max_wakeup_latency_ns = 0;
  // Running totals.
  std::uint64_t scans = 0;
  std::uint64_t overruns = 0;
  std::uint64_t fillets_fed = 0;
  std::uint64_t items_closed = 0;
};

struct SoakCriteria {
  double warm_up_s = 300.0;  // caches, pools and the tracker fill up before memory is judged
  std::uint64_t max_resident_growth_kib = 1024;
  std::int64_t max_wakeup_latency_ns = 1'000'000;  // a scan later than this missed its deadline
  bool require_fifo = true;                        // the deadline bound holds under SCHED_FIFO
};

// What the run measured, as a whole.
struct SoakRun {
  double planned_s = 0.0;
  double fed_s = 0.0;
  double elapsed_s = 0.0;
  bool stopped_by_signal = false;
  bool fifo_applied = false;
  bool memory_locked = false;
  bool dma_latency_held = false;  // /dev/cpu_dma_latency held for the whole run
  std::vector<SoakSample> timeline;
  CycleStatsSummary cycle;
  std::uint64_t scans_at_or_beyond_bound = 0;  // from the whole run's wake-up histogram
  // The machine's baseline (LatencyProbe), when one ran beside the scan.
  bool probe_ran = false;
  bool probe_fifo = false;
  DistributionSummary probe_latency;
  std::uint64_t probe_at_or_beyond_bound = 0;
  Kpis kpis;
};

struct SoakVerdict {
  bool passed = false;
  std::vector<std::string> failures;  // one sentence per criterion missed

  // Memory: the resident set at the first sample after the warm-up, the largest after it.
  std::optional<std::uint64_t> resident_at_warm_up_kib;
  std::uint64_t resident_max_after_warm_up_kib = 0;
  std::int64_t resident_growth_kib = 0;

  std::int64_t max_wakeup_latency_ns = 0;
  std::uint64_t late_scans = 0;  // woken at or beyond the bound (1 us histogram resolution)
  std::uint64_t overruns = 0;
  std::uint64_t missed_periods = 0;

  // Whose are the late scans? Sample intervals with a scan woken at or beyond the bound, and
  // how many of those had the probe late too; a sentence saying what that means (empty
  // when no scan was late).
  std::uint64_t intervals_with_late_scan = 0;
  std::uint64_t of_which_probe_late = 0;
  std::string deadline_diagnosis;

  std::uint64_t lost_fillets = 0;  // ledger kLost records
  bool books_balanced = false;     // ledger and plant truth both balance, no record dropped
};

// Scans in `histogram` at or beyond `bound_ns`, at the histogram's bin resolution.
std::uint64_t count_at_or_beyond(const DurationHistogram& histogram, std::int64_t bound_ns);

SoakVerdict evaluate_soak(const SoakRun& run, const SoakCriteria& criteria);

// The resident set of this process (/proc/self/statm); nullopt where it cannot be read.
std::optional<std::uint64_t> resident_kib();

nlohmann::json to_json(const SoakSample& sample);
nlohmann::json to_json(const SoakCriteria& criteria);
nlohmann::json to_json(const SoakVerdict& verdict);
nlohmann::json to_json(const SoakRun& run, const SoakCriteria& criteria,
                       const SoakVerdict& verdict);

}  // namespace fl::apps
