// BulkScene: the mailbox hopper, bulk belt and universal leveller as DEM walls, the fillet
// feeder, counting at the gate and the discharge edge, and the leveller's load proxy.
#include "fl/twin/dem_bulk/bulk_scene.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

#include "fl/report/csv.hpp"
#include "fl/twin/dem/body_fit.hpp"
#include "fl/twin/dem/fillet_generator.hpp"
#include "fl/twin/dem/geometry.hpp"

namespace fl {
namespace {

using dem::Vec3;
constexpr double kMm = 1e-3;
constexpr double kRpmToRadPerS = 2.0 * std::numbers::pi / 60.0;
// A sphere this far under the belt plane has left the machine. A whole fillet falling is taken
// out (lost) when its centroid passes -0.1 m, before any of its spheres (at most 0.09 m from
// the centroid) gets here, so only fragments torn off a fillet still on the belt are held.
constexpr double kFallenBelowZ_m = -0.3;
// Speed a held sphere regains in one 2 ms control step is g h = 0.02 m/s; above this it was
// still falling, so it is counted as newly fallen.
constexpr double kStoppedSpeed_m_per_s = 0.1;

void add_quad(dem::MeshWallSpec& mesh, const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& d) {
  mesh.triangles.push_back({{a, b, c}});
  mesh.triangles.push_back({{a, c, d}});
}

// A vertical wall along the segment (x0, y0) -> (x1, y1) from z0 to z1.
void add_fence(dem::MeshWallSpec& mesh, double x0, double y0, double x1, double y1, double z0,
               double z1) {
  add_quad(mesh, Vec3(x0, y0, z0), Vec3(x1, y1, z0), Vec3(x1, y1, z1), Vec3(x0, y0, z1));
}

}  // namespace

BulkScene::BulkScene(const BulkDemConfig& config) : config_(config) {
  templates_ = dem::thesis_fillet_templates(config_.simulation.sub_particle_radius_mm * kMm);
  for (const dem::FilletTemplate& t : templates_) {
    std::vector<dem::BodyBond> bonds;
    bonds.reserve(t.bonds.size());
    for (const dem::FilletBond& b : t.bonds) {
      bonds.push_back({b.i, b.j, b.contact_radius_m, b.thickness_m});
    }
    template_bonds_.push_back(std::move(bonds));
    template_mass_kg_.push_back(t.mass_kg);
  }
  model_ = build_model();
  sim_ = std::make_unique<dem::Simulation>(model_);
  place_walls();
  sim_->prepare();
  rng_state_ = config_.simulation.seed * 0x9E3779B97F4A7C15ULL + 0x2545F4914F6CDD1DULL;
  gate_target_mm_ = config_.gate.opening_mm;
  set_belt_speed_mps(config_.belt.speed_mps);
  set_leveller_rpm(config_.leveller.speed_rpm);
  initial_fill();
}

BulkScene::~BulkScene() = default;

std::shared_ptr<const dem::Model> BulkScene::build_model() {
  dem::ModelSpec spec = config_.engine;
  std::uint32_t equipment = 0;
  bool found = false;
  for (std::uint32_t t = 0; t < spec.types.size(); ++t) {
    if (spec.types[t].name == "equipment") {
      equipment = t;
      found = true;
    }
  }
  if (!found) throw std::invalid_argument("bulk scene: the engine model has no type 'equipment'");
  if (spec.types.size() < 2 || spec.types[dem::kFilletTypeA].name != "fillet_a" ||
      spec.types[dem::kFilletTypeB].name != "fillet_b") {
    throw std::invalid_argument("bulk scene: engine types 0 and 1 must be fillet_a and fillet_b");
  }
  const double radius_m = config_.simulation.sub_particle_radius_mm * kMm;
  const dem::Material& fillet = spec.materials[spec.types[dem::kFilletTypeA].material];
  const dem::Material& steel = spec.materials[spec.types[equipment].material];
  pair_e_star_pa_ = dem::make_pair_material(fillet, steel, true).effective_youngs_modulus_pa;
  spec.timestep_s = config_.simulation.rayleigh_fraction *
                    dem::rayleigh_time_s(radius_m, fillet.density_kg_per_m3,
                                         fillet.youngs_modulus_pa, fillet.poisson_ratio);
  spec.neighbor_skin_m = config_.simulation.neighbor_skin_mm * kMm;
  spec.thread_count = config_.simulation.thread_count;
  spec.planes.clear();  // planes are infinite: the scene is built of finite meshes only
  spec.meshes.clear();

  const BulkBeltConfig& b = config_.belt;
  const BulkHopperConfig& h = config_.hopper;
  const BulkGateConfig& g = config_.gate;
  const BulkLevellerConfig& l = config_.leveller;
  const double hw = b.half_width_mm * kMm;
  const double x0 = b.start_mm * kMm;
  const double x1 = b.discharge_mm * kMm;
  const double gate_x = g.x_mm * kMm;
  const double height = h.height_mm * kMm;
  spec.domain.lower_m = Vec3(x0 - 0.1, -hw - 0.1, -0.3);
  spec.domain.upper_m =
      Vec3(x1 + 0.3, hw + 0.1, std::max(height, config_.feeder.drop_height_mm * kMm) + 0.6);

  // Bulk belt: one rectangle whose surface velocity is the belt speed; with the leveller's own
  // belt, it ends where that one begins.
  const double bulk_end_x =
      config_.leveller_belt.present ? config_.leveller_belt.from_mm * kMm : x1;
  {
    dem::MeshWallSpec belt{"bulk_belt", equipment, {}};
    add_quad(belt, Vec3(x0, -hw, 0.0), Vec3(bulk_end_x, -hw, 0.0), Vec3(bulk_end_x, hw, 0.0),
             Vec3(x0, hw, 0.0));
    wall_belt_ = spec.meshes.size();
    wall_leveller_belt_ = wall_belt_;
    spec.meshes.push_back(std::move(belt));
  }
  if (config_.leveller_belt.present) {
    dem::MeshWallSpec belt{"leveller_belt", equipment, {}};
    add_quad(belt, Vec3(bulk_end_x, -hw, 0.0), Vec3(x1, -hw, 0.0), Vec3(x1, hw, 0.0),
             Vec3(bulk_end_x, hw, 0.0));
    wall_leveller_belt_ = spec.meshes.size();
    spec.meshes.push_back(std::move(belt));
  }
  // Hopper: back wall (leaning outwards, lower edge wall_gap over the belt) and the sides from
  // the back wall's top to the gate; the belt's low side walls from there to the discharge.
  const double back_x = h.back_mm * kMm;
  const double back_top_x = back_x - height * std::tan(h.back_slope_deg * std::numbers::pi / 180.0);
  {
    dem::MeshWallSpec hopper{"hopper", equipment, {}};
    const double z0 = h.wall_gap_mm * kMm;
    add_quad(hopper, Vec3(back_x, -hw, z0), Vec3(back_x, hw, z0), Vec3(back_top_x, hw, height),
             Vec3(back_top_x, -hw, height));
    for (const double y : {-hw, hw}) add_fence(hopper, back_top_x, y, gate_x, y, 0.0, height);
    // An end wall behind the belt's upstream end keeps spilled fillets on the belt.
    add_fence(hopper, x0, -hw, x0, hw, 0.0, b.side_wall_height_mm * kMm);
    for (const double y : {-hw, hw}) {
      add_fence(hopper, x0, y, back_top_x, y, 0.0, b.side_wall_height_mm * kMm);
      add_fence(hopper, gate_x, y, x1, y, 0.0, b.side_wall_height_mm * kMm);
    }
    spec.meshes.push_back(std::move(hopper));
  }
  // Gate: the hopper's front plate, lower edge at z = 0 in its reference geometry; its wall
  // translation z is the opening, so the lower edge sits exactly at the opening.
  {
    dem::MeshWallSpec gate{"hopper_gate", equipment, {}};
    add_fence(gate, gate_x, -hw, gate_x, hw, 0.0, height);
    wall_gate_ = spec.meshes.size();
    spec.meshes.push_back(std::move(gate));
  }
  // Leveller rotor: a hub cylinder and N flat radial blades across the belt (5 mm short of
  // each side wall), axis along y at tip_clearance + tip_radius over the belt.
  {
    dem::MeshWallSpec rotor{"leveller_rotor", equipment, {}};
    const double xc = l.x_mm * kMm;
    const double zc = (l.tip_clearance_mm + l.tip_radius_mm) * kMm;
    const double blade_hw = hw - 0.005;
    const double rt = l.tip_radius_mm * kMm;
    const double rh = l.hub_radius_mm * kMm;
    for (int k = 0; k < l.blades; ++k) {
      // One blade points straight down at angle 0: the lowest tip is at the clearance.
      const double a = 2.0 * std::numbers::pi * k / l.blades;
      const Vec3 dir(std::sin(a), 0.0, -std::cos(a));
      const Vec3 hub(xc + rh * dir.x(), 0.0, zc + rh * dir.z());
      const Vec3 tip(xc + rt * dir.x(), 0.0, zc + rt * dir.z());
      const Vec3 side(0.0, blade_hw, 0.0);
      add_quad(rotor, hub - side, tip - side, tip + side, hub + side);
    }
    for (int k = 0; k < l.hub_segments; ++k) {
      const double a0 = 2.0 * std::numbers::pi * k / l.hub_segments;
      const double a1 = 2.0 * std::numbers::pi * (k + 1) / l.hub_segments;
      const Vec3 p0(xc + rh * std::sin(a0), 0.0, zc - rh * std::cos(a0));
      const Vec3 p1(xc + rh * std::sin(a1), 0.0, zc - rh * std::cos(a1));
      const Vec3 side(0.0, blade_hw, 0.0);
      add_quad(rotor, p0 - side, p1 - side, p1 + side, p0 + side);
    }
    rotor_reference_ = rotor.triangles;
    wall_rotor_ = spec.meshes.size();
    spec.meshes.push_back(std::move(rotor));
  }
  // The transfer onto the takt belt: a plate across the belt's end, as high as its side walls.
  if (b.hold_at_discharge) {
    dem::MeshWallSpec stop{"discharge_stop", equipment, {}};
    add_fence(stop, x1, -hw, x1, hw, 0.0, b.side_wall_height_mm * kMm);
    spec.meshes.push_back(std::move(stop));
  }
  return std::make_shared<const dem::Model>(std::move(spec));
}

void BulkScene::place_walls() {
  dem::State& s = sim_->mutable_state();
  const BulkLevellerConfig& l = config_.leveller;
  s.walls[wall_gate_].translation_m = Vec3(0.0, 0.0, config_.gate.opening_mm * kMm);
  s.walls[wall_rotor_].pivot_m =
      Vec3(l.x_mm * kMm, 0.0, (l.tip_clearance_mm + l.tip_radius_mm) * kMm);
}

// ------------------------------------------------------------------------------ commands

void BulkScene::set_gate_opening_mm(double opening_mm) {
  gate_target_mm_ =
      std::clamp(opening_mm, config_.gate.min_opening_mm, config_.gate.max_opening_mm);
}

void BulkScene::set_belt_speed_mps(double speed_mps) {
  belt_speed_mps_ = std::clamp(speed_mps, -config_.belt.max_speed_mps, config_.belt.max_speed_mps);
}

void BulkScene::set_leveller_rpm(double rpm) { leveller_rpm_ = rpm; }

double BulkScene::leveller_belt_speed_mps() const {
  const BulkLevellerBeltConfig& b = config_.leveller_belt;
  if (!b.present) return belt_speed_mps();
  if (transfer_waiting()) return 0.0;
  return std::clamp(b.speed_mps * leveller_rpm_ / b.rotor_rpm, -config_.belt.max_speed_mps,
                    config_.belt.max_speed_mps);
}

double BulkScene::time_s() const { return sim_->state().time_s; }

double BulkScene::gate_opening_mm() const {
  return sim_->state().walls[wall_gate_].translation_m.z() / kMm;
}

double BulkScene::gate_lower_edge_z_m() const {
  const dem::WallState& w = sim_->state().walls[wall_gate_];
  double low = 1e9;
  for (const dem::Triangle& t : model_->spec().meshes[wall_gate_].triangles) {
    for (const Vec3& v : t.vertices_m) low = std::min(low, w.place(v).z());
  }
  return low;
}

double BulkScene::leveller_lowest_tip_z_m() const {
  const dem::WallState& w = sim_->state().walls[wall_rotor_];
  double low = 1e9;
  for (const dem::Triangle& t : rotor_reference_) {
    for (const Vec3& v : t.vertices_m) low = std::min(low, w.place(v).z());
  }
  return low;
}

double BulkScene::leveller_angle_rad() const {
  const Eigen::AngleAxisd aa(sim_->state().walls[wall_rotor_].rotation);
  return aa.angle() * (aa.axis().y() >= 0.0 ? 1.0 : -1.0);
}

// ------------------------------------------------------------------------------ stepping

void BulkScene::step(double seconds) {
  const double h = config_.simulation.control_step_s;
  const auto count = static_cast<long>(std::llround(seconds / h));
  LevellerLoad sum;
  for (long k = 0; k < count; ++k) {
    control_step(h);
    const LevellerLoad now = leveller_load();
    sum.force_sum_n += now.force_sum_n;
    sum.torque_nm += now.torque_nm;
    sum.contacts += now.contacts;
  }
  if (count > 0) {
    const auto n = static_cast<double>(count);
    load_mean_ = {sum.force_sum_n / n, sum.torque_nm / n,
                  static_cast<std::size_t>(std::llround(static_cast<double>(sum.contacts) / n))};
  }
}

void BulkScene::control_step(double h_s) {
  dem::State& s = sim_->mutable_state();
  const double dt = model_->spec().timestep_s;
  // The engine runs whole steps up to the control step's end (its clock never runs ahead by
  // more than half a step).
  nominal_time_s_ += h_s;
  const double steps = std::floor((nominal_time_s_ - s.time_s) / dt + 0.5);
  // Gate: the cylinder moves the plate at its speed; the velocity lands exactly on the target
  // at this control step's end (the engine integrates translation += dt v per step).
  dem::WallState& gate = s.walls[wall_gate_];
  const double to_go_m = gate_target_mm_ * kMm - gate.translation_m.z();
  const double span_s = std::max(steps, 1.0) * dt;
  const double max_m = config_.gate.cylinder_speed_mmps * kMm * span_s;
  gate.linear_velocity_m_per_s = Vec3(0.0, 0.0, std::clamp(to_go_m, -max_m, max_m) / span_s);
  s.walls[wall_belt_].surface_velocity_m_per_s = Vec3(belt_speed_mps(), 0.0, 0.0);
  if (wall_leveller_belt_ != wall_belt_) {
    s.walls[wall_leveller_belt_].surface_velocity_m_per_s =
        Vec3(leveller_belt_speed_mps(), 0.0, 0.0);
  }
  // Positive rpm sweeps back: the lowest blade moves upstream (-x), omega along +y.
  s.walls[wall_rotor_].angular_velocity_rad_per_s = Vec3(0.0, leveller_rpm_ * kRpmToRadPerS, 0.0);
  if (steps > 0.0) sim_->step(static_cast<std::size_t>(steps));
  if (std::abs(gate.translation_m.z() - gate_target_mm_ * kMm) < 1e-9) {
    gate.translation_m.z() = gate_target_mm_ * kMm;  // rounding of the velocity
  }
  scan();
  count_and_remove();
  note_arrivals_at_stop();
  stop_fallen_spheres();
  feed(h_s);
}

void BulkScene::stop_fallen_spheres() {
  // A sphere torn off a fillet and dropped over the belt's end or side falls on for as long as
  // its fillet stays on the belt; by 10 s it fell 60 m at 34 m/s, further than the skin every
  // step, and forced a neighbour rebuild at every step of the thesis' bulk run (each second of
  // its second half cost twice one of the first). EDEM deletes what leaves its domain; our engine
  // takes out whole bodies only, so a fallen sphere is held still under the scene (its velocity
  // zeroed each control step: it then creeps down g h^2 per step, far under the skin) and counted.
  dem::State& s = sim_->mutable_state();
  for (std::size_t k = 0; k < s.size(); ++k) {
    if (s.position_m[k].z() >= kFallenBelowZ_m) continue;
    // Still falling (a held one regains only g h): it arrived in this control step.
    if (s.velocity_m_per_s[k].z() < -2.0 * kStoppedSpeed_m_per_s) ++counters_.fallen_spheres;
    s.velocity_m_per_s[k] = Vec3::Zero();
    s.angular_velocity_rad_per_s[k] = Vec3::Zero();
  }
}

void BulkScene::scan() { dem::gather_sphere_groups(sim_->state(), fillet_of_body_, fillets_); }

void BulkScene::count_and_remove() {
  const double gate_x = config_.gate.x_mm * kMm;
  const double edge_x = config_.belt.discharge_mm * kMm;
  const double now = time_s();
  bool any = false;
  for (Fillet& f : fillets_) {
    const double mass = template_mass_kg_[f.variant];
    if (!f.passed_gate && f.centroid_m.x() >= gate_x) {
      f.passed_gate = true;
      ++counters_.passed_gate;
      counters_.passed_gate_mass_kg += mass;
      gate_events_.push_back({now, mass});
    }
    // Past the edge, or fallen off the scene (under the belt plane): out of the engine. With
    // the stop plate, only hand_over_front() discharges: a fillet over the plate falls off.
    const bool discharged = !config_.belt.hold_at_discharge && f.centroid_m.x() > edge_x;
    if (discharged || f.centroid_m.z() < -0.1) {
      f.remove = true;
      any = true;
      if (discharged) {
        ++counters_.discharged;
        counters_.discharged_mass_kg += mass;
        discharge_events_.push_back({now, mass});
      } else {
        ++counters_.lost;
      }
    }
  }
  if (any) take_out_removed();
}

void BulkScene::take_out_removed() {
  std::vector<std::uint32_t> bodies;
  for (const Fillet& f : fillets_) {
    if (f.remove) bodies.push_back(f.body);
  }
  if (bodies.empty()) return;
  const dem::State& state = sim_->state();
  std::vector<char> leaving(fillet_of_body_.size(), 0);
  for (const std::uint32_t b : bodies) leaving[b] = 1;
  for (std::size_t k = 0; k < state.bonds.size(); ++k) {
    const std::uint32_t body = state.body[state.bonds[k].i];
    if (state.bond_states[k].broken && body < leaving.size() && leaving[body] != 0) {
      ++counters_.broken_bonds_removed;
    }
  }
  sim_->remove_bodies(bodies);  // loose spheres and the other fillets keep their state
  std::erase_if(fillets_, [](const Fillet& f) { return f.remove; });
  std::uint32_t body_end = 0;
  for (const Fillet& f : fillets_) body_end = std::max(body_end, f.body + 1);
  fillet_of_body_.assign(body_end, -1);
  for (std::size_t f = 0; f < fillets_.size(); ++f) {
    fillet_of_body_[fillets_[f].body] = static_cast<std::int32_t>(f);
  }
  ++counters_.rebuilds;
  scan();
}

// ---------------------------------------------------------------- level and the transfer

double BulkScene::heap_height_mm(double x_from_mm, double x_to_mm) const {
  const dem::State& s = sim_->state();
  const double from_m = x_from_mm * kMm;
  const double to_m = x_to_mm * kMm;
  double top_m = 0.0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const std::uint32_t body = s.body[k];
    // Fillet spheres only: a held fragment under the scene or a loose test sphere is no heap.
    if (body >= fillet_of_body_.size() || fillet_of_body_[body] < 0) continue;
    const double x = s.position_m[k].x();
    if (x < from_m || x > to_m) continue;
    top_m = std::max(top_m, s.position_m[k].z() + s.radius_m[k]);
  }
  return top_m / kMm;
}

