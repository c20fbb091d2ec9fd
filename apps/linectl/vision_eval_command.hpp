// linectl vision eval (issue 4 item 5; docs/vision.md, "Accuracy on recordings"):
//   linectl vision eval RECORDING... [--out DIR] [--set NAME=VALUE] [--check]
// Runs the estimator over every frame of twin recordings that carry ground truth and prints
// the angle and position errors, the left/right and side-up confusion matrices and the
// singulation precision and recall, per camera and in all; writes eval.json and eval.html
// (tables and error plots) into --out. --check holds the figures to issue 4's targets.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

namespace fl::apps {

struct VisionEvalArgs {
  std::vector<std::string> recordings;
  std::string out_directory = "vision_eval";
  std::vector<std::string> estimator_settings;  // NAME=VALUE
  bool check = false;
};

CLI::App* add_vision_subcommand(CLI::App& app, VisionEvalArgs& args);
// 0 evaluated (and, with --check, every target met); 1 a target missed; 2 a recording is
// unusable or has no ground truth, or bad options.
int vision_eval_command(const VisionEvalArgs& args);

}  // namespace fl::apps
