// The DEM plant replaying a line's command log with fillets placed where the cameras first saw
// them (fl/twin/dem_plant/line_tracks.hpp).
#include "fl/twin/dem_plant/line_tracks.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>

#include "fl/twin/dem_plant/dem_plant.hpp"

namespace fl {
namespace {

constexpr double kNsPerS = 1e9;

std::int64_t to_ns(double time_s) { return std::llround(time_s * kNsPerS); }

// The product path's extent, from the upstream end of the first section to the downstream end
// of the last.
std::pair<double, double> path_extent_mm(const LineConfig& line) {
  double lower = std::numeric_limits<double>::infinity();
  double upper = -lower;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    if (!has_section(static_cast<DriveId>(d))) continue;
    lower = std::min(lower, static_cast<double>(line.sections[d].start_mm));
    upper = std::max(upper, static_cast<double>(line.sections[d].end_mm));
  }
  return {lower, upper};
}

// The log's commands as the plant takes them: every drive enabled at its configured ramp (the
// log's own samples carry the profile), the infeed off.
OutputImage plant_commands(const LineTracksRun& run, double time_s) {
  OutputImage out = run.commands(time_s);
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    out.drives[d].enable = true;
    out.drives[d].accel_mps2 = run.line.limits[d].max_accel_mps2;
  }
  out.drives[index(DriveId::kBulk)].speed_mps = 0.0F;
  out.leveller_speed_rpm = 0.0F;
  out.hopper_opening_mm = 0.0F;
  out.state = LineState::kRunning;
  return out;
}

void check_run(const LineTracksRun& run) {
  if (!run.commands) throw std::invalid_argument("run_line_tracks: no command log");
  if (!(run.command_period_s > 0.0)) {
    throw std::invalid_argument("run_line_tracks: the command period must be above 0 s");
  }
  if (run.first.size() > run.plant.simulation.max_fillets) {
    throw std::invalid_argument("run_line_tracks: " + std::to_string(run.first.size()) +
                                " fillets, the plant holds at most " +
                                std::to_string(run.plant.simulation.max_fillets) +
                                " (simulation.max_fillets)");
  }
  const auto [lower_mm, upper_mm] = path_extent_mm(run.line);
  for (std::size_t f = 0; f < run.first.size(); ++f) {
    const LineTrackStart& start = run.first[f];
    if (!(start.s_mm >= lower_mm && start.s_mm < upper_mm) || !std::isfinite(start.y_mm) ||
        !std::isfinite(start.angle_rad) || !(start.time_s >= 0.0)) {
      throw std::invalid_argument("run_line_tracks: fillet " + std::to_string(f) + " starts at s " +
                                  std::to_string(start.s_mm) + " mm, off the product path [" +
                                  std::to_string(lower_mm) + ", " + std::to_string(upper_mm) +
                                  ") mm, or at a time before 0 s");
    }
  }
  for (std::size_t k = 0; k < run.samples.size(); ++k) {
    const LineTrackSample& sample = run.samples[k];
    if (k > 0 && sample.time_s < run.samples[k - 1].time_s) {
      throw std::invalid_argument("run_line_tracks: samples must be ascending in time (sample " +
                                  std::to_string(k) + ")");
    }
    if (sample.fillet >= run.first.size()) {
      throw std::invalid_argument("run_line_tracks: sample " + std::to_string(k) + " of fillet " +
                                  std::to_string(sample.fillet) + " without a start");
    }
    if (to_ns(sample.time_s) < to_ns(run.first[sample.fillet].time_s)) {
      throw std::invalid_argument("run_line_tracks: fillet " + std::to_string(sample.fillet) +
                                  " is sampled before its start");
    }
  }
}

}  // namespace

