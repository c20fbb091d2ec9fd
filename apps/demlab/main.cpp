// demlab: the model tests of "From Bulk to Belt" (chapter 4) on the DEM engine, each as a
// subcommand writing CSV, SVG and a summary:
//   demlab settle --out out/ --radius-mm 7 --threads 2
//   demlab all --config config/model_tests.yaml --dem-config config/dem.yaml --out out/
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <exception>
#include <fstream>
#include <functional>
#include <map>

#include "commands.hpp"
#include "fl/controller/yaml_reader.hpp"
#include "fl/report/csv.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/twin/model_tests/fillet_source.hpp"

namespace {

// A relative mesh path is tried from the working folder, then from the repository root that
// the config file sits in (config/..).
std::filesystem::path resolve_mesh(const std::filesystem::path& mesh,
                                   const std::filesystem::path& config_file) {
  if (mesh.is_absolute() || std::filesystem::exists(mesh)) return mesh;
  const auto root = std::filesystem::absolute(config_file).parent_path().parent_path();
  return root / mesh;
}

}  // namespace

static int checked_main(int argc, char** argv) {
  CLI::App app{"demlab: the thesis' DEM model tests, written as CSV, SVG and Markdown"};
  app.require_subcommand(1);
  app.fallthrough();
  std::filesystem::path config_file = "config/model_tests.yaml";
  std::filesystem::path dem_config_file = "config/dem.yaml";
  std::filesystem::path out_dir = "demlab_out";
  double radius_mm = 0.0;
  int threads = 2;
  app.add_option("--config", config_file, "model test setups (YAML)")->check(CLI::ExistingFile);
  app.add_option("--dem-config", dem_config_file, "DEM engine parameters (YAML)")
      ->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "output folder (created)");
  app.add_option("--radius-mm", radius_mm, "sub-particle radius in mm (default: from --config)")
      ->check(CLI::Range(1.0, 20.0));
  app.add_option("--threads", threads, "worker threads for sweeps / engine threads")
      ->check(CLI::Range(1, 256));

  using Command = std::function<fl::demlab::Summary(const fl::demlab::Context&)>;
  const std::vector<std::pair<std::string, std::pair<std::string, Command>>> commands = {
      {"settle", {"damping: energy after a drop (3.4.1, fig. 4.2-4.3)", fl::demlab::run_settle}},
      {"bend", {"bend angle over a table edge (3.4.1, fig. 4.5)", fl::demlab::run_bend}},
      {"slide", {"slide angle vs friction and surface energy (fig. 4.6)", fl::demlab::run_slide}},
      {"compress", {"Young's modulus of a bonded block (3.5, 4.3)", fl::demlab::run_compress}},
      {"impact", {"intact bonds vs impact speed (4.2.1)", fl::demlab::run_impact}},
      {"drop", {"intact bonds vs drop orientation (4.2.2)", fl::demlab::run_drop}},
      {"scaling", {"intact bonds vs scale and timestep (4.2.3)", fl::demlab::run_scaling}},
      {"doe", {"appendix C stiffness grid: settle, stability, bend", fl::demlab::run_doe}},
  };
  for (const auto& [name, entry] : commands) app.add_subcommand(name, entry.first);
  app.add_subcommand("all", "every test above");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    fl::demlab::Context context;
    context.config = fl::model_tests::load_model_tests_config(config_file);
    fl::model_tests::CommonParams common;
    common.base_spec = fl::dem::load_model_spec(dem_config_file);
    common.sub_particle_radius_m =
        radius_mm > 0.0 ? radius_mm * 1e-3 : context.config.sub_particle_radius_m;
    common.variant = context.config.variant;
    common.rayleigh_fraction = context.config.rayleigh_fraction;
    common.bond_step_fraction = context.config.bond_step_fraction;
    common.seed = context.config.seed;
    common.thread_count = threads;
    const auto mesh = resolve_mesh(context.config.fillet_mesh_stl, config_file);
    common.fillet_mesh = fl::model_tests::load_fillet_mesh(mesh);
    fl::model_tests::apply_common(context.config, common);
    context.out_dir = out_dir;
    context.threads = threads;
    for (int k = 0; k < argc; ++k) {
      context.command_line += (k > 0 ? " " : "") + std::string(argv[k]);
    }
    std::filesystem::create_directories(out_dir);
    spdlog::info("demlab: {} mm spheres, fillet {} from {}, {} threads, output {}",
                 common.sub_particle_radius_m * 1e3,
                 fl::model_tests::fillet_variant_name(common.variant), mesh.string(), threads,
                 out_dir.string());
    std::vector<fl::demlab::Summary> summaries;
    for (const auto& [name, entry] : commands) {
      if (!app.got_subcommand(name) && !app.got_subcommand("all")) continue;
      const auto start = std::chrono::steady_clock::now();
      spdlog::info("{}: {}", name, entry.first);
      summaries.push_back(entry.second(context));
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      for (const auto& line : summaries.back().lines) spdlog::info("{}: {}", name, line);
      spdlog::info("{}: done in {:.1f} s, wrote {}/{}.csv, .svg, .md", name, seconds,
                   out_dir.string(), name);
    }
    if (summaries.size() > 1) {
      std::ofstream all(out_dir / "summary.md");
      all << "# demlab summary\n\n`" << context.command_line << "`\n\n";
      for (const auto& s : summaries) {
        all << "## " << s.name << "\n\n";
        for (const auto& line : s.lines) all << "- " << line << "\n";
        all << "\n";
      }
    }
    return 0;
  } catch (const fl::ConfigError& e) {
    spdlog::error("configuration: {}", e.what());
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "demlab: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "demlab: unknown error\n");
  }
  return 1;
}
