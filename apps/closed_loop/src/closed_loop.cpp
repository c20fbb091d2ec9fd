#include "fl/apps/closed_loop.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

namespace fl::apps {
namespace {

constexpr double kNsPerS = 1e9;

bool in_spec(const LineConfig& config, const TrueFilletExit& exit) {
  const ToleranceConfig& tolerance = config.tolerance;
  const float target = (exit.hand == Hand::kLeft && tolerance.mirror_for_left)
                           ? -tolerance.target_angle_rad
                           : tolerance.target_angle_rad;
  const float error = std::remainder(exit.angle_rad - target, 2.0F * std::numbers::pi_v<float>);
  return exit.singulated && exit.side == config.flip.target_side &&
         std::fabs(error) <= tolerance.angle_tol_rad &&
         std::fabs(exit.y_mm) <= tolerance.lateral_tol_mm;
}

}  // namespace

void KpiCollector::add_event(const Event& event) {
  if (event.code == EventCode::kFaultRaised) faults_seen_ |= 1U << event.source;
}

void KpiCollector::add_exit(const TrueFilletExit& exit) {
  const LineConfig& config = config_;
  TruthTally& truth = truth_;
  ++truth.exits;
  if (exit.singulated) ++truth.singulated_exits;
  switch (exit.exit) {
    case TrueExit::kOutfeed:
      ++truth.outfeed;
      if (in_spec(config, exit)) ++truth.outfeed_in_spec;
      if (!exit.singulated) ++truth.outfeed_not_singulated;
      if (!exit.squeezed_ok) ++truth.squeezed_badly;
      break;
    case TrueExit::kRejectCrate:
      ++truth.reject_crate;
      break;
    case TrueExit::kFinalReject:
      ++truth.final_reject;
      break;
    case TrueExit::kFellOff:
      ++truth.fell_off;
      break;
  }
}

void KpiCollector::finish(const LineController& controller, std::uint64_t fed,
                          std::uint64_t on_line, double fed_duration_s, double simulated_s,
                          double wall_s, Kpis& kpis) const {
  kpis.truth = truth_;
  kpis.faults_seen = faults_seen_;
  kpis.wall_s = wall_s;
  kpis.fed_duration_s = fed_duration_s;
  kpis.total_simulated_s = simulated_s;
  kpis.realtime_factor = wall_s > 0.0 ? simulated_s / wall_s : 0.0;
  kpis.truth.fed = fed;
  kpis.truth.on_line_at_end = on_line;
  kpis.truth_balanced = kpis.truth.fed == kpis.truth.exits + kpis.truth.on_line_at_end;

  const ControllerCounters& counters = controller.counters();
  kpis.counters = counters;
  kpis.items_created = counters.items_created;
  kpis.items_closed = counters.items_closed;
  kpis.outcomes = counters.outcomes;
  kpis.records_dropped = controller.records_dropped();
  kpis.events_dropped = controller.events_dropped();
  kpis.ledger_balanced = controller.tracked_count() == 0 && kpis.records_dropped == 0 &&
                         counters.items_created + counters.items_adopted == counters.items_closed;

  const double minutes = fed_duration_s / 60.0;
  kpis.placed_per_minute = minutes > 0.0 ? static_cast<double>(kpis.truth.outfeed) / minutes : 0.0;
  kpis.items_per_minute =
      minutes > 0.0 ? static_cast<double>(counters.takt_strokes) / minutes : 0.0;
  kpis.in_spec_share = kpis.truth.singulated_exits > 0
                           ? static_cast<double>(kpis.truth.outfeed_in_spec) /
                                 static_cast<double>(kpis.truth.singulated_exits)
                           : 0.0;
}

Kpis run_closed_loop(const LineConfig& config, Plant& plant, const RunOptions& options) {
  Kpis kpis;
  kpis.plant = plant.name();
  kpis.seed = options.seed;
  LineController controller(config);
  DurationHistogram compute_histogram(100, 1'000'000);  // 0.1 us bins to 1 ms

  InputImage in;
  OutputImage out;
  plant.reset(options.seed, in);
  controller.reset();
  controller.request_start();

  KpiCollector collector(config);
  const auto drain = [&] {
    for (const TrueFilletExit& exit : plant.drain_exits()) collector.add_exit(exit);
    while (auto record = controller.closed_records().pop()) {
      if (options.on_record) options.on_record(*record);
    }
    while (auto event = controller.events().pop()) {
      collector.add_event(*event);
      if (options.on_event) options.on_event(*event);
    }
  };

  const auto wall_start = std::chrono::steady_clock::now();
  const auto period_s = static_cast<double>(options.period_ns) / kNsPerS;
  const auto feed_scans = static_cast<std::int64_t>(std::llround(options.duration_s / period_s));
  const auto drain_scans =
      static_cast<std::int64_t>(std::llround(options.drain_timeout_s / period_s));
  const std::int64_t scans_per_second = static_cast<std::int64_t>(kNsPerS) / options.period_ns;
  std::int64_t scan = 0;
  bool stop_sent = false;
  auto second_start = wall_start;
  double slowest_second_wall_s = 0.0;
  for (; scan < feed_scans + drain_scans; ++scan) {
    if (scan == feed_scans) {
      controller.request_stop();
      stop_sent = true;
    }
    if (options.before_scan) options.before_scan(in.time_ns, controller);
    if (options.measure_compute) {
      const auto start = std::chrono::steady_clock::now();
      controller.update(in, out);
      compute_histogram.record(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                   std::chrono::steady_clock::now() - start)
                                   .count());
    } else {
      controller.update(in, out);
    }
    if (options.after_update) options.after_update(in, out);
    plant.step(out, options.period_ns, in);
    drain();
    if ((scan + 1) % scans_per_second == 0) {
      const auto now = std::chrono::steady_clock::now();
      const double second_wall_s = std::chrono::duration<double>(now - second_start).count();
      second_start = now;
      const std::uint64_t on_line = plant.fillets_on_line();
      auto load = std::lower_bound(
          kpis.pace_by_load.begin(), kpis.pace_by_load.end(), on_line,
          [](const Kpis::PaceAtLoad& entry, std::uint64_t n) { return entry.fillets_on_line < n; });
      if (load == kpis.pace_by_load.end() || load->fillets_on_line != on_line) {
        load = kpis.pace_by_load.insert(load, Kpis::PaceAtLoad{on_line, 0, 0.0});
      }
      ++load->seconds;
      load->wall_s += second_wall_s;
      if (second_wall_s > slowest_second_wall_s) {
        slowest_second_wall_s = second_wall_s;
        kpis.slowest_second_at_s = static_cast<double>(scan + 1 - scans_per_second) * period_s;
        kpis.slowest_second_fillets_on_line = on_line;
      }
    }
    if (options.progress && scan % scans_per_second == 0) {
      options.progress(static_cast<double>(scan) * period_s, options.duration_s);
    }
    if (stop_sent && controller.state() == LineState::kStopped && plant.fillets_on_line() == 0) {
      break;
    }
  }
  // Whatever is still on the belts when the drain time is up stays accounted for.
  controller.close_all_in_transit(in.time_ns, LostReason::kRunEnded);
  drain();

  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  collector.finish(controller, plant.fillets_fed(), plant.fillets_on_line(), options.duration_s,
                   static_cast<double>(scan) * period_s, wall_s, kpis);
  kpis.compute = compute_histogram.summary();
  // One second of line time per measured second: the factor is its inverse.
  kpis.slowest_second_realtime_factor =
      slowest_second_wall_s > 0.0 ? 1.0 / slowest_second_wall_s : 0.0;
  return kpis;
}

