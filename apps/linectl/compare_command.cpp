#include "compare_command.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <ctime>

#include "cli_support.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/workbench/history.hpp"
#include "fl/workbench/report.hpp"
#include "fl/workbench/twin_models.hpp"

namespace fl::apps {
namespace {

namespace fs = std::filesystem;
using namespace fl::workbench;

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

}  // namespace

CLI::App* add_compare_subcommand(CLI::App& app, CompareArgs& args) {
  CLI::App* command = app.add_subcommand("compare", "compare the DEM twin with a measured dataset");
  command->add_option("dataset", args.dataset, "dataset folder (docs/measurements.md)")->required();
  command->add_option("--out", args.out, "report folder (default compare_<dataset>)");
  command->add_option("--dem-config", args.dem_config, "DEM model (default config/dem.yaml)");
  command->add_option("--radius-mm", args.radius_mm, "sub-particle radius of the twin")
      ->check(CLI::Range(3.0, 7.0));
  command->add_option("--threads", args.threads, "engine threads per twin run")
      ->check(CLI::Range(1, 64));
  return command;
}

int compare_command(const CompareArgs& args) {
  Dataset dataset;
  try {
    dataset = load_dataset(args.dataset);
  } catch (const DatasetError& error) {
    spdlog::error("{}", error.what());
    return 2;
  }
  const fs::path dem_config =
      args.dem_config.empty() ? default_config("dem.yaml") : fs::path(args.dem_config);
  model_tests::CommonParams common;
  common.base_spec = dem::load_model_spec(dem_config);
  common.sub_particle_radius_m = args.radius_mm * 1e-3;
  common.thread_count = args.threads;
  std::unique_ptr<TrialModel> model;
  switch (dataset.experiment) {
    case ExperimentType::kCompress:
      model = std::make_unique<TwinCompressModel>(common);
      break;
    default:
      spdlog::error("{}: the twin does not reproduce {} datasets yet (compress only)", args.dataset,
                    to_string(dataset.experiment));
      return 2;
  }
  spdlog::info("comparing {} ({} trials, {}) with: {}", dataset.name, dataset.trials.size(),
               to_string(dataset.experiment), model->describe());
  const CompareReport report = compare(dataset, *model);
  const fs::path out = args.out.empty()
                           ? fs::path("compare_" + fs::path(args.dataset).filename().string())
                           : fs::path(args.out);
  write_report(report, out);
  append_history(out / "history.csv", report, utc_now());
  const std::vector<HistoryEntry> history = read_history(out / "history.csv");
  plot_history(history, out / "history.svg");
  for (std::size_t k = 0; k < std::min<std::size_t>(report.cells.size(), 5); ++k) {
    const ErrorCell& cell = report.cells[k];
    spdlog::info("  {:<8} {:<28} rms {:.4g} (score {:.3g})", cell.channel, cell.group, cell.rmse_si,
                 cell.score);
  }
  spdlog::info("report: {}", (out / "report.html").string());
  return 0;
}

}  // namespace fl::apps
