// linectl twin serve: the plant as the line's devices and cameras on DDS, in real time
// (two_process.hpp, docs/dds.md "Two-process mode").
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <spdlog/spdlog.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/monotonic_clock.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/dds/line_io.hpp"
#include "fl/drivers/dds/line_output.hpp"
#include "fl/drivers/line_devices.hpp"
#include "fl/drivers/socketcan.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "two_process.hpp"

namespace fl::apps {
namespace {

namespace dds = fl::drivers::dds;

std::atomic<bool> g_twin_interrupted{false};
extern "C" void on_twin_signal(int /*signal*/) { g_twin_interrupted.store(true); }

constexpr std::int64_t kPeriodNs = 10'000'000;  // the line's scan period, as the runtime's
// Commands older than this mean the controller is gone: 10 scans, well beyond the runtime's
// 3-scan overrun fault. Over DDS the twin then applies the safe output image, as the drives'
// own command timeout would; on CAN the emulated devices decide, as real ones do, by the
// master's heartbeat they were told to watch (can.yaml master.heartbeat_timeout_ms).
constexpr std::int64_t kCommandStaleNs = 100'000'000;
// After the controller has stopped the line (every drive disabled), fillets still on the
// belts stay there; wait this long for the plant to report them gone before ending the run.
constexpr std::int64_t kStoppedSettleNs = 1'000'000'000;

bool any_drive_enabled(const OutputImage& out) {
  for (const DriveCommand& drive : out.drives) {
    if (drive.enable) return true;
  }
  return false;
}

struct TwinStats {
  std::uint64_t ticks = 0;
  std::uint64_t late_ticks = 0;     // woke more than a period after their scheduled time
  std::uint64_t skipped_ticks = 0;  // periods the plant stepped over in one go
  std::uint64_t commands_applied = 0;
  std::uint64_t stale_ticks = 0;  // ticks on the safe output image after the line started
  std::array<std::uint64_t, kCameraCount> frames_published{};
  std::uint64_t publish_failures = 0;
};

// Where the twin meets the controller: the DDS topics (sensors out, commands in) or the
// line's CANopen devices on a bus. The cameras are on DDS either way.
class ControllerLink {
 public:
  ControllerLink() = default;
  ControllerLink(const ControllerLink&) = delete;
  ControllerLink& operator=(const ControllerLink&) = delete;
  virtual ~ControllerLink() = default;
  // Polled while waiting for the controller.
  [[nodiscard]] virtual bool controller_present() = 0;
  [[nodiscard]] virtual std::string how_to_connect() const = 0;
  // Lets time pass until deadline_ns (CLOCK_MONOTONIC), serving the link meanwhile.
  virtual void serve_until(std::int64_t deadline_ns, const std::atomic<bool>& interrupted) = 0;
  // The controller's newest commands; false when none arrived within kCommandStaleNs.
  virtual bool fresh_command(std::int64_t now_ns, OutputImage& out) = 0;
  // What the plant runs on while no fresh command comes: `safe` (DDS), or what the devices
  // themselves hold (CAN: they stop on their own when the master's heartbeat falls silent).
  [[nodiscard]] virtual OutputImage without_controller(const OutputImage& safe) const {
    return safe;
  }
  // The plant's state before the first tick, for a link whose devices answer while the
  // controller starts up.
  virtual void set_initial_state(const InputImage& /*plant*/) {}
  // The plant's state for the controller's next read (sensors, drive feedback).
  virtual bool publish(std::uint64_t tick, std::int64_t scheduled_ns, const InputImage& plant) = 0;
  virtual void report(nlohmann::json& twin_json) const = 0;
  [[nodiscard]] virtual std::string command_summary() const = 0;
};

class DdsLink final : public ControllerLink {
 public:
  explicit DdsLink(dds::Participant& participant)
      : sensors_(participant, kPeriodNs), commands_(participant, kPeriodNs) {}
  bool controller_present() override { return commands_.matched_writers() > 0; }
  [[nodiscard]] std::string how_to_connect() const override {
    return "no controller matched the command topic (is linectl control running on the same "
           "domain and CYCLONEDDS_URI?)";
  }
  void serve_until(std::int64_t deadline_ns, const std::atomic<bool>& interrupted) override {
    sleep_until_ns(deadline_ns, interrupted);
  }
  bool fresh_command(std::int64_t /*now_ns*/, OutputImage& out) override {
    if (commands_.read(command_)) have_command_ = true;
    if (!have_command_ || dds_time() - command_.arrival_ns > kCommandStaleNs) return false;
    out = command_.out;
    return true;
  }
  bool publish(std::uint64_t tick, std::int64_t scheduled_ns, const InputImage& plant) override {
    InputImage io_in = plant;
    io_in.time_ns = scheduled_ns;
    return sensors_.publish(tick, io_in);
  }
  void report(nlohmann::json& twin_json) const override {
    twin_json["commands_received"] = commands_.commands_received();
    twin_json["command_transport_us"] = summary_json(commands_.transport_latency());
  }
  [[nodiscard]] std::string command_summary() const override {
    const DistributionSummary transport = commands_.transport_latency();
    return fmt::format("{} received on DDS, command transport p50 {:.1f} us p99 {:.1f} us",
                       commands_.commands_received(), static_cast<double>(transport.p50_ns) / 1e3,
                       static_cast<double>(transport.p99_ns) / 1e3);
  }