nlohmann::json to_json(const Kpis& kpis) {
  nlohmann::json outcomes = nlohmann::json::object();
  for (std::size_t o = 0; o < kOutcomeCount; ++o) {
    outcomes[to_string(static_cast<Outcome>(o))] = kpis.outcomes[o];
  }
  nlohmann::json faults = nlohmann::json::array();
  for (std::size_t f = 0; f < static_cast<std::size_t>(FaultCode::kCount); ++f) {
    if ((kpis.faults_seen & (1U << f)) != 0) faults.push_back(to_string(static_cast<FaultCode>(f)));
  }
  const TruthTally& t = kpis.truth;
  const ControllerCounters& c = kpis.counters;
  nlohmann::json json = {
      {"plant", kpis.plant},
      {"seed", kpis.seed},
      {"fed_duration_s", kpis.fed_duration_s},
      {"simulated_s", kpis.total_simulated_s},
      {"wall_s", kpis.wall_s},
      {"realtime_factor", kpis.realtime_factor},
      {"placed_per_minute", kpis.placed_per_minute},
      {"items_per_minute", kpis.items_per_minute},
      {"in_spec_share_of_singulated", kpis.in_spec_share},
      {"truth",
       {{"fed", t.fed},
        {"exits", t.exits},
        {"on_line_at_end", t.on_line_at_end},
        {"outfeed", t.outfeed},
        {"outfeed_in_spec", t.outfeed_in_spec},
        {"outfeed_not_singulated", t.outfeed_not_singulated},
        {"reject_crate", t.reject_crate},
        {"final_reject", t.final_reject},
        {"fell_off", t.fell_off},
        {"singulated_exits", t.singulated_exits},
        {"squeezed_badly", t.squeezed_badly},
        {"balanced", kpis.truth_balanced}}},
      {"ledger",
       {{"items_created", kpis.items_created},
        {"items_adopted", kpis.counters.items_adopted},
        {"items_closed", kpis.items_closed},
        {"outcomes", outcomes},
        {"records_dropped", kpis.records_dropped},
        {"events_dropped", kpis.events_dropped},
        {"balanced", kpis.ledger_balanced}}},
      {"controller",
       {{"scans", c.scans},
        {"takt_strokes", c.takt_strokes},
        {"takt_strokes_by_travel", c.takt_strokes_by_travel},
        {"reject_reversals", c.reject_reversals},
        {"flip_conflicts", c.flip_conflicts},
        {"frames_processed", c.frames_processed},
        {"estimates_rejected", c.estimates_rejected},
        {"detections_unmatched", c.detections_unmatched},
        {"detections_duplicate", c.detections_duplicate},
        {"faults_seen", faults}}},
      {"cycle_compute_us", to_json_us(kpis.compute)},
  };
  if (kpis.slowest_second_realtime_factor > 0.0) {
    json["slowest_second"] = {{"realtime_factor", kpis.slowest_second_realtime_factor},
                              {"at_s", kpis.slowest_second_at_s},
                              {"fillets_on_line", kpis.slowest_second_fillets_on_line}};
  }
  if (!kpis.pace_by_load.empty()) {
    nlohmann::json pace = nlohmann::json::array();
    for (const Kpis::PaceAtLoad& load : kpis.pace_by_load) {
      pace.push_back({{"fillets_on_line", load.fillets_on_line},
                      {"seconds", load.seconds},
                      {"realtime_factor", load.realtime_factor()}});
    }
    json["pace_by_fillets_on_line"] = std::move(pace);
  }
  return json;
}

