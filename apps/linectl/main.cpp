// linectl: the line controller's command-line tool.
//   linectl run --plant fast --duration 10m --seed 1 [--json kpis.json] [--ledger ledger.csv]
//   linectl run --realtime ...      the same loop on the 10 ms real-time schedule
//   linectl run --realtime --duration forever   as the service runs: until SIGTERM or SIGINT
//   linectl vision eval REC...      the estimator's accuracy against the twin's ground truth
//   linectl soak [--duration 1h]    a long real-time run judged by memory, deadlines, losses
//   linectl config check [FILE]     validate a line configuration (and --plant's, --can's)
//   linectl record / replay         camera recordings and their regression replay
//   (record_replay.hpp)
//   linectl twin serve / control    the twin and the controller as two processes over DDS
//   (two_process.hpp)
//   linectl camera serve            the estimator as a camera node on DDS
//   (camera_node_command.hpp)
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "camera_node_command.hpp"
#include "cli_support.hpp"
#include "compare_command.hpp"
#include "control_recording.hpp"
#include "dataset_from_recording.hpp"
#include "dem_output.hpp"
#include "duration.hpp"
#include "fl/apps/closed_loop.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/line_controller.hpp"
#include "fl/controller/runtime.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/drivers/can_config.hpp"
#include "fl/drivers/line_devices.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"
#include "hmi_support.hpp"
#include "logging.hpp"
#include "plant_io.hpp"
#include "realtime_run.hpp"
#include "record_replay.hpp"
#include "soak_command.hpp"
#include "two_process.hpp"
#include "vision_eval_command.hpp"

namespace fl::apps {
namespace {

struct RunArgs {
  std::string plant = "fast";
  std::string duration = "60s";
  std::uint64_t seed = 1;
  std::string config;        // empty: line.yaml from the configuration search path
  std::string plant_config;  // empty: the plant's own file from the search path
  std::string infeed;        // --plant dem: levelled_layer or dem_bulk_end (empty: the file's)
  std::string json_path;
  std::string ledger_path;
  bool realtime = false;
  int fifo_priority = 0;
  bool lock_memory = false;
  int cpu_dma_latency_us = -1;
  bool quiet = false;
  std::string vtk_directory;  // --plant dem: ParaView series
  std::string video_file;     // --plant dem: top and side view video
  double frame_every_s = 0.04;
  std::string hmi_config;         // --realtime: serve the operator HMI with this config
  std::string fieldbus = "none";  // canopen: the plant behind the line's CANopen network
  std::string can_config;         // default can.yaml from the configuration search path
};

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
  if (!args.infeed.empty() && args.plant != "dem") {
    spdlog::error("--infeed {} needs --plant dem (the fast plant has one infeed model)",
                  args.infeed);
    return 2;
  }
  if (!std::isfinite(*duration_s) && !args.realtime) {
    spdlog::error("--duration forever needs --realtime (a lock-step run would never end)");
    return 2;
  }
  const std::filesystem::path config =
      args.config.empty() ? default_config("line.yaml") : std::filesystem::path(args.config);
  const LineConfig line = load_line_config(config);
  std::unique_ptr<Plant> inner_plant = make_plant(args.plant, args.plant_config, line, args.infeed);
  // --fieldbus canopen: every drive and I/O signal through the CANopen master and the
  // plant-backed emulated devices on an in-process bus (fl/drivers/line_devices.hpp).
  std::unique_ptr<fl::drivers::CanopenPlant> canopen_plant;
  Plant* plant = inner_plant.get();
  if (args.fieldbus == "canopen") {
    const std::filesystem::path can_file = config_or_default(args.can_config, "can.yaml");
    canopen_plant = std::make_unique<fl::drivers::CanopenPlant>(
        *inner_plant, fl::drivers::load_can_config(can_file, line));
    plant = canopen_plant.get();
    spdlog::info("drives and I/O over CANopen ({}), on an in-process bus", can_file.string());
  }
  spdlog::info("closed loop against the {} plant, feeding {}, seed {}, config {}", plant->name(),
               std::isfinite(*duration_s) ? fmt::format("for {} s", *duration_s) : "until stopped",
               args.seed, config.string());
  Progress progress(args.quiet);
  LedgerWriter ledger(args.ledger_path);
  Kpis kpis;
  RuntimeFault runtime_fault = RuntimeFault::kNone;
  if (args.realtime) {
    RealtimeRunOptions options;
    options.duration_s = *duration_s;
    options.seed = args.seed;
    options.fifo_priority = args.fifo_priority;
    options.lock_memory = args.lock_memory;
    options.cpu_dma_latency_us = args.cpu_dma_latency_us;
    options.hmi_config = args.hmi_config;
    options.fault_switches = inner_plant.get();
    const RealtimeRunResult result = run_realtime(options, line, *plant, progress, ledger);
    kpis = result.kpis;
    runtime_fault = result.fault;
  } else {
    RunOptions options;
    options.duration_s = *duration_s;
    options.seed = args.seed;
    options.progress = [&](double done, double total) { progress(done, total); };
    options.on_event = log_event;
    options.on_record = [&](const FilletRecord& record) { ledger.write(record); };
    std::unique_ptr<DemRunOutput> output;
    if (!args.vtk_directory.empty() || !args.video_file.empty()) {
      const auto* dem = dynamic_cast<const DemPlant*>(inner_plant.get());
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
    if (!write_json_option(args.json_path, to_json(kpis))) return 1;
    spdlog::info("KPIs written to {}", args.json_path);
  }
  // A scan runtime that faulted (a stalled scan, overruns in a row) stopped the line in its
  // safe state: a failed run, so that the service's Restart=on-failure brings it back.
  if (runtime_fault != RuntimeFault::kNone) {
    spdlog::error("the scan runtime faulted ({}): exit 4", to_string(runtime_fault));
    return 4;
  }
  // A run whose books do not balance is a failed run, whatever the throughput.
  return kpis.ledger_balanced && kpis.truth_balanced ? 0 : 3;
}

}  // namespace
}  // namespace fl::apps

