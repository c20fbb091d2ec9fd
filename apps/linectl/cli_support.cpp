#include "cli_support.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "duration.hpp"
#include "fl/twin/dem_plant/dem_plant.hpp"
#include "fl/twin/fast_plant.hpp"
#include "fl/twin/fast_plant_config.hpp"

namespace fl::apps {

std::vector<std::filesystem::path> config_search_dirs() {
  std::vector<std::filesystem::path> dirs;
  if (const char* override_dir = std::getenv("FL_CONFIG_DIR");
      override_dir != nullptr && *override_dir != '\0') {
    dirs.emplace_back(override_dir);
  }
  dirs.emplace_back(FL_INSTALLED_CONFIG_DIR);
  dirs.emplace_back(std::filesystem::path(FL_SOURCE_DIR) / "config");
  return dirs;
}

std::filesystem::path default_config(const char* file) {
  const std::vector<std::filesystem::path> dirs = config_search_dirs();
  for (const std::filesystem::path& dir : dirs) {
    std::error_code ignored;  // an unreadable folder is as good as a missing one here
    if (std::filesystem::is_regular_file(dir / file, ignored)) return dir / file;
  }
  std::string searched;
  for (const std::filesystem::path& dir : dirs) {
    searched += searched.empty() ? "" : ", ";
    searched += dir.string();
  }
  throw std::runtime_error(std::string("default configuration file ") + file +
                           " not found; searched (in order): " + searched +
                           ". Set FL_CONFIG_DIR or name the file on the command line.");
}

std::filesystem::path config_or_default(const std::string& given, const char* default_file) {
  return given.empty() ? default_config(default_file) : std::filesystem::path(given);
}

std::string read_text(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw std::runtime_error(file.string() + ": cannot open for reading");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::optional<RunTimes> parse_run_times(const std::string& duration, const std::string& wait,
                                        const std::string& drain, bool allow_forever) {
  const auto duration_s = allow_forever && duration == "forever"
                              ? std::optional<double>(std::numeric_limits<double>::infinity())
                              : parse_duration_s(duration);
  const auto wait_s = parse_duration_s(wait);
  const auto drain_s = parse_duration_s(drain);
  if (!duration_s || !wait_s || !drain_s) {
    spdlog::error(
        "--duration {}, --wait {}, --drain {}: each must be a positive duration "
        "(examples: 90s, 10m{})",
        duration, wait, drain, allow_forever ? "; --duration also forever" : "");
    return std::nullopt;
  }
  return RunTimes{*duration_s, *wait_s, *drain_s};
}

std::unique_ptr<Plant> make_plant(const std::string& name, const std::string& plant_config,
                                  const LineConfig& line, const std::string& infeed) {
  if (!infeed.empty() && name != "dem") {
    throw std::runtime_error("--infeed " + infeed + ": only the dem plant has a choice of infeed");
  }
  if (name == "fast") {
    return std::make_unique<FastPlant>(
        line, load_fast_plant_config(config_or_default(plant_config, "plant_fast.yaml")));
  }
  if (name == "dem") {
    DemPlantConfig config =
        load_dem_plant_config(config_or_default(plant_config, "plant_dem.yaml"));
    if (infeed == "levelled_layer") config.feeder.source = DemInfeedSource::kLevelledLayer;
    if (infeed == "dem_bulk_end") config.feeder.source = DemInfeedSource::kDemBulkEnd;
    if (!infeed.empty() && infeed != "levelled_layer" && infeed != "dem_bulk_end") {
      throw std::runtime_error("--infeed " + infeed +
                               ": unknown infeed (choose levelled_layer or dem_bulk_end)");
    }
    return std::make_unique<DemPlant>(line, config);
  }
  throw std::runtime_error("--plant " + name + ": unknown plant (choose fast or dem)");
}

void check_plant_config(const std::string& name, const std::string& plant_config) {
  if (name == "fast") {
    load_fast_plant_config(config_or_default(plant_config, "plant_fast.yaml"));
    return;
  }
  if (name == "dem") {
    load_dem_plant_config(config_or_default(plant_config, "plant_dem.yaml"));
    return;
  }
  throw std::runtime_error("--plant " + name + ": unknown plant (choose fast or dem)");
}

LedgerWriter::LedgerWriter(const std::string& path) {
  if (path.empty()) return;
  file_.open(path);
  if (!file_) throw std::runtime_error("--ledger " + path + ": cannot open for writing");
  file_ << "id,created_s,closed_s,outcome,lost_reason,hand,side_seen,singulated,flip_plate1,"
           "flip_plate2,multilane_unit,angle_at_camera1_deg,final_angle_deg,final_y_mm\n";
}

void LedgerWriter::write(const FilletRecord& r) {
  if (!file_.is_open()) return;
  constexpr double kDeg = 180.0 / std::numbers::pi;
  file_ << r.id << ',' << static_cast<double>(r.created_ns) / 1e9 << ','
        << static_cast<double>(r.closed_ns) / 1e9 << ',' << to_string(r.outcome) << ','
        << to_string(r.lost_reason) << ',' << static_cast<int>(r.hand) << ','
        << static_cast<int>(r.side_seen) << ',' << r.singulated << ',' << r.flip_plate1 << ','
        << r.flip_plate2 << ',' << static_cast<int>(r.multilane_unit) << ','
        << r.angle_at_camera1_rad * kDeg << ',' << r.final_angle_rad * kDeg << ',' << r.final_y_mm
        << '\n';
}

void LedgerWriter::flush() {
  if (file_.is_open()) file_.flush();
}

nlohmann::json summary_json(const DistributionSummary& summary) {
  return {{"count", summary.count},
          {"p50", static_cast<double>(summary.p50_ns) / 1e3},
          {"p99", static_cast<double>(summary.p99_ns) / 1e3},
          {"max", static_cast<double>(summary.max_ns) / 1e3}};
}

bool write_json_option(const std::string& path, const nlohmann::json& json) {
  std::ofstream file(path);
  file << json.dump(2) << '\n';
  file.close();  // a failed flush at close is a failed write too
  if (!file) {
    spdlog::error("--json {}: cannot write it", path);
    return false;
  }
  return true;
}

RuntimeOptions watchdog_runtime_options(const LineConfig& line) {
  RuntimeOptions options;
  options.period_ns = std::llround(static_cast<double>(line.watchdog.cycle_period_s) * 1e9);
  options.overrun_fault_consecutive =
      static_cast<std::uint32_t>(std::max(line.watchdog.overrun_fault_cycles, 0));
  options.watchdog_periods =
      static_cast<std::uint32_t>(std::max(line.watchdog.stall_fault_cycles, 0));
  return options;
}

void add_cpu_dma_latency_option(CLI::App& command, int& latency_us) {
  command
      .add_option("--cpu-dma-latency", latency_us,
                  "hold /dev/cpu_dma_latency at this many us while the scan runs (0: idle CPUs "
                  "stay out of deep sleep states; -1: leave it alone); needs write access to it")
      ->check(CLI::Range(-1, 100000));
}

void sleep_until_ns(std::int64_t time_ns, const std::atomic<bool>& interrupted) {
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(time_ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(time_ns % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    if (interrupted.load()) return;
  }
}

bool wait_until(const std::function<bool()>& ready, double wait_s,
                const std::function<bool()>& interrupted, std::chrono::milliseconds poll) {
  const auto start = std::chrono::steady_clock::now();
  while (!ready()) {
    const double waited_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (waited_s > wait_s || interrupted()) return false;
    std::this_thread::sleep_for(poll);
  }
  return true;
}

}  // namespace fl::apps
