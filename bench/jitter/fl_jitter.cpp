// Runs the scan runtime with an almost empty logic for a fixed time and prints the wake-up
// latency (actual wake-up minus scheduled wake-up) in microseconds, like cyclictest: min,
// avg, p50, p99, p99.9 and max, plus the compute time and the overruns. The last line,
// "RESULT key=value ...", is what compare_cyclictest.sh parses.
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <exception>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/runtime.hpp"

namespace {

// The images are copied in and out as a driver would, and the logic touches a few fields,
// so that the scan does the memory traffic of a real one without its compute time.
class CopyingIo final : public fl::ProcessIo {
 public:
  void read(std::int64_t now_ns, fl::InputImage& in) override {
    in = plant_inputs_;
    in.time_ns = now_ns;
  }
  void write(const fl::OutputImage& out) override { drive_commands_ = out; }

 private:
  fl::InputImage plant_inputs_{};
  fl::OutputImage drive_commands_{};
};

class NearlyEmptyLogic final : public fl::ScanLogic {
 public:
  void update(const fl::InputImage& in, fl::OutputImage& out) override {
    ++scans_;
    for (std::size_t d = 0; d < fl::kDriveCount; ++d) {
      out.drives[d].enable = in.estop_ok;
      out.drives[d].speed_mps = static_cast<float>(scans_ % 100) * 0.01F;
    }
  }

 private:
  std::uint64_t scans_ = 0;
};

fl::ScanRuntime* g_runtime = nullptr;

extern "C" void on_signal(int /*signal*/) {
  if (g_runtime != nullptr) g_runtime->request_stop();  // async-signal-safe
}

double to_us(std::int64_t value_ns) { return static_cast<double>(value_ns) / 1000.0; }

void print_distribution(const char* name, const fl::DistributionSummary& summary) {
  std::printf("%-15s min %8.1f  avg %8.1f  p50 %8.1f  p99 %8.1f  p99.9 %8.1f  max %8.1f us%s\n",
              name, to_us(summary.min_ns), summary.mean_ns / 1000.0, to_us(summary.p50_ns),
              to_us(summary.p99_ns), to_us(summary.p999_ns), to_us(summary.max_ns),
              summary.overflow_count > 0 ? "  (some beyond the histogram)" : "");
}

}  // namespace

static int checked_main(int argc, char** argv) {
  CLI::App app{"Scan runtime wake-up latency, in cyclictest's units (us)"};
  double period_us = 10'000.0;
  double duration_s = 60.0;
  int priority = 0;
  int cpu = -1;
  bool lock_memory = false;
  int dma_latency_us = -1;
  app.add_option("-i,--period-us", period_us, "scan period in us")->check(CLI::PositiveNumber);
  app.add_option("-D,--duration-s", duration_s, "run time in s")->check(CLI::PositiveNumber);
  app.add_option("-p,--priority", priority, "SCHED_FIFO priority 1..99, 0 for SCHED_OTHER")
      ->check(CLI::Range(0, 99));
  app.add_option("-a,--cpu", cpu, "pin the scan thread to this CPU (-1: no pinning)");
  app.add_flag("-m,--mlock", lock_memory, "mlockall(MCL_CURRENT | MCL_FUTURE)");
  app.add_option("--cpu-dma-latency-us", dma_latency_us,
                 "hold /dev/cpu_dma_latency at this value while running (-1: leave it; "
                 "cyclictest uses 0)");
  CLI11_PARSE(app, argc, argv);

  CopyingIo io;
  NearlyEmptyLogic logic;
  fl::RuntimeOptions options;
  options.period_ns = static_cast<std::int64_t>(period_us * 1000.0);
  options.duration_ns = static_cast<std::int64_t>(duration_s * 1e9);
  options.fifo_priority = priority;
  options.lock_memory = lock_memory;
  options.cpu = cpu;
  options.cpu_dma_latency_us = dma_latency_us;
  options.realtime_required = true;       // a measurement without its setup would mislead
  options.overrun_fault_consecutive = 0;  // measure overruns, do not stop on them
  options.watchdog_periods = 100;
  options.stats_range_ns = 100'000'000;  // SCHED_OTHER on a busy machine reaches milliseconds

  fl::ScanRuntime runtime(io, logic, options);
  g_runtime = &runtime;
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  const fl::RealtimeSetup setup = runtime.run();
  g_runtime = nullptr;
  if (!setup.started) {
    spdlog::error("fl_jitter: {}", setup.error);
    return 1;
  }

  const fl::CycleStatsSummary stats = runtime.stats().summary();
  std::printf("fl_jitter: %s, period %.0f us, %llu scans, %llu overruns (%llu periods missed)%s\n",
              priority > 0 ? ("SCHED_FIFO " + std::to_string(priority)).c_str() : "SCHED_OTHER",
              period_us, static_cast<unsigned long long>(stats.scans),
              static_cast<unsigned long long>(stats.overruns),
              static_cast<unsigned long long>(stats.missed_periods),
              runtime.fault() != fl::RuntimeFault::kNone ? ", FAULTED" : "");
  print_distribution("wake-up latency", stats.wakeup_latency);
  print_distribution("compute", stats.compute);
  const fl::DistributionSummary& latency = stats.wakeup_latency;
  std::printf(
      "RESULT samples=%llu min_us=%.1f avg_us=%.1f p50_us=%.1f p99_us=%.1f p999_us=%.1f "
      "max_us=%.1f overruns=%llu compute_p999_us=%.1f compute_max_us=%.1f\n",
      static_cast<unsigned long long>(latency.count), to_us(latency.min_ns),
      latency.mean_ns / 1000.0, to_us(latency.p50_ns), to_us(latency.p99_ns),
      to_us(latency.p999_ns), to_us(latency.max_ns),
      static_cast<unsigned long long>(stats.overruns), to_us(stats.compute.p999_ns),
      to_us(stats.compute.max_ns));
  return runtime.fault() == fl::RuntimeFault::kNone ? 0 : 2;
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "fl_jitter: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "fl_jitter: unknown error\n");
  }
  return 1;
}