nlohmann::json to_json_us(const DistributionSummary& summary) {
  constexpr double kNsPerUs = 1e3;
  return {{"count", summary.count},
          {"mean", summary.mean_ns / kNsPerUs},
          {"p50", static_cast<double>(summary.p50_ns) / kNsPerUs},
          {"p99", static_cast<double>(summary.p99_ns) / kNsPerUs},
          {"p999", static_cast<double>(summary.p999_ns) / kNsPerUs},
          {"max", static_cast<double>(summary.max_ns) / kNsPerUs}};
}

std::string format_kpis(const Kpis& kpis) {
  std::ostringstream text;
  const TruthTally& t = kpis.truth;
  text.setf(std::ios::fixed);
  text.precision(1);
  text << "plant " << kpis.plant << ", seed " << kpis.seed << ", " << kpis.fed_duration_s
       << " s fed + drain (" << kpis.total_simulated_s << " s simulated in " << kpis.wall_s
       << " s wall, " << kpis.realtime_factor << "x real time)\n";
  if (kpis.slowest_second_realtime_factor > 0.0) {
    text.precision(2);
    text << "slowest second  " << kpis.slowest_second_realtime_factor << "x real time, from "
         << kpis.slowest_second_at_s << " s of line time with "
         << kpis.slowest_second_fillets_on_line << " fillets on the line\n";
    // The fullest loads, where the pace matters: the top three seen.
    text << "pace by load   ";
    const std::size_t shown = std::min<std::size_t>(3, kpis.pace_by_load.size());
    for (std::size_t i = kpis.pace_by_load.size() - shown; i < kpis.pace_by_load.size(); ++i) {
      const Kpis::PaceAtLoad& load = kpis.pace_by_load[i];
      text << " " << load.fillets_on_line << " fillets " << load.realtime_factor() << "x ("
           << load.seconds << " s)" << (i + 1 < kpis.pace_by_load.size() ? "," : "\n");
    }
    text.precision(1);
  }
  text << "throughput      " << kpis.placed_per_minute << " placed/min, " << kpis.items_per_minute
       << " items/min at the takt (" << kpis.counters.takt_strokes_by_travel
       << " struck by travel)\n";
  text.precision(2);
  text << "in spec         " << 100.0 * kpis.in_spec_share << " % of singulated fillets ("
       << t.outfeed_in_spec << " of " << t.singulated_exits << ")\n";
  text << "truth           fed " << t.fed << ", placed " << t.outfeed << ", crate "
       << t.reject_crate << ", air knife " << t.final_reject << ", fell off " << t.fell_off
       << ", unsingulated placed " << t.outfeed_not_singulated << ", on line " << t.on_line_at_end
       << (kpis.truth_balanced ? " (balanced)" : " (UNBALANCED)") << "\n";
  text << "ledger          items " << kpis.items_created << ", closed " << kpis.items_closed
       << (kpis.ledger_balanced ? " (balanced)" : " (UNBALANCED)") << ":";
  for (std::size_t o = 1; o < kOutcomeCount; ++o) {
    if (kpis.outcomes[o] != 0) {
      text << " " << to_string(static_cast<Outcome>(o)) << "=" << kpis.outcomes[o];
    }
  }
  text << "\n";
  text.precision(1);
  text << "scan compute    p50 " << static_cast<double>(kpis.compute.p50_ns) / 1e3 << " us, p99.9 "
       << static_cast<double>(kpis.compute.p999_ns) / 1e3 << " us, max "
       << static_cast<double>(kpis.compute.max_ns) / 1e3 << " us\n";
  return text.str();
}

}  // namespace fl::apps