LineTracksResult run_line_tracks(const LineTracksRun& run) {
  check_run(run);
  DemPlant plant(run.line, run.plant);
  InputImage in{};
  plant.reset(run.seed, in);

  LineTracksResult result;
  result.poses.reserve(run.samples.size());
  const std::int64_t period_ns = std::max<std::int64_t>(1, to_ns(run.command_period_s));

  // Starts in time order; each fillet's group id once placed, and its last answered pose.
  std::vector<std::size_t> start_order(run.first.size());
  for (std::size_t f = 0; f < start_order.size(); ++f) start_order[f] = f;
  std::stable_sort(start_order.begin(), start_order.end(), [&run](std::size_t a, std::size_t b) {
    return run.first[a].time_s < run.first[b].time_s;
  });
  std::vector<std::optional<std::uint32_t>> group(run.first.size());
  std::vector<LineTrackPose> last(run.first.size());
  std::size_t next_start = 0;

  const auto advance_to = [&](std::int64_t target_ns) {
    while (plant.time_ns() < target_ns) {
      const std::int64_t now_ns = plant.time_ns();
      // Commands change on the scan's grid, as the controller wrote them.
      const std::int64_t grid_end_ns = (now_ns / period_ns + 1) * period_ns;
      const std::int64_t dt_ns = std::min(grid_end_ns, target_ns) - now_ns;
      plant.step(plant_commands(run, static_cast<double>(now_ns) / kNsPerS), dt_ns, in);
    }
  };
  const auto place_due = [&](std::int64_t now_ns) {
    while (next_start < start_order.size() &&
           to_ns(run.first[start_order[next_start]].time_s) <= now_ns) {
      const std::size_t f = start_order[next_start++];
      const LineTrackStart& start = run.first[f];
      const OutputImage out = plant_commands(run, static_cast<double>(now_ns) / kNsPerS);
      DemFilletSpawn spawn;
      spawn.s_mm = start.s_mm;
      spawn.y_mm = start.y_mm;
      spawn.angle_rad = start.angle_rad;
      // The commanded speed under it: a fillet placed there moves with the belt (both belts of
      // a multilane unit).
      spawn.v_mps = carrying_speed(run.line, start.s_mm, [&out](DriveId drive) {
        return static_cast<double>(out.drives[index(drive)].speed_mps);
      });
      spawn.variant = run.variant;
      spawn.side = run.side;
      group[f] = plant.spawn_fillet(spawn);
      if (!group[f]) {
        throw std::runtime_error("run_line_tracks: the plant refused to place fillet " +
                                 std::to_string(f));
      }
      last[f] = {start.s_mm, start.y_mm, start.angle_rad, true};
    }
  };

  std::size_t k = 0;
  while (k < run.samples.size()) {
    const std::int64_t time_ns = to_ns(run.samples[k].time_s);
    // Place every fillet due by then at its own time, then step on to the rows.
    while (next_start < start_order.size() &&
           to_ns(run.first[start_order[next_start]].time_s) <= time_ns) {
      advance_to(to_ns(run.first[start_order[next_start]].time_s));
      place_due(plant.time_ns());
    }
    advance_to(time_ns);
    std::map<std::uint32_t, DemFilletView> views;
    for (const DemFilletView& view : plant.fillets()) views.emplace(view.group_id, view);
    for (; k < run.samples.size() && to_ns(run.samples[k].time_s) == time_ns; ++k) {
      const std::size_t f = run.samples[k].fillet;
      LineTrackPose& pose = last[f];
      const auto found = views.find(*group[f]);
      if (found == views.end()) {
        pose.on_line = false;
        ++result.rows_after_leaving;
      } else {
        const DemFilletView& view = found->second;
        constexpr double kTurn = 2.0 * std::numbers::pi;
        // Unwrapped: the nearest turn to the fillet's last angle (it turns far less than half
        // a turn between two camera rows).
        const double angle =
            view.angle_rad + kTurn * std::round((pose.angle_rad - view.angle_rad) / kTurn);
        pose = {view.s_mm, view.y_mm, angle, true};
      }
      result.poses.push_back(pose);
    }
  }
  return result;
}

}  // namespace fl
