// linectl control: the line controller as its own process, talking only DDS (two_process.hpp,
// docs/dds.md "Two-process mode").
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <thread>

#include "cli_support.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_io.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "fl/drivers/dds/process_io.hpp"
#include "fl/drivers/dds/telemetry.hpp"
#include "realtime_run.hpp"
#include "two_process.hpp"

namespace fl::apps {
namespace {

namespace dds = fl::drivers::dds;

std::atomic<int> g_control_interrupts{0};
extern "C" void on_control_signal(int /*signal*/) { g_control_interrupts.fetch_add(1); }

// How often the non-real-time side drains the ledger and event rings: the record ring holds
// 256 records, far more than the line closes in 20 ms.
constexpr auto kDrainPeriod = std::chrono::milliseconds(20);

void log_control_event(const Event& event) {
  const double time_s = static_cast<double>(event.time_ns) / 1e9;
  switch (event.code) {
    case EventCode::kFaultRaised:
      spdlog::warn("fault raised: {} at {:.3f} s", to_string(static_cast<FaultCode>(event.source)),
                   time_s);
      break;
    case EventCode::kFaultCleared:
      spdlog::info("fault cleared: {} at {:.3f} s", to_string(static_cast<FaultCode>(event.source)),
                   time_s);
      break;
    case EventCode::kStateChanged:
      spdlog::info("line state {} at {:.3f} s", static_cast<int>(event.source), time_s);
      break;
    default:
      spdlog::debug("{} (source {}, item {}, value {:.3f}) at {:.3f} s", to_string(event.code),
                    event.source, event.item_id, event.value, time_s);
  }
}

}  // namespace

CLI::App* add_control_subcommand(CLI::App& app, ControlArgs& args) {
  CLI::App* control = app.add_subcommand("control",
                                         "run the line controller on DDS (estimates, sensors in; "
                                         "commands, status out) on the 10 ms real-time schedule");
  control->add_option("--duration", args.duration,
                      "feeding time: the line is stopped after it, e.g. 60s, 10m");
  control->add_option("--config", args.config, "line configuration (YAML)");
  control->add_option("--json", args.json_path, "write the ledger summary and timing as JSON");
  control->add_option("--ledger", args.ledger_path, "write every ledger record as CSV");
  control->add_option("--domain", args.domain, "DDS domain id (default: CYCLONEDDS_URI's)")
      ->check(CLI::Range(0, 232));
  control->add_option("--wait", args.wait, "how long to wait for the line's sensors, e.g. 30s");
  control->add_option("--drain", args.drain, "longest wait for the line to stop, e.g. 60s");
  control->add_option("--fifo", args.fifo_priority, "SCHED_FIFO priority of the scan (1-99)")
      ->check(CLI::Range(0, 99));
  control->add_flag("--mlock", args.lock_memory, "lock memory (mlockall)");
  add_cpu_dma_latency_option(*control, args.cpu_dma_latency_us);
  return control;
}

int control_command(const ControlArgs& args) {
  const std::optional<RunTimes> times = parse_run_times(args.duration, args.wait, args.drain);
  if (!times) return 2;
  const LineConfig line = load_line_config(config_or_default(args.config, "line.yaml"));
  LedgerWriter ledger(args.ledger_path);

  const dds_domainid_t domain =
      args.domain < 0 ? DDS_DOMAIN_DEFAULT : static_cast<dds_domainid_t>(args.domain);
  dds::Participant participant(domain);
  dds::DdsCameraInput cameras(participant);
  dds::DdsSensorInput sensors(participant);
  dds::DdsLineOutput output(participant);
  dds::DdsProcessIo io(cameras, sensors, output);

  LineController controller(line);
  LineControllerLogic logic(controller);
  // Telemetry for the plant beyond the HMI (MES, dashboards): the ledger, the KPIs and the
  // scan timing on their DDS topics, published from this thread as the ledger drains.
  LineStatusPublisher status;
  logic.attach_status(&status);
  dds::DdsTelemetryPublisher telemetry(participant);
  RuntimeOptions options;
  options.fifo_priority = args.fifo_priority;
  options.lock_memory = args.lock_memory;
  options.cpu_dma_latency_us = args.cpu_dma_latency_us;
  options.on_fault = [](RuntimeFault fault) {
    spdlog::error("runtime fault: {}", to_string(fault));
  };
  ScanRuntime runtime(io, logic, options);

  std::signal(SIGINT, on_control_signal);
  std::signal(SIGTERM, on_control_signal);

  // The line's I/O first: a controller that starts scanning before the sensors arrive sees an
  // open safety chain and latches kEstop (DdsProcessIo), which only an acknowledge clears.
  spdlog::info("control: waiting up to {} s for the line's sensors", times->wait_s);
  if (!wait_until([&] { return sensors.delivered(); }, times->wait_s,
                  [] { return g_control_interrupts.load() > 0; }, std::chrono::milliseconds(1))) {
    spdlog::error(
        "control: no LineSensors on '{}' within {} s (is the twin or the line's I/O "
        "running on the same domain and CYCLONEDDS_URI?)",
        dds::kSensorsTopic, times->wait_s);
    return 4;
  }

  KpiCollector collector(line);
  std::uint64_t records = 0;
  const auto drain = [&] {
    while (auto record = controller.closed_records().pop()) {
      ledger.write(*record);
      telemetry.publish(*record);
      ++records;
    }
    if (status.buffer().take()) telemetry.offer(status.buffer().front());
    while (auto event = controller.events().pop()) {
      collector.add_event(*event);
      log_control_event(*event);
    }
  };

  // The operator's start, as linectl run gives it, applied at the first scan.
  logic.request_start();
  const auto wall_start = std::chrono::steady_clock::now();
  const RealtimeSetup setup = runtime.start();
  if (!setup.error.empty()) spdlog::warn("real-time setup: {}", setup.error);
  if (!setup.started) throw std::runtime_error("the scan runtime did not start: " + setup.error);
  spdlog::info("control: scanning; {} s of feeding, then a controlled stop", times->duration_s);

  bool stop_sent = false;
  bool line_faulted = false;
  double elapsed_s = 0.0;
  while (runtime.running()) {
    std::this_thread::sleep_for(kDrainPeriod);
    drain();
    elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (!stop_sent && (elapsed_s >= times->duration_s || g_control_interrupts.load() > 0)) {
      logic.request_stop();
      stop_sent = true;
    }
    const LineState state = io.state();
    // A fault stops the line; the run ends there with whatever the ledger then holds.
    if (state == LineState::kFault && !line_faulted) {
      line_faulted = true;
      spdlog::error("control: the line faulted (active faults 0x{:x}); ending the run",
                    io.active_faults());
      runtime.request_stop();
    }
    const bool stopped = stop_sent && state == LineState::kStopped;
    if (stopped || elapsed_s > times->duration_s + times->drain_s ||
        g_control_interrupts.load() > 1) {
      runtime.request_stop();
    }
  }
  runtime.wait();
  drain();
  controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();

  Kpis kpis;
  kpis.plant = "dds";
  collector.finish(controller, 0, 0, times->duration_s, elapsed_s, elapsed_s, kpis);
  const CycleStatsSummary stats = runtime.stats().summary();
  kpis.compute = stats.compute;
  const dds::LineOutputCounters out = output.counters();
  const dds::IntakeCounters intake = cameras.counters();
  const dds::SensorInputCounters sensor_counts = sensors.counters();
  const dds::ReactionLatency latency = output.reaction_latency();

  nlohmann::json json = to_json(kpis);
  for (const char* key : {"truth", "placed_per_minute", "in_spec_share_of_singulated", "plant",
                          "seed", "simulated_s", "realtime_factor"}) {
    json.erase(key);
  }
  json["runtime"] = {{"scans", stats.scans},
                     {"overruns", stats.overruns},
                     {"fault", to_string(runtime.fault())},
                     {"line_faulted", line_faulted},
                     {"wakeup_latency_us", summary_json(stats.wakeup_latency)}};
  json["dds"] = {{"commands_published", out.commands_published},
                 {"commands_dropped", out.commands_dropped},
                 {"command_write_failures", out.write_failures},
                 {"estimates_accepted", intake.samples_accepted},
                 {"estimates_rejected", intake.rejected_total()},
                 {"sensors_accepted", sensor_counts.sensors_accepted},
                 {"sensors_rejected", sensor_counts.sensors_rejected},
                 {"feedback_accepted", sensor_counts.feedback_accepted},
                 {"sensors_stale_scans", io.sensors_stale_scans()},
                 {"estimate_transport_us", summary_json(latency.transport)},
                 {"estimate_to_command_us", summary_json(latency.reaction)},
                 {"ledger_records_published", telemetry.counters().records_published},
                 {"kpis_published", telemetry.counters().kpis_published},
                 {"telemetry_write_failures", telemetry.counters().write_failures}};

  std::printf(
      "control, %.1f s fed, %.1f s wall, %llu scans, %llu overruns, wake-up latency "
      "p99.9 %.1f us max %.1f us\n",
      times->duration_s, elapsed_s, static_cast<unsigned long long>(stats.scans),
      static_cast<unsigned long long>(stats.overruns),
      static_cast<double>(stats.wakeup_latency.p999_ns) / 1e3,
      static_cast<double>(stats.wakeup_latency.max_ns) / 1e3);
  std::printf("ledger          items %llu (+%llu adopted), closed %llu, records %llu (%s):",
              static_cast<unsigned long long>(kpis.items_created),
              static_cast<unsigned long long>(kpis.counters.items_adopted),
              static_cast<unsigned long long>(kpis.items_closed),
              static_cast<unsigned long long>(records),
              kpis.ledger_balanced ? "balanced" : "UNBALANCED");
  for (std::size_t o = 1; o < kOutcomeCount; ++o) {
    if (kpis.outcomes[o] != 0) {
      std::printf(" %s=%llu", to_string(static_cast<Outcome>(o)),
                  static_cast<unsigned long long>(kpis.outcomes[o]));
    }
  }
  std::printf("\nthroughput      %.1f items/min at the takt\n", kpis.items_per_minute);
  std::printf(
      "dds             %llu commands (%llu dropped), %llu estimates (%llu rejected), "
      "%llu sensor samples, %llu stale scans, %llu ledger records and %llu KPI samples "
      "published\n",
      static_cast<unsigned long long>(out.commands_published),
      static_cast<unsigned long long>(out.commands_dropped),
      static_cast<unsigned long long>(intake.samples_accepted),
      static_cast<unsigned long long>(intake.rejected_total()),
      static_cast<unsigned long long>(sensor_counts.sensors_accepted),
      static_cast<unsigned long long>(io.sensors_stale_scans()),
      static_cast<unsigned long long>(telemetry.counters().records_published),
      static_cast<unsigned long long>(telemetry.counters().kpis_published));
  std::printf(
      "latency         estimate transport p50 %.1f us p99 %.1f us; estimate to command "
      "p50 %.1f us p99 %.1f us max %.1f us (%llu frames)\n",
      static_cast<double>(latency.transport.p50_ns) / 1e3,
      static_cast<double>(latency.transport.p99_ns) / 1e3,
      static_cast<double>(latency.reaction.p50_ns) / 1e3,
      static_cast<double>(latency.reaction.p99_ns) / 1e3,
      static_cast<double>(latency.reaction.max_ns) / 1e3,
      static_cast<unsigned long long>(latency.reaction.count));
  std::fflush(stdout);

  if (!args.json_path.empty() && !write_json_option(args.json_path, json)) return 1;
  if (!kpis.ledger_balanced) return 3;
  if (line_faulted) return io.sensors_stale_scans() > 0 ? 4 : 1;
  if (runtime.fault() != RuntimeFault::kNone) return 1;  // the scan stopped before the line did
  return 0;
}

}  // namespace fl::apps
