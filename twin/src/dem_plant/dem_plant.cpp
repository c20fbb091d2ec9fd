// DemPlant: construction (fillet templates, the engine model with the machinery as walls),
// reset, the step loop, the particle pass, rigid poses, exits and taking fillets out.
#include "fl/twin/dem_plant/dem_plant.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "fl/twin/dem/body_fit.hpp"
#include "fl/twin/dem/fillet_bend.hpp"
#include "fl/twin/dem/fillet_generator.hpp"

namespace fl {
namespace {

using dem::Vec3;

std::int64_t to_ns(double seconds) { return std::llround(seconds * 1e9); }
constexpr double kMm = 1e-3;

std::int64_t control_step_ns(const DemPlantConfig& config) {
  return std::max<std::int64_t>(1, to_ns(config.simulation.control_step_s));
}

// A rectangle as two triangles (corners in order around it).
void add_quad(dem::MeshWallSpec& mesh, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  mesh.triangles.push_back({{a, b, c}});
  mesh.triangles.push_back({{a, c, d}});
}

// A belt or plate from (x0, z0) to (x1, z1) along the line, across y0..y1.
dem::MeshWallSpec slope_rect(std::string name, std::uint32_t type, double x0, double z0, double x1,
                             double z1, double y0, double y1) {
  dem::MeshWallSpec mesh{std::move(name), type, {}};
  add_quad(mesh, Vec3(x0, y0, z0), Vec3(x1, y0, z1), Vec3(x1, y1, z1), Vec3(x0, y1, z0));
  return mesh;
}

dem::MeshWallSpec belt_rect(std::string name, std::uint32_t type, double x0, double x1, double y0,
                            double y1) {
  return slope_rect(std::move(name), type, x0, 0.0, x1, 0.0, y0, y1);
}

// A vertical wall along the segment (x0, y0) -> (x1, y1) from z0 to z1.
void add_fence(dem::MeshWallSpec& mesh, double x0, double y0, double x1, double y1, double z0,
               double z1) {
  add_quad(mesh, Vec3(x0, y0, z0), Vec3(x1, y1, z0), Vec3(x1, y1, z1), Vec3(x0, y0, z1));
}

}  // namespace

DemPlant::PlateLayout DemPlant::plate_layout() const {
  const DemMachineryConfig& m = config_.machinery;
  PlateLayout p;
  p.start_m = line_.sections[index(DriveId::kGuide)].end_mm * kMm;
  p.end_m = line_.sections[index(DriveId::kReject)].start_mm * kMm;
  p.top_z_m = m.plate1_drop_mm * kMm;
  p.end_z_m = m.plate1_end_height_mm * kMm;
  p.upstream_z_m = p.top_z_m - m.guide_rise_mm * kMm;
  const double gap_m = 0.5 * m.belt_gap_mm * kMm;
  const double right_m = -m.belt_half_width_mm * kMm;
  p.hinge_m = Vec3(p.start_m + gap_m, right_m, p.top_z_m);
  p.plate_end_m = Vec3(p.end_m - gap_m, right_m, p.end_z_m);
  p.slide_direction = (p.plate_end_m - p.hinge_m).normalized();
  return p;
}

double DemPlant::deck_z_m(double s_m) const {
  const PlateLayout p = plate_layout();
  const double guide_start_m = line_.sections[index(DriveId::kGuide)].start_mm * kMm;
  const auto ramp = [](double s, double s0, double z0, double s1, double z1) {
    return z0 + (z1 - z0) * std::clamp((s - s0) / (s1 - s0), 0.0, 1.0);
  };
  if (s_m <= guide_start_m) return p.upstream_z_m;
  if (s_m <= p.start_m) return ramp(s_m, guide_start_m, p.upstream_z_m, p.start_m, p.top_z_m);
  if (s_m <= p.end_m) return ramp(s_m, p.start_m, p.top_z_m, p.end_m, p.end_z_m);
  return 0.0;
}

double DemPlant::deck_slope(double s_m) const {
  constexpr double kHalfBaseM = 0.001;  // central difference: a kink reads as the mean slope
  return (deck_z_m(s_m + kHalfBaseM) - deck_z_m(s_m - kHalfBaseM)) / (2.0 * kHalfBaseM);
}

std::shared_ptr<const dem::Model> DemPlant::build_model() const {
  dem::ModelSpec spec = config_.engine;
  const auto equipment = [&]() -> std::uint32_t {
    for (std::uint32_t t = 0; t < spec.types.size(); ++t) {
      if (spec.types[t].name == "equipment") return t;
    }
    throw std::invalid_argument("dem plant: the engine model has no type 'equipment'");
  }();
  if (spec.types.size() < 2 || spec.types[dem::kFilletTypeA].name != "fillet_a" ||
      spec.types[dem::kFilletTypeB].name != "fillet_b") {
    throw std::invalid_argument("dem plant: engine types 0 and 1 must be fillet_a and fillet_b");
  }
  const double radius_m = config_.simulation.sub_particle_radius_mm * kMm;
  const dem::Material& fillet = spec.materials[spec.types[dem::kFilletTypeA].material];
  spec.timestep_s = config_.simulation.rayleigh_fraction *
                    dem::rayleigh_time_s(radius_m, fillet.density_kg_per_m3,
                                         fillet.youngs_modulus_pa, fillet.poisson_ratio);
  spec.neighbor_skin_m = config_.simulation.neighbor_skin_mm * kMm;
  spec.thread_count = config_.simulation.thread_count;
  spec.min_particles_per_thread = config_.simulation.min_particles_per_thread;
  spec.planes.clear();  // planes are infinite: the line is built of finite meshes only
  spec.meshes.clear();

  const DemMachineryConfig& m = config_.machinery;
  const double half_w = m.belt_half_width_mm * kMm;
  const double gap = 0.5 * m.belt_gap_mm * kMm;
  const double start_m = -static_cast<double>(line_.takt_belt_length_mm) * kMm;
  const double end_m = line_.placed_at_s_mm * kMm;
  spec.domain.lower_m = Vec3(start_m - 0.2, -half_w - 0.3, -0.2);
  spec.domain.upper_m = Vec3(end_m + 0.3, half_w + 0.3, 0.4 + plate_layout().top_z_m);

  auto self = const_cast<DemPlant*>(this);  // wall indices are recorded with the model
  self->wall_belt_.assign(kDriveCount, static_cast<std::size_t>(-1));
  const double ml_gap = 0.5 * m.multilane_gap_mm * kMm;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const auto id = static_cast<DriveId>(d);
    if (!has_section(id)) continue;
    const BeltSection& section = line_.sections[d];
    if (!(section.end_mm > section.start_mm)) continue;
    const double x0 = section.start_mm * kMm + (id == DriveId::kTakt ? 0.0 : gap);
    const double x1 = section.end_mm * kMm - (id == DriveId::kOutfeed ? 0.0 : gap);
    if (const DriveId right = carrying_partner(id); right != id) {  // a multilane unit
      self->wall_belt_[d] = spec.meshes.size();
      spec.meshes.push_back(
          belt_rect("belt_left_" + std::to_string(d), equipment, x0, x1, ml_gap, half_w));
      self->wall_belt_[index(right)] = spec.meshes.size();
      spec.meshes.push_back(
          belt_rect("belt_right_" + std::to_string(d), equipment, x0, x1, -half_w, -ml_gap));
      continue;
    }
    self->wall_belt_[d] = spec.meshes.size();
    // Each belt at its level; the guide rises from the upstream level to its raised end.
    const double z0 = deck_z_m(x0);
    const double z1 = deck_z_m(x1);
    spec.meshes.push_back(
        slope_rect("belt_" + std::to_string(d), equipment, x0, z0, x1, z1, -half_w, half_w));
  }
  // Flip plates (see the header): plate 1 a slide over the whole section from the guide's
  // raised end down to the reject belt, hinged along the belt's right edge to swing up out of
  // the way; under it the landing, at the reject belt's level, catches a fillet that falls.
  const PlateLayout plates = plate_layout();
  self->wall_plate1_ = spec.meshes.size();
  spec.meshes.push_back(slope_rect("flip_plate1", equipment, plates.hinge_m.x(), plates.hinge_m.z(),
                                   plates.plate_end_m.x(), plates.plate_end_m.z(),
                                   plates.hinge_m.y(), half_w));
  self->wall_landing_ = spec.meshes.size();
  spec.meshes.push_back(belt_rect("flip_plates_landing", equipment, plates.start_m + gap,
                                  plates.end_m - gap, -half_w, half_w));

