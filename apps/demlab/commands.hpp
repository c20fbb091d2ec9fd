// demlab's commands: each runs one model test and writes <name>.csv, <name>.svg and
// <name>.md (headline numbers next to the thesis') into the output folder.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "fl/twin/model_tests/config.hpp"

namespace fl::demlab {

struct Context {
  model_tests::ModelTestsConfig config;
  std::filesystem::path out_dir;
  int threads = 1;
  std::string command_line;  // for the summaries: how the figures were made
};

// One headline per command, also written to <name>.md.
struct Summary {
  std::string name;
  std::vector<std::string> lines;
};

Summary run_settle(const Context& context);
Summary run_bend(const Context& context);
Summary run_slide(const Context& context);
Summary run_compress(const Context& context);
Summary run_impact(const Context& context);
Summary run_drop(const Context& context);
Summary run_scaling(const Context& context);
Summary run_doe(const Context& context);

}  // namespace fl::demlab