bool BulkScene::at_stop(const Fillet& fillet) const {
  // Under the belt plane it has fallen off, whatever its x.
  return config_.belt.hold_at_discharge && !fillet.particles.empty() &&
         fillet.upper_m.x() >= (config_.belt.discharge_mm - kAtStopMm) * kMm &&
         fillet.centroid_m.z() >= 0.0;
}

void BulkScene::note_arrivals_at_stop() {
  for (Fillet& f : fillets_) {
    if (f.at_stop_since_s < 0.0 && at_stop(f)) f.at_stop_since_s = time_s();
  }
}

const BulkScene::Fillet* BulkScene::front_fillet() const {
  // Fillets side by side can all press on the plate: the first to arrive leaves first.
  const Fillet* front = nullptr;
  for (const Fillet& f : fillets_) {
    if (!at_stop(f)) continue;
    if (front == nullptr || f.at_stop_since_s < front->at_stop_since_s ||
        (f.at_stop_since_s == front->at_stop_since_s && f.id < front->id)) {
      front = &f;
    }
  }
  return front;
}

BulkHandover BulkScene::handover_of(const Fillet& fillet) const {
  BulkHandover handover;
  handover.id = fillet.id;
  handover.variant = fillet.variant;
  handover.time_s = time_s();
  handover.centroid_m = fillet.centroid_m;
  handover.velocity_m_per_s = fillet.velocity_m_per_s;
  handover.lower_m = fillet.lower_m;
  handover.upper_m = fillet.upper_m;
  handover.rotation = dem::fit_template_rotation(
      sim_->state(), fillet.particles, templates_[fillet.variant], fillet.first_id,
      fillet.centroid_m, "bulk scene: fillet " + std::to_string(fillet.id));
  return handover;
}