 private:
  dds::DdsSensorPublisher sensors_;
  dds::DdsCommandInput commands_;
  dds::ReceivedCommand command_;
  bool have_command_ = false;
};

// The line's drives and I/O modules as config/can.yaml lays them out, answering the
// controller's CANopen master on a SocketCAN interface: the controller cannot tell them from
// the real devices (issue 5 item 4).
class CanLink final : public ControllerLink {
 public:
  // On config.interface_name.
  explicit CanLink(const drivers::CanConfig& config)
      : bus_(drivers::SocketCanOptions{config.interface_name, {}, true, false, 0}),
        devices_(bus_, config),
        interface_name_(config.interface_name) {}
  // The controller is there when its master sends SYNC: its scan runs (start-up is over).
  bool controller_present() override { return syncs() > 0; }
  [[nodiscard]] std::string how_to_connect() const override {
    return fmt::format("no SYNC from a CANopen master on {} (is linectl control --can {} running?)",
                       interface_name_, interface_name_);
  }
  void serve_until(std::int64_t deadline_ns, const std::atomic<bool>& interrupted) override {
    // Frames are answered as they arrive (a SYNC's TPDOs within the master's cycle); the
    // devices' own timers (heartbeats) are stepped at least every millisecond.
    constexpr std::int64_t kMaxSleepNs = 1'000'000;
    for (;;) {
      std::int64_t now_ns = monotonic_now_ns();
      devices_.poll(now_ns);
      now_ns = monotonic_now_ns();
      if (now_ns >= deadline_ns || interrupted.load()) return;
      const std::int64_t sleep_ns = std::min(kMaxSleepNs, deadline_ns - now_ns);
      pollfd socket{bus_.native_handle(), POLLIN, 0};
      const timespec timeout{0, static_cast<long>(sleep_ns)};
      ppoll(&socket, 1, &timeout, nullptr);
    }
  }
  bool fresh_command(std::int64_t now_ns, OutputImage& out) override {
    const std::uint64_t syncs_now = syncs();
    if (syncs_now != syncs_seen_) {
      syncs_seen_ = syncs_now;
      last_sync_ns_ = now_ns;
    }
    if (syncs_seen_ == 0 || now_ns - last_sync_ns_ > kCommandStaleNs) return false;
    out = devices_.commands();
    return true;
  }
  [[nodiscard]] OutputImage without_controller(const OutputImage& /*safe*/) const override {
    return devices_.commands();
  }
  void set_initial_state(const InputImage& plant) override { devices_.set_plant_state(plant); }
  bool publish(std::uint64_t /*tick*/, std::int64_t /*scheduled_ns*/,
               const InputImage& plant) override {
    devices_.set_plant_state(plant);  // sampled into the TPDOs at the next SYNC
    return true;
  }
  void report(nlohmann::json& twin_json) const override {
    const drivers::CanBusCounters& bus = bus_.counters();
    twin_json["can"] = {{"interface", interface_name_},
                        {"syncs_received", syncs_seen_},
                        {"frames_sent", bus.frames_sent},
                        {"frames_received", bus.frames_received},
                        {"tx_queue_full", bus.tx_queue_full},
                        {"tx_errors", bus.tx_errors},
                        {"rx_overruns", bus.rx_overruns},
                        {"error_state", drivers::to_string(bus_.error_state())},
                        {"devices_that_lost_the_master", devices_that_lost_the_master()}};
  }
  [[nodiscard]] std::string command_summary() const override {
    return fmt::format("{} SYNCs on {}, {} frames sent, {} received", syncs_seen_, interface_name_,
                       bus_.counters().frames_sent, bus_.counters().frames_received);
  }

