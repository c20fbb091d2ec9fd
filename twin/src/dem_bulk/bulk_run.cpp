// run_bulk_experiment: the bulk box emptied by the belt under a schedule of gate openings and
// belt speeds, sampled as an experimenter logs it, with the run's cost.
#include "fl/twin/dem_bulk/bulk_run.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>

#include "fl/report/csv.hpp"
#include "fl/report/svg_plot.hpp"
#include "fl/twin/dem/vtk_writer.hpp"

namespace fl {
namespace {

std::string number_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// "--gate: entry 2 ('5:abc'): why".
[[noreturn]] void refuse_entry(std::string_view what, std::size_t entry, std::string_view part,
                               const std::string& why) {
  throw std::invalid_argument(std::string(what) + ": entry " + std::to_string(entry) + " ('" +
                              std::string(part) + "'): " + why);
}

double parse_number(std::string_view text, std::string_view what, std::size_t entry,
                    std::string_view part) {
  const auto refuse = [&](const std::string& why) { refuse_entry(what, entry, part, why); };
  const auto blank = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (!text.empty() && blank(text.front())) text.remove_prefix(1);
  while (!text.empty() && blank(text.back())) text.remove_suffix(1);
  if (text.empty()) refuse("a number is missing");
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) {
    refuse("'" + std::string(text) + "' is not a number");
  }
  if (!std::isfinite(value)) refuse("'" + std::string(text) + "' is not a finite number");
  return value;
}

// Control steps in `seconds`, or a refusal naming the option: the scene runs whole steps.
long whole_steps(double seconds, double control_step_s, const std::string& option,
                 bool zero_allowed) {
  if (!(std::isfinite(seconds) && (seconds > 0.0 || (zero_allowed && seconds == 0.0)))) {
    throw std::invalid_argument(option + " " + number_text(seconds) + " s: must be " +
                                (zero_allowed ? "0 or " : "") + "positive");
  }
  if (!is_whole_control_steps(seconds, control_step_s)) {
    throw std::invalid_argument(option + " " + number_text(seconds) +
                                " s is not a whole number of control steps of " +
                                number_text(control_step_s) + " s");
  }
  return std::lround(seconds / control_step_s);
}

struct StepCommand {
  long step = 0;
  double value = 0.0;
};

std::vector<StepCommand> schedule_steps(std::span<const TimedSetpoint> schedule, double lo,
                                        double hi, long total_steps, double control_step_s,
                                        const std::string& what) {
  std::vector<StepCommand> out;
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    const TimedSetpoint& p = schedule[k];
    const std::string name = what + " setpoint " + std::to_string(k + 1);
    const long step = whole_steps(p.time_s, control_step_s, name + " at", true);
    if (step >= total_steps) {  // at the end it would hold for no step at all
      throw std::invalid_argument(name + " at " + number_text(p.time_s) +
                                  " s is not before the run's end");
    }
    if (!(p.value >= lo && p.value <= hi)) {
      throw std::invalid_argument(name + ": " + number_text(p.value) + " is outside " +
                                  number_text(lo) + " .. " + number_text(hi) +
                                  " (the scene would clamp it)");
    }
    if (!out.empty() && step <= out.back().step) {
      throw std::invalid_argument(name + " at " + number_text(p.time_s) +
                                  " s does not come after the one before");
    }
    out.push_back({step, p.value});
  }
  return out;
}

struct BondCount {
  std::size_t total = 0;
  std::size_t broken = 0;
};

report::Series line_series(std::string label, std::vector<double> x, std::vector<double> y) {
  report::Series series;
  series.label = std::move(label);
  series.x = std::move(x);
  series.y = std::move(y);
  return series;
}

BondCount count_bonds(const dem::State& state) {
  BondCount count{state.bond_states.size(), 0};
  for (const dem::BondState& b : state.bond_states) count.broken += b.broken ? 1 : 0;
  return count;
}

}  // namespace

