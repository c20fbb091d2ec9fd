// Compression test, thesis 3.5 and 4.3: a bonded block between a floor plane and a top plane
// that moves down; Young's modulus from E = F L / (A dL) (eq. 3.7).
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {
namespace {

// Least-squares slope of y over x.
double slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < x.size(); ++k) {
    sx += x[k];
    sy += y[k];
    sxx += x[k] * x[k];
    sxy += x[k] * y[k];
  }
  const double d = n * sxx - sx * sx;
  return d > 0.0 ? (n * sxy - sx * sy) / d : std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

CompressResult run_compress(const CompressParams& params) {
  dem::ModelSpec spec = make_spec(params.common);
  const double r = params.common.sub_particle_radius_m;
  const dem::FilletTemplate block =
      make_block(r, params.block_nx, params.block_ny, params.block_nz);
  const std::uint32_t equipment = equipment_type(spec);
  const double height = params.block_nz * 2.0 * r;
  // The real block is 10 mm tall and weighs ~12 g against the 5 N load: no gravity here, or
  // the soft lattice would start 4% pre-strained by its own weight.
  spec.gravity_m_per_s2 = Vec3::Zero();
  spec.planes.push_back(floor_plane(equipment));
  spec.planes.push_back({"top", equipment, Vec3(0.0, 0.0, height), -Vec3::UnitZ()});
  const double half_width = std::max(params.block_nx, params.block_ny) * r + 0.05;
  spec.domain.lower_m = Vec3(-half_width, -half_width, -0.02);
  spec.domain.upper_m = Vec3(half_width, half_width, height + 0.02);
  spec.timestep_s = choose_timestep_s(params.common, spec, block);

  CompressResult result;
  result.timestep_s = spec.timestep_s;
  result.gauge_length_m = (params.block_nz - 1) * 2.0 * r;
  result.area_m2 = params.block_nx * params.block_ny * 4.0 * r * r;
  const double disk = spec_disk_scale(spec);
  result.analytic_youngs_modulus_pa =
      std::numbers::pi * spec_stiffness(spec).normal_n_per_m3 * disk * disk * r / 2.0;

  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  add_fillet(sim, block, Eigen::Quaterniond::Identity(), 0.0, 0.0, 0.0);
  sim.prepare();
  const std::uint32_t top_plane = 1;
  const double mid_z = 0.5 * height;
  // Layers by creation order: the block template is z-major.
  const auto per_layer = static_cast<std::uint32_t>(params.block_nx * params.block_ny);
  const std::uint32_t top_first = per_layer * static_cast<std::uint32_t>(params.block_nz - 1);

  auto layer_gap = [&] {
    const dem::State& s = sim.state();
    double top = 0.0, bottom = 0.0;
    for (std::size_t k = 0; k < s.size(); ++k) {
      if (s.id[k] < per_layer) bottom += s.position_m[k].z();
      if (s.id[k] >= top_first) top += s.position_m[k].z();
    }
    return (top - bottom) / per_layer;
  };
  // Compressive force through the bonds that cross mid-height (on the upper particle, up).
  auto section_force = [&] {
    const dem::State& s = sim.state();
    double force = 0.0;
    for (std::size_t b = 0; b < s.bonds.size(); ++b) {
      const dem::Bond& bond = s.bonds[b];
      const dem::BondState& state = s.bond_states[b];
      if (state.broken) continue;
      const Vec3& xi = s.position_m[bond.i];
      const Vec3& xj = s.position_m[bond.j];
      if ((xi.z() - mid_z) * (xj.z() - mid_z) >= 0.0) continue;
      const Vec3 normal = (xi - xj).normalized();
      const Vec3 on_i = state.normal_force_n * normal + state.shear_force_n;
      force += xi.z() > xj.z() ? on_i.z() : -on_i.z();
    }
    return force;
  };
  // The particles' force on the top plate from the engine's last force evaluation (every law
  // of the chain), pushing it up: the force a load cell behind the plate reads.
  auto plate_force = [&] { return sim.state().wall_force_n[top_plane].z(); };

  const double gap0 = layer_gap();
  dem::WallState& top = sim.wall("top");
  const auto record = [&] {
    CompressSample s;
    s.time_s = sim.state().time_s;
    s.plate_travel_m = -top.translation_m.z();
    s.block_shortening_m = gap0 - layer_gap();
    s.section_force_n = section_force();
    s.plate_force_n = plate_force();
    result.series.push_back(s);
  };
  if (!params.profile_time_s.empty()) {
    const std::vector<double>& times = params.profile_time_s;
    const std::vector<double>& travels = params.profile_travel_m;
    if (travels.size() != times.size() || !std::is_sorted(times.begin(), times.end())) {
      throw std::invalid_argument(
          "compress profile: times and travels differ in length or times are not sorted");
    }
    const double dt = spec.timestep_s;
    std::size_t segment = 0;
    const auto travel_at = [&](double t) {
      while (segment + 1 < times.size() && times[segment + 1] < t) ++segment;
      if (t <= times.front()) return travels.front();
      if (segment + 1 >= times.size()) return travels.back();
      const double share = (t - times[segment]) / (times[segment + 1] - times[segment]);
      return travels[segment] + share * (travels[segment + 1] - travels[segment]);
    };
    const double start_s = times.front();
    for (std::size_t sample = 0; sample < times.size(); ++sample) {
      // Plate velocity each step lands it on the profile at the step's end: no drift.
      while (sim.state().time_s + start_s < times[sample] - 0.5 * dt) {
        const double target = travel_at(sim.state().time_s + start_s + dt);
        top.linear_velocity_m_per_s = Vec3(0.0, 0.0, -(target + top.translation_m.z()) / dt);
        sim.step(1);
      }
      record();
    }
    top.linear_velocity_m_per_s = Vec3::Zero();
    return result;
  }
  const double travel_total = params.max_strain * height;
  // Smooth start (half-cosine velocity ramp over 20% of the travel time) so that the
  // undamped bonds are not set ringing by a jump in plate speed.
  const double ramp_s = 0.2 * travel_total / params.speed_m_per_s;
  const double run_s = travel_total / params.speed_m_per_s + 0.5 * ramp_s;
  const auto samples = static_cast<std::size_t>(std::max(10, params.samples));
  const auto steps_per_sample = static_cast<std::size_t>(
      std::max(1.0, std::ceil(run_s / spec.timestep_s / static_cast<double>(samples))));
  for (std::size_t sample = 0; sample < samples; ++sample) {
    for (std::size_t k = 0; k < steps_per_sample; ++k) {
      const double t = sim.state().time_s;
      const double share = t < ramp_s ? 0.5 * (1.0 - std::cos(std::numbers::pi * t / ramp_s)) : 1.0;
      top.linear_velocity_m_per_s = Vec3(0.0, 0.0, -params.speed_m_per_s * share);
      sim.step(1);
    }
    record();
  }
  // Fit over the loading part past the ramp (strain from 20% of the maximum on).
  std::vector<double> shortening, section, travel, plate;
  for (const auto& s : result.series) {
    if (s.plate_travel_m < 0.2 * travel_total) continue;
    shortening.push_back(s.block_shortening_m);
    section.push_back(s.section_force_n);
    travel.push_back(s.plate_travel_m);
    plate.push_back(s.plate_force_n);
  }
  result.youngs_modulus_pa = slope(shortening, section) * result.gauge_length_m / result.area_m2;
  result.plate_youngs_modulus_pa = slope(travel, plate) * height / result.area_m2;
  return result;
}

}  // namespace fl::model_tests
