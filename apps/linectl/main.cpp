// linectl: the line controller's command-line tool.
//   linectl run --plant fast --duration 10m --seed 1 [--json kpis.json] [--ledger ledger.csv]
//   linectl run --realtime ...      the same loop on the 10 ms real-time schedule
//   linectl config check FILE       validate a line configuration
//   linectl record / replay         camera recordings and their regression replay
//   (record_replay.hpp)
//   linectl twin serve / control    the twin and the controller as two processes over DDS
//   (two_process.hpp)
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
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
#include "plant_io.hpp"
#include "record_replay.hpp"
#include "two_process.hpp"

namespace fl::apps {
namespace {

std::atomic<bool> g_interrupted{false};
extern "C" void on_signal(int /*signal*/) { g_interrupted.store(true); }

struct RunArgs {
  std::string plant = "fast";
  std::string duration = "60s";
  std::uint64_t seed = 1;
  std::string config = default_config("line.yaml").string();
  std::string plant_config = default_config("plant_fast.yaml").string();
  std::string json_path;
  std::string ledger_path;
  bool realtime = false;
  int fifo_priority = 0;
  bool lock_memory = false;
  bool quiet = false;
  std::string vtk_directory;  // --plant dem: ParaView series
  std::string video_file;     // --plant dem: top and side view video
  double frame_every_s = 0.04;
};

std::unique_ptr<Plant> make_run_plant(const RunArgs& args, const LineConfig& line) {
  // --plant-config names the fast plant's file by default: the DEM plant reads its own.
  const bool default_file = args.plant_config == default_config("plant_fast.yaml");
  return make_plant(args.plant, default_file ? std::string() : args.plant_config, line);
}

// Progress on stderr: a redrawn line on a terminal, a log line every 10 % otherwise.
class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), tty_(isatty(STDERR_FILENO) != 0) {}
  void operator()(double done_s, double total_s) {
    if (quiet_ || total_s <= 0.0) return;
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
  };
  const auto wall_start = std::chrono::steady_clock::now();
  const RealtimeSetup setup = runtime.start();
  if (!setup.error.empty()) spdlog::warn("real-time setup: {}", setup.error);
  if (!setup.started) throw std::runtime_error("the scan runtime did not start: " + setup.error);
  bool stop_sent = false;
  double elapsed_s = 0.0;
  while (runtime.running()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    drain();
    elapsed_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
    progress(std::min(elapsed_s, duration_s), duration_s);
    if (!stop_sent && (elapsed_s >= duration_s || g_interrupted.load())) {
      io.request_line_stop();
      stop_sent = true;
    }
    // Drained after the stop, or a second interrupt: end the run.
    const bool drained =
        stop_sent && controller.state() == LineState::kStopped && io.fillets_on_line() == 0;
    if (drained || elapsed_s > duration_s + 60.0) runtime.request_stop();
  }
  runtime.wait();
  drain();
  controller.close_all_in_transit(io.last_scan_time_ns(), LostReason::kRunEnded);
  drain();
  Kpis kpis;
  kpis.plant = plant.name();
  kpis.seed = args.seed;
  kpis.compute = runtime.stats().summary().compute;
  collector.finish(controller, io.fillets_fed(), io.fillets_on_line(), duration_s, elapsed_s,
                   elapsed_s, kpis);
  const CycleStatsSummary stats = runtime.stats().summary();
  spdlog::info("real-time scans {}, overruns {}, wake-up latency p99.9 {:.1f} us max {:.1f} us",
               stats.scans, stats.overruns, static_cast<double>(stats.wakeup_latency.p999_ns) / 1e3,
               static_cast<double>(stats.wakeup_latency.max_ns) / 1e3);
  return kpis;
}

int run_command(const RunArgs& args) {
  const std::optional<double> duration_s = parse_duration_s(args.duration);
  if (!duration_s) {
    spdlog::error("--duration {}: not a positive duration (examples: 90s, 10m, 1h)", args.duration);
    return 2;
  }
  const LineConfig line = load_line_config(args.config);
  std::unique_ptr<Plant> plant = make_run_plant(args, line);
  spdlog::info("closed loop against the {} plant: {} s of feeding, seed {}, config {}",
               plant->name(), *duration_s, args.seed, args.config);
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
  spdlog::set_default_logger(spdlog::stderr_color_mt("linectl"));
  CLI::App app{"linectl: real-time line controller for the chicken-fillet line"};
  app.require_subcommand(1);
  app.fallthrough();  // global options may also follow the subcommand
  std::string log_level = "info";
  app.add_option("--log-level", log_level, "trace, debug, info, warn, error")
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error"}));

  RunArgs run_args;
  CLI::App* run = app.add_subcommand("run", "run the controller closed loop against a plant");
  run->add_option("--plant", run_args.plant, "fast (2D plant) or dem (DEM twin)")
      ->check(CLI::IsMember({"fast", "dem"}));
  run->add_option("--duration", run_args.duration, "feeding time, e.g. 90s, 10m, 1h");
  run->add_option("--seed", run_args.seed, "plant seed; the same seed gives the same run");
  run->add_option("--config", run_args.config, "line configuration (YAML)");
  run->add_option("--plant-config", run_args.plant_config, "fast plant configuration (YAML)");
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

  std::string check_path;
  CLI::App* config = app.add_subcommand("config", "configuration tools");
  CLI::App* check = config->add_subcommand("check", "validate a line configuration file");
  check->add_option("file", check_path, "line configuration (YAML)")->required();
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

  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(spdlog::level::from_str(log_level));
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
    if (check->parsed()) {
      fl::load_line_config(check_path);
      spdlog::info("{}: valid", check_path);
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
