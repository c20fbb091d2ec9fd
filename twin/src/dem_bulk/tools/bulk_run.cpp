// bulk_run: the thesis' bulk experiment as one timed DEM run (thesis 6.1, paper section C): the
// box full of fillets, the belt pulling them out under the gate, the opening changed during the
// run. The thesis ran 450 fillets (over 160k particles) for 15 s in about an hour on a GPU;
// config/bulk_thesis.yaml is that box.
//   bulk_run [--config config/bulk_thesis.yaml] [--out out/bulk_run] [--duration 15]
//            [--gate 0:60,5:100,10:40] [--belt 0:0.2] [--sample 0.1] [--vtk-every 1]
//            [--video out/bulk_run.mkv]
// Logs its progress, and writes OUT/bulk_run.csv (one row per sample), OUT/bulk_run.json (the
// run's cost and totals), three SVG plots, with --vtk-every OUT/vtk/run.pvd for ParaView, and
// with --video a video of the top and side views.
#include "fl/twin/dem_bulk/bulk_run.hpp"

#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "fl/controller/yaml_reader.hpp"  // ConfigError
#include "fl/report/csv.hpp"              // ReportError
#include "fl/twin/render/dem_scene.hpp"

namespace {

std::string minutes_text(double seconds) {
  const auto total = static_cast<long>(std::lround(seconds));
  return std::to_string(total / 60) + " min " + std::to_string(total % 60) + " s";
}

nlohmann::json schedule_json(const std::vector<fl::TimedSetpoint>& schedule, const char* unit) {
  nlohmann::json out = nlohmann::json::array();
  for (const fl::TimedSetpoint& p : schedule) {
    out.push_back({{"time_s", p.time_s}, {unit, p.value}});
  }
  return out;
}

struct RunSetup {
  std::string config_file;
  double build_s = 0.0;
  const fl::BulkDemConfig* config = nullptr;
  const fl::dem::TimestepReport* timestep = nullptr;
};

void write_summary_json(const fl::BulkRunSummary& summary, const fl::BulkRunOptions& options,
                        const RunSetup& setup, const std::filesystem::path& file) {
  const fl::BulkRunSample& last = summary.last;
  const fl::BulkSimulationConfig& sim = setup.config->simulation;
  const nlohmann::json out = {
      {"config", setup.config_file},
      {"seed", sim.seed},
      {"sub_particle_radius_mm", sim.sub_particle_radius_mm},
      {"rayleigh_fraction", sim.rayleigh_fraction},
      {"neighbor_skin_mm", sim.neighbor_skin_mm},
      {"threads_asked", sim.thread_count},
      {"threads", summary.threads},
      {"timestep_s", summary.timestep_s},
      {"timestep_check", setup.timestep->message},
      {"duration_s", summary.duration_s},
      {"engine_steps", summary.engine_steps},
      {"initial",
       {{"fillets", summary.initial_fillets},
        {"spheres", summary.initial_spheres},
        {"bonds", summary.initial_bonds}}},
      {"schedule",
       {{"gate", schedule_json(options.gate_opening_mm, "opening_mm")},
        {"belt", schedule_json(options.belt_speed_mps, "speed_mps")},
        {"leveller", schedule_json(options.leveller_rpm, "rpm")}}},
      {"build_s", setup.build_s},
      {"wall_s", summary.wall_s},
      {"output_wall_s", summary.output_wall_s},
      {"vtk_frames", summary.vtk_frames},
      {"video_frames", summary.frames},
      {"particle_steps", summary.particle_steps},
      {"particle_steps_per_s", summary.particle_steps_per_s()},
      {"end",
       {{"fillets_in_scene", last.fillets_in_scene},
        {"fillets_in_box", last.fillets_in_hopper},
        {"passed_gate", last.passed_gate},
        {"discharged", last.discharged},
        {"discharged_mass_kg", last.discharged_mass_kg},
        {"lost", last.lost},
        {"fallen_spheres", last.fallen_spheres},
        {"bonds", last.bonds},
        {"broken_bonds_total", last.broken_bonds_total},
        {"neighbor_rebuilds", last.neighbor_rebuilds}}},
  };
  std::ofstream stream(file);
  stream << out.dump(2) << '\n';
  if (!stream) throw std::runtime_error("cannot write " + file.string());
}

}  // namespace

