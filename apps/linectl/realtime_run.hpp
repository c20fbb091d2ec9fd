// The real-time closed loop that `linectl run --realtime` and `linectl soak` share: the
// controller on the 10 ms scan runtime against a plant behind PlantIo, a stop signal that
// drains the belts before the run ends, progress on stderr and the event log.
#pragma once

#include <CLI/CLI.hpp>
#include <atomic>
#include <functional>
#include <string>

#include "cli_support.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/controller/plant.hpp"
#include "fl/controller/runtime.hpp"
#include "plant_io.hpp"

namespace fl::apps {

// SIGINT and SIGTERM counted: the first stops the line and drains it, a second ends the run
// at once (still writing the ledger and KPIs).
std::atomic<int>& stop_signals();
void install_stop_signal_handlers();

// Progress on stderr: a redrawn line on a terminal, a log line every 10 % otherwise.
class Progress {
 public:
  explicit Progress(bool quiet);
  void operator()(double done_s, double total_s);
  void finish();

 private:
  bool quiet_;
  bool tty_;
  int last_decile_ = -1;
};

// Logs a controller event at the level its kind deserves (faults warn, items debug).
void log_event(const Event& event);

struct RealtimeRunOptions {
  double duration_s = 60.0;  // feeding time; infinity: until a stop signal
  std::uint64_t seed = 1;
  int fifo_priority = 0;
  bool lock_memory = false;
  // >= 0: hold /dev/cpu_dma_latency at this many us during the run, so that idle CPUs stay
  // out of deep C-states whose exit would delay the scan's wake-up. -1: leave it alone.
  int cpu_dma_latency_us = -1;
  std::string hmi_config;  // empty: no HMI
  // The plant whose fault switches the HMI's twin panel drives, when the run's plant wraps
  // it (--fieldbus canopen); null: the run's plant.
  Plant* fault_switches = nullptr;
  // Called from the run's own (non-real-time) thread every 50 ms while the loop runs.
  std::function<void(double elapsed_s, const PlantIo& io)> on_tick;
  // Publishes the scan's status snapshots when set and no HMI runs (the HMI owns the one
  // publisher a logic has); its buffer is for on_tick to read.
  LineStatusPublisher* status = nullptr;
};

struct RealtimeRunResult {
  Kpis kpis;
  RealtimeSetup setup;  // what the runtime could apply (SCHED_FIFO, mlockall)
  CycleStats cycle_stats;
  double fed_s = 0.0;      // feeding time up to the stop request
  double elapsed_s = 0.0;  // wall time of the whole run, drain included
  bool stopped_by_signal = false;
  bool drained = false;                      // the belts were empty when the run ended
  RuntimeFault fault = RuntimeFault::kNone;  // the runtime's own fault (stall, overruns, ...)
};

// Throws std::runtime_error when the runtime cannot start.
RealtimeRunResult run_realtime(const RealtimeRunOptions& options, const LineConfig& line,
                               Plant& plant, Progress& progress, LedgerWriter& ledger);

}  // namespace fl::apps