std::optional<BulkHandover> BulkScene::front_at_discharge() const {
  const Fillet* front = front_fillet();
  if (front == nullptr) return std::nullopt;
  return handover_of(*front);
}

std::optional<BulkHandover> BulkScene::hand_over_front() {
  const Fillet* front = front_fillet();
  if (front == nullptr) return std::nullopt;
  BulkHandover handover = handover_of(*front);
  Fillet& leaving = fillets_[static_cast<std::size_t>(front - fillets_.data())];
  leaving.remove = true;
  const double mass = template_mass_kg_[leaving.variant];
  ++counters_.discharged;
  counters_.discharged_mass_kg += mass;
  discharge_events_.push_back({time_s(), mass});
  take_out_removed();
  return handover;
}

// ------------------------------------------------------------------------------ feeding

double BulkScene::uniform() {
  // splitmix64: the same sequence on every platform and standard library.
  std::uint64_t z = (rng_state_ += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

std::uint32_t BulkScene::add_fillet(std::uint8_t variant, const Vec3& centroid_m,
                                    const Eigen::Quaterniond& orientation,
                                    const Vec3& velocity_m_per_s) {
  if (variant >= templates_.size()) throw std::invalid_argument("bulk scene: no such variant");
  const dem::FilletTemplate& t = templates_[variant];
  dem::BodyPose pose;
  pose.position_m = centroid_m;
  pose.orientation = orientation;
  pose.velocity_m_per_s = velocity_m_per_s;
  const std::size_t first = sim_->state().size();
  const std::uint32_t body =
      sim_->add_body(t.positions_m, t.radii_m, t.types, template_bonds_[variant], pose);
  Fillet f;
  f.id = ++last_id_;
  f.variant = variant;
  f.body = body;
  f.first_id = sim_->state().id[first];
  f.centroid_m = centroid_m;
  f.passed_gate = centroid_m.x() >= config_.gate.x_mm * kMm;
  if (fillet_of_body_.size() <= body) fillet_of_body_.resize(body + 1, -1);
  fillet_of_body_[body] = static_cast<std::int32_t>(fillets_.size());
  fillets_.push_back(std::move(f));
  ++counters_.fed;
  scan();
  return fillets_.back().id;
}

std::uint32_t BulkScene::add_sphere(const Vec3& position_m, double radius_m) {
  dem::SphereSpec sphere;
  sphere.position_m = position_m;
  sphere.radius_m = radius_m;
  sphere.type = dem::kFilletTypeA;
  const std::uint32_t k = sim_->add_sphere(sphere);
  return sim_->state().id[k];
}

bool BulkScene::drop_random_fillet(const Vec3& centre_m) {
  const auto variant = static_cast<std::uint8_t>(std::min<std::size_t>(
      static_cast<std::size_t>(uniform() * static_cast<double>(templates_.size())),
      templates_.size() - 1));
  // Random heading, skin or bone side up, and a tilt of the fillet's plane up to max_tilt about
  // a random horizontal axis: a fillet tipped from a crate.
  const double yaw = 2.0 * std::numbers::pi * uniform();
  const bool bone_up = uniform() < 0.5;
  const double tilt = config_.feeder.max_tilt_deg * std::numbers::pi / 180.0 * uniform();
  const double tilt_axis = 2.0 * std::numbers::pi * uniform();
  Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Vec3::UnitZ()));
  if (bone_up) q = q * Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX());
  q = Eigen::AngleAxisd(tilt, Vec3(std::cos(tilt_axis), std::sin(tilt_axis), 0.0)) * q;
  // Room: nothing of another fillet within this one's bounding sphere.
  const dem::FilletTemplate& t = templates_[variant];
  double reach_m = 0.0;
  for (std::size_t i = 0; i < t.positions_m.size(); ++i) {
    reach_m = std::max(reach_m, t.positions_m[i].norm() + t.radii_m[i]);
  }
  const dem::State& s = sim_->state();
  for (std::size_t k = 0; k < s.size(); ++k) {
    if ((s.position_m[k] - centre_m).norm() < reach_m + s.radius_m[k]) return false;
  }
  add_fillet(variant, centre_m, q);
  return true;
}

