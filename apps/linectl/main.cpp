// linectl: the line controller's command-line tool.
//   linectl run --plant fast --duration 10m --seed 1 [--json kpis.json] [--ledger ledger.csv]
//   linectl run --realtime ...      the same loop on the 10 ms real-time schedule
//   linectl run --realtime --duration forever   as the service runs: until SIGTERM or SIGINT
//   linectl config check [FILE]     validate a line configuration (and --plant's)
//   linectl record / replay         camera recordings and their regression replay
//   (record_replay.hpp)
//   linectl twin serve / control    the twin and the controller as two processes over DDS
//   (two_process.hpp)
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <thread>

#include "cli_support.hpp"
#include "compare_command.hpp"
#include "dem_output.hpp"
#include "duration.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "hmi_support.hpp"
#include "logging.hpp"
#include "plant_io.hpp"
#include "record_replay.hpp"
#include "two_process.hpp"

namespace fl::apps {
namespace {

// SIGINT and SIGTERM counted: the first stops the line and drains it, a second ends the run
// at once (still writing the ledger and KPIs).
std::atomic<int> g_stop_signals{0};
extern "C" void on_signal(int /*signal*/) { g_stop_signals.fetch_add(1); }

// A controlled stop normally empties the belts well within this; past it the run ends anyway.
constexpr double kDrainTimeoutS = 60.0;

struct RunArgs {
  std::string plant = "fast";
  std::string duration = "60s";
  std::uint64_t seed = 1;
  std::string config;        // empty: line.yaml from the configuration search path
  std::string plant_config;  // empty: the plant's own file from the search path
  std::string json_path;
  std::string ledger_path;
  bool realtime = false;
  int fifo_priority = 0;
  bool lock_memory = false;
  bool quiet = false;
  std::string vtk_directory;  // --plant dem: ParaView series
  std::string video_file;     // --plant dem: top and side view video
  double frame_every_s = 0.04;
  std::string hmi_config;  // --realtime: serve the operator HMI with this config
};

// Progress on stderr: a redrawn line on a terminal, a log line every 10 % otherwise.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}
  void operator()(double done_s, double total_s) {
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
  void finish() {
    if (!quiet_ && tty_) std::fprintf(stderr, "\n");
  }

 private:
  bool quiet_;
  bool tty_;
  int last_decile_ = -1;
};

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

Kpis run_realtime(const RunArgs& args, const LineConfig& line, Plant& plant, double duration_s,
                  Progress& progress, LedgerWriter& ledger) {
  LineController controller(line);
  LineControllerLogic logic(controller);
  PlantIo io(plant, args.seed);
  // Before the runtime: the HMI outlives the scans that publish to it.
  const std::unique_ptr<HmiRun> hmi = start_hmi(args.hmi_config, line, logic, io);
  io.request_line_start();
  RuntimeOptions options;
  options.fifo_priority = args.fifo_priority;
  options.lock_memory = args.lock_memory;
  options.on_fault = [](RuntimeFault fault) {
    spdlog::error("runtime fault: {}", to_string(fault));
  };
  ScanRuntime runtime(io, logic, options);
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
  const auto wall_start = std::chrono::steady_clock::now();
  const RealtimeSetup setup = runtime.start();
  if (!setup.error.empty()) spdlog::warn("real-time setup: {}", setup.error);
  if (!setup.started) throw std::runtime_error("the scan runtime did not start: " + setup.error);
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
    const int signals = g_stop_signals.load();
    if (!stop_sent && (elapsed_s >= duration_s || signals > 0)) {
      if (signals > 0) spdlog::info("stop requested by signal: stopping the line, draining belts");
      io.request_line_stop();
      stop_sent = true;
      fed_s = std::min(elapsed_s, duration_s);
    }
    // Drained after the stop, a second signal, or a drain that takes too long: end the run.
    const bool drained =
        stop_sent && controller.state() == LineState::kStopped && io.fillets_on_line() == 0;
    const bool give_up = stop_sent && (signals > 1 || elapsed_s > fed_s + kDrainTimeoutS);
    if (!stop_requested && (drained || give_up)) {
      if (!drained) spdlog::warn("ending the run before the belts were drained");
      runtime.request_stop();
      stop_requested = true;
    }
  }
  runtime.wait();
  drain();
  controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();
  Kpis kpis;
  kpis.plant = plant.name();
  kpis.seed = args.seed;
  kpis.compute = runtime.stats().summary().compute;
  collector.finish(controller, io.fillets_fed(), io.fillets_on_line(), fed_s, elapsed_s, elapsed_s,
                   kpis);
  const CycleStatsSummary stats = runtime.stats().summary();
  spdlog::info("real-time scans {}, overruns {}, wake-up latency p99.9 {:.1f} us max {:.1f} us",
               stats.scans, stats.overruns, static_cast<double>(stats.wakeup_latency.p999_ns) / 1e3,
               static_cast<double>(stats.wakeup_latency.max_ns) / 1e3);
  return kpis;
}

int run_command(const RunArgs& args) {
  // "forever" is the service's duration: the real-time loop runs until a stop signal.
  const std::optional<double> duration_s = args.duration == "forever"
                                               ? std::numeric_limits<double>::infinity()
                                               : parse_duration_s(args.duration);
  if (!duration_s) {
    spdlog::error("--duration {}: not a positive duration (examples: 90s, 10m, 1h, forever)",
                  args.duration);
    return 2;
  }
  if (!args.hmi_config.empty() && !args.realtime) {
    spdlog::error("--hmi needs --realtime (the HMI shows a line running in real time)");
    return 2;
  }
  if (!std::isfinite(*duration_s) && !args.realtime) {
    spdlog::error("--duration forever needs --realtime (a lock-step run would never end)");
    return 2;
  }
  const std::filesystem::path config =
      args.config.empty() ? default_config("line.yaml") : std::filesystem::path(args.config);
  const LineConfig line = load_line_config(config);
  std::unique_ptr<Plant> plant = make_plant(args.plant, args.plant_config, line);
  spdlog::info("closed loop against the {} plant, feeding {}, seed {}, config {}", plant->name(),
               std::isfinite(*duration_s) ? fmt::format("for {} s", *duration_s) : "until stopped",
               args.seed, config.string());
  Progress progress(args.quiet);
  LedgerWriter ledger(args.ledger_path);
  Kpis kpis;
  if (args.realtime) {
    kpis = run_realtime(args, line, *plant, *duration_s, progress, ledger);
  } else {
    RunOptions options;
    options.duration_s = *duration_s;
    options.seed = args.seed;
    options.progress = [&](double done, double total) { progress(done, total); };
    options.on_event = log_event;
    options.on_record = [&](const FilletRecord& record) { ledger.write(record); };
    std::unique_ptr<DemRunOutput> output;
    if (!args.vtk_directory.empty() || !args.video_file.empty()) {
      const auto* dem = dynamic_cast<const DemPlant*>(plant.get());
      if (dem == nullptr) {
        spdlog::error("--vtk and --video need --plant dem");
        return 2;
      }
      output = std::make_unique<DemRunOutput>(*dem, args.vtk_directory, args.video_file,
                                              args.frame_every_s, line.placed_at_s_mm * 1e-3);
      options.before_scan = [&](std::int64_t time_ns, LineController&) {
        output->on_scan(time_ns);
      };
    }
    kpis = run_closed_loop(line, *plant, options);
    if (output) spdlog::info("{} frames written", output->frames());
  }
  progress.finish();
  std::fputs(format_kpis(kpis).c_str(), stdout);
  std::fflush(stdout);
  if (!args.json_path.empty()) {
    std::ofstream json(args.json_path);
    if (!json) {
      spdlog::error("--json {}: cannot open for writing", args.json_path);
      return 1;
    }
    json << to_json(kpis).dump(2) << '\n';
    spdlog::info("KPIs written to {}", args.json_path);
  }
  // A run whose books do not balance is a failed run, whatever the throughput.
  return kpis.ledger_balanced && kpis.truth_balanced ? 0 : 3;
}

}  // namespace
}  // namespace fl::apps