  // Side walls along the whole line and an end wall behind the takt belt.
  {
    dem::MeshWallSpec walls{"side_walls", equipment, {}};
    const double h = m.side_wall_height_mm * kMm + plates.top_z_m;
    add_fence(walls, start_m, half_w, end_m + 0.1, half_w, 0.0, h);
    add_fence(walls, start_m, -half_w, end_m + 0.1, -half_w, 0.0, h);
    add_fence(walls, start_m, -half_w, start_m, half_w, 0.0, h);
    spec.meshes.push_back(std::move(walls));
  }
  // Guide rails: funnel from the belt edges to the channel, then straight to the guide's end.
  {
    dem::MeshWallSpec rails{"guide_rails", equipment, {}};
    const double g0 = line_.sections[index(DriveId::kGuide)].start_mm * kMm;
    const double g1 = line_.sections[index(DriveId::kGuide)].end_mm * kMm;
    const double funnel_end = std::min(g1, g0 + m.rail_funnel_length_mm * kMm);
    const double channel = m.rail_channel_half_width_mm * kMm;
    const double h = m.rail_height_mm * kMm + plates.top_z_m;
    for (const double sign : {1.0, -1.0}) {
      add_fence(rails, g0, sign * half_w, funnel_end, sign * channel, 0.0, h);
      add_fence(rails, funnel_end, sign * channel, g1, sign * channel, 0.0, h);
    }
    spec.meshes.push_back(std::move(rails));
  }
  // Centring pusher (or the first of the two jaws): a plate in the x-z plane at y = 0, moved
  // sideways by its wall state.
  {
    dem::MeshWallSpec pusher{"centring_pusher", equipment, {}};
    const double cs = line_.centring.s_mm * kMm;
    const double half_len = (m.centring_unit == DemCentringUnit::kJaws ? m.jaw_half_length_mm
                                                                       : m.pusher_half_length_mm) *
                            kMm;
    add_fence(pusher, cs - half_len, 0.0, cs + half_len, 0.0, 0.002,
              0.002 + m.pusher_height_mm * kMm);
    dem::MeshWallSpec jaw{"centring_jaw", equipment, pusher.triangles};
    self->wall_pusher_ = spec.meshes.size();
    spec.meshes.push_back(std::move(pusher));
    // The second jaw, parked unless the unit is built as jaws (the pusher is the first).
    self->wall_jaw_ = spec.meshes.size();
    spec.meshes.push_back(std::move(jaw));
  }
  // Squeeze roller: the lateral surface of a cylinder across the belt (axis along y).
  {
    dem::MeshWallSpec roller{"squeeze_roller", equipment, {}};
    const double rs = line_.squeeze.roller_s_mm * kMm;
    const double r = m.roller_radius_mm * kMm;
    const double zc = m.roller_up_gap_mm * kMm + r;
    const int n = m.roller_segments;
    for (int k = 0; k < n; ++k) {
      const double a0 = 2.0 * std::numbers::pi * k / n;
      const double a1 = 2.0 * std::numbers::pi * (k + 1) / n;
      const Vec3 p0(rs + r * std::sin(a0), 0.0, zc - r * std::cos(a0));
      const Vec3 p1(rs + r * std::sin(a1), 0.0, zc - r * std::cos(a1));
      const Vec3 side(0.0, half_w, 0.0);
      add_quad(roller, p0 - side, p1 - side, p1 + side, p0 + side);
    }
    self->wall_roller_ = spec.meshes.size();
    spec.meshes.push_back(std::move(roller));
  }
  return std::make_shared<const dem::Model>(std::move(spec));
}