void BulkScene::initial_fill() {
  // Layers of slots on the hopper floor, each one fillet's footprint (headings within +-10
  // degrees of along or against the travel, as fillets tipped in slide into line with the
  // hopper), so a layer holds (floor length / fillet length) x (width / fillet width) fillets.
  // Fillets that do not fit below the hopper's top are dropped later by the feeder.
  const double tilt = config_.feeder.max_tilt_deg * std::numbers::pi / 180.0;
  const double yaw_max = 10.0 * std::numbers::pi / 180.0;
  Vec3 half = Vec3::Zero();
  for (const dem::FilletTemplate& t : templates_) half = half.cwiseMax(t.half_extent_m);
  const double margin_m = 0.01;
  // Footprint of a yawed, tilted fillet: the length and width turn into each other by sin(yaw),
  // the thickness tips into the plane by sin(tilt).
  const double hx =
      half.x() * std::cos(0.0) + half.y() * std::sin(yaw_max) + half.z() * std::sin(tilt);
  const double hy = half.x() * std::sin(yaw_max) + half.y() + half.z() * std::sin(tilt);
  const double hz = half.z() * std::cos(tilt) + half.x() * std::sin(tilt);
  const double x_lo = config_.hopper.back_mm * kMm + hx + margin_m;
  const double x_hi = config_.gate.x_mm * kMm - hx - margin_m;
  const double y_hi = config_.belt.half_width_mm * kMm - hy - margin_m;
  const int nx =
      std::max(1, static_cast<int>(std::floor((x_hi - x_lo) / (2.0 * hx + margin_m))) + 1);
  const int ny = std::max(1, static_cast<int>(std::floor(2.0 * y_hi / (2.0 * hy + margin_m))) + 1);
  const double top_m = config_.hopper.height_mm * kMm;
  std::uint32_t placed = 0;
  for (int layer = 0; placed < config_.feeder.initial_fill; ++layer) {
    const double z = hz + margin_m + layer * (2.0 * hz + margin_m);
    if (z + hz > top_m) break;
    for (int i = 0; i < nx && placed < config_.feeder.initial_fill; ++i) {
      for (int j = 0; j < ny && placed < config_.feeder.initial_fill; ++j) {
        const double x = nx == 1 ? 0.5 * (x_lo + x_hi) : x_lo + (x_hi - x_lo) * i / (nx - 1);
        const double y = ny == 1 ? 0.0 : -y_hi + 2.0 * y_hi * j / (ny - 1);
        const auto variant = static_cast<std::uint8_t>(std::min<std::size_t>(
            static_cast<std::size_t>(uniform() * static_cast<double>(templates_.size())),
            templates_.size() - 1));
        const double yaw =
            yaw_max * (2.0 * uniform() - 1.0) + (uniform() < 0.5 ? 0.0 : std::numbers::pi);
        const bool bone_up = uniform() < 0.5;
        const double tilt_now = tilt * uniform();
        const double tilt_axis = 2.0 * std::numbers::pi * uniform();
        Eigen::Quaterniond q(Eigen::AngleAxisd(yaw, Vec3::UnitZ()));
        if (bone_up) q = q * Eigen::AngleAxisd(std::numbers::pi, Vec3::UnitX());
        q = Eigen::AngleAxisd(tilt_now, Vec3(std::cos(tilt_axis), std::sin(tilt_axis), 0.0)) * q;
        add_fillet(variant, Vec3(x, y, z), q);
        ++placed;
      }
    }
  }
  pending_ = config_.feeder.initial_fill - placed;
}