static int checked_main(int argc, char** argv) {
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
  run->add_option("--infeed", run_args.infeed,
                  "--plant dem: what feeds the takt belt, levelled_layer (plant_fast.yaml's "
                  "model) or dem_bulk_end (hopper, bulk belt and leveller as DEM; about half "
                  "real time); default: plant_dem.yaml's feeder.source")
      ->check(CLI::IsMember({"levelled_layer", "dem_bulk_end"}));
  run->add_option("--json", run_args.json_path, "write the KPIs as JSON to this file");
  run->add_option("--ledger", run_args.ledger_path, "write every ledger record as CSV");
  run->add_flag("--realtime", run_args.realtime, "run on the 10 ms real-time schedule");
  run->add_option("--fifo", run_args.fifo_priority, "SCHED_FIFO priority for --realtime (1-99)")
      ->check(CLI::Range(0, 99));
  run->add_flag("--mlock", run_args.lock_memory, "lock memory for --realtime (mlockall)");
  add_cpu_dma_latency_option(*run, run_args.cpu_dma_latency_us);
  run->add_flag("--quiet", run_args.quiet, "no progress display");
  run->add_option("--vtk", run_args.vtk_directory,
                  "--plant dem: write a ParaView series (particles, walls) to this folder");
  run->add_option("--video", run_args.video_file,
                  "--plant dem: write a top and side view video (.mkv lossless, .avi MJPG)");
  run->add_option("--frame-every", run_args.frame_every_s,
                  "seconds of line time between --vtk/--video frames")
      ->check(CLI::Range(1e-3, 10.0));
  run->add_option("--fieldbus", run_args.fieldbus,
                  "none, or canopen: drives and I/O through the CANopen master and the "
                  "plant-backed emulated devices")
      ->check(CLI::IsMember({"none", "canopen"}));
  run->add_option("--can-config", run_args.can_config,
                  "--fieldbus canopen: the bus configuration (default can.yaml)");
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
  bool check_can = false;
  std::string check_can_config;
  check->add_flag("--can", check_can,
                  "also validate the CANopen bus configuration (can.yaml from the search path)");
  check->add_option("--can-config", check_can_config,
                    "also validate this CANopen bus configuration (implies --can)");
  config->require_subcommand(1);

  RecordArgs record_args;
  CLI::App* record = add_record_subcommand(app, record_args);
  ReplayArgs replay_args;
  CLI::App* replay = add_replay_subcommand(app, replay_args);
  TwinServeArgs twin_args;
  CLI::App* twin_serve = add_twin_subcommand(app, twin_args);
  ControlArgs control_args;
  control_args.record_factory = control_recorder_factory();
  CLI::App* control = add_control_subcommand(app, control_args);
  CameraServeArgs camera_args;
  CLI::App* camera_serve = add_camera_subcommand(app, camera_args);
  CompareArgs compare_args;
  CLI::App* compare = add_compare_subcommand(app, compare_args);
  CompareArgs diagnose_args;
  CLI::App* diagnose = add_diagnose_subcommand(app, diagnose_args);
  CalibrateArgs calibrate_args;
  CLI::App* calibrate = add_calibrate_subcommand(app, calibrate_args);
  GenerateArgs generate_args;
  CLI::App* dataset = add_dataset_subcommand(app, generate_args);
  FromRecordingArgs from_recording_args;
  CLI::App* from_recording = add_from_recording_subcommand(*dataset, from_recording_args);
  VisionEvalArgs vision_eval_args;
  CLI::App* vision_eval = add_vision_subcommand(app, vision_eval_args);
  SoakArgs soak_args;
  CLI::App* soak = add_soak_subcommand(app, soak_args);
  HmiToolArgs hmi_args;
  CLI::App* hmi = add_hmi_subcommand(app, hmi_args);

  CLI11_PARSE(app, argc, argv);
  try {
    setup_logging(log_options);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "linectl: %s\n", error.what());
    return 1;
  }
  install_stop_signal_handlers();
  try {
    if (run->parsed()) return run_command(run_args);
    if (record->parsed()) return record_command(record_args);
    if (replay->parsed()) return replay_command(replay_args);
    if (twin_serve->parsed()) return twin_serve_command(twin_args);
    if (control->parsed()) return control_command(control_args);
    if (camera_serve->parsed()) return camera_serve_command(camera_args);
    if (compare->parsed()) return compare_command(compare_args);
    if (diagnose->parsed()) return diagnose_command(diagnose_args);
    if (calibrate->parsed()) return calibrate_command(calibrate_args);
    if (from_recording->parsed()) return from_recording_command(from_recording_args);
    if (dataset->parsed()) return generate_command(generate_args);
    if (hmi->parsed()) return hmi_command(hmi_args);
    if (soak->parsed()) return soak_command(soak_args);
    if (vision_eval->parsed()) return vision_eval_command(vision_eval_args);
    if (check->parsed()) {
      const std::filesystem::path line_file =
          check_path.empty() ? default_config("line.yaml") : std::filesystem::path(check_path);
      fl::load_line_config(line_file);
      spdlog::info("{}: valid", line_file.string());
      if (!check_plant.empty()) {
        check_plant_config(check_plant, check_plant_config_path);
        spdlog::info("{} plant configuration: valid", check_plant);
      }
      if (check_can || !check_can_config.empty()) {
        const std::filesystem::path can_file = config_or_default(check_can_config, "can.yaml");
        fl::drivers::load_can_config(can_file, fl::load_line_config(line_file));
        spdlog::info("{}: valid", can_file.string());
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

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "linectl: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "linectl: unknown error\n");
  }
  return 1;
}
