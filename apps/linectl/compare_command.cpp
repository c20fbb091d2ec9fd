#include "compare_command.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <memory>
#include <optional>

#include "cli_support.hpp"
#include "fl/controller/config_loader.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/report/csv.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem_plant/dem_plant_config.hpp"
#include "fl/workbench/calibrate.hpp"
#include "fl/workbench/diagnose.hpp"
#include "fl/workbench/generator.hpp"
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

// The dataset and the base model both commands start from; nullopt (reported) when unusable.
struct WorkbenchInputs {
  Dataset dataset;
  model_tests::CommonParams common;
};

std::optional<WorkbenchInputs> load_inputs(const CompareArgs& args) {
  WorkbenchInputs inputs;
  try {
    inputs.dataset = load_dataset(args.dataset);
  } catch (const DatasetError& error) {
    spdlog::error("{}", error.what());
    return std::nullopt;
  }
  const fs::path dem_config =
      args.dem_config.empty() ? default_config("dem.yaml") : fs::path(args.dem_config);
  inputs.common.base_spec = dem::load_model_spec(dem_config);
  inputs.common.sub_particle_radius_m = args.radius_mm * 1e-3;
  inputs.common.thread_count = args.threads;
  return inputs;
}

fs::path out_folder(const CompareArgs& args, const char* prefix) {
  return args.out.empty()
             ? fs::path(std::string(prefix) + fs::path(args.dataset).filename().string())
             : fs::path(args.out);
}

void add_model_options(CLI::App& command, CompareArgs& args) {
  command.add_option("dataset", args.dataset, "dataset folder (docs/measurements.md)")->required();
  command.add_option("--out", args.out, "output folder");
  command.add_option("--dem-config", args.dem_config, "DEM model (default config/dem.yaml)");
  command.add_option("--line-config", args.line_config,
                     "line_tracks taken on the line: the line (default config/line.yaml)");
  command.add_option(
      "--plant-config", args.plant_config,
      "line_tracks taken on the line: the DEM plant (default config/plant_dem.yaml)");
  command.add_option("--radius-mm", args.radius_mm, "sub-particle radius of the twin")
      ->check(CLI::Range(3.0, 7.0));
  command.add_option("--threads", args.threads, "engine threads per twin run")
      ->check(CLI::Range(1, 64));
}

// compare and diagnose: the ensemble's size, for line-track and slide datasets.
void add_ensemble_option(CLI::App& command, CompareArgs& args) {
  command
      .add_option("--ensemble", args.ensemble,
                  "twin runs per trial: line_tracks from first poses jittered by the noise, "
                  "slide from placements turned within +-5 deg; the mean is compared and the "
                  "spread added to the noise")
      ->check(CLI::Range(1, 64));
}

// The line and the DEM plant that line tracks taken on the line replay on; false (reported) when
// a file is unusable.
bool load_line_run_configs(const std::string& line_file, const std::string& plant_file,
                           LineTracksSettings& settings) {
  const fs::path line = line_file.empty() ? default_config("line.yaml") : fs::path(line_file);
  const fs::path plant =
      plant_file.empty() ? default_config("plant_dem.yaml") : fs::path(plant_file);
  try {
    settings.line = std::make_shared<const LineConfig>(load_line_config(line));
    settings.plant = std::make_shared<const DemPlantConfig>(load_dem_plant_config(plant));
  } catch (const ConfigError& error) {
    spdlog::error("{}", error.what());
    return false;
  }
  return true;
}

// The twin settings of the arguments; nullopt (reported) for an ensemble of a dataset that is
// neither line tracks nor slide, or for unusable line or plant files.
std::optional<TwinSettings> twin_settings(const CompareArgs& args, const Dataset& dataset) {
  TwinSettings settings;
  const bool on_line =
      std::any_of(dataset.trials.begin(), dataset.trials.end(),
                  [](const Trial& trial) { return runs_on_line(trial.conditions); });
  if (on_line &&
      !load_line_run_configs(args.line_config, args.plant_config, settings.line_tracks)) {
    return std::nullopt;
  }
  if (args.ensemble > 1 && dataset.experiment != ExperimentType::kLineTracks &&
      dataset.experiment != ExperimentType::kSlide) {
    spdlog::error("{}: --ensemble runs line_tracks and slide datasets, and this one is {}",
                  args.dataset, to_string(dataset.experiment));
    return std::nullopt;
  }
  if (const std::string_view unknown = line_tracks_channel_without_noise(dataset);
      args.ensemble > 1 && dataset.experiment == ExperimentType::kLineTracks && !unknown.empty()) {
    spdlog::error(
        "{}: --ensemble jitters the first poses by the manifest's noise, and it gives none for "
        "'{}'",
        args.dataset, unknown);
    return std::nullopt;
  }
  settings.line_tracks.ensemble_runs = args.ensemble;
  settings.slide.ensemble_runs = args.ensemble;
  return settings;
}

}  // namespace