std::vector<TimedSetpoint> parse_setpoint_schedule(std::string_view text, std::string_view what) {
  std::vector<TimedSetpoint> schedule;
  if (text.empty()) return schedule;
  std::size_t entry = 0;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    const std::size_t comma = std::min(text.find(',', begin), text.size());
    const std::string_view part = text.substr(begin, comma - begin);
    ++entry;
    const std::size_t colon = part.find(':');
    if (colon == std::string_view::npos) {
      refuse_entry(what, entry, part, "not TIME:VALUE (seconds, a colon, the value)");
    }
    TimedSetpoint p;
    p.time_s = parse_number(part.substr(0, colon), what, entry, part);
    p.value = parse_number(part.substr(colon + 1), what, entry, part);
    if (p.time_s < 0.0) refuse_entry(what, entry, part, "the time is negative");
    if (!schedule.empty() && p.time_s <= schedule.back().time_s) {
      refuse_entry(what, entry, part, "times must rise from entry to entry");
    }
    schedule.push_back(p);
    begin = comma + 1;
  }
  return schedule;
}

BulkRunSummary run_bulk_experiment(BulkScene& scene, const BulkRunOptions& options,
                                   const std::function<void(const BulkRunSample&)>& on_sample,
                                   std::vector<BulkRunSample>* samples) {
  const BulkDemConfig& config = scene.config();
  const double h = config.simulation.control_step_s;
  const long total = whole_steps(options.duration_s, h, "duration", false);
  const long sample_every = whole_steps(options.sample_s, h, "sample interval", false);
  const long vtk_every = whole_steps(options.vtk_every_s, h, "VTK interval", true);
  const long frame_every = whole_steps(options.frame_every_s, h, "frame interval", true);
  if (frame_every > 0 && !options.on_frame) {
    throw std::invalid_argument("frames asked for without a frame handler");
  }
  if (!(options.rate_window_s > 0.0 && std::isfinite(options.rate_window_s))) {
    throw std::invalid_argument("rate window " + number_text(options.rate_window_s) +
                                " s: must be positive");
  }
  if (vtk_every > 0 && options.vtk_directory.empty()) {
    throw std::invalid_argument("VTK frames asked for without a directory");
  }
  const std::vector<StepCommand> gate =
      schedule_steps(options.gate_opening_mm, config.gate.min_opening_mm,
                     config.gate.max_opening_mm, total, h, "gate opening (mm)");
  const std::vector<StepCommand> belt =
      schedule_steps(options.belt_speed_mps, -config.belt.max_speed_mps, config.belt.max_speed_mps,
                     total, h, "belt speed (m/s)");
  // BulkScene::set_leveller_rpm does not clamp; the config loader's range is the rotor's.
  const std::vector<StepCommand> leveller =
      schedule_steps(options.leveller_rpm, -1000.0, 1000.0, total, h, "leveller (rpm)");

  const dem::Simulation& sim = scene.simulation();
  BulkRunSummary summary;
  summary.duration_s = options.duration_s;
  summary.timestep_s = sim.model().spec().timestep_s;
  summary.initial_fillets = scene.fillets_in_scene();
  summary.initial_spheres = sim.state().size();
  summary.initial_bonds = sim.state().bonds.size();

  std::optional<dem::VtkSeriesWriter> vtk;
  const auto start = std::chrono::steady_clock::now();
  const auto seconds_since = [](std::chrono::steady_clock::time_point from) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - from).count();
  };
  const auto write_vtk = [&] {
    const auto frame_start = std::chrono::steady_clock::now();
    vtk->write(sim);
    summary.output_wall_s += seconds_since(frame_start);
  };
  const auto show_frame = [&] {
    const auto frame_start = std::chrono::steady_clock::now();
    options.on_frame(sim);
    ++summary.frames;
    summary.output_wall_s += seconds_since(frame_start);
  };

  const double run_start_s = scene.time_s();
  const std::uint64_t first_step = sim.state().step;
  const std::uint64_t first_rebuilds = sim.stats().neighbor_rebuilds;
  double torque_sum_nm = 0.0;
  long torque_count = 0;
  long done = 0;  // control steps run
  const auto take_sample = [&] {
    BulkRunSample s;
    s.time_s = static_cast<double>(done) * h;
    s.engine_time_s = scene.time_s() - run_start_s;
    s.wall_s = seconds_since(start);
    s.gate_target_mm = scene.gate_target_mm();
    s.gate_opening_mm = scene.gate_opening_mm();
    s.belt_speed_mps = scene.belt_speed_mps();
    s.leveller_rpm = scene.leveller_rpm();
    s.fillets_in_scene = scene.fillets_in_scene();
    s.fillets_in_hopper = scene.fillets_in_hopper();
    s.spheres = sim.state().size();
    s.passed_gate = scene.counters().passed_gate;
    s.discharged = scene.counters().discharged;
    s.discharged_mass_kg = scene.counters().discharged_mass_kg;
    s.lost = scene.counters().lost;
    s.fallen_spheres = scene.counters().fallen_spheres;
    s.gate_passes_per_s = scene.gate_pass_rate_per_s(options.rate_window_s);
    s.gate_mass_flow_kg_per_s = scene.gate_mass_flow_kg_per_s(options.rate_window_s);
    s.discharge_mass_flow_kg_per_s = scene.mass_flow_kg_per_s(options.rate_window_s);
    s.leveller_torque_nm =
        torque_count > 0 ? torque_sum_nm / static_cast<double>(torque_count) : 0.0;
    const BondCount bonds = count_bonds(sim.state());
    s.bonds = bonds.total;
    s.broken_bonds = bonds.broken;
    s.broken_bonds_total = bonds.broken + scene.counters().broken_bonds_removed;
    s.touching_pairs = sim.stats().touching_pairs;
    s.listed_pairs = sim.stats().neighbor_pairs;
    s.engine_steps = sim.state().step - first_step;
    s.neighbor_rebuilds = sim.stats().neighbor_rebuilds - first_rebuilds;
    torque_sum_nm = 0.0;
    torque_count = 0;
    if (samples != nullptr) samples->push_back(s);
    if (on_sample) on_sample(s);
    return s;
  };

  std::size_t next_gate = 0;
  std::size_t next_belt = 0;
  std::size_t next_leveller = 0;
  // Commands due before control step k (those at 0 before the first sample, so the first row
  // shows what the run starts with).
  const auto apply_commands = [&](long k) {
    for (; next_gate < gate.size() && gate[next_gate].step == k; ++next_gate) {
      scene.set_gate_opening_mm(gate[next_gate].value);
    }
    for (; next_belt < belt.size() && belt[next_belt].step == k; ++next_belt) {
      scene.set_belt_speed_mps(belt[next_belt].value);
    }
    for (; next_leveller < leveller.size() && leveller[next_leveller].step == k; ++next_leveller) {
      scene.set_leveller_rpm(leveller[next_leveller].value);
    }
  };
  apply_commands(0);
  if (vtk_every > 0) {
    vtk.emplace(options.vtk_directory);
    write_vtk();
  }
  if (frame_every > 0) show_frame();
  summary.last = take_sample();
  for (long k = 0; k < total; ++k) {
    apply_commands(k);
    // The engine steps of this control step run with the spheres in the scene now; the feeder
    // and the discharge edge change the count only at the control step's end.
    const std::size_t spheres = sim.state().size();
    const std::uint64_t steps_before = sim.state().step;
    scene.step(h);
    summary.particle_steps +=
        static_cast<double>(sim.state().step - steps_before) * static_cast<double>(spheres);
    torque_sum_nm += scene.leveller_load_mean().torque_nm;
    ++torque_count;
    done = k + 1;
    if (done % sample_every == 0 || done == total) summary.last = take_sample();
    if (vtk_every > 0 && (done % vtk_every == 0 || done == total)) write_vtk();
    if (frame_every > 0 && done % frame_every == 0) show_frame();
  }
  summary.engine_steps = sim.state().step - first_step;
  summary.wall_s = seconds_since(start);
  summary.vtk_frames = vtk ? vtk->frames() : 0;
  summary.threads = sim.active_thread_count();
  return summary;
}