 private:
  // Every drive sees every SYNC; the first one's count stands for the bus.
  std::uint64_t syncs() { return devices_.drive(DriveId{}).counters().syncs; }
  // Devices whose watch of the master's heartbeat ran out (and that then stopped themselves).
  [[nodiscard]] std::size_t devices_that_lost_the_master() const {
    std::size_t lost = 0;
    for (std::size_t d = 0; d < kDriveCount; ++d) {
      lost += devices_.drive(static_cast<DriveId>(d)).counters().heartbeats_lost > 0 ? 1 : 0;
    }
    for (std::size_t m = 0; m < drivers::kIoModuleCount; ++m) {
      lost += devices_.module(static_cast<drivers::IoModuleId>(m)).counters().heartbeats_lost > 0
                  ? 1
                  : 0;
    }
    return lost;
  }

  drivers::SocketCanBus bus_;
  drivers::emulation::LineDevices devices_;
  std::string interface_name_;
  std::uint64_t syncs_seen_ = 0;
  std::int64_t last_sync_ns_ = 0;
};

}  // namespace

CLI::App* add_twin_subcommand(CLI::App& app, TwinServeArgs& args) {
  CLI::App* twin = app.add_subcommand("twin", "the digital twin as a separate process");
  twin->require_subcommand(1);
  CLI::App* serve = twin->add_subcommand(
      "serve", "run a plant in real time as the line's devices and cameras on DDS");
  serve->add_option("--plant", args.plant, "fast (2D plant) or dem (DEM twin)")
      ->check(CLI::IsMember({"fast", "dem"}));
  serve->add_option("--seed", args.seed, "plant seed");
  serve->add_option("--duration", args.duration, "feeding time, e.g. 60s, 10m (as linectl run)");
  serve->add_option("--config", args.config, "line configuration (YAML)");
  serve->add_option("--plant-config", args.plant_config, "plant configuration (YAML)");
  serve->add_option("--json", args.json_path, "write the ground-truth KPIs as JSON to this file");
  serve->add_option("--domain", args.domain, "DDS domain id (default: CYCLONEDDS_URI's)")
      ->check(CLI::Range(0, 232));
  serve->add_option("--wait", args.wait, "how long to wait for a controller, e.g. 30s");
  serve->add_option("--drain", args.drain, "longest run after the feeding time, e.g. 60s");
  serve->add_option("--fifo", args.fifo_priority, "SCHED_FIFO priority of the tick loop (1-99)")
      ->check(CLI::Range(0, 99));
  serve->add_option("--can", args.can_interface,
                    "serve the line's CANopen drives and I/O on this SocketCAN interface "
                    "(e.g. vcan0) instead of the DDS sensor and command topics");
  serve->add_option("--can-config", args.can_config,
                    "--can: the bus configuration (default can.yaml)");
  return serve;
}

int twin_serve_command(const TwinServeArgs& args) {
  const std::optional<RunTimes> times = parse_run_times(args.duration, args.wait, args.drain);
  if (!times) return 2;
  const LineConfig line = load_line_config(config_or_default(args.config, "line.yaml"));
  std::unique_ptr<Plant> plant = make_plant(args.plant, args.plant_config, line);

  const dds_domainid_t domain =
      args.domain < 0 ? DDS_DOMAIN_DEFAULT : static_cast<dds_domainid_t>(args.domain);
  dds::Participant participant(domain);
  // One writer for every camera, offering the slowest camera's deadline: each camera is an
  // instance and the faster ones meet it with room to spare.
  dds::DdsCameraPublisher cameras(participant, dds::kSlowestCameraPeriodNs);
  std::unique_ptr<ControllerLink> link;
  if (args.can_interface.empty()) {
    link = std::make_unique<DdsLink>(participant);
  } else {
    drivers::CanConfig can =
        drivers::load_can_config(config_or_default(args.can_config, "can.yaml"), line);
    can.interface_name = args.can_interface;
    try {
      link = std::make_unique<CanLink>(can);
    } catch (const drivers::SocketCanError& error) {
      spdlog::error("twin: --can {}: {}", args.can_interface, error.what());
      return 2;
    }
  }

  std::signal(SIGINT, on_twin_signal);
  std::signal(SIGTERM, on_twin_signal);

  // The devices answer from the plant's state at time 0 while the controller starts up.
  InputImage plant_in;
  plant->reset(args.seed, plant_in);
  link->set_initial_state(plant_in);

  // The plant's clock starts when a controller is there (DDS: a matched command writer; CAN:
  // the master's first SYNC). Until then no camera frame is published, so the controller's
  // first input image is the plant at time 0.
  spdlog::info("twin: {} plant, seed {}, {} s of feeding; waiting up to {} s for a controller{}",
               plant->name(), args.seed, times->duration_s, times->wait_s,
               args.can_interface.empty() ? "" : " on " + args.can_interface);
  constexpr std::int64_t kWaitServeNs = 1'000'000;
  if (!wait_until(
          [&] {
            link->serve_until(monotonic_now_ns() + kWaitServeNs, g_twin_interrupted);
            return link->controller_present();
          },
          times->wait_s, [] { return g_twin_interrupted.load(); }, std::chrono::milliseconds(0))) {
    spdlog::error("twin: {} within {} s", link->how_to_connect(), times->wait_s);
    return 4;
  }

  if (args.fifo_priority > 0) {
    // The tick loop runs on this thread. Like the runtime without realtime_required: a
    // refusal (no CAP_SYS_NICE) is logged and the twin runs on SCHED_OTHER.
    sched_param param{};
    param.sched_priority = args.fifo_priority;
    if (const int error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param); error != 0) {
      spdlog::warn("twin: SCHED_FIFO {} refused ({}); running on SCHED_OTHER", args.fifo_priority,
                   std::strerror(error));
    }
  }
  KpiCollector collector(line);
  TwinStats stats;
  DurationHistogram lateness(10'000, 100'000'000);  // tick wake-up lateness, 10 us bins
  std::array<std::uint32_t, kCameraCount> published_sequence{};
  for (std::size_t c = 0; c < kCameraCount; ++c) {
    published_sequence[c] = plant_in.cameras[c].sequence;
  }

  const std::int64_t start_ns = monotonic_now_ns() + kPeriodNs;
  // Frame times are on the plant's clock; the controller's is CLOCK_MONOTONIC of this host.
  const std::int64_t offset_ns = start_ns - plant_in.time_ns;
  const auto limit_ns = static_cast<std::int64_t>((times->duration_s + times->drain_s) * 1e9);
  const OutputImage safe = make_safe_output_image();
  OutputImage command{};
  bool line_ran = false;
  bool controller_lost = false;
  std::int64_t stopped_since_ns = -1;
  std::int64_t scheduled_ns = start_ns;
  std::int64_t last_stepped_ns = start_ns;
  const auto wall_start = std::chrono::steady_clock::now();

  for (std::uint64_t tick = 0; !g_twin_interrupted.load(); ++tick) {
    link->serve_until(scheduled_ns, g_twin_interrupted);
    const std::int64_t woke_ns = monotonic_now_ns();
    lateness.record(woke_ns - scheduled_ns);
    ++stats.ticks;
    if (woke_ns - scheduled_ns > kPeriodNs) ++stats.late_ticks;

    const bool fresh = link->fresh_command(woke_ns, command);
    const OutputImage applied = fresh ? command : link->without_controller(safe);
    if (fresh) ++stats.commands_applied;
    if (!fresh && line_ran) {
      ++stats.stale_ticks;
      if (stopped_since_ns < 0) controller_lost = true;  // stale while the line was running
    }

    // Skipped periods after a late wake-up advance the plant by the whole gap, as PlantIo
    // does: the real line would have moved on.
    const std::int64_t dt_ns = scheduled_ns - last_stepped_ns;
    if (dt_ns > 0) plant->step(applied, dt_ns, plant_in);
    last_stepped_ns = scheduled_ns;
    for (const TrueFilletExit& exit : plant->drain_exits()) collector.add_exit(exit);

    for (std::size_t c = 0; c < kCameraCount; ++c) {
      CameraFrame frame = plant_in.cameras[c];
      if (frame.sequence == published_sequence[c]) continue;
      published_sequence[c] = frame.sequence;
      frame.frame_time_ns += offset_ns;
      try {
        cameras.publish(static_cast<CameraId>(c), frame);
        ++stats.frames_published[c];
      } catch (const dds::DdsError& error) {
        ++stats.publish_failures;
        spdlog::warn("twin: camera {} frame {}: {}", c, frame.sequence, error.what());
      }
    }
    if (!link->publish(tick, scheduled_ns, plant_in)) ++stats.publish_failures;

    // The run ends when the controller has stopped the line after running it and the belts
    // are empty (or have stood still long enough), or at the time limit.
    if (any_drive_enabled(applied)) {
      line_ran = true;
      stopped_since_ns = -1;
    } else if (line_ran && stopped_since_ns < 0) {
      stopped_since_ns = scheduled_ns;
    }
    const bool stopped = stopped_since_ns >= 0;
    const bool settled = stopped && (plant->fillets_on_line() == 0 ||
                                     scheduled_ns - stopped_since_ns >= kStoppedSettleNs);
    if (settled || plant_in.time_ns >= limit_ns) break;

    // Next tick on the absolute schedule; after a late wake-up, the next one in the future.
    scheduled_ns += kPeriodNs;
    const std::int64_t now_ns = monotonic_now_ns();
    if (now_ns > scheduled_ns) {
      const std::int64_t behind = (now_ns - scheduled_ns) / kPeriodNs;
      stats.skipped_ticks += static_cast<std::uint64_t>(behind);
      scheduled_ns += behind * kPeriodNs;
    }
  }
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  // The ground truth, counted by the same collector as linectl run. The controller's side of
  // the books is in the other process: a controller that never ran supplies empty counters,
  // and its sections are left out of the JSON.
  const LineController no_controller(line);
  Kpis kpis;
  kpis.plant = plant->name();
  kpis.seed = args.seed;
  const double simulated_s = static_cast<double>(plant_in.time_ns) / 1e9;
  collector.finish(no_controller, plant->fillets_fed(), plant->fillets_on_line(), times->duration_s,
                   simulated_s, wall_s, kpis);
  nlohmann::json json = to_json(kpis);
  for (const char* key : {"ledger", "controller", "cycle_compute_us", "items_per_minute"}) {
    json.erase(key);
  }
  const DistributionSummary late = lateness.summary();
  json["twin"] = {{"ticks", stats.ticks},
                  {"late_ticks", stats.late_ticks},
                  {"skipped_ticks", stats.skipped_ticks},
                  {"wakeup_lateness_us", summary_json(late)},
                  {"commands_applied", stats.commands_applied},
                  {"stale_ticks", stats.stale_ticks},
                  {"controller_lost", controller_lost},
                  {"frames_published", stats.frames_published},
                  {"publish_failures", stats.publish_failures}};
  link->report(json["twin"]);

  const TruthTally& t = kpis.truth;
  std::printf("twin %s, seed %llu, %.1f s fed, %.1f s line time in %.1f s wall\n",
              kpis.plant.c_str(), static_cast<unsigned long long>(args.seed), times->duration_s,
              simulated_s, wall_s);
  std::printf("throughput      %.1f placed/min\n", kpis.placed_per_minute);
  std::printf("in spec         %.2f %% of singulated fillets (%llu of %llu)\n",
              100.0 * kpis.in_spec_share, static_cast<unsigned long long>(t.outfeed_in_spec),
              static_cast<unsigned long long>(t.singulated_exits));
  std::printf(
      "truth           fed %llu, placed %llu, crate %llu, air knife %llu, fell off %llu, "
      "on line %llu (%s)\n",
      static_cast<unsigned long long>(t.fed), static_cast<unsigned long long>(t.outfeed),
      static_cast<unsigned long long>(t.reject_crate),
      static_cast<unsigned long long>(t.final_reject), static_cast<unsigned long long>(t.fell_off),
      static_cast<unsigned long long>(t.on_line_at_end),
      kpis.truth_balanced ? "balanced" : "UNBALANCED");
  std::printf("ticks           %llu, late %llu, wake-up lateness p99 %.1f us max %.1f us\n",
              static_cast<unsigned long long>(stats.ticks),
              static_cast<unsigned long long>(stats.late_ticks),
              static_cast<double>(late.p99_ns) / 1e3, static_cast<double>(late.max_ns) / 1e3);
  std::printf("commands        %llu applied; %s\n",
              static_cast<unsigned long long>(stats.commands_applied),
              link->command_summary().c_str());
  std::fflush(stdout);

  if (!args.json_path.empty() && !write_json_option(args.json_path, json)) return 1;
  if (!line_ran) {
    spdlog::error("twin: the controller never started the line");
    return 4;
  }
  if (controller_lost) {
    spdlog::error("twin: the controller's commands stopped while the line was running");
    return 4;
  }
  return kpis.truth_balanced ? 0 : 3;
}

}  // namespace fl::apps