CLI::App* add_diagnose_subcommand(CLI::App& app, CompareArgs& args) {
  CLI::App* command = app.add_subcommand(
      "diagnose", "find which effect of the effect library the model lacks for a dataset");
  add_model_options(*command, args);
  add_ensemble_option(*command, args);
  return command;
}

CLI::App* add_dataset_subcommand(CLI::App& app, GenerateArgs& args) {
  CLI::App* dataset = app.add_subcommand("dataset", "measurement dataset tools");
  dataset->require_subcommand(1);
  CLI::App* generate = dataset->add_subcommand(
      "generate",
      "write a synthetic compress, slide, bend, drop or line_tracks dataset with a hidden effect");
  generate->add_option("--out", args.out, "dataset folder to write")->required();
  generate
      ->add_option("--experiment", args.experiment, "compress, slide, bend, drop or line_tracks")
      ->check(CLI::IsMember({"compress", "slide", "bend", "drop", "line_tracks"}));
  generate->add_option("--effect", args.effect, "random, none, or an effect law");
  generate->add_option("--seed", args.seed, "random seed (effect, parameters, noise)");
  generate->add_option("--force-noise-n", args.force_noise_n, "1-sigma force noise in N")
      ->check(CLI::Range(0.0, 10.0));
  generate
      ->add_option("--displacement-noise-um", args.displacement_noise_um,
                   "compress: 1-sigma noise on the logged displacement")
      ->check(CLI::Range(0.0, 100.0));
  generate->add_option("--row-ms", args.compress_row_ms, "compress: the logger's row interval")
      ->check(CLI::Range(0.01, 5.0));
  generate->add_option("--angle-noise-deg", args.angle_noise_deg, "slide: 1-sigma angle noise")
      ->check(CLI::Range(0.0, 10.0));
  generate->add_option("--height-noise-mm", args.height_noise_mm, "drop: 1-sigma height noise")
      ->check(CLI::Range(0.0, 10.0));
  generate->add_option("--bend-noise-deg", args.bend_angle_noise_deg, "bend: 1-sigma angle noise")
      ->check(CLI::Range(0.0, 10.0));
  generate
      ->add_option("--position-noise-mm", args.position_noise_mm,
                   "line_tracks: 1-sigma camera position noise")
      ->check(CLI::Range(0.0, 50.0));
  generate
      ->add_option("--tilt-rates", args.slide_tilt_rates_deg_per_s,
                   "slide: tilt rates in deg/s, each trial repeated at each (e.g. 5,20)")
      ->delimiter(',')
      ->check(CLI::Range(0.1, 90.0));
  generate->add_flag("--relaid", args.slide_relaid,
                     "slide: re-lay the fillet for each repetition, turned at random within the "
                     "placement tolerance (default: laid once, straight)");
  generate->add_option("--fillets", args.fillets_per_trial, "line_tracks: fillets per trial")
      ->check(CLI::Range(1, 100));
  generate
      ->add_option("--trials", args.trials,
                   "trials (0: the experiment's default; line_tracks: takts of 4 and 7 m/s^2 "
                   "in turn, each dry then wet)")
      ->check(CLI::Range(0, 64));
  generate->add_flag("--on-line", args.on_line,
                     "line_tracks: tracks taken on the line (machine: line), replayed on the DEM "
                     "plant of config/line.yaml and config/plant_dem.yaml");
  generate->add_flag("--truth-from-true-pose", args.truth_starts_at_true_pose,
                     "line_tracks: the truth starts at each fillet's true first pose, which the "
                     "camera sees with noise like any other row (as on a real line)");
  return dataset;
}