void BulkScene::feed(double h_s) {
  // The initial fill's rest first (one try per control step), then the rate.
  if (pending_ == 0) {
    if (config_.feeder.rate_per_s <= 0.0) return;
    feed_credit_ = std::min(feed_credit_ + config_.feeder.rate_per_s * h_s, 2.0);
  }
  if ((pending_ == 0 && feed_credit_ < 1.0) || fillets_.size() >= config_.feeder.max_fillets) {
    return;
  }
  // A random point over the hopper's floor at the drop height; a blocked drop retries at the
  // next control step (the crate waits).
  const double back = config_.hopper.back_mm * kMm + 0.09;
  const double front = config_.gate.x_mm * kMm - 0.09;
  const double hw = std::max(config_.belt.half_width_mm * kMm - 0.09, 0.0);
  const Vec3 centre(back + (front - back) * uniform(), hw * (2.0 * uniform() - 1.0),
                    config_.feeder.drop_height_mm * kMm);
  if (drop_random_fillet(centre)) {
    if (pending_ > 0) {
      --pending_;
    } else {
      feed_credit_ -= 1.0;
    }
  }
}

// ------------------------------------------------------------------------------ measurements

std::vector<BulkFilletView> BulkScene::fillets() const {
  std::vector<BulkFilletView> views;
  views.reserve(fillets_.size());
  for (const Fillet& f : fillets_) {
    views.push_back({f.id, f.variant, f.centroid_m, f.velocity_m_per_s, f.lower_m, f.upper_m,
                     template_mass_kg_[f.variant], f.passed_gate});
  }
  return views;
}