void write_bulk_run_csv(std::span<const BulkRunSample> samples, const std::filesystem::path& file) {
  report::CsvTable table({"time_s",
                          "engine_time_s",
                          "wall_s",
                          "gate_target_mm",
                          "gate_opening_mm",
                          "belt_speed_mps",
                          "leveller_rpm",
                          "fillets_in_scene",
                          "fillets_in_hopper",
                          "spheres",
                          "passed_gate",
                          "discharged",
                          "discharged_mass_kg",
                          "lost",
                          "fallen_spheres",
                          "gate_passes_per_s",
                          "gate_mass_flow_kg_per_s",
                          "discharge_mass_flow_kg_per_s",
                          "leveller_torque_nm",
                          "bonds",
                          "broken_bonds",
                          "broken_bonds_total",
                          "touching_pairs",
                          "listed_pairs",
                          "engine_steps",
                          "neighbor_rebuilds"});
  const auto d = [](auto v) { return static_cast<double>(v); };
  for (const BulkRunSample& s : samples) {
    table.add_row({s.time_s,
                   s.engine_time_s,
                   s.wall_s,
                   s.gate_target_mm,
                   s.gate_opening_mm,
                   s.belt_speed_mps,
                   s.leveller_rpm,
                   d(s.fillets_in_scene),
                   d(s.fillets_in_hopper),
                   d(s.spheres),
                   d(s.passed_gate),
                   d(s.discharged),
                   s.discharged_mass_kg,
                   d(s.lost),
                   d(s.fallen_spheres),
                   s.gate_passes_per_s,
                   s.gate_mass_flow_kg_per_s,
                   s.discharge_mass_flow_kg_per_s,
                   s.leveller_torque_nm,
                   d(s.bonds),
                   d(s.broken_bonds),
                   d(s.broken_bonds_total),
                   d(s.touching_pairs),
                   d(s.listed_pairs),
                   d(s.engine_steps),
                   d(s.neighbor_rebuilds)});
  }
  table.write(file);
}

