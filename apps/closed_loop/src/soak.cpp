#include "fl/apps/soak.hpp"

#include <spdlog/fmt/fmt.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

namespace fl::apps {

std::uint64_t count_at_or_beyond(const DurationHistogram& histogram, std::int64_t bound_ns) {
  if (bound_ns <= 0) return histogram.count();
  const std::vector<std::uint64_t>& bins = histogram.bins();
  // Bins are [k w, (k+1) w); the one holding bound_ns counts whole, so a sample a little under
  // the bound may count as late but none beyond it is missed.
  const auto first = static_cast<std::size_t>(bound_ns / histogram.bin_width_ns());
  std::uint64_t count = 0;
  for (std::size_t bin = std::min(first, bins.size() - 1); bin < bins.size(); ++bin) {
    count += bins[bin];
  }
  return count;
}

namespace {

// Whose the late scans are, from the latency probe beside the scan.
std::string late_scan_diagnosis(const SoakRun& run, const SoakCriteria& criteria,
                                const SoakVerdict& verdict) {
  const double bound_us = static_cast<double>(criteria.max_wakeup_latency_ns) / 1e3;
  if (!run.probe_ran) {
    return "no latency probe ran beside the scan, so the late scans cannot be told the "
           "machine's or the controller's";
  }
  if (run.probe_at_or_beyond_bound > 0) {
    return fmt::format(
        "the machine itself is late: a bare thread on the same 10 ms schedule{} woke {} times "
        "{:.0f} us or more late (worst {:.0f} us), and was late in {} of the {} intervals in "
        "which the scan was. The tails are the machine's (hypervisor, firmware, kernel), not "
        "the controller's: measure on the line PC, or tune it (isolated core, C-states)",
        run.probe_fifo ? " (SCHED_FIFO, one below the scan)" : " (SCHED_OTHER)",
        run.probe_at_or_beyond_bound, bound_us, static_cast<double>(run.probe_latency.max_ns) / 1e3,
        verdict.of_which_probe_late, verdict.intervals_with_late_scan);
  }
  return fmt::format(
      "the machine was never late (a bare thread on the same schedule stayed under {:.0f} us, "
      "worst {:.0f} us) while the scan was: the controller delays its own scans (compute, "
      "locks, page faults, I/O)",
      bound_us, static_cast<double>(run.probe_latency.max_ns) / 1e3);
}

}  // namespace

SoakVerdict evaluate_soak(const SoakRun& run, const SoakCriteria& criteria) {
  SoakVerdict verdict;
  std::vector<std::string>& failures = verdict.failures;

  if (run.stopped_by_signal) {
    failures.push_back(
        fmt::format("stopped by a signal after {:.0f} of {:.0f} s", run.fed_s, run.planned_s));
  }

  // Memory after the warm-up.
  for (const SoakSample& sample : run.timeline) {
    if (sample.elapsed_s < criteria.warm_up_s || sample.resident_kib == 0) continue;
    if (!verdict.resident_at_warm_up_kib) verdict.resident_at_warm_up_kib = sample.resident_kib;
    verdict.resident_max_after_warm_up_kib =
        std::max(verdict.resident_max_after_warm_up_kib, sample.resident_kib);
  }
  if (!verdict.resident_at_warm_up_kib) {
    failures.push_back(fmt::format(
        "no memory sample after the {:.0f} s warm-up: the run is too short to judge memory",
        criteria.warm_up_s));
  } else {
    verdict.resident_growth_kib =
        static_cast<std::int64_t>(verdict.resident_max_after_warm_up_kib) -
        static_cast<std::int64_t>(*verdict.resident_at_warm_up_kib);
    if (verdict.resident_growth_kib >=
        static_cast<std::int64_t>(criteria.max_resident_growth_kib)) {
      failures.push_back(fmt::format("resident memory grew {} KiB after the warm-up (bound {} KiB)",
                                     verdict.resident_growth_kib,
                                     criteria.max_resident_growth_kib));
    }
  }

  // Deadlines.
  verdict.max_wakeup_latency_ns = run.cycle.wakeup_latency.max_ns;
  verdict.late_scans = run.scans_at_or_beyond_bound;
  verdict.overruns = run.cycle.overruns;
  verdict.missed_periods = run.cycle.missed_periods;
  if (run.cycle.scans == 0) failures.push_back("no scan ran");
  if (criteria.require_fifo && !run.fifo_applied) {
    failures.push_back("the scan did not run under SCHED_FIFO, so its deadlines prove nothing");
  }
  if (verdict.late_scans > 0) {
    failures.push_back(fmt::format("{} scans woke {:.0f} us or more late (worst {:.0f} us)",
                                   verdict.late_scans,
                                   static_cast<double>(criteria.max_wakeup_latency_ns) / 1e3,
                                   static_cast<double>(verdict.max_wakeup_latency_ns) / 1e3));
  }
  if (verdict.overruns > 0) {
    failures.push_back(fmt::format("{} scans overran their period ({} periods missed)",
                                   verdict.overruns, verdict.missed_periods));
  }

  // The machine's share of the misses: a bare thread on the same schedule, late in the same
  // intervals, points at the machine; a probe that was never late points at the controller.
  for (const SoakSample& sample : run.timeline) {
    if (sample.max_wakeup_latency_ns < criteria.max_wakeup_latency_ns) continue;
    ++verdict.intervals_with_late_scan;
    if (sample.probe_max_wakeup_latency_ns >= criteria.max_wakeup_latency_ns) {
      ++verdict.of_which_probe_late;
    }
  }
  if (verdict.late_scans > 0) {
    verdict.deadline_diagnosis = late_scan_diagnosis(run, criteria, verdict);
  }

  // Fillets.
  const Kpis& kpis = run.kpis;
  verdict.lost_fillets = kpis.outcomes[static_cast<std::size_t>(Outcome::kLost)];
  verdict.books_balanced = kpis.ledger_balanced && kpis.truth_balanced &&
                           kpis.records_dropped == 0 && kpis.events_dropped == 0;
  if (verdict.lost_fillets > 0) {
    failures.push_back(fmt::format("{} fillets lost (ledger)", verdict.lost_fillets));
  }
  if (!verdict.books_balanced) {
    failures.push_back(fmt::format(
        "books do not balance: ledger {}, truth {}, records dropped {}, events dropped {}",
        kpis.ledger_balanced ? "balanced" : "unbalanced",
        kpis.truth_balanced ? "balanced" : "unbalanced", kpis.records_dropped,
        kpis.events_dropped));
  }
  if (kpis.truth.fed == 0) failures.push_back("no fillet was fed");

  verdict.passed = failures.empty();
  return verdict;
}

std::optional<std::uint64_t> resident_kib() {
  // statm: size resident shared text lib data dt, in pages.
  std::ifstream statm("/proc/self/statm");
  std::uint64_t size_pages = 0;
  std::uint64_t resident_pages = 0;
  if (!(statm >> size_pages >> resident_pages)) return std::nullopt;
  const long page_bytes = sysconf(_SC_PAGESIZE);
  if (page_bytes <= 0) return std::nullopt;
  return resident_pages * static_cast<std::uint64_t>(page_bytes) / 1024U;
}

nlohmann::json to_json(const SoakSample& sample) {
  return {{"elapsed_s", sample.elapsed_s},
          {"resident_kib", sample.resident_kib},
          {"max_wakeup_latency_us", static_cast<double>(sample.max_wakeup_latency_ns) / 1e3},
          {"max_compute_us", static_cast<double>(sample.max_compute_ns) / 1e3},
          {"probe_max_wakeup_latency_us",
           static_cast<double>(sample.probe_max_wakeup_latency_ns) / 1e3},
          {"scans", sample.scans},
          {"overruns", sample.overruns},
          {"fillets_fed", sample.fillets_fed},
          {"items_closed", sample.items_closed}};
}

nlohmann::json to_json(const SoakCriteria& criteria) {
  return {{"warm_up_s", criteria.warm_up_s},
          {"max_resident_growth_kib", criteria.max_resident_growth_kib},
          {"max_wakeup_latency_us", static_cast<double>(criteria.max_wakeup_latency_ns) / 1e3},
          {"require_fifo", criteria.require_fifo}};
}

nlohmann::json to_json(const SoakVerdict& verdict) {
  nlohmann::json json = {
      {"passed", verdict.passed},
      {"failures", verdict.failures},
      {"resident_max_after_warm_up_kib", verdict.resident_max_after_warm_up_kib},
      {"resident_growth_kib", verdict.resident_growth_kib},
      {"max_wakeup_latency_us", static_cast<double>(verdict.max_wakeup_latency_ns) / 1e3},
      {"late_scans", verdict.late_scans},
      {"overruns", verdict.overruns},
      {"missed_periods", verdict.missed_periods},
      {"intervals_with_late_scan", verdict.intervals_with_late_scan},
      {"of_which_probe_late", verdict.of_which_probe_late},
      {"deadline_diagnosis", verdict.deadline_diagnosis},
      {"lost_fillets", verdict.lost_fillets},
      {"books_balanced", verdict.books_balanced}};
  json["resident_at_warm_up_kib"] = verdict.resident_at_warm_up_kib
                                        ? nlohmann::json(*verdict.resident_at_warm_up_kib)
                                        : nlohmann::json(nullptr);
  return json;
}

nlohmann::json to_json(const SoakRun& run, const SoakCriteria& criteria,
                       const SoakVerdict& verdict) {
  nlohmann::json timeline = nlohmann::json::array();
  for (const SoakSample& sample : run.timeline) timeline.push_back(to_json(sample));
  return {
      {"verdict", to_json(verdict)},
      {"criteria", to_json(criteria)},
      {"planned_s", run.planned_s},
      {"fed_s", run.fed_s},
      {"elapsed_s", run.elapsed_s},
      {"stopped_by_signal", run.stopped_by_signal},
      {"fifo_applied", run.fifo_applied},
      {"memory_locked", run.memory_locked},
      {"dma_latency_held", run.dma_latency_held},
      {"scans", run.cycle.scans},
      {"wakeup_latency_us", to_json_us(run.cycle.wakeup_latency)},
      {"compute_us", to_json_us(run.cycle.compute)},
      {"probe", run.probe_ran ? nlohmann::json{{"fifo", run.probe_fifo},
                                               {"wakeup_latency_us", to_json_us(run.probe_latency)},
                                               {"at_or_beyond_bound", run.probe_at_or_beyond_bound}}
                              : nlohmann::json(nullptr)},
      {"kpis", to_json(run.kpis)},
      {"timeline", timeline}};
}

}  // namespace fl::apps