std::size_t BulkScene::fillets_in_hopper() const {
  const double gate_x = config_.gate.x_mm * kMm;
  return static_cast<std::size_t>(
      std::count_if(fillets_.begin(), fillets_.end(),
                    [&](const Fillet& f) { return f.centroid_m.x() < gate_x; }));
}

double BulkScene::rate(const std::vector<Event>& events, double window_s, bool mass) const {
  const double now = time_s();
  const double span = std::min(window_s, now);
  if (span <= 0.0) return 0.0;
  double sum = 0.0;
  for (auto it = events.rbegin(); it != events.rend() && it->time_s > now - span; ++it) {
    sum += mass ? it->mass_kg : 1.0;
  }
  return sum / span;
}

double BulkScene::outflow_rate_per_s(double window_s) const {
  return rate(discharge_events_, window_s, false);
}
double BulkScene::mass_flow_kg_per_s(double window_s) const {
  return rate(discharge_events_, window_s, true);
}
double BulkScene::gate_pass_rate_per_s(double window_s) const {
  return rate(gate_events_, window_s, false);
}
double BulkScene::gate_mass_flow_kg_per_s(double window_s) const {
  return rate(gate_events_, window_s, true);
}

bool is_whole_control_steps(double seconds, double control_step_s) {
  const double steps = seconds / control_step_s;
  return std::abs(steps - std::round(steps)) <= 1e-9 * std::max(1.0, steps);
}

