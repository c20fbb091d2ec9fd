// What linectl's subcommands share: where the default configuration files are, how a plant is
// made from its name, and the ledger CSV every command that runs the controller writes.
#pragma once

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "fl/controller/ledger.hpp"
#include "fl/controller/line_config.hpp"
#include "fl/controller/plant.hpp"

namespace fl::apps {

// Default configuration files: beside the sources in a build tree, else ./config.
std::filesystem::path default_config(const char* file);

// "fast" or "dem"; an empty plant_config takes the plant's default file. Throws
// std::runtime_error for an unknown name and ConfigError for a bad file.
std::unique_ptr<Plant> make_plant(const std::string& name, const std::string& plant_config,
                                  const LineConfig& line);

// One CSV row per closed ledger record; does nothing when the path is empty. The constructor
// throws std::runtime_error naming a file it cannot open.
class LedgerWriter {
 public:
  explicit LedgerWriter(const std::string& path);
  void write(const FilletRecord& record);

 private:
  std::ofstream file_;
};

}  // namespace fl::apps
