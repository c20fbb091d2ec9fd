// What linectl's subcommands share: where the default configuration files are, how a plant is
// made from its name, and the ledger CSV every command that runs the controller writes.
#pragma once

#include <CLI/CLI.hpp>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fl/controller/cycle_stats.hpp"
#include "fl/controller/ledger.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/plant.hpp"
#include "fl/controller/process_image.hpp"
#include "fl/controller/runtime.hpp"

namespace fl::apps {

// Folders searched for default configuration files, in order: $FL_CONFIG_DIR when set, the
// installed configuration folder (/etc/fillet-line for a /usr install), then the source
// tree's config/ (so a build tree and the tests run without installing).
std::vector<std::filesystem::path> config_search_dirs();

// The first of config_search_dirs() that holds file. Throws std::runtime_error naming the
// file and every folder searched when none does.
std::filesystem::path default_config(const char* file);

// The file named on the command line, or default_config(default_file) when none is.
std::filesystem::path config_or_default(const std::string& given, const char* default_file);

// A whole text file (a configuration to attach to a recording). Throws std::runtime_error
// naming the file when it cannot be opened.
std::string read_text(const std::filesystem::path& file);

// --duration, --wait and --drain of a command that waits for a peer, runs and drains.
struct RunTimes {
  double duration_s = 0.0;
  double wait_s = 0.0;
  double drain_s = 0.0;
};

// Logs which options must be positive durations and returns nullopt when one is not.
// With allow_forever, --duration forever gives an infinite feeding time (a service that runs
// until it is stopped).
std::optional<RunTimes> parse_run_times(const std::string& duration, const std::string& wait,
                                        const std::string& drain, bool allow_forever = false);

// "fast" or "dem"; an empty plant_config takes the plant's default file. `infeed` (dem only;
// empty: the file's feeder.source) is levelled_layer or dem_bulk_end. Throws
// std::runtime_error for an unknown name or an infeed for the fast plant, and ConfigError for
// a bad file.
std::unique_ptr<Plant> make_plant(const std::string& name, const std::string& plant_config,
                                  const LineConfig& line, const std::string& infeed = {});

// Reads the plant's configuration file (the default one when plant_config is empty) without
// building the plant; the same errors as make_plant.
void check_plant_config(const std::string& name, const std::string& plant_config);

// One CSV row per closed ledger record; does nothing when the path is empty. The constructor
// throws std::runtime_error naming a file it cannot open.
class LedgerWriter {
 public:
  explicit LedgerWriter(const std::string& path);
  void write(const FilletRecord& record);
  // Pushes buffered rows to the file, so a stopped or killed service leaves them on disk.
  void flush();

 private:
  std::ofstream file_;
};

// A latency distribution for the JSON reports: count, and p50, p99 and max in microseconds.
nlohmann::json summary_json(const DistributionSummary& summary);

// --json FILE: writes `json` indented; logs and returns false when the file cannot be written.
bool write_json_option(const std::string& path, const nlohmann::json& json);

// The scan runtime's period and overrun fault from the line's watchdog (line.yaml): the same
// period the logic judges overruns by and the CAN master's SYNC runs at, and the same count of
// overruns in a row that faults the line. Scheduling options are the caller's.
RuntimeOptions watchdog_runtime_options(const LineConfig& line);

// --cpu-dma-latency US: the PM QoS request the scan's commands share (-1, the default, off).
void add_cpu_dma_latency_option(CLI::App& command, int& latency_us);

// Sleeps until time_ns on CLOCK_MONOTONIC (absolute), waking early only when a signal
// handler has set `interrupted`.
void sleep_until_ns(std::int64_t time_ns, const std::atomic<bool>& interrupted);

// Polls `ready` every `poll` until it holds (true), `wait_s` has passed or `interrupted`
// holds (false): how the two-process commands and the camera node wait for their peer.
bool wait_until(const std::function<bool()>& ready, double wait_s,
                const std::function<bool()>& interrupted, std::chrono::milliseconds poll);

}  // namespace fl::apps
