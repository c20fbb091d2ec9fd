// The thesis' bulk experiment as one timed model run (thesis 6.1 and paper section C: a bulk
// box of fillets over a conveyor that pulls them out under an adjustable opening; the opening
// was changed during the run; the EDEM run of 450 fillets took about an hour for 15 s).
//
// run_bulk_experiment() drives a BulkScene through a schedule of gate openings and belt
// speeds, and samples what an experimenter would log: fillets under the gate and over the
// discharge edge, the flows, the pile left in the box, the leveller's torque and the share of
// bonds still intact (a fillet torn apart by the machine shows there first), with the wall time
// so the run's cost is read from the same table.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fl/twin/dem_bulk/bulk_scene.hpp"

namespace fl {

// A command that holds from `time_s` on (seconds from the run's start).
struct TimedSetpoint {
  double time_s = 0.0;
  double value = 0.0;
};

// Reads "T:V[,T:V...]" (seconds, then the value in the caller's unit), for example
// "0:60,5:100,10:40". Throws std::invalid_argument naming `what`, the entry and its position for
// an entry without ':', text that is not a number, NaN or infinity, a negative time, or times
// that do not rise strictly. An empty text is an empty schedule.
std::vector<TimedSetpoint> parse_setpoint_schedule(std::string_view text, std::string_view what);

struct BulkRunOptions {
  double duration_s = 15.0;             // scene time run
  double sample_s = 0.1;                // one sample row per this much scene time
  double rate_window_s = 1.0;           // the flows are means over this window
  double vtk_every_s = 0.0;             // a VTK frame (particles and walls) this often; 0: none
  std::filesystem::path vtk_directory;  // where the frames go (needed when vtk_every_s > 0)
  // Called with the engine at the start and every frame_every_s (for a video; 0: never). Its
  // time counts as output, as the VTK frames' does, not as the run's computing.
  double frame_every_s = 0.0;
  std::function<void(const dem::Simulation&)> on_frame;
  // Commands over time; an empty schedule keeps the scene's value. A setpoint's time must be
  // a whole number of control steps and before the run's end; those at 0 hold from the first
  // sample on.
  std::vector<TimedSetpoint> gate_opening_mm;
  std::vector<TimedSetpoint> belt_speed_mps;
  std::vector<TimedSetpoint> leveller_rpm;
};

// Totals are since the scene was built; times since the run began.
struct BulkRunSample {
  double time_s = 0.0;         // whole control steps
  double engine_time_s = 0.0;  // the engine's clock: within half a timestep of time_s
  double wall_s = 0.0;         // computer time since the run began
  double gate_target_mm = 0.0;
  double gate_opening_mm = 0.0;  // where the plate is (the cylinder moves at its speed)
  double belt_speed_mps = 0.0;
  double leveller_rpm = 0.0;
  std::size_t fillets_in_scene = 0;
  std::size_t fillets_in_hopper = 0;  // centroid upstream of the gate
  std::size_t spheres = 0;
  std::uint64_t passed_gate = 0;  // totals since the start
  std::uint64_t discharged = 0;
  double discharged_mass_kg = 0.0;
  std::uint64_t lost = 0;            // fell off the scene
  std::uint64_t fallen_spheres = 0;  // torn off and fallen under the scene (held there)
  double gate_passes_per_s = 0.0;    // over the rate window
  double gate_mass_flow_kg_per_s = 0.0;
  double discharge_mass_flow_kg_per_s = 0.0;
  double leveller_torque_nm = 0.0;       // mean over the sample's control steps
  std::size_t bonds = 0;                 // of the fillets in the scene
  std::size_t broken_bonds = 0;          // of those
  std::uint64_t broken_bonds_total = 0;  // and those that left with removed fillets
  std::size_t touching_pairs = 0;        // sphere-sphere, last force evaluation
  std::size_t listed_pairs = 0;          // sphere-sphere in the neighbour list (skin included)
  std::uint64_t engine_steps = 0;        // since the start
  std::uint64_t neighbor_rebuilds = 0;
};

struct BulkRunSummary {
  double duration_s = 0.0;
  double timestep_s = 0.0;
  std::uint64_t engine_steps = 0;
  double particle_steps = 0.0;  // sum over engine steps of the spheres then in the scene
  double wall_s = 0.0;
  double output_wall_s = 0.0;  // of wall_s, writing VTK frames and in on_frame
  std::size_t vtk_frames = 0;
  std::size_t frames = 0;  // on_frame calls
  int threads = 0;         // engine threads used at the end
  std::size_t initial_fillets = 0;
  std::size_t initial_spheres = 0;
  std::size_t initial_bonds = 0;
  BulkRunSample last;
  // The engine's and the scene's pace, without the time spent writing frames.
  [[nodiscard]] double particle_steps_per_s() const {
    const double computing_s = wall_s - output_wall_s;
    return computing_s > 0.0 ? particle_steps / computing_s : 0.0;
  }
};

// Runs the scene for options.duration_s from where it is. The sample rows start at the scene's
// time and end at the run's end; `on_sample` (may be empty) sees each row as it is taken, for
// progress. Throws std::invalid_argument, naming the option and value, for a duration, sample,
// VTK or frame interval that is not a positive whole number of control steps (VTK and frames:
// or 0), a frame interval without on_frame, a setpoint
// out of the run or off the control steps, and an opening or speed outside what the scene's
// gate and belt can do (they would be clamped: a run that did something other than asked).
BulkRunSummary run_bulk_experiment(BulkScene& scene, const BulkRunOptions& options,
                                   const std::function<void(const BulkRunSample&)>& on_sample,
                                   std::vector<BulkRunSample>* samples = nullptr);

// Columns named with their units (time_s, wall_s, gate_target_mm, ...), one row per sample,
// fl_report CSV; creates parent folders.
void write_bulk_run_csv(std::span<const BulkRunSample> samples, const std::filesystem::path& file);
// Plots a person opens: flows under the gate and over the edge against time with the commands'
// changes marked, and the pile left in the box with the share of intact bonds.
void write_bulk_run_plots(std::span<const BulkRunSample> samples, const BulkRunOptions& options,
                          const std::filesystem::path& directory);

}  // namespace fl