LevellerLoad BulkScene::leveller_load() const {
  const dem::State& s = sim_->state();
  const dem::WallState& w = s.walls[wall_rotor_];
  const Vec3 axis_point = w.pivot_m + w.translation_m;
  const double reach = config_.leveller.tip_radius_mm * kMm;
  LevellerLoad load;
  const double sign = leveller_rpm_ >= 0.0 ? 1.0 : -1.0;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const Vec3 rel = s.position_m[k] - axis_point;
    const double r = s.radius_m[k];
    if (rel.x() * rel.x() + rel.z() * rel.z() > (reach + r) * (reach + r)) continue;
    // Deepest overlap with any rotor triangle (a sphere at a blade root may touch two).
    double overlap = 0.0;
    for (const dem::Triangle& t : rotor_reference_) {
      const dem::ClosestPoint cp =
          dem::closest_point_on_triangle(s.position_m[k], w.place(t.vertices_m[0]),
                                         w.place(t.vertices_m[1]), w.place(t.vertices_m[2]));
      const double dist = (s.position_m[k] - cp.point_m).norm();
      if (dist < r && dist > 0.0) overlap = std::max(overlap, r - dist);
    }
    if (overlap <= 0.0) continue;
    load.force_sum_n += 4.0 / 3.0 * pair_e_star_pa_ * std::sqrt(r) * std::pow(overlap, 1.5);
    ++load.contacts;
  }
  // The wall's torque is about its moved pivot, the rotor axis; signed so that a load resisting
  // the commanded rotation (about +y for positive rpm) counts positive.
  load.torque_nm = -sign * s.wall_torque_nm[wall_rotor_].y();
  return load;
}