int generate_command(const GenerateArgs& args) {
  GeneratorOptions options;
  options.seed = args.seed;
  options.effect = args.effect;
  options.experiment = *experiment_from_string(args.experiment);  // checked by the option
  options.force_noise_n = args.force_noise_n;
  options.displacement_noise_um = args.displacement_noise_um;
  options.compress_row_s = args.compress_row_ms * 1e-3;
  options.angle_noise_deg = args.angle_noise_deg;
  options.height_noise_mm = args.height_noise_mm;
  options.bend_angle_noise_deg = args.bend_angle_noise_deg;
  options.position_noise_mm = args.position_noise_mm;
  options.fillets_per_trial = args.fillets_per_trial;
  options.truth_starts_at_true_pose = args.truth_starts_at_true_pose;
  options.trials = args.trials;
  options.slide_tilt_rates_deg_per_s = args.slide_tilt_rates_deg_per_s;
  options.slide_relaid = args.slide_relaid;
  options.common.base_spec = dem::load_model_spec(default_config("dem.yaml"));
  options.line_tracks_on_line = args.on_line;
  if (args.on_line) {
    LineTracksSettings line_run;
    if (!load_line_run_configs({}, {}, line_run)) return 2;
    options.line_tracks_line = line_run.line;
    options.line_tracks_plant = line_run.plant;
  }
  const GeneratedDataset made = generate_dataset(options);
  write_dataset(made.dataset, args.out);
  const std::string truth_file = fs::path(args.out).string() + ".truth.yaml";
  write_truth(made.truth, truth_file);
  spdlog::info("dataset written to {} ({} trials); the hidden truth is in {}", args.out,
               made.dataset.trials.size(), truth_file);
  return 0;
}

int diagnose_command(const CompareArgs& args) {
  const std::optional<WorkbenchInputs> inputs = load_inputs(args);
  if (!inputs) return 2;
  std::vector<EffectCandidate> candidates;
  try {
    candidates = candidates_for(inputs->dataset.experiment);
  } catch (const std::invalid_argument& error) {
    spdlog::error("{}: {}", args.dataset, error.what());
    return 2;
  }
  DiagnoseOptions options;
  const std::optional<TwinSettings> twin = twin_settings(args, inputs->dataset);
  if (!twin) return 2;
  options.twin = *twin;
  const Diagnosis diagnosis = diagnose(inputs->dataset, inputs->common, candidates, options);
  const fs::path out = out_folder(args, "diagnose_");
  fs::create_directories(out);
  std::ofstream(out / "diagnosis.json") << diagnosis_json(diagnosis) << "\n";
  spdlog::info("{:<18} {:>10} {:>12} {:>14}  fitted", "effect", "delta BIC", "RMS fall %",
               "held-out RMS");
  for (const CandidateResult& r : diagnosis.ranked) {
    std::string fitted;
    for (const auto& [key, value] : r.fitted) fitted += fmt::format("{} {:.4g}  ", key, value);
    spdlog::info("{:<18} {:>10.1f} {:>12.1f} {:>14.4g}  {}{}", r.law, r.delta_bic,
                 100.0 * r.improvement, r.held_out_rmse, fitted, r.proposed ? "<- proposed" : "");
  }
  if (!diagnosis.by_trial.empty()) {
    spdlog::info("where the error fell with {} (RMS, SI):", diagnosis.ranked.front().law);
    for (const Diagnosis::TrialError& t : diagnosis.by_trial) {
      spdlog::info("  {:<24} {:>12.4g} -> {:<12.4g}{}", t.trial, t.base_rmse, t.fitted_rmse,
                   t.trial == diagnosis.held_out_trial ? " (held out)" : "");
    }
  }
  spdlog::info("{}", diagnosis.verdict);
  const HiddenEffect effect = proposed_effect(diagnosis);
  fs::remove(out / "effect.yaml");  // a rerun that proposes nothing leaves none behind
  if (!effect.law.empty()) {
    // The whole law list or block as the fitted model has it, so it loads as pasted (a
    // static_kinetic_friction needs the kinetic coefficient it inherits from the coulomb).
    const bool contact_effect = inputs->dataset.experiment == ExperimentType::kSlide ||
                                inputs->dataset.experiment == ExperimentType::kLineTracks;
    std::string snippet;
    try {
      snippet = effect_config_snippet(inputs->common.base_spec, inputs->dataset.experiment, effect);
    } catch (const std::invalid_argument& error) {
      spdlog::error("{}: {}", args.dataset, error.what());
      return 2;
    }
    if (contact_effect) {
      spdlog::info(
          "to add it, make these the items of the contact_laws list of every fillet-equipment "
          "interaction of the DEM config (in config/dem.yaml the list anchored "
          "&fillet_equipment):\n{}",
          snippet);
    } else {
      spdlog::info("to add it, make this the bond_law of the DEM config:\n{}", snippet);
    }
    std::ofstream file(out / "effect.yaml");
    file << snippet;
    if (!file) {
      spdlog::error("{}: cannot write", (out / "effect.yaml").string());
      return 2;
    }
  }
  spdlog::info("diagnosis: {}", (out / "diagnosis.json").string());
  return 0;
}