int main(int argc, char** argv) {
  using namespace fl::apps;
  CLI::App app{"linectl: real-time line controller for the chicken-fillet line"};
  app.require_subcommand(1);
  app.fallthrough();  // global options may also follow the subcommand
  LogOptions log_options;
  app.add_option("--log-level", log_options.level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));
  app.add_option("--log-file", log_options.file,
                 "also log to this file, rotated by size (the console or journal keeps logging)");
  app.add_option("--log-file-size", log_options.file_size,
                 "rotate the log file at this size, e.g. 512K, 10M (default 10M)");
  app.add_option("--log-file-count", log_options.file_count,
                 "rotated log files kept beside the current one (default 5)")
      ->check(CLI::Range(1, 1000));

  RunArgs run_args;
  CLI::App* run = app.add_subcommand("run", "run the controller closed loop against a plant");
  run->add_option("--plant", run_args.plant, "fast (2D plant) or dem (DEM twin)")
      ->check(CLI::IsMember({"fast", "dem"}));
  run->add_option("--duration", run_args.duration,
                  "feeding time, e.g. 90s, 10m, 1h; forever (--realtime): until SIGTERM/SIGINT");
  run->add_option("--seed", run_args.seed, "plant seed; the same seed gives the same run");
  run->add_option("--config", run_args.config,
                  "line configuration (YAML; default line.yaml from $FL_CONFIG_DIR, the installed "
                  "configuration folder or the source tree)");
  run->add_option("--plant-config", run_args.plant_config,
                  "the plant's configuration (YAML; default plant_fast.yaml or plant_dem.yaml)");
  run->add_option("--json", run_args.json_path, "write the KPIs as JSON to this file");
  run->add_option("--ledger", run_args.ledger_path, "write every ledger record as CSV");
  run->add_flag("--realtime", run_args.realtime, "run on the 10 ms real-time schedule");
  run->add_option("--fifo", run_args.fifo_priority, "SCHED_FIFO priority for --realtime (1-99)")
      ->check(CLI::Range(0, 99));
  run->add_flag("--mlock", run_args.lock_memory, "lock memory for --realtime (mlockall)");
  run->add_flag("--quiet", run_args.quiet, "no progress display");
  run->add_option("--vtk", run_args.vtk_directory,
                  "--plant dem: write a ParaView series (particles, walls) to this folder");
  run->add_option("--video", run_args.video_file,
                  "--plant dem: write a top and side view video (.mkv lossless, .avi MJPG)");
  run->add_option("--frame-every", run_args.frame_every_s,
                  "seconds of line time between --vtk/--video frames")
      ->check(CLI::Range(1e-3, 10.0));
  run->add_option("--hmi", run_args.hmi_config,
                  "--realtime: serve the operator HMI with this config (e.g. config/hmi.yaml)");

  std::string check_path;
  std::string check_plant;
  std::string check_plant_config_path;
  CLI::App* config = app.add_subcommand("config", "configuration tools");
  CLI::App* check = config->add_subcommand(
      "check", "validate a line configuration file (and a plant's, with --plant)");
  check->add_option("file", check_path,
                    "line configuration (YAML; default line.yaml from the configuration "
                    "search path)");
  check->add_option("--plant", check_plant, "also validate this plant's configuration")
      ->check(CLI::IsMember({"fast", "dem"}));
  check->add_option("--plant-config", check_plant_config_path,
                    "the plant's configuration (default: its file from the search path)");
  config->require_subcommand(1);

  RecordArgs record_args;
  CLI::App* record = add_record_subcommand(app, record_args);
  ReplayArgs replay_args;
  CLI::App* replay = add_replay_subcommand(app, replay_args);
  TwinServeArgs twin_args;
  CLI::App* twin_serve = add_twin_subcommand(app, twin_args);
  ControlArgs control_args;
  CLI::App* control = add_control_subcommand(app, control_args);
  CompareArgs compare_args;
  CLI::App* compare = add_compare_subcommand(app, compare_args);
  CompareArgs diagnose_args;
  CLI::App* diagnose = add_diagnose_subcommand(app, diagnose_args);
  GenerateArgs generate_args;
  CLI::App* dataset = add_dataset_subcommand(app, generate_args);
  HmiToolArgs hmi_args;
  CLI::App* hmi = add_hmi_subcommand(app, hmi_args);

  CLI11_PARSE(app, argc, argv);
  try {
    setup_logging(log_options);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "linectl: %s\n", error.what());
    return 1;
  }
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    if (run->parsed()) return run_command(run_args);
    if (record->parsed()) return record_command(record_args);
    if (replay->parsed()) return replay_command(replay_args);
    if (twin_serve->parsed()) return twin_serve_command(twin_args);
    if (control->parsed()) return control_command(control_args);
    if (compare->parsed()) return compare_command(compare_args);
    if (diagnose->parsed()) return diagnose_command(diagnose_args);
    if (dataset->parsed()) return generate_command(generate_args);
    if (hmi->parsed()) return hmi_command(hmi_args);
    if (check->parsed()) {
      const std::filesystem::path line_file =
          check_path.empty() ? default_config("line.yaml") : std::filesystem::path(check_path);
      fl::load_line_config(line_file);
      spdlog::info("{}: valid", line_file.string());
      if (!check_plant.empty()) {
        check_plant_config(check_plant, check_plant_config_path);
        spdlog::info("{} plant configuration: valid", check_plant);
      }
      return 0;
    }
  } catch (const fl::ConfigError& error) {
    spdlog::error("invalid configuration, nothing started:\n{}", error.what());
    return 2;
  } catch (const std::exception& error) {
    spdlog::error("{}", error.what());
    return 1;
  }
  return 0;
}
