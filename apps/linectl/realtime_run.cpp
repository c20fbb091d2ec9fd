#include "realtime_run.hpp"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "fl/controller/line_controller.hpp"
#include "hmi_support.hpp"

namespace fl::apps {
namespace {

std::atomic<int> g_stop_signals{0};
extern "C" void on_signal(int /*signal*/) { g_stop_signals.fetch_add(1); }

// A controlled stop normally empties the belts well within this; past it the run ends anyway.
constexpr double kDrainTimeoutS = 60.0;

}  // namespace

std::atomic<int>& stop_signals() { return g_stop_signals; }

void install_stop_signal_handlers() {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
}

Progress::Progress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}

void Progress::operator()(double done_s, double total_s) {
  if (quiet_ || total_s <= 0.0 || !std::isfinite(total_s)) return;
  const int percent = static_cast<int>(100.0 * std::min(done_s / total_s, 1.0));
  if (tty_) {
    std::fprintf(stderr, "\r[%-40s] %3d%%  %.0f / %.0f s line time",
                 std::string(static_cast<std::size_t>(percent * 40 / 100), '#').c_str(), percent,
                 done_s, total_s);
    std::fflush(stderr);
  } else if (percent / 10 != last_decile_) {
    last_decile_ = percent / 10;
    spdlog::info("progress {}% ({:.0f} of {:.0f} s line time)", percent, done_s, total_s);
  }
}

void Progress::finish() {
  if (!quiet_ && tty_) std::fprintf(stderr, "\n");
}

void log_event(const Event& event) {
  switch (event.code) {
    case EventCode::kItemCreated:
    case EventCode::kItemClosed:
    case EventCode::kItemAdopted:
    case EventCode::kRejectReversal:
      spdlog::debug("{} item {} at {:.3f} s ({:.1f})", to_string(event.code), event.item_id,
                    static_cast<double>(event.time_ns) / 1e9, event.value);
      break;
    case EventCode::kFaultRaised:
      spdlog::warn("fault raised: {} at {:.3f} s", to_string(static_cast<FaultCode>(event.source)),
                   static_cast<double>(event.time_ns) / 1e9);
      break;
    case EventCode::kFaultCleared:
      spdlog::info("fault cleared: {} at {:.3f} s", to_string(static_cast<FaultCode>(event.source)),
                   static_cast<double>(event.time_ns) / 1e9);
      break;
    case EventCode::kStateChanged:
      spdlog::info("line state {} at {:.3f} s", static_cast<int>(event.source),
                   static_cast<double>(event.time_ns) / 1e9);
      break;
    default:
      spdlog::warn("{} (camera/drive {}, item {}, value {:.3f}) at {:.3f} s", to_string(event.code),
                   event.source, event.item_id, event.value,
                   static_cast<double>(event.time_ns) / 1e9);
  }
}

RealtimeRunResult run_realtime(const RealtimeRunOptions& options, const LineConfig& line,
                               Plant& plant, Progress& progress, LedgerWriter& ledger) {
  LineController controller(line);
  LineControllerLogic logic(controller);
  PlantIo io(plant, options.seed, options.fault_switches);
  // Before the runtime: the HMI outlives the scans that publish to it.
  const std::unique_ptr<HmiRun> hmi = start_hmi(options.hmi_config, line, logic, io);
  if (!hmi && options.status != nullptr) logic.attach_status(options.status);
  io.request_line_start();
  RuntimeOptions runtime_options = watchdog_runtime_options(line);
  runtime_options.fifo_priority = options.fifo_priority;
  runtime_options.lock_memory = options.lock_memory;
  runtime_options.cpu_dma_latency_us = options.cpu_dma_latency_us;
  runtime_options.on_fault = [](RuntimeFault fault) {
    spdlog::error("runtime fault: {}", to_string(fault));
  };
  ScanRuntime runtime(io, logic, runtime_options);
  KpiCollector collector(line);
  const auto drain = [&] {
    while (auto exit = io.exits().pop()) collector.add_exit(*exit);
    while (auto record = controller.closed_records().pop()) ledger.write(*record);
    while (auto event = controller.events().pop()) {
      collector.add_event(*event);
      log_event(*event);
    }
    ledger.flush();  // a killed service keeps the rows written so far
  };
  RealtimeRunResult result;
  const double duration_s = options.duration_s;
  const auto wall_start = std::chrono::steady_clock::now();
  result.setup = runtime.start();
  if (!result.setup.error.empty()) spdlog::warn("real-time setup: {}", result.setup.error);
  if (!result.setup.started) {
    throw std::runtime_error("the scan runtime did not start: " + result.setup.error);
  }
  bool stop_sent = false;
  double elapsed_s = 0.0;
  double fed_s = duration_s;  // feeding time, up to the stop request
  bool stop_requested = false;
  while (runtime.running()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    drain();
    elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    progress(std::min(elapsed_s, duration_s), duration_s);
    if (options.on_tick) options.on_tick(elapsed_s, io);
    const int signals = g_stop_signals.load();
    if (!stop_sent && (elapsed_s >= duration_s || signals > 0)) {
      if (signals > 0) spdlog::info("stop requested by signal: stopping the line, draining belts");
      io.request_line_stop();
      stop_sent = true;
      result.stopped_by_signal = signals > 0;
      fed_s = std::min(elapsed_s, duration_s);
    }
    // Drained after the stop, a second signal, or a drain that takes too long: end the run.
    const bool drained =
        stop_sent && controller.state() == LineState::kStopped && io.fillets_on_line() == 0;
    const bool give_up = stop_sent && (signals > 1 || elapsed_s > fed_s + kDrainTimeoutS);
    if (!stop_requested && (drained || give_up)) {
      if (!drained) spdlog::warn("ending the run before the belts were drained");
      result.drained = drained;
      runtime.request_stop();
      stop_requested = true;
    }
  }
  runtime.wait();
  drain();
  controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();
  result.kpis.plant = plant.name();
  result.kpis.seed = options.seed;
  result.cycle_stats = runtime.stats();
  result.fault = runtime.fault();
  const CycleStatsSummary stats = result.cycle_stats.summary();
  result.kpis.compute = stats.compute;
  collector.finish(controller, io.fillets_fed(), io.fillets_on_line(), fed_s, elapsed_s, elapsed_s,
                   result.kpis);
  result.fed_s = fed_s;
  result.elapsed_s = elapsed_s;
  spdlog::info("real-time scans {}, overruns {}, wake-up latency p99.9 {:.1f} us max {:.1f} us",
               stats.scans, stats.overruns, static_cast<double>(stats.wakeup_latency.p999_ns) / 1e3,
               static_cast<double>(stats.wakeup_latency.max_ns) / 1e3);
  return result;
}

}  // namespace fl::apps