void write_bulk_run_plots(std::span<const BulkRunSample> samples, const BulkRunOptions& options,
                          const std::filesystem::path& directory) {
  if (samples.empty()) throw report::ReportError("bulk run plots: no samples");
  std::vector<double> t;
  std::vector<double> gate_flow;
  std::vector<double> edge_flow;
  std::vector<double> in_box;
  std::vector<double> in_scene;
  std::vector<double> broken;
  for (const BulkRunSample& s : samples) {
    t.push_back(s.time_s);
    gate_flow.push_back(s.gate_mass_flow_kg_per_s);
    edge_flow.push_back(s.discharge_mass_flow_kg_per_s);
    in_box.push_back(static_cast<double>(s.fillets_in_hopper));
    in_scene.push_back(static_cast<double>(s.fillets_in_scene));
    broken.push_back(static_cast<double>(s.broken_bonds_total));
  }
  // The commands' changes, so a flow's step is read against what caused it.
  std::vector<report::ReferenceLine> changes;
  for (const TimedSetpoint& p : options.gate_opening_mm) {
    changes.push_back({true, p.time_s, "gate " + number_text(p.value) + " mm"});
  }
  for (const TimedSetpoint& p : options.belt_speed_mps) {
    changes.push_back({true, p.time_s, "belt " + number_text(p.value) + " m/s"});
  }
  for (const TimedSetpoint& p : options.leveller_rpm) {
    changes.push_back({true, p.time_s, "leveller " + number_text(p.value) + " rpm"});
  }
  const std::string window = number_text(options.rate_window_s);

  const auto plot_over_time = [&](std::string title, std::string y_label,
                                  std::vector<report::Series> series, const char* file) {
    report::Plot plot;
    plot.title = std::move(title);
    plot.x.label = "time (s)";
    plot.y.label = std::move(y_label);
    plot.y.min = 0.0;  // flows, counts: all from 0
    plot.series = std::move(series);
    plot.references = changes;
    report::write_svg(plot, directory / file);
  };
  plot_over_time("Bulk box: mass flow (means over " + window + " s)", "mass flow (kg/s)",
                 {line_series("under the gate", t, gate_flow),
                  line_series("over the discharge edge", t, edge_flow)},
                 "bulk_run_flow.svg");
  plot_over_time("Bulk box: fillets left", "fillets",
                 {line_series("in the box (upstream of the gate)", t, in_box),
                  line_series("in the scene", t, in_scene)},
                 "bulk_run_pile.svg");
  // Broken bonds as a count from 0: a fraction of a per cent torn is what matters, and it
  // keeps counting when torn fillets leave the scene.
  plot_over_time("Bonds broken since the start (the fillets' damage)", "broken bonds",
                 {line_series("", t, broken)}, "bulk_run_bonds.svg");
}

}  // namespace fl