DemPlant::DemPlant(const LineConfig& line, const DemPlantConfig& config)
    : line_(line),
      config_(config),
      step_ns_(control_step_ns(config)),
      drives_(line.limits, static_cast<double>(config.shared.belts.drive_delay_s)),
      cameras_(line.cameras, config.shared.cameras, control_step_ns(config)) {
  if (config_.simulation.max_fillets == 0) throw std::invalid_argument("max_fillets must be > 0");
  templates_ = dem::thesis_fillet_templates(config_.simulation.sub_particle_radius_mm * kMm);
  for (const dem::FilletTemplate& t : templates_) {
    std::vector<dem::BodyBond> bonds;
    bonds.reserve(t.bonds.size());
    for (const dem::FilletBond& b : t.bonds) {
      bonds.push_back({b.i, b.j, b.contact_radius_m, b.thickness_m});
    }
    template_bonds_.push_back(std::move(bonds));
    pair_offset_m_.push_back(
        {pair_partner_offset_m(t, SideUp::kSkin), pair_partner_offset_m(t, SideUp::kBone)});
  }
  model_ = build_model();
  check_timestep();
  exits_.resize(std::max<std::size_t>(config_.simulation.exit_capacity, 1));
  InputImage scratch{};
  reset(0, scratch);
}

