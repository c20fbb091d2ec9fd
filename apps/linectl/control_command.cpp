// linectl control: the line controller as its own process, talking only DDS (two_process.hpp,
// docs/dds.md "Two-process mode").
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <optional>
#include <thread>

#include "cli_support.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/monotonic_clock.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/canopen_io.hpp"
#include "fl/drivers/dds/camera_input.hpp"
#include "fl/drivers/dds/line_io.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "fl/drivers/dds/process_io.hpp"
#include "fl/drivers/dds/telemetry.hpp"
#include "fl/drivers/socketcan.hpp"
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

// What both modes share, set up by control_command().
struct ControlParts {
  const ControlArgs& args;
  const RunTimes& times;
  const LineConfig& line;
  LedgerWriter& ledger;
  LineController& controller;
  LineControllerLogic& logic;
  LineStatusPublisher& status;
  dds::DdsTelemetryPublisher& telemetry;
  dds::DdsCameraInput& cameras;
  dds::DdsLineOutput& output;
  ControlRecorder* recorder;  // --record, or nullptr
};

// Where the modes differ once the scan runs.
struct ModeHooks {
  std::function<void()> drain;                  // the mode's own events, non-real-time
  std::function<void(nlohmann::json&)> report;  // its counters into the JSON
  std::function<void()> print;                  // and onto stdout
  std::function<bool()> peer_lost;              // the line faulted for a lost peer
  // The devices brought up right before the first scan, once memory is locked (0, or the
  // exit code to end with); empty when there is nothing to bring up.
  std::function<int()> bring_up;
  // And taken down after the last scan; empty when there is nothing to take down.
  std::function<void()> shut_down;
};

}  // namespace

CLI::App* add_control_subcommand(CLI::App& app, ControlArgs& args) {
  CLI::App* control = app.add_subcommand("control",
                                         "run the line controller on DDS (estimates, sensors in; "
                                         "commands, status out) on the 10 ms real-time schedule");
  control->add_option("--duration", args.duration,
                      "feeding time: the line is stopped after it, e.g. 60s, 10m; forever: "
                      "until SIGTERM or SIGINT (the service)");
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
  control->add_option("--can", args.can_interface,
                      "drives and I/O through the CANopen master on this SocketCAN interface "
                      "(e.g. can0, vcan0) instead of the DDS sensor and command topics");
  control->add_option("--can-config", args.can_config,
                      "--can: the bus configuration (default can.yaml)");
  control->add_option("--record", args.record_path,
                      "record every scan's line state and the estimates as they arrived (MCAP; "
                      "linectl replay runs it through the controller again)");
  return control;
}