CLI::App* add_calibrate_subcommand(CLI::App& app, CalibrateArgs& args) {
  CLI::App* command = app.add_subcommand(
      "calibrate", "fit base parameters of the DEM model to a dataset (design of experiments)");
  add_model_options(*command, args.model);
  command
      ->add_option("--param", args.params,
                   "ADDRESS=MIN:MAX[:log], ADDRESS bond.KEY, fillet_equipment.LAW.KEY or "
                   "fillet_fillet.LAW.KEY (repeat for each parameter)")
      ->required();
  command->add_option("--design", args.design, "hammersley or factorial")
      ->check(CLI::IsMember({"hammersley", "factorial"}));
  command->add_option("--points", args.points, "Hammersley points")->check(CLI::Range(1, 4096));
  command->add_option("--levels", args.levels, "factorial levels per parameter")
      ->check(CLI::Range(1, 64));
  command
      ->add_option("--local-evaluations", args.local_evaluations,
                   "twin evaluations of the local fit after the design (0: none)")
      ->check(CLI::Range(0, 10000));
  command
      ->add_option("--profile", args.profile_evaluations,
                   "trace each parameter's profile, the others re-fitted with at most this many "
                   "twin evaluations per step of a tenth of the box (0: no profile)")
      ->check(CLI::Range(0, 1000));
  return command;
}