DemPlant::~DemPlant() = default;

void DemPlant::check_timestep() const {
  // The line starts empty, so the engine's check runs on a probe holding one fillet of each
  // variant, apart and at rest: the bonds and contacts the run will have. A timestep the
  // stiffnesses cannot carry (dem.yaml's bonds made much stiffer, a larger Rayleigh fraction)
  // would run, and give numbers, unstable: refused here, naming the numbers.
  dem::Simulation probe(model_);
  const Vec3 lower = model_->spec().domain.lower_m;
  for (std::size_t v = 0; v < templates_.size(); ++v) {
    const dem::FilletTemplate& t = templates_[v];
    dem::BodyPose pose;
    pose.position_m = lower + Vec3(0.3 * static_cast<double>(v + 1), 0.3, 0.3);
    (void)probe.add_body(t.positions_m, t.radii_m, t.types, template_bonds_[v], pose);
  }
  const dem::TimestepReport report = probe.check_timestep();
  // Refused where the run would be unstable, with a factor of 2 to spare (explicit integration
  // diverges from dt = 2/omega on), or beyond EDEM's 40 % of the Rayleigh time. Between a fifth
  // and half of 2/omega the run is stable, its oscillations less accurate than the engine's
  // check asks: a coarse, fast line is the engineer's choice, so it runs.
  const double critical_s = std::min(report.bond_critical_step_s, report.contact_critical_step_s);
  const bool unstable = report.timestep_s > 0.5 * critical_s;
  if (unstable || report.rayleigh_fraction > 0.4) {
    throw std::invalid_argument(
        std::string("dem plant: ") +
        (unstable ? "the timestep is over half the critical step 2/omega, unstable: " : "") +
        report.message +
        " (lower simulation.rayleigh_fraction in the plant config, or the stiffnesses in the "
        "engine config)");
  }
}

double DemPlant::engine_timestep_s() const { return model_->spec().timestep_s; }

void DemPlant::reset(std::uint64_t seed, InputImage& in) {
  sim_ = std::make_unique<dem::Simulation>(model_);
  dem::State& state = sim_->mutable_state();
  const DemMachineryConfig& m = config_.machinery;
  // Pusher parked outside the side wall; roller pivots about its own axis.
  state.walls[wall_pusher_].translation_m = Vec3(0.0, m.belt_half_width_mm * kMm + 0.15, 0.0);
  state.walls[wall_jaw_].translation_m = Vec3(0.0, -(m.belt_half_width_mm * kMm + 0.15), 0.0);
  state.walls[wall_roller_].pivot_m =
      Vec3(line_.squeeze.roller_s_mm * kMm, 0.0, (m.roller_up_gap_mm + m.roller_radius_mm) * kMm);
  state.walls[wall_plate1_].pivot_m = plate_layout().hinge_m;
  sim_->prepare();

  counters_ = DemPlantCounters{};
  faults_ = DemPlantFaults{};
  time_ns_ = 0;
  drives_.reset();
  stations_ = Stations{};
  infeed_ = Infeed{};
  fillets_.clear();
  fillet_of_body_.clear();
  exit_count_ = 0;
  exits_drained_ = 0;
  last_plant_id_ = 0;
  last_group_id_ = 0;
  beam_ = false;
  feed_rng_.seed_with(stream_seed(seed, 1));
  body_rng_.seed_with(stream_seed(seed, 2));
  sensor_rng_.seed_with(stream_seed(seed, 3));
  const FastInfeedConfig& infeed = config_.shared.infeed;
  infeed_.hopper_opening_mm = std::clamp(static_cast<double>(infeed.hopper_initial_opening_mm),
                                         static_cast<double>(infeed.hopper_min_opening_mm),
                                         static_cast<double>(infeed.hopper_max_opening_mm));
  if (config_.feeder.source == DemInfeedSource::kDemBulkEnd) {
    start_bulk_end(seed);
  } else {
    bulk_.reset();
  }
  draw_next_feed();
  std::memset(static_cast<void*>(&image_), 0, sizeof(image_));
  cameras_.reset(seed, time_ns_);
  write_image(in);
}

