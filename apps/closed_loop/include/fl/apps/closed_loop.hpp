// Lock-step closed loop: a LineController and a Plant advanced together in simulated time,
// one scan per period, with the KPIs a line operator and a commissioning engineer read.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/ledger.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/plant.hpp"

namespace fl::apps {

struct RunOptions {
  double duration_s = 60.0;  // feeding time; the line is drained afterwards
  std::uint64_t seed = 1;
  std::int64_t period_ns = 10'000'000;  // the scan period, 10 ms as on the line PC
  double drain_timeout_s = 30.0;        // a controlled stop empties the belts within this
  bool measure_compute = true;          // time each update() (the logic only)
  // Called about once per simulated second with (simulated s, total s); may be empty.
  std::function<void(double, double)> progress;
  // Called for each controller event outside the scan (logging); may be empty.
  std::function<void(const Event&)> on_event;
  // Called for each closed ledger record; may be empty.
  std::function<void(const FilletRecord&)> on_record;
  // Called before each scan with the scan's time, for scenarios that inject faults or
  // operator actions; may be empty.
  std::function<void(std::int64_t time_ns, LineController& controller)> before_scan;
  // Called after each scan's update() with the input image it read and the output image it
  // wrote, for scenarios that check in which scan a reaction happened; may be empty.
  std::function<void(const InputImage& in, const OutputImage& out)> after_update;
};

// Ground truth tally from the plant: what physically happened to every fillet.
struct TruthTally {
  std::uint64_t fed = 0;  // crossed the takt barrier
  std::uint64_t on_line_at_end = 0;
  std::uint64_t exits = 0;
  std::uint64_t outfeed = 0;
  std::uint64_t outfeed_in_spec = 0;  // singulated, right side, angle and position in tolerance
  std::uint64_t outfeed_not_singulated = 0;  // must stay 0: a touching pair was placed
  std::uint64_t reject_crate = 0;
  std::uint64_t final_reject = 0;
  std::uint64_t fell_off = 0;
  std::uint64_t singulated_exits = 0;  // denominator of the in-spec share
  std::uint64_t squeezed_badly = 0;
};

struct Kpis {
  std::string plant;
  std::uint64_t seed = 0;
  double fed_duration_s = 0.0;
  double total_simulated_s = 0.0;
  double wall_s = 0.0;
  double realtime_factor = 0.0;
  // The pace in the slowest whole second of line time (lock-step runs): what a hardware-in-
  // the-loop twin must keep up at all times, where the overall factor averages over a line
  // that starts empty. 0 when no whole second was run.
  double slowest_second_realtime_factor = 0.0;
  double slowest_second_at_s = 0.0;                  // line time at the start of that second
  std::uint64_t slowest_second_fillets_on_line = 0;  // on the belts at its end
  // The pace against the load (lock-step runs): every whole second of line time, grouped by
  // the fillets on the belts at its end. A twin's cost grows with what it carries, so the
  // factor at the fullest line is the one hardware-in-the-loop has to meet.
  struct PaceAtLoad {
    std::uint64_t fillets_on_line = 0;
    std::uint64_t seconds = 0;  // whole seconds of line time that ended with this many
    double wall_s = 0.0;        // their wall time together
    [[nodiscard]] double realtime_factor() const {
      return wall_s > 0.0 ? static_cast<double>(seconds) / wall_s : 0.0;
    }
  };
  std::vector<PaceAtLoad> pace_by_load;  // ascending fillets_on_line, only loads seen

  TruthTally truth;
  double placed_per_minute = 0.0;  // fillets placed at the outfeed per minute of feeding
  double items_per_minute = 0.0;   // takt strokes (items) per minute of feeding
  double in_spec_share = 0.0;      // outfeed_in_spec / singulated fillets that exited

  // Controller ledger.
  std::uint64_t items_created = 0;
  std::uint64_t items_closed = 0;
  std::array<std::uint64_t, kOutcomeCount> outcomes{};
  std::uint64_t records_dropped = 0;  // ring overflow: must stay 0
  std::uint64_t events_dropped = 0;
  ControllerCounters counters;
  std::uint32_t faults_seen = 0;  // every fault bit raised during the run

  DistributionSummary compute;   // update() time per scan
  bool ledger_balanced = false;  // created == closed, nothing in transit
  bool truth_balanced = false;   // fed == exits + on line
};

// Runs the loop. The plant is reset with the seed; the controller is reset and started.
Kpis run_closed_loop(const LineConfig& config, Plant& plant, const RunOptions& options);

// Collects what a run produces (truth exits, ledger records, events) and turns it into KPIs;
// shared by the lock-step loop and the real-time run so that both report the same way.
class KpiCollector {
 public:
  explicit KpiCollector(const LineConfig& config) : config_(config) {}
  void add_exit(const TrueFilletExit& exit);
  void add_event(const Event& event);
  // Completes the KPIs from the controller's counters and the plant's balance.
  void finish(const LineController& controller, std::uint64_t fed, std::uint64_t on_line,
              double fed_duration_s, double simulated_s, double wall_s, Kpis& kpis) const;
  [[nodiscard]] const TruthTally& truth() const { return truth_; }

 private:
  const LineConfig& config_;
  TruthTally truth_;
  std::uint32_t faults_seen_ = 0;
};

nlohmann::json to_json(const Kpis& kpis);
// A duration distribution in microseconds: count, mean, p50, p99, p99.9, max.
nlohmann::json to_json_us(const DistributionSummary& summary);
// A few lines for a terminal.
std::string format_kpis(const Kpis& kpis);

}  // namespace fl::apps