namespace {

// The scan on the real-time runtime until the controlled stop (or a fault) ends the run; the
// ledger summary, the timing and the mode's counters as the report.
int run_control(ControlParts& parts, dds::DdsProcessIo& io, const ModeHooks& hooks) {
  const ControlArgs& args = parts.args;
  const RunTimes& times = parts.times;
  RuntimeOptions options = watchdog_runtime_options(parts.line);
  options.fifo_priority = args.fifo_priority;
  options.lock_memory = args.lock_memory;
  options.cpu_dma_latency_us = args.cpu_dma_latency_us;
  // Called on the scan thread: the fault is published from the drain, not from there.
  std::atomic<RuntimeFault> runtime_fault{RuntimeFault::kNone};
  options.on_fault = [&runtime_fault](RuntimeFault fault) {
    spdlog::error("runtime fault: {}", to_string(fault));
    runtime_fault.store(fault);
  };
  ScanRuntime runtime(io, parts.logic, options);

  KpiCollector collector(parts.line);
  std::uint64_t records = 0;
  const auto drain = [&] {
    while (auto record = parts.controller.closed_records().pop()) {
      parts.ledger.write(*record);
      parts.telemetry.publish(*record);
      ++records;
    }
    if (parts.status.buffer().take()) parts.telemetry.offer(parts.status.buffer().front());
    while (auto event = parts.controller.events().pop()) {
      collector.add_event(*event);
      log_control_event(*event);
      if (auto fault = dds::fault_report(*event)) parts.telemetry.publish(*fault);
    }
    if (parts.recorder != nullptr) parts.recorder->drain();
    if (const RuntimeFault fault = runtime_fault.exchange(RuntimeFault::kNone);
        fault != RuntimeFault::kNone) {
      parts.telemetry.publish(dds::FaultReport{monotonic_now_ns(), dds::FaultOrigin::kRuntime, true,
                                               static_cast<std::uint32_t>(fault), 0,
                                               std::string("scan runtime: ") + to_string(fault)});
    }
    hooks.drain();
  };

  // Memory is locked before the devices come up, not after: locking takes long (0.7 s for
  // this process in an emulated guest), and the drives a CANopen start-up enables expect
  // SYNC and commands right after it. The twin's drives stopped on that gap as lost
  // commands, as real drives with a command timeout would.
  runtime.prepare();
  if (hooks.bring_up) {
    if (const int code = hooks.bring_up(); code != 0) return code;
  }

  // The operator's start, as linectl run gives it, applied at the first scan.
  parts.logic.request_start();
  const auto wall_start = std::chrono::steady_clock::now();
  const RealtimeSetup setup = runtime.start();
  if (!setup.error.empty()) spdlog::warn("real-time setup: {}", setup.error);
  if (!setup.started) throw std::runtime_error("the scan runtime did not start: " + setup.error);
  if (std::isfinite(times.duration_s)) {
    spdlog::info("control: scanning; {} s of feeding, then a controlled stop", times.duration_s);
  } else {
    spdlog::info("control: scanning until a stop signal, then a controlled stop");
  }

  bool stop_sent = false;
  bool line_faulted = false;
  double elapsed_s = 0.0;
  double fed_s = times.duration_s;  // until the stop request (forever: a stop signal)
  while (runtime.running()) {
    std::this_thread::sleep_for(kDrainPeriod);
    drain();
    elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    if (!stop_sent && (elapsed_s >= times.duration_s || g_control_interrupts.load() > 0)) {
      // The journal says why the line stopped: a service stop or ^C, or the set duration.
      if (g_control_interrupts.load() > 0) {
        spdlog::info("control: stop requested by signal: stopping the line, draining belts");
      } else {
        spdlog::info("control: {} s of feeding done: stopping the line, draining belts",
                     times.duration_s);
      }
      parts.logic.request_stop();
      stop_sent = true;
      fed_s = std::min(times.duration_s, elapsed_s);
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
    if (stopped || elapsed_s > times.duration_s + times.drain_s ||
        g_control_interrupts.load() > 1) {
      runtime.request_stop();
    }
  }
  runtime.wait();
  if (hooks.shut_down) hooks.shut_down();
  drain();
  parts.controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();
  if (parts.recorder != nullptr) {
    parts.recorder->close();
    spdlog::info(
        "control: {} scans recorded to {}{}", parts.recorder->scans_written(), args.record_path,
        parts.recorder->scans_dropped() > 0
            ? fmt::format(", {} dropped (the writer fell behind)", parts.recorder->scans_dropped())
            : std::string());
  }

  Kpis kpis;
  kpis.plant = args.can_interface.empty() ? "dds" : "canopen+dds";
  if (!stop_sent) fed_s = std::min(times.duration_s, elapsed_s);  // ended by a fault
  collector.finish(parts.controller, 0, 0, fed_s, elapsed_s, elapsed_s, kpis);
  const CycleStatsSummary stats = runtime.stats().summary();
  kpis.compute = stats.compute;
  const dds::LineOutputCounters out = parts.output.counters();
  const dds::IntakeCounters intake = parts.cameras.counters();
  const dds::ReactionLatency latency = parts.output.reaction_latency();
  const dds::TelemetryCounters telemetry = parts.telemetry.counters();

  nlohmann::json json = to_json(kpis);
  for (const char* key : {"truth", "placed_per_minute", "in_spec_share_of_singulated", "plant",
                          "seed", "simulated_s", "realtime_factor", "slowest_second"}) {
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
                 {"estimate_transport_us", summary_json(latency.transport)},
                 {"estimate_to_command_us", summary_json(latency.reaction)},
                 {"ledger_records_published", telemetry.records_published},
                 {"kpis_published", telemetry.kpis_published},
                 {"fault_reports_published", telemetry.faults_published},
                 {"telemetry_write_failures", telemetry.write_failures}};
  if (parts.recorder != nullptr) {
    json["record"] = {{"path", args.record_path},
                      {"scans_written", parts.recorder->scans_written()},
                      {"scans_dropped", parts.recorder->scans_dropped()}};
  }
  hooks.report(json);

  std::printf(
      "control, %.1f s fed, %.1f s wall, %llu scans, %llu overruns, wake-up latency "
      "p99.9 %.1f us max %.1f us\n",
      fed_s, elapsed_s, static_cast<unsigned long long>(stats.scans),
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
      "%llu ledger records and %llu KPI samples published\n",
      static_cast<unsigned long long>(out.commands_published),
      static_cast<unsigned long long>(out.commands_dropped),
      static_cast<unsigned long long>(intake.samples_accepted),
      static_cast<unsigned long long>(intake.rejected_total()),
      static_cast<unsigned long long>(telemetry.records_published),
      static_cast<unsigned long long>(telemetry.kpis_published));
  hooks.print();
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
  if (line_faulted) return hooks.peer_lost() ? 4 : 1;
  if (runtime.fault() != RuntimeFault::kNone) return 1;  // the scan stopped before the line did
  return 0;
}

// The line's I/O on DDS (the twin's sensor and command topics).
int control_over_dds(ControlParts& parts, dds::Participant& participant) {
  dds::DdsSensorInput sensors(participant);
  dds::DdsProcessIo io(parts.cameras, sensors, parts.output);

  // The line's I/O first: a controller that starts scanning before the sensors arrive sees an
  // open safety chain and latches kEstop (DdsProcessIo), which only an acknowledge clears.
  spdlog::info("control: waiting up to {} s for the line's sensors", parts.times.wait_s);
  if (!wait_until([&] { return sensors.delivered(); }, parts.times.wait_s,
                  [] { return g_control_interrupts.load() > 0; }, std::chrono::milliseconds(1))) {
    spdlog::error(
        "control: no LineSensors on '{}' within {} s (is the twin or the line's I/O "
        "running on the same domain and CYCLONEDDS_URI?)",
        dds::kSensorsTopic, parts.times.wait_s);
    return 4;
  }
  ModeHooks hooks;
  hooks.drain = [] {};
  hooks.report = [&](nlohmann::json& json) {
    const dds::SensorInputCounters counts = sensors.counters();
    json["dds"]["sensors_accepted"] = counts.sensors_accepted;
    json["dds"]["sensors_rejected"] = counts.sensors_rejected;
    json["dds"]["feedback_accepted"] = counts.feedback_accepted;
    json["dds"]["sensors_stale_scans"] = io.sensors_stale_scans();
  };
  hooks.print = [&] {
    std::printf("sensors         %llu samples on DDS, %llu stale scans\n",
                static_cast<unsigned long long>(sensors.counters().sensors_accepted),
                static_cast<unsigned long long>(io.sensors_stale_scans()));
  };
  hooks.peer_lost = [&] { return io.sensors_stale_scans() > 0; };
  return run_control(parts, io, hooks);
}

// The line's drives and I/O on CANopen (config/can.yaml) over a SocketCAN interface.
int control_over_can(ControlParts& parts) {
  drivers::CanConfig config =
      drivers::load_can_config(config_or_default(parts.args.can_config, "can.yaml"), parts.line);
  config.interface_name = parts.args.can_interface;
  std::unique_ptr<drivers::SocketCanBus> bus;
  try {
    drivers::SocketCanOptions options{config.interface_name, {}, true, false, 0};
    options.confirm_sends = true;  // SYNC period and send delay as they are on the wire
    bus = std::make_unique<drivers::SocketCanBus>(options);
  } catch (const drivers::SocketCanError& error) {
    spdlog::error("control: --can {}: {}", config.interface_name, error.what());
    return 2;
  }
  drivers::CanopenIo master(*bus, config);
  dds::DdsProcessIo io(parts.cameras, master, parts.output);
  ModeHooks hooks;
  // Every node or bus fault the master reports goes onto fl/line/faults as well as the log.
  const auto publish_can_fault = [&parts](const drivers::CanopenEvent& event) {
    const std::optional<bool> raised = drivers::fault_transition(event);
    if (!raised) return;
    const bool on_bus = event.kind == drivers::CanopenEventKind::kBusStateChanged;
    const bool emergency = event.kind == drivers::CanopenEventKind::kEmergency ||
                           event.kind == drivers::CanopenEventKind::kEmergencyCleared;
    parts.telemetry.publish(dds::FaultReport{
        event.time_ns, on_bus ? dds::FaultOrigin::kCanBus : dds::FaultOrigin::kCanNode, *raised,
        on_bus || emergency ? event.code : 0U, event.node, drivers::describe(event)});
  };

  // Start-up (NMT reset, SDO configuration, NMT start) until every node answers: on power-up
  // the drives may still be booting, and a twin may start later. The drives are enabled by
  // the scan (the line's start, CiA 402 one transition per cycle), not here: a drive enabled
  // by the start-up would run its command timeout through the wait until the first scan's
  // SYNC, which the twin's drives (100 ms) saw expire in an emulated guest.
  drivers::StartupReport startup;
  hooks.bring_up = [&] {
    spdlog::info("control: CANopen start-up on {}, retried for up to {} s", config.interface_name,
                 parts.times.wait_s);
    const bool up = wait_until(
        [&] {
          startup = master.start_up(drivers::monotonic_bus_clock(), /*enable_drives=*/false);
          master.log_events(publish_can_fault);
          return startup.ok;
        },
        parts.times.wait_s, [] { return g_control_interrupts.load() > 0; },
        std::chrono::milliseconds(200));
    if (!up) {
      spdlog::error("control: the CANopen start-up on {} did not complete within {} s:",
                    config.interface_name, parts.times.wait_s);
      for (const std::string& problem : startup.problems) spdlog::error("  {}", problem);
      return 4;
    }
    spdlog::info("control: CANopen start-up in {:.0f} ms",
                 static_cast<double>(startup.duration_ns) / 1e6);
    return 0;
  };
  // After the last scan the drives are disabled and every node stopped (NMT), rather than
  // left Operational to run into their command timeouts.
  hooks.shut_down = [&] {
    if (master.shut_down(drivers::monotonic_bus_clock())) {
      spdlog::info("control: drives disabled, every CANopen node stopped (NMT stop)");
    } else {
      spdlog::warn("control: not every drive confirmed disabled before the NMT stop");
    }
  };
  hooks.drain = [&] { master.log_events(publish_can_fault); };
  hooks.report = [&](nlohmann::json& json) {
    const drivers::CanopenCounters& counts = master.counters();
    const drivers::CanBusCounters& frames = bus->counters();
    json["can"] = {{"interface", config.interface_name},
                   {"startup_ms", static_cast<double>(startup.duration_ns) / 1e6},
                   {"syncs_sent", counts.syncs_sent},
                   {"frames_handled", counts.frames_handled},
                   {"frames_sent", frames.frames_sent},
                   {"frames_received", frames.frames_received},
                   {"send_failures", counts.send_failures},
                   {"unknown_cob_id", counts.unknown_cob_id},
                   {"malformed_frames", counts.malformed_frames},
                   {"events_dropped", counts.events_dropped},
                   {"nodes_lost", counts.heartbeats_lost},
                   {"nodes_restarted", counts.nodes_restarted},
                   {"nodes_reconfigured", counts.nodes_reconfigured},
                   {"reconfigurations_failed", counts.reconfigurations_failed},
                   {"error_state", drivers::to_string(bus->error_state())}};
    const drivers::CanBusTiming& timing = master.bus_timing();
    json["can"]["on_the_wire"] = {
        {"syncs", timing.syncs_on_bus},
        {"sync_period_mean_ms", timing.sync_period_mean_ns() / 1e6},
        {"sync_period_min_ms", static_cast<double>(timing.sync_period_min_ns) / 1e6},
        {"sync_period_max_ms", static_cast<double>(timing.sync_period_max_ns) / 1e6},
        {"sync_jitter_ms",
         static_cast<double>(timing.sync_jitter_ns(config.cycle_period_ns)) / 1e6},
        {"frames_confirmed", timing.frames_confirmed},
        {"frames_unconfirmed", frames.sends_unconfirmed},
        {"send_delay_mean_us", timing.send_delay_mean_ns() / 1e3},
        {"send_delay_max_us", static_cast<double>(timing.send_delay_max_ns) / 1e3},
        {"estimate_to_sync_us", summary_json(io.estimate_to_devices())},
        {"estimates_unstamped", io.estimates_unstamped()}};
  };
  hooks.print = [&] {
    std::printf(
        "can             %s: %llu SYNCs, %llu frames sent, %llu handled, %llu send "
        "failures, %llu node losses\n",
        config.interface_name.c_str(),
        static_cast<unsigned long long>(master.counters().syncs_sent),
        static_cast<unsigned long long>(bus->counters().frames_sent),
        static_cast<unsigned long long>(master.counters().frames_handled),
        static_cast<unsigned long long>(master.counters().send_failures),
        static_cast<unsigned long long>(master.counters().heartbeats_lost));
    const drivers::CanBusTiming& timing = master.bus_timing();
    if (timing.sync_periods > 0) {
      std::printf(
          "can timing      SYNC every %.3f ms (min %.3f, max %.3f, jitter %.3f ms); send() "
          "to bus mean %.1f us, max %.1f us\n",
          timing.sync_period_mean_ns() / 1e6, static_cast<double>(timing.sync_period_min_ns) / 1e6,
          static_cast<double>(timing.sync_period_max_ns) / 1e6,
          static_cast<double>(timing.sync_jitter_ns(config.cycle_period_ns)) / 1e6,
          timing.send_delay_mean_ns() / 1e3, static_cast<double>(timing.send_delay_max_ns) / 1e3);
      const DistributionSummary reaction = io.estimate_to_devices();
      std::printf(
          "can reaction    estimate published -> its command's SYNC on the wire p50 %.1f us "
          "p99 %.1f us max %.1f us (%llu frames)\n",
          static_cast<double>(reaction.p50_ns) / 1e3, static_cast<double>(reaction.p99_ns) / 1e3,
          static_cast<double>(reaction.max_ns) / 1e3,
          static_cast<unsigned long long>(reaction.count));
    }
  };
  hooks.peer_lost = [&] { return master.counters().heartbeats_lost > 0; };
  return run_control(parts, io, hooks);
}

}  // namespace

int control_command(const ControlArgs& args) {
  const std::optional<RunTimes> times =
      parse_run_times(args.duration, args.wait, args.drain, /*allow_forever=*/true);
  if (!times) return 2;
  const LineConfig line = load_line_config(config_or_default(args.config, "line.yaml"));
  LedgerWriter ledger(args.ledger_path);

  const dds_domainid_t domain =
      args.domain < 0 ? DDS_DOMAIN_DEFAULT : static_cast<dds_domainid_t>(args.domain);
  dds::Participant participant(domain);
  dds::DdsCameraInput cameras(participant);
  dds::DdsLineOutput output(participant);

  LineController controller(line);
  LineControllerLogic logic(controller);
  // Telemetry for the plant beyond the HMI (MES, dashboards): the ledger, the KPIs and the
  // scan timing on their DDS topics, published from this thread as the ledger drains.
  LineStatusPublisher status;
  logic.attach_status(&status);
  dds::DdsTelemetryPublisher telemetry(participant);

  std::unique_ptr<ControlRecorder> recorder;
  if (!args.record_path.empty()) {
    if (!args.record_factory) {
      spdlog::error("control: --record: this binary has no recording library (use linectl)");
      return 2;
    }
    try {
      recorder = args.record_factory(read_text(config_or_default(args.config, "line.yaml")),
                                     args.record_path);
    } catch (const std::exception& error) {
      spdlog::error("control: --record {}: {}", args.record_path, error.what());
      return 2;
    }
    logic.attach_recorder(recorder.get());
    spdlog::info("control: recording every scan to {}", args.record_path);
  }

  std::signal(SIGINT, on_control_signal);
  std::signal(SIGTERM, on_control_signal);

  ControlParts parts{args,   *times,    line,    ledger, controller,    logic,
                     status, telemetry, cameras, output, recorder.get()};
  return args.can_interface.empty() ? control_over_dds(parts, participant)
                                    : control_over_can(parts);
}

}  // namespace fl::apps