void DemPlant::step(const OutputImage& out, std::int64_t dt_ns, InputImage& in) {
  if (exits_drained_ > 0) {
    const std::size_t left = exit_count_ - exits_drained_;
    for (std::size_t i = 0; i < left; ++i) exits_[i] = exits_[exits_drained_ + i];
    exit_count_ = left;
    exits_drained_ = 0;
  }
  drives_.command(out.drives, time_ns_);
  std::int64_t remaining = dt_ns;
  while (remaining > 0) {
    const std::int64_t h_ns = std::min(remaining, step_ns_);
    control_step(h_ns, out);
    remaining -= h_ns;
  }
  cameras_.publish(time_ns_, faults_.cameras, image_.cameras);
  write_image(in);
}

// The fillets as the cameras see them, in the plant's order; pose and contact are computed
// only for a fillet in a camera's view (an SVD and a sphere-pair scan each).
class DemPlant::FilletScene final : public CameraScene {
 public:
  explicit FilletScene(const DemPlant& plant) : plant_(plant) {}
  [[nodiscard]] std::size_t size() const override { return plant_.fillets_.size(); }
  [[nodiscard]] double s_mm(std::size_t item) const override {
    const Fillet& fillet = plant_.fillets_[item];
    // A fillet without spheres (taken out this step) is in no camera's view.
    if (fillet.particles.empty()) return std::numeric_limits<double>::infinity();
    return fillet.centroid_m.x() / kMm;
  }
  [[nodiscard]] CameraTruth truth(std::size_t item) const override {
    const Fillet& fillet = plant_.fillets_[item];
    const Pose pose = plant_.fit_pose(fillet);
    return {fillet.centroid_m.y() / kMm, pose.angle_rad, plant_.hand_of(fillet), pose.side,
            plant_.touching(item)};
  }

 private:
  const DemPlant& plant_;
};

Hand DemPlant::hand_of(const Fillet& fillet) const {
  return templates_[fillet.variant].name.ends_with("_left") ? Hand::kLeft : Hand::kRight;
}

void DemPlant::control_step(std::int64_t h_ns, const OutputImage& out) {
  const double h_s = static_cast<double>(h_ns) * 1e-9;
  // The safety chain cuts every drive (STO).
  drives_.step(time_ns_, h_s, faults_.drive_fault, !faults_.estop_open);
  step_stations(h_s, out);
  command_walls(h_s);
  // The engine runs whole steps up to the control step's end (its clock never runs ahead by
  // more than half a step).
  const double target_s = static_cast<double>(time_ns_ + h_ns) * 1e-9;
  const double steps = std::floor((target_s - sim_->state().time_s) / engine_timestep_s() + 0.5);
  if (steps > 0.0) {
    sim_->step(static_cast<std::size_t>(steps));
    counters_.engine_steps += static_cast<std::uint64_t>(steps);
  }
  time_ns_ += h_ns;
  scan_particles();
  apply_events(out);
  step_infeed(h_s, out);
  beam_ = beam_broken();
  cameras_.capture_due(time_ns_, FilletScene(*this), faults_.cameras);
}

