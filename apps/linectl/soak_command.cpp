#include "soak_command.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "cli_support.hpp"
#include "duration.hpp"
#include "fl/apps/latency_probe.hpp"
#include "fl/apps/soak.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/report/csv.hpp"
#include "fl/report/svg_plot.hpp"
#include "realtime_run.hpp"

namespace fl::apps {
namespace {

constexpr double kNsPerUs = 1e3;
constexpr double kSecondsPerMinute = 60.0;

// Samples the timeline from the scan's status snapshots and /proc, on the run's own thread.
class SoakSampler {
 public:
  SoakSampler(LineStatusPublisher& status, LatencyProbe* probe, double sample_every_s)
      : status_(status),
        probe_(probe),
        sample_every_s_(sample_every_s),
        next_sample_s_(sample_every_s) {}

  void on_tick(double elapsed_s, const PlantIo& io) {
    if (status_.buffer().take()) {
      const LineStatus& snapshot = status_.buffer().front();
      // The window maxima cover the last completed 100-scan window (1 s); ticks come every
      // 50 ms, so every window is seen; the newest scan's own figures cover the rest.
      interval_latency_ns_ =
          std::max({interval_latency_ns_, snapshot.timing.window_max_wakeup_latency_ns,
                    snapshot.timing.last_wakeup_latency_ns});
      interval_compute_ns_ = std::max({interval_compute_ns_, snapshot.timing.window_max_compute_ns,
                                       snapshot.timing.last_compute_ns});
      scans_ = snapshot.timing.scans;
      overruns_ = snapshot.timing.overruns;
      items_closed_ = snapshot.counters.items_closed;
    }
    if (elapsed_s < next_sample_s_) return;
    next_sample_s_ += sample_every_s_;
    SoakSample sample;
    sample.elapsed_s = elapsed_s;
    sample.resident_kib = resident_kib().value_or(0);
    sample.max_wakeup_latency_ns = interval_latency_ns_;
    sample.max_compute_ns = interval_compute_ns_;
    if (probe_ != nullptr) sample.probe_max_wakeup_latency_ns = probe_->take_interval_max_ns();
    sample.scans = scans_;
    sample.overruns = overruns_;
    sample.fillets_fed = io.fillets_fed();
    sample.items_closed = items_closed_;
    timeline_.push_back(sample);
    interval_latency_ns_ = 0;
    interval_compute_ns_ = 0;
    // A log line a minute: journal and log file show the soak's health while it runs.
    if (elapsed_s - last_log_s_ >= kSecondsPerMinute) {
      last_log_s_ = elapsed_s;
      spdlog::info(
          "soak {:.0f} s: resident {} KiB, worst wake-up {:.0f} us, scans {}, overruns {}, "
          "fed {}, closed {}",
          elapsed_s, sample.resident_kib,
          static_cast<double>(sample.max_wakeup_latency_ns) / kNsPerUs, sample.scans,
          sample.overruns, sample.fillets_fed, sample.items_closed);
    }
  }

  [[nodiscard]] std::vector<SoakSample>& timeline() { return timeline_; }