// ------------------------------------------------------------------------------ sweep

std::vector<GateSweepPoint> sweep_gate_opening(const BulkDemConfig& config,
                                               std::span<const double> openings_mm,
                                               const GateSweepOptions& options) {
  // The scene runs whole control steps and the rates divide by the time asked for, and a
  // clamped opening would be measured under another name: a point that measured something
  // other than what was asked is refused, not returned. NaN passes every < and >, so each
  // range is written as what is allowed.
  const double step_s = config.simulation.control_step_s;
  const auto whole_steps = [step_s](double seconds) {
    return is_whole_control_steps(seconds, step_s);
  };
  const auto refuse = [](const std::string& what) {
    throw std::runtime_error("gate sweep: " + what);
  };
  if (!(options.settle_s >= 0.0) || !std::isfinite(options.settle_s) ||
      !whole_steps(options.settle_s)) {
    refuse("settling time " + std::to_string(options.settle_s) +
           " s must be zero or more whole control steps of " + std::to_string(step_s) + " s");
  }
  if (!(options.measure_s >= step_s) || !std::isfinite(options.measure_s) ||
      !whole_steps(options.measure_s)) {
    refuse("measuring time " + std::to_string(options.measure_s) +
           " s must be one or more whole control steps of " + std::to_string(step_s) + " s");
  }
  for (const double opening : openings_mm) {
    if (!(opening >= config.gate.min_opening_mm && opening <= config.gate.max_opening_mm)) {
      std::ostringstream reason;
      reason << "the gate opens " << config.gate.min_opening_mm << " to "
             << config.gate.max_opening_mm << " mm, not " << opening << " mm";
      refuse(reason.str());
    }
  }
  std::vector<GateSweepPoint> points;
  for (const double opening : openings_mm) {
    const auto start = std::chrono::steady_clock::now();
    BulkDemConfig c = config;
    // The gate stands at the opening from the start (no cylinder travel in the measurement).
    c.gate.opening_mm = opening;
    BulkScene scene(c);
    scene.step(options.settle_s);
    const BulkCounters before = scene.counters();
    scene.step(options.measure_s);
    const BulkCounters& after = scene.counters();
    GateSweepPoint p;
    p.opening_mm = c.gate.opening_mm;
    p.gate_passes = after.passed_gate - before.passed_gate;
    p.discharged = after.discharged - before.discharged;
    p.gate_passes_per_s = static_cast<double>(p.gate_passes) / options.measure_s;
    p.outflow_per_s = static_cast<double>(p.discharged) / options.measure_s;
    p.mass_flow_kg_per_s =
        (after.discharged_mass_kg - before.discharged_mass_kg) / options.measure_s;
    p.gate_mass_flow_kg_per_s =
        (after.passed_gate_mass_kg - before.passed_gate_mass_kg) / options.measure_s;
    p.leveller_torque_nm = scene.leveller_load_mean().torque_nm;
    p.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    points.push_back(p);
  }
  return points;
}

void write_gate_sweep_csv(std::span<const GateSweepPoint> points,
                          const std::filesystem::path& file) {
  report::CsvTable table({"opening_mm", "gate_passes_per_s", "outflow_per_s", "mass_flow_kg_per_s",
                          "gate_passes", "discharged", "leveller_torque_nm", "wall_s"});
  for (const GateSweepPoint& p : points) {
    table.add_row({p.opening_mm, p.gate_passes_per_s, p.outflow_per_s, p.mass_flow_kg_per_s,
                   static_cast<double>(p.gate_passes), static_cast<double>(p.discharged),
                   p.leveller_torque_nm, p.wall_s});
  }
  table.write(file);
}

}  // namespace fl