// ---------------------------------------------------------------- particles and poses

void DemPlant::scan_particles() {
  dem::gather_sphere_groups(sim_->state(), fillet_of_body_, fillets_);
}

DemPlant::Pose DemPlant::fit_pose(const Fillet& fillet) const {
  // Least-squares rotation of the template onto the spheres (Kabsch): H = sum p (x - c)^T.
  Pose pose;
  pose.rotation = dem::fit_template_rotation(
      sim_->state(), fillet.particles, templates_[fillet.variant], fillet.first_id,
      fillet.centroid_m, "dem plant: fillet " + std::to_string(fillet.plant_id));
  // Body x runs from the thick end to the tip; body z is the skin side's normal.
  pose.angle_rad = wrap_angle_rad(std::atan2(pose.rotation(1, 0), pose.rotation(0, 0)));
  pose.side = pose.rotation(2, 2) >= 0.0 ? SideUp::kSkin : SideUp::kBone;
  return pose;
}

double DemPlant::in_plane_bend_per_mm(const Fillet& fillet, const Pose& pose) const {
  const dem::State& s = sim_->state();
  const dem::FilletTemplate& t = templates_[fillet.variant];
  dem::InPlaneBendFit fit(pose.rotation);
  // fit_pose has checked every index of this scan.
  for (const std::uint32_t k : fillet.particles) {
    fit.add(t.positions_m[s.id[k] - fillet.first_id], s.position_m[k] - fillet.centroid_m);
  }
  return fit.curvature_per_m() * kMm;
}

bool DemPlant::touching(std::size_t f) const {
  // A sphere of this fillet within contact (plus 0.5 mm for the soft overlap's rounding) of a
  // sphere of another: JKR holds touching fillets together, so contact is what a camera sees.
  constexpr double kToleranceM = 0.0005;
  const dem::State& s = sim_->state();
  const Fillet& a = fillets_[f];
  for (std::size_t g = 0; g < fillets_.size(); ++g) {
    if (g == f) continue;
    const Fillet& b = fillets_[g];
    if ((a.lower_m.array() > b.upper_m.array() + kToleranceM).any() ||
        (b.lower_m.array() > a.upper_m.array() + kToleranceM).any()) {
      continue;
    }
    for (const std::uint32_t i : a.particles) {
      for (const std::uint32_t j : b.particles) {
        const double reach = s.radius_m[i] + s.radius_m[j] + kToleranceM;
        if ((s.position_m[i] - s.position_m[j]).squaredNorm() < reach * reach) return true;
      }
    }
  }
  return false;
}

bool DemPlant::beam_broken() const {
  // The beam runs across the belt at s = 0 and beam height: any sphere crossing it.
  const dem::State& s = sim_->state();
  const double beam_z = deck_z_m(0.0) + config_.machinery.beam_height_mm * kMm;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double dx = s.position_m[k].x();
    const double dz = s.position_m[k].z() - beam_z;
    const double r = s.radius_m[k];
    if (dx * dx + dz * dz < r * r) return true;
  }
  return false;
}

std::uint32_t DemPlant::add_fillet(std::uint8_t variant, SideUp side,
                                   const Eigen::Vector3d& centroid_m, double angle_rad,
                                   double v_mps, std::uint32_t group_id) {
  const dem::FilletTemplate& t = templates_[variant];
  dem::BodyPose pose;
  pose.position_m = centroid_m;
  // Bone side up: the template turned over about its length axis (heading unchanged).
  // Lying on the deck: pitched to its slope (the guide rises, the plates fall).
  const double slope = deck_slope(centroid_m.x());
  const double pitch_rad = -std::atan(slope);
  pose.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(pitch_rad, Vec3::UnitY()) *
                                        Eigen::AngleAxisd(angle_rad, Vec3::UnitZ()));
  if (side == SideUp::kBone) {
    pose.orientation = pose.orientation * Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX());
  }
  pose.velocity_m_per_s = v_mps * Vec3(1.0, 0.0, slope).normalized();
  const std::size_t first = sim_->state().size();
  const std::uint32_t body =
      sim_->add_body(t.positions_m, t.radii_m, t.types, template_bonds_[variant], pose);
  Fillet f;
  f.plant_id = ++last_plant_id_;
  f.group_id = group_id;
  f.variant = variant;
  f.body = body;
  f.first_id = sim_->state().id[first];
  f.centroid_m = centroid_m;
  f.previous_s_m = centroid_m.x();
  f.progress_s_m = centroid_m.x();
  f.progress_ns = time_ns_;
  if (centroid_m.x() >= 0.0) {
    f.fed = true;
    ++counters_.fillets_fed;
  }
  f.thick_passed_roller = centroid_m.x() > line_.squeeze.roller_s_mm * kMm;
  if (fillet_of_body_.size() <= body) fillet_of_body_.resize(body + 1, -1);
  fillet_of_body_[body] = static_cast<std::int32_t>(fillets_.size());
  fillets_.push_back(std::move(f));
  ++counters_.fillets_spawned;
  return fillets_.back().plant_id;
}