 private:
  LineStatusPublisher& status_;
  LatencyProbe* probe_;
  double sample_every_s_;
  double next_sample_s_;
  double last_log_s_ = 0.0;
  std::int64_t interval_latency_ns_ = 0;
  std::int64_t interval_compute_ns_ = 0;
  std::uint64_t scans_ = 0;
  std::uint64_t overruns_ = 0;
  std::uint64_t items_closed_ = 0;
  std::vector<SoakSample> timeline_;
};

void write_timeline_csv(const std::vector<SoakSample>& timeline,
                        const std::filesystem::path& file) {
  report::CsvTable table({"elapsed_s", "resident_kib", "max_wakeup_latency_us", "max_compute_us",
                          "probe_max_wakeup_latency_us", "scans", "overruns", "fillets_fed",
                          "items_closed"});
  for (const SoakSample& sample : timeline) {
    table.add_row({sample.elapsed_s, static_cast<double>(sample.resident_kib),
                   static_cast<double>(sample.max_wakeup_latency_ns) / kNsPerUs,
                   static_cast<double>(sample.max_compute_ns) / kNsPerUs,
                   static_cast<double>(sample.probe_max_wakeup_latency_ns) / kNsPerUs,
                   static_cast<double>(sample.scans), static_cast<double>(sample.overruns),
                   static_cast<double>(sample.fillets_fed),
                   static_cast<double>(sample.items_closed)});
  }
  table.write(file);
}

report::Series series(const char* label, const std::vector<double>& x,
                      const std::vector<double>& y) {
  report::Series line;
  line.label = label;
  line.x = x;
  line.y = y;
  return line;
}

// Plots of memory and wake-up latency over the run, with the criteria drawn in.
std::string timeline_plots(const SoakRun& run, const SoakCriteria& criteria,
                           const SoakVerdict& verdict) {
  std::vector<double> time_min;
  std::vector<double> resident_mib;
  std::vector<double> latency_us;
  std::vector<double> compute_us;
  std::vector<double> probe_us;
  for (const SoakSample& sample : run.timeline) {
    if (sample.resident_kib == 0) continue;
    time_min.push_back(sample.elapsed_s / kSecondsPerMinute);
    resident_mib.push_back(static_cast<double>(sample.resident_kib) / 1024.0);
    // Log axis: a scan cannot take less than the histogram's 1 us resolution.
    latency_us.push_back(
        std::max(1.0, static_cast<double>(sample.max_wakeup_latency_ns) / kNsPerUs));
    compute_us.push_back(std::max(1.0, static_cast<double>(sample.max_compute_ns) / kNsPerUs));
    probe_us.push_back(
        std::max(1.0, static_cast<double>(sample.probe_max_wakeup_latency_ns) / kNsPerUs));
  }
  if (time_min.empty()) return "<p>No timeline sample was taken.</p>\n";
  report::Plot memory;
  memory.title = "Resident memory";
  memory.x.label = "time (min)";
  memory.y.label = "resident set (MiB)";
  memory.series.push_back(series("resident set", time_min, resident_mib));
  memory.references.push_back(
      {.vertical = true, .value = criteria.warm_up_s / kSecondsPerMinute, .label = "warm-up"});
  if (verdict.resident_at_warm_up_kib) {
    memory.references.push_back({.vertical = false,
                                 .value = static_cast<double>(*verdict.resident_at_warm_up_kib +
                                                              criteria.max_resident_growth_kib) /
                                          1024.0,
                                 .label = "bound"});
  }
  report::Plot timing;
  timing.title = "Worst scan per sample interval";
  timing.x.label = "time (min)";
  timing.y.label = "time (us)";
  timing.y.log = true;
  timing.series.push_back(series("wake-up latency", time_min, latency_us));
  timing.series.push_back(series("compute", time_min, compute_us));
  if (run.probe_ran) timing.series.push_back(series("machine (probe) wake-up", time_min, probe_us));
  timing.references.push_back(
      {.vertical = false,
       .value = static_cast<double>(criteria.max_wakeup_latency_ns) / kNsPerUs,
       .label = "deadline bound"});
  return report::render_svg(memory) + "\n" + report::render_svg(timing) + "\n";
}

void write_html(const SoakRun& run, const SoakCriteria& criteria, const SoakVerdict& verdict,
                const std::filesystem::path& file) {
  std::ostringstream html;
  html << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>linectl soak</title>"
       << "<style>body{font-family:sans-serif;margin:2em}td,th{padding:2px 10px;text-align:left}"
       << ".pass{color:#1a7f37}.fail{color:#c62828}</style></head><body>\n";
  html << "<h1>Soak: <span class=\"" << (verdict.passed ? "pass\">PASSED" : "fail\">FAILED")
       << "</span></h1>\n";
  if (!verdict.failures.empty()) {
    html << "<ul>\n";
    // The sentences are evaluate_soak()'s own, numbers and words only: nothing to escape.
    for (const std::string& failure : verdict.failures) html << "<li>" << failure << "</li>\n";
    html << "</ul>\n";
  }
  if (!verdict.deadline_diagnosis.empty()) {
    html << "<p><b>Late scans:</b> " << verdict.deadline_diagnosis << ".</p>\n";
  }
  const auto row = [&](const char* name, const std::string& value, const std::string& bound) {
    html << "<tr><th>" << name << "</th><td>" << value << "</td><td>" << bound << "</td></tr>\n";
  };
  html << "<table><tr><th>figure</th><th>value</th><th>bound</th></tr>\n";
  row("run",
      fmt::format("{:.0f} s fed of {:.0f} s planned, {:.0f} s with the drain", run.fed_s,
                  run.planned_s, run.elapsed_s),
      "");
  row("SCHED_FIFO / mlockall / cpu_dma_latency",
      fmt::format("{} / {} / {}", run.fifo_applied ? "yes" : "no", run.memory_locked ? "yes" : "no",
                  run.dma_latency_held ? "held" : "not held"),
      criteria.require_fifo ? "SCHED_FIFO required" : "");
  row("resident growth after warm-up", fmt::format("{} KiB", verdict.resident_growth_kib),
      fmt::format("&lt; {} KiB after {:.0f} s", criteria.max_resident_growth_kib,
                  criteria.warm_up_s));
  row("scans", std::to_string(run.cycle.scans), "");
  row("worst wake-up latency",
      fmt::format("{:.0f} us (p99.9 {:.0f} us)",
                  static_cast<double>(verdict.max_wakeup_latency_ns) / kNsPerUs,
                  static_cast<double>(run.cycle.wakeup_latency.p999_ns) / kNsPerUs),
      "");
  row("scans woken late", std::to_string(verdict.late_scans),
      fmt::format("0 at or beyond {:.0f} us",
                  static_cast<double>(criteria.max_wakeup_latency_ns) / kNsPerUs));
  if (run.probe_ran) {
    row("machine baseline (probe beside the scan)",
        fmt::format("{} wake-ups, {} at or beyond the bound, worst {:.0f} us ({})",
                    run.probe_latency.count, run.probe_at_or_beyond_bound,
                    static_cast<double>(run.probe_latency.max_ns) / kNsPerUs,
                    run.probe_fifo ? "SCHED_FIFO" : "SCHED_OTHER"),
        "");
  }
  row("overruns", std::to_string(verdict.overruns), "0");
  row("worst compute",
      fmt::format("{:.0f} us", static_cast<double>(run.cycle.compute.max_ns) / kNsPerUs), "");
  row("fillets fed / placed", fmt::format("{} / {}", run.kpis.truth.fed, run.kpis.truth.outfeed),
      "");
  row("fillets lost", std::to_string(verdict.lost_fillets), "0");
  row("books", verdict.books_balanced ? "balanced" : "unbalanced", "balanced");
  html << "</table>\n" << timeline_plots(run, criteria, verdict);
  html << "<p>Figures: <a href=\"soak.json\">soak.json</a>, timeline: "
       << "<a href=\"soak_timeline.csv\">soak_timeline.csv</a>, ledger: "
       << "<a href=\"ledger.csv\">ledger.csv</a>.</p>\n</body></html>\n";
  std::ofstream out(file);
  out << html.str();
  if (!out) throw std::runtime_error(file.string() + ": cannot write");
}

}  // namespace

CLI::App* add_soak_subcommand(CLI::App& app, SoakArgs& args) {
  CLI::App* soak = app.add_subcommand(
      "soak",
      "long closed-loop run on the real-time schedule against the fast plant, judged "
      "by flat memory, deadlines and zero lost fillets");
  soak->add_option("--duration", args.duration, "feeding time, e.g. 1h (default), 20m, 30s");
  soak->add_option("--seed", args.seed, "plant seed");
  soak->add_option("--config", args.config, "line configuration (default line.yaml)");
  soak->add_option("--plant-config", args.plant_config,
                   "the fast plant's configuration (default plant_fast.yaml)");
  soak->add_option("--out", args.out_directory,
                   "folder for soak.json, soak_timeline.csv, soak.html and ledger.csv");
  soak->add_option("--fifo", args.fifo_priority, "SCHED_FIFO priority of the scan thread (1-99)")
      ->check(CLI::Range(1, 99));
  soak->add_flag("--allow-no-fifo", args.allow_no_fifo,
                 "judge the run even when SCHED_FIFO cannot be applied (e.g. no CAP_SYS_NICE)");
  soak->add_flag("!--no-mlock", args.lock_memory, "do not lock memory (mlockall)");
  add_cpu_dma_latency_option(*soak, args.cpu_dma_latency_us);
  soak->add_flag("!--no-probe", args.latency_probe,
                 "no machine baseline: by default a bare thread sleeps on the scan's schedule "
                 "one priority below it, so late scans can be told the machine's or the "
                 "controller's");
  soak->add_option("--warm-up", args.warm_up, "time before memory is judged (default 5m)");
  soak->add_option("--sample-every", args.sample_every, "timeline interval (default 10s)");
  soak->add_option("--max-growth-kib", args.max_resident_growth_kib,
                   "allowed resident memory growth after the warm-up (default 1024 KiB)");
  soak->add_option("--max-latency-us", args.max_wakeup_latency_us,
                   "a scan woken this late or later missed its deadline (default 1000 us)")
      ->check(CLI::Range(1.0, 1e6));
  soak->add_flag("--quiet", args.quiet, "no progress display");
  return soak;
}

int soak_command(const SoakArgs& args) {
  const std::optional<double> duration_s = parse_duration_s(args.duration);
  const std::optional<double> warm_up_s = parse_duration_s(args.warm_up);
  const std::optional<double> sample_every_s = parse_duration_s(args.sample_every);
  for (const auto& [name, value, text] :
       {std::tuple{"--duration", duration_s, args.duration},
        std::tuple{"--warm-up", warm_up_s, args.warm_up},
        std::tuple{"--sample-every", sample_every_s, args.sample_every}}) {
    if (!value) {
      spdlog::error("{} {}: not a positive duration (examples: 30s, 5m, 1h)", name, text);
      return 2;
    }
  }
  if (*warm_up_s >= *duration_s) {
    spdlog::error("--warm-up {} is not shorter than --duration {}: memory could not be judged",
                  args.warm_up, args.duration);
    return 2;
  }
  SoakCriteria criteria;
  criteria.warm_up_s = *warm_up_s;
  criteria.max_resident_growth_kib = args.max_resident_growth_kib;
  criteria.max_wakeup_latency_ns = static_cast<std::int64_t>(args.max_wakeup_latency_us * kNsPerUs);
  criteria.require_fifo = !args.allow_no_fifo;

  const std::filesystem::path out = args.out_directory;
  std::filesystem::create_directories(out);
  const std::filesystem::path config =
      args.config.empty() ? default_config("line.yaml") : std::filesystem::path(args.config);
  const LineConfig line = load_line_config(config);
  std::unique_ptr<Plant> plant = make_plant("fast", args.plant_config, line);
  spdlog::info(
      "soak: {} s against the {} plant on the real-time schedule, SCHED_FIFO {}, seed "
      "{}, config {}, results in {}",
      *duration_s, plant->name(), args.fifo_priority, args.seed, config.string(), out.string());

  LineStatusPublisher status;
  // The machine's baseline beside the scan, one priority below it, as cyclictest -p79 would.
  std::optional<LatencyProbe> probe;
  if (args.latency_probe) {
    probe.emplace(RuntimeOptions{}.period_ns, args.fifo_priority > 1 ? args.fifo_priority - 1 : 0);
    if (const std::string refused = probe->start(); !refused.empty()) spdlog::warn("{}", refused);
  }
  SoakSampler sampler(status, probe ? &*probe : nullptr, *sample_every_s);
  RealtimeRunOptions options;
  options.duration_s = *duration_s;
  options.seed = args.seed;
  options.fifo_priority = args.fifo_priority;
  options.lock_memory = args.lock_memory;
  options.cpu_dma_latency_us = args.cpu_dma_latency_us;
  options.status = &status;
  options.on_tick = [&](double elapsed_s, const PlantIo& io) { sampler.on_tick(elapsed_s, io); };
  Progress progress(args.quiet);
  LedgerWriter ledger((out / "ledger.csv").string());
  RealtimeRunResult result = run_realtime(options, line, *plant, progress, ledger);
  progress.finish();

  SoakRun run;
  run.planned_s = *duration_s;
  run.fed_s = result.fed_s;
  run.elapsed_s = result.elapsed_s;
  run.stopped_by_signal = result.stopped_by_signal;
  run.fifo_applied = result.setup.fifo_applied;
  run.memory_locked = result.setup.memory_locked;
  run.dma_latency_held = result.setup.dma_latency_applied;
  run.timeline = std::move(sampler.timeline());
  run.cycle = result.cycle_stats.summary();
  run.scans_at_or_beyond_bound =
      count_at_or_beyond(result.cycle_stats.wakeup_latency(), criteria.max_wakeup_latency_ns);
  run.kpis = result.kpis;
  if (probe) {
    probe->stop();
    run.probe_ran = true;
    run.probe_fifo = probe->fifo_applied();
    run.probe_latency = probe->histogram().summary();
    run.probe_at_or_beyond_bound =
        count_at_or_beyond(probe->histogram(), criteria.max_wakeup_latency_ns);
  }
  const SoakVerdict verdict = evaluate_soak(run, criteria);

  {
    std::ofstream json(out / "soak.json");
    json << to_json(run, criteria, verdict).dump(2) << '\n';
    if (!json) throw std::runtime_error((out / "soak.json").string() + ": cannot write");
  }
  write_timeline_csv(run.timeline, out / "soak_timeline.csv");
  write_html(run, criteria, verdict, out / "soak.html");

  std::fputs(format_kpis(run.kpis).c_str(), stdout);
  std::printf(
      "soak %s: resident growth %lld KiB after warm-up, worst wake-up %.0f us, %llu late "
      "scans, %llu overruns, %llu lost fillets\n",
      verdict.passed ? "PASSED" : "FAILED", static_cast<long long>(verdict.resident_growth_kib),
      static_cast<double>(verdict.max_wakeup_latency_ns) / kNsPerUs,
      static_cast<unsigned long long>(verdict.late_scans),
      static_cast<unsigned long long>(verdict.overruns),
      static_cast<unsigned long long>(verdict.lost_fillets));
  for (const std::string& failure : verdict.failures) {
    std::printf("  failed: %s\n", failure.c_str());
  }
  if (!verdict.deadline_diagnosis.empty()) {
    std::printf("  late scans: %s\n", verdict.deadline_diagnosis.c_str());
  }
  std::fflush(stdout);
  spdlog::info("soak report: {}", (out / "soak.html").string());
  return verdict.passed ? 0 : 1;
}

}  // namespace fl::apps
