// Settle (damping) test, thesis 3.4.1 and 4.1.2: a meta-particle dropped on a floor; energy
// over time, the time to dampen 90/95/99% of it, intact bonds.
#include <algorithm>
#include <cmath>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {
namespace {

// Figure 3.10's basic meta-particle: 2x2x2 spheres, A/B alternating, 12 face bonds.
dem::FilletTemplate basic_cube(double radius_m) { return make_block(radius_m, 2, 2, 2); }

double lowest_bottom_m(const dem::State& s) {
  double lowest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < s.size(); ++k) {
    lowest = std::min(lowest, s.position_m[k].z() - s.radius_m[k]);
  }
  return lowest;
}

// Time after `impact` from which `kinetic` stays below `share` of `reference`.
std::optional<double> settle_time(const std::vector<EnergySample>& series, double impact_time_s,
                                  double reference_j, double share) {
  const double limit = share * reference_j;
  if (series.empty() || series.back().kinetic_j > limit) return std::nullopt;
  double last_above = impact_time_s;
  for (const auto& sample : series) {
    if (sample.time_s >= impact_time_s && sample.kinetic_j > limit) last_above = sample.time_s;
  }
  return last_above - impact_time_s;
}

}  // namespace

SettleResult run_settle(const SettleParams& params) {
  dem::ModelSpec spec = make_spec(params.common);
  if (params.restitution) {
    set_contact_parameter(spec, "hertz_mindlin", "restitution", *params.restitution, std::nullopt);
  }
  const dem::FilletTemplate body = params.body == SettleBody::kBasicCube
                                       ? basic_cube(params.common.sub_particle_radius_m)
                                       : make_fillet(params.common);
  spec.planes.push_back(floor_plane(equipment_type(spec)));
  const double reach = params.drop_height_m + 2.0 * body.half_extent_m.norm() + 0.1;
  spec.domain.lower_m = Vec3(-0.6, -0.6, -0.1);
  spec.domain.upper_m = Vec3(0.6, 0.6, reach);
  spec.timestep_s = choose_timestep_s(params.common, spec, body);

  SettleResult result;
  result.timestep_s = spec.timestep_s;
  result.bond_critical_step_s = bond_critical_step_s(spec, body);
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  std::mt19937 rng(params.common.seed);
  const Eigen::Quaterniond orientation = params.body == SettleBody::kBasicCube
                                             ? yaw_pitch_roll(0.0, 0.5, 0.3)  // lands on an edge
                                             : random_orientation(rng);
  add_fillet(sim, body, orientation, 0.0, 0.0, params.drop_height_m);
  sim.prepare();
  result.particles = sim.state().size();
  result.bonds = sim.state().bonds.size();

  const auto steps_per_sample = static_cast<std::size_t>(
      std::max(1.0, std::round(params.sample_interval_s / spec.timestep_s)));
  bool impacted = false;
  double impact_total_j = 0.0;
  auto record = [&] {
    const dem::EnergyReport e = sim.energy();
    EnergySample sample;
    sample.time_s = sim.state().time_s;
    sample.kinetic_j = kinetic_energy_j(e);
    sample.gravitational_j = e.gravitational_j;
    sample.bond_elastic_j = e.bond_elastic_j;
    sample.contact_elastic_j = e.contact_elastic_j;
    sample.total_j = e.total_j();
    sample.intact_bond_share = intact_bond_share(sim.state());
    result.series.push_back(sample);
    if (!impacted && lowest_bottom_m(sim.state()) <= 0.0) {
      impacted = true;
      result.impact_time_s = sample.time_s;
      result.impact_kinetic_j = sample.kinetic_j;
      impact_total_j = sample.total_j;
    }
    if (impacted) {
      result.energy_gain_j = std::max(result.energy_gain_j, sample.total_j - impact_total_j);
    }
  };
  record();
  // Single steps until the first contact, so the impact energy is taken at the touch.
  std::size_t since_sample = 0;
  while (!impacted && sim.state().time_s < params.duration_s) {
    sim.step(1);
    if (++since_sample == steps_per_sample || lowest_bottom_m(sim.state()) <= 0.0) {
      record();
      since_sample = 0;
    }
  }
  while (sim.state().time_s < params.duration_s) {
    sim.step(steps_per_sample);
    record();
  }
  if (impacted && result.impact_kinetic_j > 0.0) {
    result.settle_90_s =
        settle_time(result.series, result.impact_time_s, result.impact_kinetic_j, 0.10);
    result.settle_95_s =
        settle_time(result.series, result.impact_time_s, result.impact_kinetic_j, 0.05);
    result.settle_99_s =
        settle_time(result.series, result.impact_time_s, result.impact_kinetic_j, 0.01);
  }
  result.intact_bond_share = intact_bond_share(sim.state());
  return result;
}

}  // namespace fl::model_tests