double DemPlant::pair_partner_offset_m(const dem::FilletTemplate& t, SideUp side) {
  // The partner's offset where the closest two spheres touch with 0.1 mm overlap, so that the
  // JKR neck forms and holds the pair together.
  const double contact_m = 2.0 * t.radii_m.front();
  const double flip = side == SideUp::kBone ? -1.0 : 1.0;  // turned over: y -> -y
  double offset_m = 0.0;
  for (const Vec3& a : t.positions_m) {
    for (const Vec3& b : t.positions_m) {
      const double dx = a.x() - b.x();
      const double dz = a.z() - b.z();
      const double rest = contact_m * contact_m - dx * dx - dz * dz;
      if (rest > 0.0) offset_m = std::max(offset_m, flip * (a.y() - b.y()) + std::sqrt(rest));
    }
  }
  return offset_m - 0.0001;
}

double DemPlant::pair_offset_m(std::uint8_t variant, SideUp side) const {
  return pair_offset_m_[variant][side == SideUp::kBone ? 1 : 0];
}

std::optional<std::uint32_t> DemPlant::spawn_fillet(const DemFilletSpawn& spawn) {
  const std::size_t members = spawn.touching_pair ? 2 : 1;
  if (fillets_.size() + members > config_.simulation.max_fillets) return std::nullopt;
  const std::uint8_t variant =
      std::min<std::uint8_t>(spawn.variant, static_cast<std::uint8_t>(templates_.size() - 1));
  const dem::FilletTemplate& t = templates_[variant];
  const double lift_m = config_.feeder.spawn_lift_mm * kMm;
  const std::uint32_t group = ++last_group_id_;
  const double s_m = spawn.s_mm * kMm;
  const double slope = deck_slope(s_m);
  const Vec3 centre(s_m, spawn.y_mm * kMm,
                    deck_z_m(s_m) + t.half_extent_m.z() * std::sqrt(1.0 + slope * slope) + lift_m);
  add_fillet(variant, spawn.side, centre, spawn.angle_rad, spawn.v_mps, group);
  if (spawn.touching_pair) {
    // Side by side to the fillet's left, at the offset where the closest two spheres touch
    // with 0.1 mm overlap, so that the JKR neck forms and holds the pair together.
    const Vec3 left(-std::sin(spawn.angle_rad), std::cos(spawn.angle_rad), 0.0);
    add_fillet(variant, spawn.side, centre + pair_offset_m(variant, spawn.side) * left,
               spawn.angle_rad, spawn.v_mps, group);
  }
  scan_particles();
  return group;
}

// ---------------------------------------------------------------- exits and removal

void DemPlant::record_exit(const Fillet& fillet, TrueExit exit) {
  if (!fillet.fed) {
    ++counters_.unfed_losses;
    return;
  }
  ++counters_.exits[static_cast<std::size_t>(exit)];
  if (exit_count_ >= exits_.size()) {
    ++counters_.exits_not_recorded;
    return;
  }
  const Pose pose = fit_pose(fillet);
  const auto f = static_cast<std::size_t>(&fillet - fillets_.data());
  TrueFilletExit& record = exits_[exit_count_++];
  record = TrueFilletExit{};
  record.plant_id = fillet.plant_id;
  record.group_id = fillet.group_id;
  record.time_ns = time_ns_;
  record.exit = exit;
  record.hand = hand_of(fillet);
  record.side = pose.side;
  record.angle_rad = static_cast<float>(pose.angle_rad);
  record.y_mm = static_cast<float>(fillet.centroid_m.y() / kMm);
  record.singulated = !touching(f);
  record.squeezed_ok = fillet.squeezed_ok;
}