int calibrate_command(const CalibrateArgs& args) {
  std::vector<CalibratedParameter> parameters;
  for (const std::string& text : args.params) {
    try {
      parameters.push_back(parse_calibrated_parameter(text));
    } catch (const std::invalid_argument& error) {
      spdlog::error("--param: {}", error.what());
      return 2;
    }
  }
  const std::optional<WorkbenchInputs> inputs = load_inputs(args.model);
  if (!inputs) return 2;
  CalibrationOptions options;
  options.design =
      args.design == "factorial" ? DesignKind::kFullFactorial : DesignKind::kHammersley;
  options.hammersley_points = args.points;
  options.factorial_levels = args.levels;
  options.max_local_evaluations = args.local_evaluations;
  options.profile_fit_evaluations = args.profile_evaluations;
  Calibration result;
  try {
    result = calibrate(inputs->dataset, inputs->common, parameters, options);
  } catch (const std::invalid_argument& error) {
    spdlog::error("{}", error.what());
    return 2;
  }
  const fs::path out = out_folder(args.model, "calibrate_");
  fs::create_directories(out);
  std::ofstream(out / "calibration.json") << calibration_json(result) << "\n";
  {
    std::vector<std::string> header;
    header.reserve(parameters.size());
    for (const CalibratedParameter& p : parameters) header.push_back(p.address);
    header.emplace_back("rmse_si");
    std::ofstream design(out / "design.csv");
    for (std::size_t k = 0; k < header.size(); ++k) design << (k ? "," : "") << header[k];
    design << ",failure\n";
    for (const DesignRun& run : result.design) {
      for (const double value : run.values) design << report::format_double(value) << ",";
      design << (run.failure.empty() ? report::format_double(run.rmse) : "") << ",\"" << run.failure
             << "\"\n";
    }
  }
  spdlog::info("calibrated {} ({}): RMS {:.4g} -> {:.4g} (SI), noise {:.4g}, {} twin evaluations",
               args.model.dataset, result.channel, result.base_rmse, result.rmse, result.noise_si,
               result.evaluations);
  std::string change;
  for (std::size_t p = 0; p < parameters.size(); ++p) {
    change += fmt::format("  {}: {:.6g} -> {:.6g}\n", parameters[p].address, result.base_values[p],
                          result.best[p]);
  }
  spdlog::info("to take it, set these in config/dem.yaml (every law the address names):\n{}",
               change);
  const auto rms_text = [](double rmse) {
    return std::isfinite(rmse) ? fmt::format("{:.4g}", rmse) : std::string("-");
  };
  std::string sensitivity;
  for (std::size_t p = 0; p < parameters.size(); ++p) {
    const ParameterSensitivity& s = result.sensitivity[p];
    const std::string interval =
        std::isfinite(s.interval_low) && std::isfinite(s.interval_high)
            ? fmt::format("95 % interval {:.4g} .. {:.4g}", s.interval_low, s.interval_high)
            : std::string("no interval: the moves do not bound it");
    const std::string joint =
        std::isfinite(s.joint_interval_low) && std::isfinite(s.joint_interval_high)
            ? fmt::format("joint {:.4g} .. {:.4g}", s.joint_interval_low, s.joint_interval_high)
            : std::string("no joint interval");
    const auto bound_text = [](double bound, bool open) {
      return open ? fmt::format("open at the box's {:.4g}", bound) : fmt::format("{:.4g}", bound);
    };
    const std::string profile =
        args.profile_evaluations == 0 ? std::string()
        : std::isfinite(s.profile_interval_low) && std::isfinite(s.profile_interval_high)
            ? fmt::format("; profile {} .. {}",
                          bound_text(s.profile_interval_low, s.profile_low_open),
                          bound_text(s.profile_interval_high, s.profile_high_open))
            : std::string("; no profile interval");
    sensitivity += fmt::format(
        "  {}: at {:.4g} down to {:.4g}: {}, up to {:.4g}: {} -> {}; {}; {}{}\n",
        parameters[p].address, result.best[p], s.value_down, rms_text(s.rmse_down), s.value_up,
        rms_text(s.rmse_up), s.determined ? "determined" : "NOT determined by this dataset",
        interval, joint, profile);
  }
  spdlog::info(
      "sensitivity, RMS (SI) with each parameter alone moved a tenth of its box, its 95 % "
      "interval with the others held (conditional), with them re-fitted about the calibrated "
      "point (joint) and along the way (profile, --profile):\n{}",
      sensitivity);
  if (parameters.size() > 1 && result.correlation.empty()) {
    spdlog::warn(
        "the parameters are not determined together: the curvature of the error is not positive "
        "definite, so some combination of them leaves the fit unchanged (calibrate fewer, or "
        "add a dataset that separates them)");
  } else {
    for (std::size_t p = 0; p < result.correlation.size(); ++p) {
      for (std::size_t q = p + 1; q < result.correlation.size(); ++q) {
        spdlog::info("correlation {} / {}: {:+.3f}", parameters[p].address, parameters[q].address,
                     result.correlation[p][q]);
      }
    }
  }
  try {
    for (const fs::path& plot : write_sensitivity_plots(result, out)) {
      spdlog::info("sensitivity plot: {}", plot.string());
    }
  } catch (const std::exception& error) {
    spdlog::error("{}", error.what());
    return 1;
  }
  spdlog::info("calibration: {}", (out / "calibration.json").string());
  return 0;
}

CLI::App* add_compare_subcommand(CLI::App& app, CompareArgs& args) {
  CLI::App* command = app.add_subcommand("compare", "compare the DEM twin with a measured dataset");
  add_model_options(*command, args);
  add_ensemble_option(*command, args);
  return command;
}

int compare_command(const CompareArgs& args) {
  const std::optional<WorkbenchInputs> inputs = load_inputs(args);
  if (!inputs) return 2;
  const Dataset& dataset = inputs->dataset;
  const std::optional<TwinSettings> twin = twin_settings(args, dataset);
  if (!twin) return 2;
  std::unique_ptr<TrialModel> model = make_twin_model(dataset.experiment, inputs->common, *twin);
  spdlog::info("comparing {} ({} trials, {}) with: {}", dataset.name, dataset.trials.size(),
               to_string(dataset.experiment), model->describe());
  const CompareReport report = compare(dataset, *model);
  const fs::path out = out_folder(args, "compare_");
  write_report(report, out);
  append_history(out / "history.csv", report, utc_now(), model_effects(inputs->common.base_spec));
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
