// Slide test, thesis 3.4.1 figure 3.12 and 4.1.4: a fillet on a one-metre plate (a box) that
// is tilted slowly; the plate angle at which the fillet starts to slide.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "fl/twin/model_tests/model_tests.hpp"

namespace fl::model_tests {

SlideResult run_slide(const SlideParams& params) {
  CommonParams common = params.common;
  if (params.rigid) common.stiffness = params.rigid_stiffness;
  dem::ModelSpec spec = make_spec(common);
  const std::uint32_t equipment = equipment_type(spec);
  set_friction_coefficient(spec, params.friction_coefficient, equipment);
  // A model without adhesion has no jkr in the chain: it slides at zero surface energy, and
  // only a sweep that asks for adhesion needs one.
  const bool has_jkr = has_fillet_contact_law(spec, "jkr", equipment);
  if (has_jkr) {
    set_contact_parameter(spec, "jkr", "surface_energy_j_per_m2", params.surface_energy_j_per_m2,
                          equipment);
  } else if (params.surface_energy_j_per_m2 != 0.0) {
    throw std::invalid_argument(
        "slide: the fillet-equipment contact laws have no jkr to take a surface energy of " +
        std::to_string(params.surface_energy_j_per_m2) +
        " J/m^2; add one after hertz_mindlin, or slide at 0");
  }
  const dem::FilletTemplate fillet = make_fillet(common);
  // Plate top at z = 0 through the pivot (origin), long along x; tilting about +y lowers +x.
  spec.meshes.push_back(dem::box_mesh_wall(
      "plate", equipment,
      Vec3(-0.5 * params.plate_length_m, -0.5 * params.plate_width_m, -params.plate_thickness_m),
      Vec3(0.5 * params.plate_length_m, 0.5 * params.plate_width_m, 0.0)));
  spec.domain.lower_m = Vec3(-0.8, -0.5, -0.8);
  spec.domain.upper_m = Vec3(0.8, 0.5, 0.8);
  spec.timestep_s = choose_timestep_s(common, spec, fillet);

  SlideResult result;
  result.timestep_s = spec.timestep_s;
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  add_fillet(sim, fillet, yaw_pitch_roll(params.placement_yaw_rad, 0.0, 0.0), 0.0, 0.0, 0.0005);
  if (params.rigid) {
    // bpm has no bending moment: bonded neighbours can counter-rotate like gears and the
    // clump rolls instead of sliding (see DemFriction in twin/tests/dem). A solid body's
    // spheres do not spin on their own.
    for (double& inverse : sim.mutable_state().inverse_inertia_per_kg_m2) inverse = 0.0;
  }
  sim.step(static_cast<std::size_t>(std::ceil(params.settle_s / spec.timestep_s)));

  const double rate_rad_per_s = params.tilt_rate_deg_per_s * std::numbers::pi / 180.0;
  dem::WallState& plate = sim.wall("plate");
  plate.angular_velocity_rad_per_s = Vec3(0.0, rate_rad_per_s, 0.0);
  const double tilt_start_s = sim.state().time_s;
  auto along_plate = [&] {
    const Vec3 c = centroid_m(sim.state());
    return (plate.rotation.conjugate() * c).x();  // pivot at the origin, never translated
  };
  const double x0 = along_plate();
  const double max_rad = params.max_angle_deg * std::numbers::pi / 180.0;
  // Sample every 0.05 degrees of tilt: the angle resolution of the result.
  const auto steps_per_sample = static_cast<std::size_t>(
      std::max(1.0, std::round(0.05 / params.tilt_rate_deg_per_s / spec.timestep_s)));
  while (true) {
    sim.step(steps_per_sample);
    const double angle_rad = rate_rad_per_s * (sim.state().time_s - tilt_start_s);
    const double travel = along_plate() - x0;
    result.series.push_back({sim.state().time_s, angle_rad * 180.0 / std::numbers::pi, travel});
    if (!result.slide_angle_deg && travel >= params.slide_distance_m) {
      result.slide_angle_deg = angle_rad * 180.0 / std::numbers::pi;
      break;
    }
    if (angle_rad >= max_rad) break;
  }
  result.intact_bond_share = intact_bond_share(sim.state());
  return result;
}

}  // namespace fl::model_tests
