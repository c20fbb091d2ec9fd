#include "hmi_support.hpp"

#include <spdlog/spdlog.h>
#include <termios.h>
#include <unistd.h>

#include <iostream>
#include <stdexcept>

#include "fl/hmi/auth.hpp"
#include "fl/hmi/hmi_config.hpp"
#include "fl/hmi/server.hpp"
#include "fl/hmi/status_json.hpp"

namespace fl::apps {
namespace {

// The HMI's twin panel names faults and targets; PlantIo takes them as indices.
std::string raise_twin_fault(PlantIo& io, std::string_view fault, std::string_view target,
                             bool active) {
  try {
    if (fault == "camera_silent") {
      const auto camera = parse<CameraId>(target);
      if (!camera) return "unknown camera '" + std::string(target) + "'";
      io.set_twin_fault(TwinFault::kCameraSilent, index(*camera), active);
    } else if (fault == "drive_lost") {
      const auto drive = parse<DriveId>(target);
      if (!drive) return "unknown drive '" + std::string(target) + "'";
      io.set_twin_fault(TwinFault::kDriveLost, index(*drive), active);
    } else if (fault == "estop") {
      io.set_twin_fault(TwinFault::kEstopOpen, 0, active);
    } else if (fault == "leveller_overload") {
      io.set_twin_fault(TwinFault::kLevellerOverload, 0, active);
    } else {
      return "unknown twin fault '" + std::string(fault) +
             "' (camera_silent, drive_lost, estop, leveller_overload)";
    }
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return {};
}

// One line from the terminal without echo, or from a pipe as it comes.
std::string read_secret(const char* prompt) {
  const bool tty = isatty(STDIN_FILENO) != 0;
  termios saved{};
  if (tty) {
    std::cerr << prompt << std::flush;
    tcgetattr(STDIN_FILENO, &saved);
    termios quiet = saved;
    quiet.c_lflag &= ~static_cast<tcflag_t>(ECHO);
    tcsetattr(STDIN_FILENO, TCSANOW, &quiet);
  }
  std::string line;
  std::getline(std::cin, line);
  if (tty) {
    tcsetattr(STDIN_FILENO, TCSANOW, &saved);
    std::cerr << '\n';
  }
  return line;
}

}  // namespace

HmiRun::HmiRun(const std::string& config_path, const LineConfig& line, LineControllerLogic& logic,
               PlantIo& io) {
  const hmi::HmiConfig config = hmi::load_hmi_config(config_path);
  hmi::HmiCommands commands;
  commands.start_line = [&logic] { logic.request_start(); };
  commands.stop_line = [&logic] { logic.request_stop(); };
  commands.acknowledge_faults = [&logic] { logic.acknowledge_faults(); };
  commands.twin_fault = [&io](std::string_view fault, std::string_view target, bool active) {
    return raise_twin_fault(io, fault, target, active);
  };
  server_ = std::make_unique<hmi::HmiServer>(config, publisher_.buffer(), hmi::layout_to_json(line),
                                             std::move(commands));
  logic.attach_status(&publisher_);
  server_->start();
}

HmiRun::~HmiRun() { server_->stop(); }

std::unique_ptr<HmiRun> start_hmi(const std::string& config_path, const LineConfig& line,
                                  LineControllerLogic& logic, PlantIo& io) {
  if (config_path.empty()) return nullptr;
  return std::make_unique<HmiRun>(config_path, line, logic, io);
}

CLI::App* add_hmi_subcommand(CLI::App& app, HmiToolArgs& args) {
  CLI::App* hmi = app.add_subcommand("hmi", "operator HMI tools");
  CLI::App* hash = hmi->add_subcommand(
      "hash-password",
      "hash an operator password for the HMI config (reads it from the terminal or stdin)");
  hash->add_option("--iterations", args.iterations, "PBKDF2-SHA256 iterations")
      ->check(CLI::Range(hmi::kMinPbkdf2Iterations, 100'000'000U));
  hmi->require_subcommand(1);
  return hmi;
}

int hmi_command(const HmiToolArgs& args) {
  const std::string password = read_secret("operator password: ");
  if (isatty(STDIN_FILENO) != 0 && read_secret("again: ") != password) {
    spdlog::error("the two passwords differ; nothing written");
    return 2;
  }
  if (password.empty()) {
    spdlog::error("empty password: nothing written");
    return 2;
  }
  std::cout << hmi::hash_password(password, args.iterations) << '\n';
  std::cerr << "paste it as operator.password_hash into the HMI config (e.g. config/hmi.yaml)\n";
  return 0;
}

}  // namespace fl::apps