static int checked_main(int argc, char** argv) {
  CLI::App app{"the thesis' bulk experiment as one timed DEM run (thesis 6.1)"};
  std::string config_file = "config/bulk_thesis.yaml";
  std::string out_dir = "out/bulk_run";
  std::string gate_text;
  std::string belt_text;
  std::string leveller_text;
  int fill = -1;
  int threads = 0;
  double progress_every_s = 1.0;
  std::string video_file;
  double video_fps = 25.0;
  fl::BulkRunOptions options;
  app.add_option("--config", config_file, "bulk scene configuration")->check(CLI::ExistingFile);
  app.add_option("--out", out_dir, "folder for the CSV, JSON, plots and VTK frames (created)");
  app.add_option("--duration", options.duration_s, "scene seconds to run (whole control steps)");
  app.add_option("--gate", gate_text,
                 "gate openings over time, TIME:MM,... (seconds from the start; default: the "
                 "config's opening throughout)");
  app.add_option("--belt", belt_text,
                 "belt speeds over time, TIME:MPS,... (default: the config's speed throughout)");
  app.add_option(
      "--leveller", leveller_text,
      "leveller speeds over time, TIME:RPM,... (default: the config's speed throughout)");
  app.add_option("--sample", options.sample_s, "seconds between sample rows");
  app.add_option("--rate-window", options.rate_window_s, "seconds the flows are averaged over");
  app.add_option("--vtk-every", options.vtk_every_s,
                 "seconds between VTK frames (0: none; a 450-fillet frame is about 20 MB)");
  app.add_option("--video", video_file,
                 "a video of the run, top and side views (.mkv lossless FFV1, .avi MJPG)");
  app.add_option("--video-fps", video_fps, "video frames per second of scene time")
      ->check(CLI::Range(1.0, 500.0));
  app.add_option("--fill", fill, "fillets in the box at the start (default: the config's)")
      ->check(CLI::Range(0, 100000));
  app.add_option("--threads", threads, "engine threads (default: the config's)")
      ->check(CLI::Range(1, 256));
  app.add_option("--progress", progress_every_s, "scene seconds between progress lines")
      ->check(CLI::PositiveNumber);
  CLI11_PARSE(app, argc, argv);
  try {
    options.gate_opening_mm = fl::parse_setpoint_schedule(gate_text, "--gate");
    options.belt_speed_mps = fl::parse_setpoint_schedule(belt_text, "--belt");
    options.leveller_rpm = fl::parse_setpoint_schedule(leveller_text, "--leveller");
    fl::BulkDemConfig config = fl::load_bulk_dem_config(config_file);
    if (fill >= 0) config.feeder.initial_fill = static_cast<std::uint32_t>(fill);
    if (threads > 0) config.simulation.thread_count = threads;
    // A command at 0 is where the machine stands when the box is filled, not a move at the
    // start (the gate's cylinder would spend the first tenths of a second getting there).
    if (!options.gate_opening_mm.empty() && options.gate_opening_mm.front().time_s == 0.0) {
      config.gate.opening_mm = options.gate_opening_mm.front().value;
    }
    if (!options.belt_speed_mps.empty() && options.belt_speed_mps.front().time_s == 0.0) {
      config.belt.speed_mps = options.belt_speed_mps.front().value;
    }
    if (!options.leveller_rpm.empty() && options.leveller_rpm.front().time_s == 0.0) {
      config.leveller.speed_rpm = options.leveller_rpm.front().value;
    }
    const std::filesystem::path out(out_dir);
    std::filesystem::create_directories(out);
    if (options.vtk_every_s > 0.0) options.vtk_directory = out / "vtk";

    spdlog::info("bulk_run: building the scene from {} ({} fillets at {} mm)", config_file,
                 config.feeder.initial_fill, config.simulation.sub_particle_radius_mm);
    const auto build_start = std::chrono::steady_clock::now();
    fl::BulkScene scene(config);
    const double build_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - build_start).count();
    spdlog::info("bulk_run: {} fillets, {} spheres, {} bonds placed in {:.1f} s; timestep {:.3g} s",
                 scene.fillets_in_scene(), scene.simulation().state().size(),
                 scene.simulation().state().bonds.size(), build_s,
                 scene.simulation().model().spec().timestep_s);
    const fl::dem::TimestepReport timestep = scene.simulation().check_timestep();
    spdlog::info("bulk_run: {}", timestep.message);
    if (scene.fillets_in_scene() < config.feeder.initial_fill) {
      spdlog::warn("bulk_run: only {} of {} fillets fit the box; the feeder drops the rest",
                   scene.fillets_in_scene(), config.feeder.initial_fill);
    }

    // The video shows the whole scene: from the belt's start to its discharge edge, the belt's
    // width, and from under the belt to over the box.
    std::unique_ptr<fl::render::DemVideoWriter> video;
    fl::render::DemSceneView view;
    view.x_min_m = config.belt.start_mm * 1e-3 - 0.05;
    view.x_max_m = config.belt.discharge_mm * 1e-3 + 0.05;
    view.y_half_width_m = config.belt.half_width_mm * 1e-3 + 0.05;
    view.z_min_m = -0.05;
    view.z_max_m = config.hopper.height_mm * 1e-3 + 0.05;
    view.width_px = 1280;
    if (!video_file.empty()) {
      // The scene runs whole control steps, so the frame interval is rounded to them. The
      // writer opens now, so a file OpenCV cannot write stops the run before it begins.
      const double step_s = config.simulation.control_step_s;
      options.frame_every_s = std::max(1.0, std::round(1.0 / video_fps / step_s)) * step_s;
      const cv::Size size = fl::render::render_dem_scene(scene.simulation(), view).size();
      video = std::make_unique<fl::render::DemVideoWriter>(video_file, 1.0 / options.frame_every_s,
                                                           size);
      options.on_frame = [&](const fl::dem::Simulation& sim) {
        video->write(fl::render::render_dem_scene(sim, view));
      };
    }

    std::vector<fl::BulkRunSample> samples;
    double next_progress_s = 0.0;
    const auto progress = [&](const fl::BulkRunSample& s) {
      if (s.time_s + 1e-9 < next_progress_s && s.time_s + 1e-9 < options.duration_s) return;
      next_progress_s += progress_every_s;
      const std::string left =
          s.time_s > 0.0 ? "~" + minutes_text(s.wall_s * (options.duration_s - s.time_s) / s.time_s)
                         : "?";
      spdlog::info(
          "t {:6.2f} / {} s | wall {} | left {} | box {} | under the gate {} | "
          "discharged {} ({:.2f} kg) | flow {:.2f} kg/s | bonds broken {}",
          s.time_s, options.duration_s, minutes_text(s.wall_s), left, s.fillets_in_hopper,
          s.passed_gate, s.discharged, s.discharged_mass_kg, s.gate_mass_flow_kg_per_s,
          s.broken_bonds_total);
      // The rows so far, so an hour's run stopped near its end keeps what it measured.
      fl::write_bulk_run_csv(samples, out / "bulk_run.csv");
    };
    const fl::BulkRunSummary summary = fl::run_bulk_experiment(scene, options, progress, &samples);

    fl::write_bulk_run_csv(samples, out / "bulk_run.csv");
    fl::write_bulk_run_plots(samples, options, out);
    write_summary_json(summary, options, {config_file, build_s, &config, &timestep},
                       out / "bulk_run.json");
    spdlog::info(
        "bulk_run: {} s of scene in {} ({} engine steps of {:.3g} s, {} threads): {:.3e} "
        "particle-steps/s without the {:.1f} s of output (VTK, video)",
        summary.duration_s, minutes_text(summary.wall_s), summary.engine_steps, summary.timestep_s,
        summary.threads, summary.particle_steps_per_s(), summary.output_wall_s);
    spdlog::info("bulk_run: wrote {}/bulk_run.csv, bulk_run.json, bulk_run_*.svg{}", out_dir,
                 summary.vtk_frames > 0 ? " and vtk/run.pvd" : "");
    if (video) spdlog::info("bulk_run: wrote {} ({} frames)", video_file, video->frames());
  } catch (const fl::report::ReportError& e) {  // an output file (before invalid_argument)
    spdlog::error("bulk_run: {}", e.what());
    return 1;
  } catch (const fl::ConfigError& e) {
    spdlog::error("bulk_run: {}", e.what());
    return 2;
  } catch (const std::invalid_argument& e) {  // a run the scene cannot make as asked
    spdlog::error("bulk_run: {} ({})", e.what(), config_file);
    return 2;
  } catch (const std::exception& e) {
    spdlog::error("bulk_run: {}", e.what());
    return 1;
  }
  return 0;
}

int main(int argc, char** argv) {
  // What escapes the commands' own handling (an option table that throws, memory): a message
  // and exit status 1 instead of std::terminate.
  try {
    return checked_main(argc, argv);
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bulk_run: %s\n", error.what());
  } catch (...) {
    std::fprintf(stderr, "bulk_run: unknown error\n");
  }
  return 1;
}