void DemPlant::take_out_removed() {
  std::vector<std::uint32_t> bodies;
  for (const Fillet& f : fillets_) {
    if (f.remove) bodies.push_back(f.body);
  }
  if (bodies.empty()) return;
  sim_->remove_bodies(bodies);
  std::erase_if(fillets_, [](const Fillet& f) { return f.remove; });
  std::uint32_t body_end = 0;
  for (const Fillet& f : fillets_) body_end = std::max(body_end, f.body + 1);
  fillet_of_body_.assign(body_end, -1);
  for (std::size_t f = 0; f < fillets_.size(); ++f) {
    fillet_of_body_[fillets_[f].body] = static_cast<std::int32_t>(f);
  }
  ++counters_.rebuilds;
  scan_particles();
}

std::span<const TrueFilletExit> DemPlant::drain_exits() {
  const std::span<const TrueFilletExit> fresh(exits_.data() + exits_drained_,
                                              exit_count_ - exits_drained_);
  exits_drained_ = exit_count_;
  return fresh;
}

std::uint64_t DemPlant::fillets_on_line() const {
  std::uint64_t count = 0;
  for (const Fillet& f : fillets_) count += f.fed && !f.remove ? 1 : 0;
  return count;
}

std::vector<DemFilletView> DemPlant::fillets() const {
  std::vector<DemFilletView> views;
  for (std::size_t f = 0; f < fillets_.size(); ++f) {
    const Fillet& fillet = fillets_[f];
    const Pose pose = fit_pose(fillet);
    DemFilletView v;
    v.plant_id = fillet.plant_id;
    v.group_id = fillet.group_id;
    v.hand = hand_of(fillet);
    // thesis_fillet_variants() lists each table 3.1 size left, then right.
    v.size_variant = static_cast<std::uint8_t>(fillet.variant / 2);
    v.side = pose.side;
    v.s_mm = fillet.centroid_m.x() / kMm;
    v.y_mm = fillet.centroid_m.y() / kMm;
    v.z_mm = fillet.centroid_m.z() / kMm;
    v.angle_rad = pose.angle_rad;
    v.bend_per_mm = in_plane_bend_per_mm(fillet, pose);
    v.v_mps = fillet.velocity_m_per_s.x();
    v.min_s_mm = fillet.lower_m.x() / kMm;
    v.max_s_mm = fillet.upper_m.x() / kMm;
    v.fed = fillet.fed;
    v.touching = touching(f);
    v.spheres = fillet.particles.size();
    views.push_back(v);
  }
  return views;
}

// ---------------------------------------------------------------- input image

void DemPlant::write_image(InputImage& in) {
  InputImage& image = image_;
  image.time_ns = time_ns_;
  drives_.write(image.drives);
  infeed_.level_reading_mm = level_mm();
  image.takt_beam_broken = beam_;
  image.level_mm = static_cast<float>(infeed_.level_reading_mm);
  image.hopper_opening_mm = static_cast<float>(infeed_.hopper_opening_mm);
  image.leveller_speed_rpm = static_cast<float>(infeed_.leveller_rpm);
  image.leveller_overload = infeed_.leveller_overload;
  image.flip_plate1_flipping = stations_.plate1_travel >= 1.0;
  image.flip_plate2_flipping = stations_.plate2_travel >= 1.0;
  image.centring_position_mm = static_cast<float>(stations_.pusher_mm);
  image.squeeze_roller_down = stations_.roller_travel >= 1.0;
  image.estop_ok = !faults_.estop_open;
  image.start_request = false;
  image.stop_request = false;
  image.fault_reset_request = false;
  std::memcpy(static_cast<void*>(&in), static_cast<const void*>(&image_), sizeof(InputImage));
}

}  // namespace fl
