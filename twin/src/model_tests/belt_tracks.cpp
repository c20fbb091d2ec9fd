// Fillets tracked on a moving belt (the workbench's line-track experiment): spawn each at its
// first sample's pose, drive the belt by the command log, report every sampled pose.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {

double logged_value_at(const std::vector<double>& time_s, const std::vector<double>& value,
                       double at_s, bool linear) {
  if (at_s <= time_s.front()) return value.front();
  if (at_s >= time_s.back()) return value.back();
  const auto after = std::upper_bound(time_s.begin(), time_s.end(), at_s);
  const auto k = static_cast<std::size_t>(after - time_s.begin());
  if (!linear) return value[k - 1];
  const double share = (at_s - time_s[k - 1]) / (time_s[k] - time_s[k - 1]);
  return value[k - 1] + share * (value[k] - value[k - 1]);
}

namespace {

double belt_speed_at(const BeltTracksParams& params, double time_s) {
  if (params.command_time_s.empty()) return 0.0;
  return logged_value_at(params.command_time_s, params.belt_speed_m_per_s, time_s);
}

// A tracked fillet: the creation numbers of its spheres (stable while the engine re-orders
// particles), and the sphere that marks its long axis.
struct Tracked {
  std::uint32_t first_id = 0;
  std::size_t spheres = 0;
  std::size_t axis_sphere = 0;  // template index of the sphere furthest along body +x
  double axis_angle_rad = 0.0;  // that sphere's angle from the centre in the body frame
  double last_yaw_rad = 0.0;    // for unwrapping
  bool spawned = false;
};

BeltPose pose_of(const dem::State& state, Tracked& fillet) {
  Vec3 sum = Vec3::Zero();
  Vec3 axis_point = Vec3::Zero();
  std::size_t found = 0;
  for (std::size_t k = 0; k < state.size(); ++k) {
    if (state.id[k] < fillet.first_id || state.id[k] >= fillet.first_id + fillet.spheres) continue;
    sum += state.position_m[k];
    if (state.id[k] == fillet.first_id + fillet.axis_sphere) axis_point = state.position_m[k];
    ++found;
  }
  if (found != fillet.spheres) throw std::logic_error("run_belt_tracks: a fillet lost spheres");
  const Vec3 centre = sum / static_cast<double>(found);
  const Vec3 to_axis = axis_point - centre;
  double yaw = std::atan2(to_axis.y(), to_axis.x()) - fillet.axis_angle_rad;
  // Unwrapped: the nearest turn to the last yaw (a fillet turns far less than half a turn
  // between two samples).
  yaw +=
      2.0 * std::numbers::pi * std::round((fillet.last_yaw_rad - yaw) / (2.0 * std::numbers::pi));
  fillet.last_yaw_rad = yaw;
  return {centre.x(), centre.y(), yaw};
}

}  // namespace

BeltTracksResult run_belt_tracks(const BeltTracksParams& params) {
  if (params.command_time_s.size() != params.belt_speed_m_per_s.size() ||
      !std::is_sorted(params.command_time_s.begin(), params.command_time_s.end())) {
    throw std::invalid_argument("run_belt_tracks: command times must be ascending, one speed each");
  }
  for (std::size_t k = 1; k < params.samples.size(); ++k) {
    if (params.samples[k].time_s < params.samples[k - 1].time_s) {
      throw std::invalid_argument("run_belt_tracks: samples must be ascending in time");
    }
  }
  dem::ModelSpec spec = make_spec(params.common);
  const dem::FilletTemplate fillet = make_fillet(params.common);
  spec.planes.push_back(floor_plane(equipment_type(spec)));
  double reach_m = 1.0;
  for (const BeltPose& pose : params.first_poses) {
    reach_m = std::max({reach_m, std::abs(pose.x_m), std::abs(pose.y_m)});
  }
  double travel_m = 0.0;  // the belt can carry a fillet at most this far
  const double end_s = params.samples.empty() ? 0.0 : params.samples.back().time_s;
  for (const double v : params.belt_speed_m_per_s) travel_m = std::max(travel_m, std::abs(v));
  travel_m *= end_s;
  spec.domain.lower_m = Vec3(-reach_m - travel_m - 1.0, -reach_m - 1.0, -0.1);
  spec.domain.upper_m = Vec3(reach_m + travel_m + 1.0, reach_m + 1.0, 0.5);
  spec.timestep_s = choose_timestep_s(params.common, spec, fillet);

  BeltTracksResult result;
  result.timestep_s = spec.timestep_s;
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  std::vector<Tracked> tracked(params.first_poses.size());
  std::size_t axis_sphere = 0;
  for (std::size_t k = 0; k < fillet.positions_m.size(); ++k) {
    if (fillet.positions_m[k].x() > fillet.positions_m[axis_sphere].x()) axis_sphere = k;
  }
  const Vec3& axis_body = fillet.positions_m[axis_sphere];
  const double axis_angle_rad = std::atan2(axis_body.y(), axis_body.x());
  std::uint32_t next_id = 0;

  const auto set_belt = [&] {
    sim.wall("floor").surface_velocity_m_per_s =
        Vec3(belt_speed_at(params, sim.state().time_s), 0.0, 0.0);
  };
  const auto advance_to = [&](double time_s) {
    const double half_step_s = 0.5 * spec.timestep_s;
    while (sim.state().time_s < time_s - half_step_s) {
      set_belt();
      const double chunk_s = std::min(params.command_interval_s, time_s - sim.state().time_s);
      sim.step(std::max<std::size_t>(
          1, static_cast<std::size_t>(std::llround(chunk_s / spec.timestep_s))));
    }
  };

  for (const BeltFilletSample& sample : params.samples) {
    if (sample.fillet >= tracked.size()) {
      throw std::invalid_argument("run_belt_tracks: sample of fillet " +
                                  std::to_string(sample.fillet) + " without a first pose");
    }
    advance_to(sample.time_s);
    Tracked& fillet_track = tracked[sample.fillet];
    if (!fillet_track.spawned) {
      const BeltPose& pose = params.first_poses[sample.fillet];
      const double speed = belt_speed_at(params, sim.state().time_s);
      // The template's origin is its spheres' centroid: placed at the pose's centre.
      add_fillet(sim, fillet, yaw_pitch_roll(pose.yaw_rad, 0.0, 0.0), pose.x_m, pose.y_m, 0.0,
                 Vec3(speed, 0.0, 0.0));
      fillet_track = {next_id, fillet.positions_m.size(), axis_sphere, axis_angle_rad, pose.yaw_rad,
                      true};
      next_id += static_cast<std::uint32_t>(fillet.positions_m.size());
      set_belt();
      sim.prepare();
    }
    const BeltPose pose = pose_of(sim.state(), fillet_track);
    if (!std::isfinite(pose.x_m) || !std::isfinite(pose.yaw_rad)) break;  // blown up
    result.poses.push_back(pose);
  }
  result.particles = sim.state().size();
  return result;
}

}  // namespace fl::model_tests
