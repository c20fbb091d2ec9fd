// Sensitivity drops, thesis 3.4.2 and 4.2: impact speed, impact angle and scale against the
// share of intact bonds.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {

DropResult run_drop(const DropParams& params) {
  dem::ModelSpec spec = make_spec(params.common);
  const dem::FilletTemplate fillet = make_fillet(params.common, params.scale);
  spec.planes.push_back(floor_plane(equipment_type(spec)));
  const double size = 2.0 * fillet.half_extent_m.norm();
  spec.domain.lower_m = Vec3(-1.0, -1.0, -0.1) * std::max(1.0, size);
  spec.domain.upper_m = Vec3(1.0, 1.0, 1.0) * std::max(1.0, size + params.drop_height_m);
  DropResult result;
  result.bond_critical_step_s = bond_critical_step_s(spec, fillet);
  spec.timestep_s = params.timestep_factor_of_bond_critical
                        ? *params.timestep_factor_of_bond_critical * result.bond_critical_step_s
                        : choose_timestep_s(params.common, spec, fillet);
  result.timestep_s = spec.timestep_s;

  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  std::mt19937 rng(params.common.seed);
  const Eigen::Quaterniond orientation =
      params.orientation ? *params.orientation : random_orientation(rng);
  const bool from_height = params.drop_height_m > 0.0;
  add_fillet(sim, fillet, orientation, 0.0, 0.0, from_height ? params.drop_height_m : 0.001,
             from_height ? Vec3::Zero() : Vec3(0.0, 0.0, -params.speed_m_per_s));
  sim.prepare();
  result.particles = sim.state().size();

  const auto steps_per_sample = static_cast<std::size_t>(
      std::max(1.0, std::round(params.sample_interval_s / spec.timestep_s)));
  std::vector<std::pair<double, double>> kinetic;  // (time, J)
  double impact_time = -1.0, impact_kinetic = 0.0;
  const std::vector<double>& height_times = params.height_times_s;
  const double end_s =
      std::max(params.duration_s, height_times.empty() ? 0.0 : height_times.back());
  const double half_step_s = 0.5 * spec.timestep_s;
  std::size_t next_height = 0;
  // Heights at the requested times (to the nearest step), kinetic samples between them.
  const auto record_heights = [&] {
    while (next_height < height_times.size() &&
           sim.state().time_s >= height_times[next_height] - half_step_s) {
      result.centre_height_m.push_back(centroid_m(sim.state()).z());
      ++next_height;
    }
  };
  record_heights();
  while (sim.state().time_s < end_s - half_step_s) {
    std::size_t steps = steps_per_sample;
    if (next_height < height_times.size()) {
      const double to_next_s = height_times[next_height] - sim.state().time_s;
      steps = std::clamp<std::size_t>(
          static_cast<std::size_t>(std::max(0LL, std::llround(to_next_s / spec.timestep_s))), 1,
          steps_per_sample);
    }
    sim.step(steps);
    record_heights();
    const double share = intact_bond_share(sim.state());
    result.min_intact_bond_share = std::min(result.min_intact_bond_share, share);
    const double e = kinetic_energy_j(sim.energy());
    if (!std::isfinite(e)) break;  // blown up: nothing more to learn
    kinetic.emplace_back(sim.state().time_s, e);
    if (impact_time < 0.0) {
      double lowest = std::numeric_limits<double>::infinity();
      for (std::size_t k = 0; k < sim.state().size(); ++k) {
        lowest = std::min(lowest, sim.state().position_m[k].z() - sim.state().radius_m[k]);
      }
      if (lowest <= 0.0) {
        impact_time = sim.state().time_s;
        impact_kinetic = e;
      }
    }
  }
  result.intact_bond_share = intact_bond_share(sim.state());
  if (impact_time >= 0.0 && !kinetic.empty() && kinetic.back().second <= 0.05 * impact_kinetic) {
    double last_above = impact_time;
    for (const auto& [t, e] : kinetic) {
      if (t >= impact_time && e > 0.05 * impact_kinetic) last_above = t;
    }
    result.settle_95_s = last_above - impact_time;
  }
  return result;
}

std::vector<ImpactRow> run_impact(const ImpactParams& params) {
  std::vector<ImpactRow> rows;
  for (const Stiffness& stiffness : params.stiffness_sets) {
    for (const double speed : params.speeds_m_per_s) {
      for (int o = 0; o < params.orientations; ++o) rows.push_back({stiffness, speed, o, 1.0});
    }
  }
  parallel_for(
      rows.size(), params.threads,
      [&](std::size_t k) {
        DropParams drop = params.drop;
        drop.common.stiffness = rows[k].stiffness;
        drop.common.thread_count = 1;
        drop.common.seed =
            params.drop.common.seed + static_cast<std::uint32_t>(rows[k].orientation);
        drop.speed_m_per_s = rows[k].speed_m_per_s;
        drop.drop_height_m = 0.0;
        rows[k].intact_bond_share = run_drop(drop).intact_bond_share;
      },
      params.progress);
  return rows;
}

std::vector<AngleRow> run_angle_drop(const AngleParams& params) {
  std::vector<AngleRow> rows(static_cast<std::size_t>(std::max(0, params.samples)));
  const double tau = 2.0 * std::numbers::pi;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const auto h = hammersley3(k, rows.size());
    rows[k].yaw_rad = tau * h[0];
    rows[k].pitch_rad = tau * h[1];
    rows[k].roll_rad = tau * h[2];
  }
  parallel_for(
      rows.size(), params.threads,
      [&](std::size_t k) {
        DropParams drop = params.drop;
        drop.common.thread_count = 1;
        drop.drop_height_m = 0.0;
        drop.orientation = yaw_pitch_roll(rows[k].yaw_rad, rows[k].pitch_rad, rows[k].roll_rad);
        rows[k].intact_bond_share = run_drop(drop).intact_bond_share;
      },
      params.progress);
  return rows;
}

std::vector<ScalingRow> run_scaling(const ScalingParams& params) {
  std::vector<ScalingRow> rows;
  for (const double scale : params.scales) rows.push_back({scale, {}});
  parallel_for(
      rows.size(), params.threads,
      [&](std::size_t k) {
        DropParams drop = params.drop;
        drop.common.thread_count = 1;
        drop.scale = rows[k].scale;
        rows[k].result = run_drop(drop);
      },
      params.progress);
  return rows;
}

std::vector<DoeRow> run_doe(const DoeParams& params) {
  std::vector<DoeRow> rows;
  for (const double normal : params.normal_levels_n_per_m3) {
    for (const double shear : params.shear_levels_n_per_m3) {
      rows.push_back({{normal, shear}, {}, std::nullopt});
    }
  }
  parallel_for(
      rows.size(), params.threads,
      [&](std::size_t k) {
        SettleParams settle = params.settle;
        settle.common.stiffness = rows[k].stiffness;
        settle.common.thread_count = 1;
        rows[k].settle = run_settle(settle);
        rows[k].settle.series.clear();
        rows[k].settle.series.shrink_to_fit();
        if (params.bend) {
          BendParams bend = *params.bend;
          bend.common.stiffness = rows[k].stiffness;
          bend.common.thread_count = 1;
          rows[k].bend = run_bend(bend);
          rows[k].bend->series.clear();
        }
      },
      params.progress);
  return rows;
}

}  // namespace fl::model_tests
