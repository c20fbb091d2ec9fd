// linectl's operator HMI: the web server beside `linectl run --realtime --hmi FILE`, and
// `linectl hmi hash-password` for the operator password in that file (docs/hmi.md).
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "fl/controller/line_config.hpp"
#include "fl/controller/line_status.hpp"
#include "fl/controller/runtime.hpp"
#include "plant_io.hpp"

namespace fl::hmi {
class HmiServer;
}

namespace fl::apps {

// The HMI server of one real-time run. Construct it after the logic and the plant I/O and
// before the runtime, so that it outlives the scans that publish to it and dies before what
// its commands call.
class HmiRun {
 public:
  // Loads the config (ConfigError on problems), attaches the status publisher to the logic and
  // starts the server (std::runtime_error if it cannot bind).
  HmiRun(const std::string& config_path, const LineConfig& line, LineControllerLogic& logic,
         PlantIo& io);
  ~HmiRun();
  HmiRun(const HmiRun&) = delete;
  HmiRun& operator=(const HmiRun&) = delete;

 private:
  LineStatusPublisher publisher_;
  std::unique_ptr<hmi::HmiServer> server_;
};

// nullptr when no --hmi file was given.
std::unique_ptr<HmiRun> start_hmi(const std::string& config_path, const LineConfig& line,
                                  LineControllerLogic& logic, PlantIo& io);

struct HmiToolArgs {
  std::uint32_t iterations = 600'000;
};
CLI::App* add_hmi_subcommand(CLI::App& app, HmiToolArgs& args);
int hmi_command(const HmiToolArgs& args);

}  // namespace fl::apps
