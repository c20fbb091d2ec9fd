#include "fl/twin/dem/simulation.hpp"

#include <omp.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "fl/twin/dem/geometry.hpp"

namespace fl::dem {
namespace {

constexpr std::uint32_t kNoTriangle = std::numeric_limits<std::uint32_t>::max();
constexpr int kMeshSlots = 4;  // history slots per particle per mesh (contacts at once)

struct MeshSlot {
  std::uint32_t triangle = kNoTriangle;
  PairState state;
};

struct CarriedContact {  // contact history carried over a neighbour-list rebuild
  std::uint32_t i;
  std::uint32_t j;
  PairState state;
};

struct ThreadTally {  // per-thread sums, reduced in thread order
  double contact_energy_j = 0.0;
  std::size_t touching = 0;
  bool bond_broke = false;
  char padding[64] = {};  // keep threads' tallies on separate cache lines
};

// Thread t's equal share [begin, end) of n particles: the share it clears, sums and kicks.
std::pair<std::size_t, std::size_t> equal_share(std::size_t n, std::size_t t, std::size_t threads) {
  return {n * t / threads, n * (t + 1) / threads};
}

// Applies a permutation (new index n takes old index order[n]) using a scratch vector of the
// same capacity, then swaps: no allocation once both have their capacity.
// values becomes values[order[0]], values[order[1]], ... (stride elements per index): a
// permutation when order holds every index once, a compaction when it holds a subset.
template <typename T>
void gather(std::vector<T>& values, std::vector<T>& scratch,
            const std::vector<std::uint32_t>& order, std::size_t stride = 1) {
  scratch.resize(order.size() * stride);
  for (std::size_t n = 0; n < order.size(); ++n) {
    for (std::size_t s = 0; s < stride; ++s) {
      scratch[n * stride + s] = values[order[n] * stride + s];
    }
  }
  values.swap(scratch);
}

// Joins per-thread lists (CSR segments of two parallel arrays, each thread's offsets local
// to its own buffers) in thread order: the joined list is the same for any thread count.
// Done in two parts so that the threads copy their own parts at once: the joined arrays are
// sized first (by one thread), then each thread shifts its offsets and copies its part.
template <typename A, typename B>
void size_joined_segments(const std::vector<std::vector<A>>& parts_a,
                          std::vector<std::uint32_t>& offsets, std::vector<A>& joined_a,
                          std::vector<B>& joined_b) {
  std::size_t total = 0;
  for (const auto& part : parts_a) total += part.size();
  joined_a.resize(total);
  joined_b.resize(total);
  offsets.back() = static_cast<std::uint32_t>(total);
}

// Returns where thread t's part starts in the joined arrays.
template <typename A, typename B>
std::size_t join_thread_segment(std::size_t t, const std::vector<std::uint32_t>& thread_begin,
                                const std::vector<std::vector<A>>& parts_a,
                                const std::vector<std::vector<B>>& parts_b,
                                std::vector<std::uint32_t>& offsets, std::vector<A>& joined_a,
                                std::vector<B>& joined_b) {
  std::size_t at = 0;
  for (std::size_t before = 0; before < t; ++before) at += parts_a[before].size();
  const auto shift = static_cast<std::uint32_t>(at);
  for (std::uint32_t i = thread_begin[t]; i < thread_begin[t + 1]; ++i) offsets[i] += shift;
  const auto to = static_cast<std::ptrdiff_t>(at);
  std::copy(parts_a[t].begin(), parts_a[t].end(), joined_a.begin() + to);
  std::copy(parts_b[t].begin(), parts_b[t].end(), joined_b.begin() + to);
  return at;
}

// A bond's two types in ascending order: the model holds one bond law per ordered type pair.
std::pair<std::uint32_t, std::uint32_t> ordered_types(const State& s, const Bond& bond) {
  const std::uint32_t type_i = s.type[bond.i];
  const std::uint32_t type_j = s.type[bond.j];
  return {std::min(type_i, type_j), std::max(type_i, type_j)};
}

}  // namespace

struct Simulation::Impl {
  // resolved model
  std::size_t type_count = 0;
  std::vector<const Interaction*> interactions;  // type pair -> interaction (contact laws)
  std::vector<double> pair_range_m;              // adhesion range per type pair
  int threads = 1;                               // at most (ModelSpec::thread_count)
  int active_threads = 1;                        // for the current particle count, set by prepare()
  double dt = 0.0;
  Vec3 gravity = Vec3::Zero();

  bool prepared = false;
  bool forces_valid = false;
  bool rebuild_requested = true;

  // cell list and neighbour list (half list: j > i under i), with contact history
  double cell_size = 0.0;
  double skin = 0.0;
  Eigen::Vector3i cell_dims = Eigen::Vector3i::Ones();  // this build's grid (see rebuild)
  Vec3 cell_origin = Vec3::Zero();
  double min_cell_size = 0.0;  // the largest reach: two radii, adhesion range and skin
  std::size_t max_cells = 0;   // cap on the grid, so that passes over cells stay O(particles)
  std::vector<std::uint32_t> cell_start;
  std::vector<std::uint32_t> cell_particles;
  // positions in cell_particles' order: the candidate loop reads them in sequence, not
  // scattered over the particle arrays between re-orderings
  std::vector<Vec3> cell_position_m;
  std::vector<std::uint32_t> particle_cell;
  std::vector<std::uint32_t> pair_offsets;
  std::vector<std::uint32_t> old_pair_offsets;  // the last list's, while the next is built
  std::vector<std::uint32_t> pair_j;
  std::vector<PairState> pair_states;
  // per listed pair: whether its state holds history (PairState::active()). Most listed pairs
  // are out of reach at any step; this keeps the force loop from reading their states.
  std::vector<std::uint8_t> pair_history;
  std::vector<CarriedContact> carried;
  std::vector<Vec3> build_position_m;
  std::size_t rebuilds_since_sort = 0;

  // bonds
  std::vector<const BondLaw*> bond_laws;
  std::vector<std::uint32_t> partner_offsets;  // per particle: bonded partners (CSR)
  std::vector<std::uint32_t> partner_particle;
  bool partners_valid = false;  // until a bond breaks, particles are re-ordered or added
  std::vector<std::uint8_t> bond_break_handled;  // per bond: its freed pair has been checked
  std::vector<std::uint32_t> bond_order;         // sort_bonds' scratch
  std::vector<std::uint32_t> bond_order_next;
  std::vector<std::uint32_t> bond_bucket;
  std::vector<Bond> scratch_bonds;
  std::vector<BondState> scratch_bond_states;
  std::vector<std::uint8_t> scratch_u8;
  // neighbour-list build, per thread
  std::vector<std::uint32_t> build_begin;
  std::vector<std::vector<std::uint32_t>> build_pair_j;
  std::vector<std::vector<PairState>> build_pair_states;
  std::vector<std::vector<std::uint32_t>> build_stamps;
  std::vector<std::vector<std::uint32_t>> build_in_reach;
  std::vector<std::vector<std::uint32_t>> build_wall_mesh;
  std::vector<std::vector<std::uint32_t>> build_wall_triangle;

  // walls: current geometry and history
  std::vector<Vec3> plane_point_m;
  std::vector<Vec3> plane_normal;
  std::vector<std::vector<PairState>> plane_states;   // [plane][particle]
  std::vector<std::vector<Triangle>> mesh_triangles;  // current pose
  std::vector<std::vector<Eigen::AlignedBox3d>> mesh_triangle_boxes;
  std::vector<Eigen::AlignedBox3d> mesh_boxes;
  // Per mesh: the pose its triangles were placed with, and a count of the placements that
  // moved it (0: not placed yet). A mesh placed as at the last neighbour build is searched
  // through the wall list.
  std::vector<WallState> mesh_pose;
  std::vector<std::uint64_t> mesh_moves;
  std::vector<std::uint64_t> mesh_moves_at_build;
  // Wall list (CSR per particle): the triangles within reach plus skin at the last build, by
  // mesh then triangle, as (mesh, triangle). A particle moves at most the skin before the next
  // build (step), so no other triangle of an unmoved mesh can reach it.
  std::vector<std::uint32_t> wall_list_offsets;
  std::vector<std::uint32_t> wall_list_mesh;
  std::vector<std::uint32_t> wall_list_triangle;
  std::vector<std::vector<MeshSlot>> mesh_slots;  // [mesh][particle * kMeshSlots + slot]
  // Per particle, bit w (w < 63) or bit 63 (walls 63 and up): the particle may hold contact
  // history with wall w. Far walls without history are skipped without touching their slots.
  std::vector<std::uint64_t> wall_history;
  std::vector<const Interaction*> wall_interactions;  // [type * wall_count + wall]
  std::vector<double> wall_range_m;

  // threads
  std::vector<std::uint32_t> particle_begin;  // threads + 1 boundaries
  // Per thread: the lowest particle index its bonds touch (none: max). A thread's pairs are
  // listed under its own particles with j > i, so it writes no force below
  // min(particle_begin[t], bond_low[t]): its buffer is cleared and summed from there only.
  std::vector<std::uint32_t> bond_low;
  // The first particle index thread t (> 0) can write in its force buffer (see bond_low).
  [[nodiscard]] std::size_t buffer_written_from(std::size_t t, std::size_t n) const {
    return std::min<std::size_t>({particle_begin[t], bond_low[t], n});
  }
  // per particle: its listed pairs that held contact history at the last build, the pairs the
  // laws will run on; they weigh the threads' particle ranges
  std::vector<std::uint32_t> contacts_at_build;
  std::vector<std::uint32_t> bond_begin;
  std::vector<std::vector<Vec3>> force_buffers;  // threads 1.. (thread 0 writes the state)
  std::vector<std::vector<Vec3>> torque_buffers;
  // per thread (all of them), per wall: reactions summed in thread order after the step, so a
  // run stays bit-identical for a fixed thread count
  std::vector<std::vector<Vec3>> wall_force_buffers;
  std::vector<std::vector<Vec3>> wall_torque_buffers;
  std::vector<ThreadTally> tallies;

  // scratch for re-ordering
  std::vector<std::uint32_t> order;
  std::vector<std::uint32_t> new_of_old;
  std::vector<Vec3> scratch_vec3;
  std::vector<double> scratch_double;
  std::vector<std::uint32_t> scratch_u32;
  std::vector<PairState> scratch_states;
  std::vector<MeshSlot> scratch_slots;
  std::vector<std::uint64_t> scratch_u64;

  // Centre distance below which a pair is listed: the contact reach plus the skin. The
  // neighbour build and the check on a freed bond pair must use the same one.
  [[nodiscard]] double listing_reach_m(double radius_i_m, double radius_j_m,
                                       std::size_t pair_type) const {
    return radius_i_m + radius_j_m + pair_range_m[pair_type] + skin;
  }

  double last_contact_energy_j = 0.0;
  std::uint32_t next_body = 0;
  std::uint32_t next_id = 0;
};

Simulation::Simulation(std::shared_ptr<const Model> model)
    : model_(std::move(model)), impl_(std::make_unique<Impl>()) {
  if (!model_) {
    throw std::invalid_argument("dem simulation: no model");
  }
  const ModelSpec& spec = model_->spec();
  Impl& m = *impl_;
  m.type_count = model_->type_count();
  m.threads = spec.thread_count;
  m.dt = spec.timestep_s;
  m.gravity = spec.gravity_m_per_s2;
  m.skin = spec.neighbor_skin_m;
  m.interactions.resize(m.type_count * m.type_count);
  for (std::uint32_t a = 0; a < m.type_count; ++a) {
    for (std::uint32_t b = 0; b < m.type_count; ++b) {
      m.interactions[a * m.type_count + b] = &model_->interaction(a, b);
    }
  }
  const std::size_t wall_count = spec.planes.size() + spec.meshes.size();
  state_.walls.resize(wall_count);
  state_.wall_force_n.assign(wall_count, Vec3::Zero());
  state_.wall_torque_nm.assign(wall_count, Vec3::Zero());
  m.plane_point_m.resize(spec.planes.size());
  m.plane_normal.resize(spec.planes.size());
  m.plane_states.resize(spec.planes.size());
  m.mesh_triangles.resize(spec.meshes.size());
  m.mesh_triangle_boxes.resize(spec.meshes.size());
  m.mesh_boxes.resize(spec.meshes.size());
  m.mesh_pose.resize(spec.meshes.size());
  m.mesh_moves.assign(spec.meshes.size(), 0);
  m.mesh_moves_at_build.assign(spec.meshes.size(), std::numeric_limits<std::uint64_t>::max());
  m.mesh_slots.resize(spec.meshes.size());
  for (std::size_t w = 0; w < spec.meshes.size(); ++w) {
    m.mesh_triangles[w] = spec.meshes[w].triangles;
    m.mesh_triangle_boxes[w].resize(spec.meshes[w].triangles.size());
  }
  m.wall_interactions.resize(m.type_count * wall_count);
  for (std::uint32_t t = 0; t < m.type_count; ++t) {
    for (std::size_t w = 0; w < wall_count; ++w) {
      const std::uint32_t wall_type =
          w < spec.planes.size() ? spec.planes[w].type : spec.meshes[w - spec.planes.size()].type;
      m.wall_interactions[t * wall_count + w] = &model_->interaction(t, wall_type);
    }
  }
  m.tallies.resize(static_cast<std::size_t>(m.threads));
  m.force_buffers.resize(static_cast<std::size_t>(m.threads));
  m.torque_buffers.resize(static_cast<std::size_t>(m.threads));
  m.wall_force_buffers.assign(static_cast<std::size_t>(m.threads),
                              std::vector<Vec3>(wall_count, Vec3::Zero()));
  m.wall_torque_buffers.assign(static_cast<std::size_t>(m.threads),
                               std::vector<Vec3>(wall_count, Vec3::Zero()));
}

Simulation::~Simulation() = default;

int Simulation::thread_count() const { return impl_->threads; }
int Simulation::active_thread_count() const { return impl_->active_threads; }

void Simulation::reserve(std::size_t particles, std::size_t bonds) {
  State& s = state_;
  s.position_m.reserve(particles);
  s.velocity_m_per_s.reserve(particles);
  s.angular_velocity_rad_per_s.reserve(particles);
  s.force_n.reserve(particles);
  s.torque_nm.reserve(particles);
  s.radius_m.reserve(particles);
  s.inverse_mass_per_kg.reserve(particles);
  s.inverse_inertia_per_kg_m2.reserve(particles);
  s.type.reserve(particles);
  s.body.reserve(particles);
  s.id.reserve(particles);
  s.bonds.reserve(bonds);
  s.bond_states.reserve(bonds);
}

std::uint32_t Simulation::add_sphere(const SphereSpec& sphere) {
  if (sphere.type >= model_->type_count() || !(sphere.radius_m > 0.0)) {
    throw std::invalid_argument("dem add_sphere: unknown type or radius <= 0");
  }
  State& s = state_;
  const double density = model_->material_of_type(sphere.type).density_kg_per_m3;
  const double mass =
      density * 4.0 / 3.0 * std::numbers::pi * sphere.radius_m * sphere.radius_m * sphere.radius_m;
  s.position_m.push_back(sphere.position_m);
  s.velocity_m_per_s.push_back(sphere.velocity_m_per_s);
  s.angular_velocity_rad_per_s.push_back(sphere.angular_velocity_rad_per_s);
  s.force_n.push_back(Vec3::Zero());
  s.torque_nm.push_back(Vec3::Zero());
  s.radius_m.push_back(sphere.radius_m);
  s.inverse_mass_per_kg.push_back(1.0 / mass);
  s.inverse_inertia_per_kg_m2.push_back(1.0 / (0.4 * mass * sphere.radius_m * sphere.radius_m));
  s.type.push_back(sphere.type);
  s.body.push_back(impl_->next_body++);
  s.id.push_back(impl_->next_id++);
  impl_->prepared = false;
  return static_cast<std::uint32_t>(s.size() - 1);
}

std::uint32_t Simulation::add_body(std::span<const Vec3> positions_m,
                                   std::span<const double> radii_m,
                                   std::span<const std::uint8_t> types,
                                   std::span<const BodyBond> bonds, const BodyPose& pose) {
  if (positions_m.size() != radii_m.size() || positions_m.size() != types.size()) {
    throw std::invalid_argument("dem add_body: positions, radii and types differ in length");
  }
  const auto first = static_cast<std::uint32_t>(state_.size());
  const std::uint32_t body = impl_->next_body;
  const Eigen::Matrix3d rotation = pose.orientation.normalized().toRotationMatrix();
  for (std::size_t k = 0; k < positions_m.size(); ++k) {
    const Vec3 arm = rotation * positions_m[k];
    SphereSpec sphere;
    sphere.position_m = pose.position_m + arm;
    sphere.radius_m = radii_m[k];
    sphere.type = types[k];
    sphere.velocity_m_per_s = pose.velocity_m_per_s + pose.angular_velocity_rad_per_s.cross(arm);
    sphere.angular_velocity_rad_per_s = pose.angular_velocity_rad_per_s;
    add_sphere(sphere);
    state_.body.back() = body;
  }
  impl_->next_body = body + 1;
  for (const BodyBond& bond : bonds) {
    if (bond.i >= positions_m.size() || bond.j >= positions_m.size() || bond.i == bond.j) {
      throw std::invalid_argument("dem add_body: bond index out of range");
    }
    Bond b;
    b.i = first + bond.i;
    b.j = first + bond.j;
    b.rest_length_m = (state_.position_m[b.i] - state_.position_m[b.j]).norm();
    b.bond_radius_m = std::min(state_.radius_m[b.i], state_.radius_m[b.j]);
    b.break_distance_m = 2.0 * bond.contact_radius_m;
    b.thickness_m = bond.thickness_m;
    const BondLaw* law = model_->interaction(state_.type[b.i], state_.type[b.j]).bond_law.get();
    if (law == nullptr) {
      throw std::invalid_argument("dem add_body: no bond law for the types of a bond");
    }
    if (law->needs_bond_thickness() && !(bond.thickness_m > 0.0)) {
      throw std::invalid_argument(
          "dem add_body: the bond law grades its stiffness with the body's thickness, but bond " +
          std::to_string(bond.i) + "-" + std::to_string(bond.j) +
          " has none (BodyBond::thickness_m)");
    }
    state_.bonds.push_back(b);
    state_.bond_states.emplace_back();
    impl_->bond_break_handled.push_back(0);
  }
  return body;
}

std::size_t Simulation::wall_index(std::string_view name) const {
  const ModelSpec& spec = model_->spec();
  for (std::size_t w = 0; w < spec.planes.size(); ++w) {
    if (spec.planes[w].name == name) return w;
  }
  for (std::size_t w = 0; w < spec.meshes.size(); ++w) {
    if (spec.meshes[w].name == name) return spec.planes.size() + w;
  }
  throw std::invalid_argument("dem: no wall named '" + std::string(name) + "'");
}

WallState& Simulation::wall(std::string_view name) { return state_.walls[wall_index(name)]; }

// ------------------------------------------------------------------------------------ setup

void Simulation::prepare() {
  Impl& m = *impl_;
  State& s = state_;
  const std::size_t n = s.size();
  const ModelSpec& spec = model_->spec();
  double max_radius = 0.0;
  for (const double r : s.radius_m) max_radius = std::max(max_radius, r);
  if (max_radius == 0.0) max_radius = 0.004;
  const double range = model_->max_range_m(max_radius);
  m.min_cell_size = 2.0 * max_radius + range + m.skin;
  m.max_cells = 8 * n + 4096;  // the grid is sized at each rebuild (rebuild_neighbors)
  m.cell_start.assign(m.max_cells + 1, 0);

  m.pair_range_m.assign(m.type_count * m.type_count, 0.0);
  for (std::size_t k = 0; k < m.pair_range_m.size(); ++k) {
    for (const auto& law : m.interactions[k]->contact_laws) {
      m.pair_range_m[k] = std::max(m.pair_range_m[k], law->range_m(max_radius));
    }
  }
  const std::size_t wall_count = spec.planes.size() + spec.meshes.size();
  m.wall_range_m.assign(m.wall_interactions.size(), 0.0);
  for (std::size_t k = 0; k < m.wall_interactions.size(); ++k) {
    for (const auto& law : m.wall_interactions[k]->contact_laws) {
      m.wall_range_m[k] = std::max(m.wall_range_m[k], law->range_m(max_radius));
    }
  }
  (void)wall_count;

  for (auto& states : m.plane_states) states.resize(n);
  for (auto& slots : m.mesh_slots) slots.resize(n * kMeshSlots);
  m.wall_history.resize(n, ~std::uint64_t{0});  // new particles: check every wall once
  m.active_threads = static_cast<int>(std::clamp<std::size_t>(
      n / static_cast<std::size_t>(std::max(1, spec.min_particles_per_thread)), 1,
      static_cast<std::size_t>(m.threads)));
  const std::size_t threads = static_cast<std::size_t>(m.active_threads);
  for (std::size_t t = 1; t < threads; ++t) {
    m.force_buffers[t].resize(n);
    m.torque_buffers[t].resize(n);
  }
  m.build_position_m.resize(n);
  m.particle_cell.resize(n);
  m.cell_particles.resize(n);
  m.cell_position_m.resize(n);
  m.order.resize(n);
  m.new_of_old.resize(n);
  m.scratch_vec3.reserve(n);
  m.scratch_double.reserve(n);
  m.scratch_u32.reserve(n);
  m.scratch_states.reserve(std::max(n, m.pair_states.capacity()));
  m.scratch_slots.reserve(n * kMeshSlots);
  m.scratch_u64.reserve(n);
  const std::uint32_t listed = m.pair_offsets.empty() ? 0U : m.pair_offsets.back();
  m.pair_offsets.resize(n + 1, listed);  // new particles: empty lists until the rebuild

  assign_bond_laws();
  m.particle_begin.assign(threads + 1, static_cast<std::uint32_t>(n));
  m.particle_begin[0] = 0;

  update_wall_geometry();
  m.partners_valid = false;
  m.prepared = true;
  m.rebuild_requested = true;
  rebuild_neighbors();
  if (!m.forces_valid) {
    compute_forces();  // velocity Verlet needs F(t0); later additions start from zero force
    m.forces_valid = true;
  }
}

// Each bond's law from its types in ascending order: the model holds one law per ordered pair,
// the same parameters both ways, and a fillet's A-B and B-A bonds alternate. Looked up by the
// ordered pair, a body's bonds split into runs of one or two, and a vector kernel needs whole
// runs of one law. Also splits the bonds between the threads by count.
void Simulation::assign_bond_laws() {
  Impl& m = *impl_;
  const State& s = state_;
  m.bond_laws.resize(s.bonds.size());
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    const auto [low, high] = ordered_types(s, s.bonds[k]);
    m.bond_laws[k] = model_->interaction(low, high).bond_law.get();
  }
  const auto threads = static_cast<std::size_t>(m.active_threads);
  m.bond_begin.resize(threads + 1);
  for (std::size_t t = 0; t <= threads; ++t) {
    m.bond_begin[t] = static_cast<std::uint32_t>(s.bonds.size() * t / threads);
  }
  m.bond_low.assign(threads, std::numeric_limits<std::uint32_t>::max());
  stats_.bond_law_runs = 0;
  for (std::size_t t = 0; t < threads; ++t) {
    for (std::uint32_t k = m.bond_begin[t]; k < m.bond_begin[t + 1]; ++k) {
      m.bond_low[t] = std::min({m.bond_low[t], s.bonds[k].i, s.bonds[k].j});
      if (k == m.bond_begin[t] || m.bond_laws[k] != m.bond_laws[k - 1]) ++stats_.bond_law_runs;
    }
  }
}

// Re-orders the bonds after the particles: by law (the kernels need whole runs of one law),
// then by the lower particle index, ties in the old order (two stable counting passes, so the
// order is a function of the state alone). In creation order a body's bonds read and write
// particles all over the cell-sorted arrays; in the thesis' bulk run the bond kernel spent most
// of its time waiting on those loads (docs/benchmarks.md). Each bond keeps its i and j, so its
// history keeps its sign.
void Simulation::sort_bonds() {
  Impl& m = *impl_;
  State& s = state_;
  const std::size_t count = s.bonds.size();
  if (count < 2) return;
  const std::size_t n = s.size();
  const auto law_key = [&](const Bond& bond) {
    const auto [low, high] = ordered_types(s, bond);
    return low * m.type_count + high;
  };
  const auto counting_pass = [&m](const std::vector<std::uint32_t>& from,
                                  std::vector<std::uint32_t>& to, std::size_t buckets,
                                  const auto& key) {
    m.bond_bucket.assign(buckets + 1, 0U);
    for (const std::uint32_t k : from) ++m.bond_bucket[key(k) + 1];
    for (std::size_t b = 0; b < buckets; ++b) m.bond_bucket[b + 1] += m.bond_bucket[b];
    to.resize(from.size());
    for (const std::uint32_t k : from) to[m.bond_bucket[key(k)]++] = k;
  };
  m.bond_order.resize(count);
  for (std::size_t k = 0; k < count; ++k) m.bond_order[k] = static_cast<std::uint32_t>(k);
  counting_pass(m.bond_order, m.bond_order_next, n, [&s](std::uint32_t k) {
    return static_cast<std::size_t>(std::min(s.bonds[k].i, s.bonds[k].j));
  });
  counting_pass(m.bond_order_next, m.bond_order, m.type_count * m.type_count,
                [&](std::uint32_t k) { return static_cast<std::size_t>(law_key(s.bonds[k])); });
  m.bond_break_handled.resize(count, 0);
  gather(s.bonds, m.scratch_bonds, m.bond_order);
  gather(s.bond_states, m.scratch_bond_states, m.bond_order);
  gather(m.bond_break_handled, m.scratch_u8, m.bond_order);
  assign_bond_laws();
}

void Simulation::update_wall_geometry() {
  const ModelSpec& spec = model_->spec();
  const State& state = state_;
  Impl& m = *impl_;
  for (std::size_t w = 0; w < spec.planes.size(); ++w) {
    const WallState& ws = state.walls[w];
    m.plane_normal[w] = (ws.rotation * spec.planes[w].normal).normalized();
    m.plane_point_m[w] =
        ws.rotation * (spec.planes[w].point_m - ws.pivot_m) + ws.pivot_m + ws.translation_m;
  }
  for (std::size_t w = 0; w < spec.meshes.size(); ++w) {
    const WallState& ws = state.walls[spec.planes.size() + w];
    WallState& placed = m.mesh_pose[w];
    if (m.mesh_moves[w] != 0 && placed.pivot_m == ws.pivot_m &&
        placed.translation_m == ws.translation_m &&
        placed.rotation.coeffs() == ws.rotation.coeffs()) {
      continue;  // the same pose gives the same triangles
    }
    placed = ws;
    ++m.mesh_moves[w];
    const auto& reference = spec.meshes[w].triangles;
    auto& current = m.mesh_triangles[w];
    auto& boxes = m.mesh_triangle_boxes[w];
    Eigen::AlignedBox3d all;
    const Eigen::Matrix3d rotation = ws.rotation.toRotationMatrix();
    for (std::size_t k = 0; k < reference.size(); ++k) {
      boxes[k].setEmpty();
      for (int v = 0; v < 3; ++v) {
        current[k].vertices_m[v] =
            rotation * (reference[k].vertices_m[v] - ws.pivot_m) + ws.pivot_m + ws.translation_m;
        boxes[k].extend(current[k].vertices_m[v]);
      }
      all.extend(boxes[k]);
    }
    m.mesh_boxes[w] = all;
  }
}

// --------------------------------------------------------------------- neighbour search

namespace {

// History bit of a wall; walls 63 and up share the last bit.
inline std::uint64_t wall_bit(std::size_t wall) {
  return std::uint64_t{1} << std::min<std::size_t>(wall, 63);
}

inline std::uint32_t cell_coordinate(double x, double origin, double size, int dims) {
  const double c = std::floor((x - origin) / size);
  if (!(c > 0.0)) return 0;  // also NaN
  if (c >= static_cast<double>(dims - 1)) return static_cast<std::uint32_t>(dims - 1);
  return static_cast<std::uint32_t>(c);
}

}  // namespace

// Every per-particle array, state and history alike, re-ordered (or compacted) by `order`.
void Simulation::gather_particles(const std::vector<std::uint32_t>& order) {
  Impl& m = *impl_;
  State& s = state_;
  gather(s.position_m, m.scratch_vec3, order);
  gather(s.velocity_m_per_s, m.scratch_vec3, order);
  gather(s.angular_velocity_rad_per_s, m.scratch_vec3, order);
  gather(s.force_n, m.scratch_vec3, order);
  gather(s.torque_nm, m.scratch_vec3, order);
  gather(m.build_position_m, m.scratch_vec3, order);
  gather(s.radius_m, m.scratch_double, order);
  gather(s.inverse_mass_per_kg, m.scratch_double, order);
  gather(s.inverse_inertia_per_kg_m2, m.scratch_double, order);
  gather(s.type, m.scratch_u32, order);
  gather(s.body, m.scratch_u32, order);
  gather(s.id, m.scratch_u32, order);
  gather(m.particle_cell, m.scratch_u32, order);
  for (auto& states : m.plane_states) gather(states, m.scratch_states, order);
  for (auto& slots : m.mesh_slots) gather(slots, m.scratch_slots, order, kMeshSlots);
  gather(m.wall_history, m.scratch_u64, order);
}

void Simulation::sort_particles() {
  Impl& m = *impl_;
  State& s = state_;
  const std::size_t n = s.size();
  // m.order holds old indices in cell order (from the binning in rebuild_neighbors)
  for (std::size_t k = 0; k < n; ++k) m.new_of_old[m.order[k]] = static_cast<std::uint32_t>(k);
  gather_particles(m.order);
  for (Bond& bond : s.bonds) {
    bond.i = m.new_of_old[bond.i];
    bond.j = m.new_of_old[bond.j];
  }
  for (CarriedContact& c : m.carried) {
    c.i = m.new_of_old[c.i];
    c.j = m.new_of_old[c.j];
  }
  sort_bonds();
  m.partners_valid = false;
  ++stats_.particle_sorts;
}

std::size_t Simulation::remove_bodies(std::span<const std::uint32_t> bodies) {
  Impl& m = *impl_;
  State& s = state_;
  // Bring the neighbour list and wall history up to the particles added since, so that
  // every per-particle array is compacted alike.
  if (!m.prepared && s.size() > 0) prepare();
  const std::size_t n = s.size();
  std::vector<bool> removed_body(m.next_body, false);
  for (const std::uint32_t body : bodies) {
    if (body < removed_body.size()) removed_body[body] = true;
  }
  // The kept particles in their current order: a compaction with the permutation machinery.
  std::vector<std::uint32_t> kept;
  kept.reserve(n);
  constexpr std::uint32_t kGone = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> new_index(n, kGone);
  for (std::size_t k = 0; k < n; ++k) {
    if (removed_body[s.body[k]]) continue;
    new_index[k] = static_cast<std::uint32_t>(kept.size());
    kept.push_back(static_cast<std::uint32_t>(k));
  }
  const std::size_t removed = n - kept.size();
  if (removed == 0) return 0;

  gather_particles(kept);
  // Contact history between kept particles survives: the neighbour list is compacted and
  // its active pairs are carried into the rebuild that prepare() does.
  std::vector<std::uint32_t> offsets(kept.size() + 1, 0);
  std::vector<std::uint32_t> pair_j;
  std::vector<PairState> pair_states;
  if (m.pair_offsets.size() == n + 1) {
    for (std::size_t k = 0; k < kept.size(); ++k) {
      const std::uint32_t old_i = kept[k];
      for (std::uint32_t p = m.pair_offsets[old_i]; p < m.pair_offsets[old_i + 1]; ++p) {
        const std::uint32_t j = new_index[m.pair_j[p]];
        if (j == kGone) continue;
        pair_j.push_back(j);
        pair_states.push_back(m.pair_states[p]);
      }
      offsets[k + 1] = static_cast<std::uint32_t>(pair_j.size());
    }
  }
  m.pair_offsets.swap(offsets);
  m.pair_j.swap(pair_j);
  m.pair_states.swap(pair_states);
  // Bonds keep their order; those with a removed end go with it.
  std::size_t kept_bonds = 0;
  for (std::size_t b = 0; b < s.bonds.size(); ++b) {
    Bond bond = s.bonds[b];
    bond.i = new_index[bond.i];
    bond.j = new_index[bond.j];
    if (bond.i == kGone || bond.j == kGone) continue;
    s.bonds[kept_bonds] = bond;
    s.bond_states[kept_bonds] = s.bond_states[b];
    m.bond_break_handled[kept_bonds] = m.bond_break_handled[b];
    ++kept_bonds;
  }
  s.bonds.resize(kept_bonds);
  s.bond_states.resize(kept_bonds);
  m.bond_break_handled.resize(kept_bonds);
  m.carried.clear();
  prepare();  // threads, bond laws and the neighbour list for the smaller system
  return removed;
}

void Simulation::rebuild_neighbors() {
  Impl& m = *impl_;
  State& s = state_;
  const std::size_t n = s.size();
  const auto list_capacity = [&m] {
    std::size_t capacity = m.pair_j.capacity() + m.pair_states.capacity();
    for (const auto& buffer : m.build_pair_j) capacity += buffer.capacity();
    for (const auto& buffer : m.build_pair_states) capacity += buffer.capacity();
    return capacity;
  };
  const std::size_t capacity_before = list_capacity();

  // 1. history of active pairs, to carry into the new list. Without a re-ordering of the
  // particles each new segment is merged with the old one (both sorted by j), in parallel; the
  // serial copy of every active pair was a third of a rebuild in the thesis' bulk run.
  const int sort_every = model_->spec().sort_every_rebuilds;
  const bool reordered = sort_every > 0 &&
                         (m.rebuilds_since_sort++ % static_cast<std::size_t>(sort_every)) == 0 &&
                         n > 0;
  m.carried.clear();
  if (reordered && m.pair_offsets.size() == n + 1 && !m.pair_states.empty()) {
    for (std::uint32_t i = 0; i + 1 < m.pair_offsets.size(); ++i) {
      for (std::uint32_t k = m.pair_offsets[i]; k < m.pair_offsets[i + 1]; ++k) {
        if (m.pair_states[k].active()) m.carried.push_back({i, m.pair_j[k], m.pair_states[k]});
      }
    }
  }

  // 2. bin particles (counting sort by cell) on a grid over the particles' bounding box within
  // the domain, not over the whole domain: a line or a race scene is mostly empty space, so
  // the passes over empty cells were half of the binning, and capping a domain-wide grid at a
  // few cells per particle made a line's cells several times the reach. Cells are at least the
  // reach; particles outside the domain go into its edge cells, so the 27-cell search still
  // reaches every pair.
  {
    const ModelSpec& spec = model_->spec();
    Vec3 lower = spec.domain.upper_m;
    Vec3 upper = spec.domain.lower_m;
    for (std::size_t k = 0; k < n; ++k) {
      lower = lower.cwiseMin(s.position_m[k]);  // a NaN position leaves the box as it is
      upper = upper.cwiseMax(s.position_m[k]);
    }
    Vec3 extent = Vec3::Zero();
    for (int d = 0; d < 3; ++d) {
      const double low = std::max(lower[d], spec.domain.lower_m[d]);
      const double high = std::min(upper[d], spec.domain.upper_m[d]);
      m.cell_origin[d] = low <= high ? low : spec.domain.lower_m[d];
      extent[d] = low <= high ? high - low : 0.0;
    }
    m.cell_size = m.min_cell_size;
    for (;;) {
      for (int d = 0; d < 3; ++d) {
        m.cell_dims[d] = std::max(1, static_cast<int>(std::floor(extent[d] / m.cell_size)));
      }
      if (m.cell_dims.cast<double>().prod() <= static_cast<double>(m.max_cells)) break;
      m.cell_size *= 1.25;  // sparse: fewer, larger cells
    }
  }
  const auto cells = static_cast<std::size_t>(m.cell_dims.prod());
  std::fill(m.cell_start.begin(), m.cell_start.begin() + static_cast<std::ptrdiff_t>(cells + 1),
            0U);
  for (std::size_t k = 0; k < n; ++k) {
    const Vec3& x = s.position_m[k];
    const std::uint32_t cx =
        cell_coordinate(x.x(), m.cell_origin.x(), m.cell_size, m.cell_dims.x());
    const std::uint32_t cy =
        cell_coordinate(x.y(), m.cell_origin.y(), m.cell_size, m.cell_dims.y());
    const std::uint32_t cz =
        cell_coordinate(x.z(), m.cell_origin.z(), m.cell_size, m.cell_dims.z());
    const std::uint32_t cell = (cz * static_cast<std::uint32_t>(m.cell_dims.y()) + cy) *
                                   static_cast<std::uint32_t>(m.cell_dims.x()) +
                               cx;
    m.particle_cell[k] = cell;
    ++m.cell_start[cell + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) m.cell_start[c + 1] += m.cell_start[c];
  for (std::size_t k = 0; k < n; ++k) {
    m.order[m.cell_start[m.particle_cell[k]]++] = static_cast<std::uint32_t>(k);
  }
  for (std::size_t c = cells; c > 0; --c) m.cell_start[c] = m.cell_start[c - 1];
  m.cell_start[0] = 0;

  // 3. re-order particles by cell every few rebuilds (cache locality)
  if (reordered) {
    sort_particles();
    for (std::size_t k = 0; k < n; ++k) m.cell_particles[k] = static_cast<std::uint32_t>(k);
  } else {
    std::copy(m.order.begin(), m.order.begin() + static_cast<std::ptrdiff_t>(n),
              m.cell_particles.begin());
  }
  for (std::size_t k = 0; k < n; ++k) m.cell_position_m[k] = s.position_m[m.cell_particles[k]];

  // 4. bonded partners (pairs excluded from contact unless configured)
  if (!m.partners_valid || m.partner_offsets.size() != n + 1) {
    m.partner_offsets.assign(n + 1, 0);
    for (std::size_t k = 0; k < s.bonds.size(); ++k) {
      if (s.bond_states[k].broken) continue;
      ++m.partner_offsets[s.bonds[k].i + 1];
      ++m.partner_offsets[s.bonds[k].j + 1];
    }
    for (std::size_t k = 0; k < n; ++k) m.partner_offsets[k + 1] += m.partner_offsets[k];
    m.partner_particle.resize(m.partner_offsets[n]);
    m.scratch_u32.assign(m.partner_offsets.begin(), m.partner_offsets.end() - 1);
    for (std::size_t k = 0; k < s.bonds.size(); ++k) {
      if (s.bond_states[k].broken) continue;
      const Bond& b = s.bonds[k];
      m.partner_particle[m.scratch_u32[b.i]++] = b.j;
      m.partner_particle[m.scratch_u32[b.j]++] = b.i;
    }
    m.partners_valid = true;
  }

  // 5. half neighbour list from the 27 surrounding cells
  // The carried history is in list order: by i, then j, with i < j. Only a re-ordering of the
  // particles breaks that, so only then is it sorted again (each pair once: a unique order).
  if (reordered) {
    for (CarriedContact& c : m.carried) {  // re-ordering may have swapped a pair's order
      if (c.i > c.j) {
        std::swap(c.i, c.j);
        c.state.tangential_displacement_m = -c.state.tangential_displacement_m;
      }
    }
    std::sort(m.carried.begin(), m.carried.end(),
              [](const CarriedContact& a, const CarriedContact& b) {
                return a.i != b.i ? a.i < b.i : a.j < b.j;
              });
  }
  // Each thread lists the pairs of a contiguous range of i into its own buffers; the buffers
  // are then joined in thread order. A particle's segment does not depend on the split, so the
  // list is the same for any thread count.
  m.old_pair_offsets.swap(m.pair_offsets);
  const bool merge_old_list = !reordered && m.old_pair_offsets.size() == n + 1;
  m.pair_offsets.resize(n + 1);
  const int dx = m.cell_dims.x();
  const int dy = m.cell_dims.y();
  const int dz = m.cell_dims.z();
  const auto build_threads = static_cast<std::size_t>(m.active_threads);
  m.build_pair_j.resize(build_threads);
  m.build_pair_states.resize(build_threads);
  m.build_stamps.resize(build_threads);
  m.build_in_reach.resize(build_threads);
  m.build_wall_mesh.resize(build_threads);
  m.build_wall_triangle.resize(build_threads);
  const ModelSpec& spec = model_->spec();
  const std::size_t planes = spec.planes.size();
  const std::size_t wall_count = planes + spec.meshes.size();
  m.wall_list_offsets.resize(n + 1);
  m.contacts_at_build.resize(n);
  m.build_begin.assign(build_threads + 1, 0);
  for (std::size_t t = 0; t <= build_threads; ++t) {
    m.build_begin[t] = static_cast<std::uint32_t>(n * t / build_threads);
  }
  // Every pair's reach is at most the cell size's (two of the largest radii, the largest range
  // and the skin; IEEE addition is monotonic, so also as computed).
  const double largest_reach_squared = m.min_cell_size * m.min_cell_size;
  const Vec3* cell_position = m.cell_position_m.data();
#pragma omp parallel num_threads(m.active_threads) if (m.active_threads > 1)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    // The thread's growing buffers are swapped into vectors of its own for the build and back
    // after it (no allocation). In the shared arrays the threads' vector headers sit side by
    // side on one cache line, and every push_back writes its header: the two threads' pushes
    // passed that line between the cores at each listed pair.
    std::vector<std::uint32_t> pair_j;
    std::vector<PairState> pair_states;
    std::vector<std::uint32_t> wall_mesh;
    std::vector<std::uint32_t> wall_triangle;
    pair_j.swap(m.build_pair_j[t]);
    pair_states.swap(m.build_pair_states[t]);
    wall_mesh.swap(m.build_wall_mesh[t]);
    wall_triangle.swap(m.build_wall_triangle[t]);
    std::vector<std::uint32_t>& stamp = m.build_stamps[t];  // i + 1 at i's bonded partners
    pair_j.clear();
    pair_states.clear();
    wall_mesh.clear();
    wall_triangle.clear();
    stamp.assign(n, 0);
    // a particle's candidates within reach: at most every particle once
    std::vector<std::uint32_t>& in_reach = m.build_in_reach[t];
    in_reach.resize(n);
    const std::uint32_t i_begin = m.build_begin[t];
    const std::uint32_t i_end = m.build_begin[t + 1];
    std::size_t carried_next = static_cast<std::size_t>(
        std::lower_bound(m.carried.begin(), m.carried.end(), i_begin,
                         [](const CarriedContact& c, std::uint32_t i) { return c.i < i; }) -
        m.carried.begin());
    for (std::uint32_t i = i_begin; i < i_end; ++i) {
      m.pair_offsets[i] = static_cast<std::uint32_t>(pair_j.size());  // local; shifted below
      const Vec3 xi = s.position_m[i];
      const double ri = s.radius_m[i];
      const std::uint32_t ti = s.type[i];
      for (std::uint32_t p = m.partner_offsets[i]; p < m.partner_offsets[i + 1]; ++p) {
        stamp[m.partner_particle[p]] = i + 1;
      }
      const std::size_t type_row = ti * m.type_count;
      std::uint32_t in_reach_count = 0;
      const int cell = static_cast<int>(m.particle_cell[i]);
      const int cx = cell % dx;
      const int cy = (cell / dx) % dy;
      const int cz = cell / (dx * dy);
      for (int z = std::max(cz - 1, 0); z <= std::min(cz + 1, dz - 1); ++z) {
        for (int y = std::max(cy - 1, 0); y <= std::min(cy + 1, dy - 1); ++y) {
          const int row = (z * dy + y) * dx;
          for (int x = std::max(cx - 1, 0); x <= std::min(cx + 1, dx - 1); ++x) {
            const auto searched_cell = static_cast<std::size_t>(row) + static_cast<std::size_t>(x);
            const auto cell_begin = m.cell_particles.begin() + m.cell_start[searched_cell];
            const auto cell_end = m.cell_particles.begin() + m.cell_start[searched_cell + 1];
            // A cell lists its particles in ascending order (the binning is a stable counting
            // sort), so those up to i, never kept (pairs are listed under the lower index),
            // are a prefix: skipped. Right after a re-ordering by cell that is every particle
            // of the 13 cells before i's, half the candidates. The kept pairs are the same.
            if (cell_begin == cell_end || *(cell_end - 1) <= i) continue;
            const auto first =
                *cell_begin > i ? cell_begin : std::upper_bound(cell_begin, cell_end, i);
            // Most candidates fail the distance test, and half of them at random, so it is
            // folded into the count of a write that always happens: mispredicted branches were
            // most of the list build's time on a line. The test is against the largest reach
            // (no type, radius or range to look up per candidate); the few kept ones are then
            // tested against their own reach, for contact laws and for bonds.
            for (auto c = first; c < cell_end; ++c) {
              const auto slot = static_cast<std::size_t>(c - m.cell_particles.begin());
              const bool near = (xi - cell_position[slot]).squaredNorm() < largest_reach_squared;
              in_reach[in_reach_count] = *c;
              in_reach_count += near ? 1U : 0U;
            }
          }
        }
      }
      for (std::uint32_t k = 0; k < in_reach_count; ++k) {
        const std::uint32_t j = in_reach[k];
        const std::size_t pair_type = type_row + s.type[j];
        const double reach = m.listing_reach_m(ri, s.radius_m[j], pair_type);
        if ((xi - s.position_m[j]).squaredNorm() >= reach * reach) continue;
        const Interaction& interaction = *m.interactions[pair_type];
        if (!interaction.has_contact()) continue;
        if (!interaction.contact_between_bonded && stamp[j] == i + 1) continue;
        pair_j.push_back(j);
      }
      // sorted segment: deterministic order and merge with the old segment or the carried
      // history (the same states either way: an active pair's, else none)
      const auto segment_begin = pair_j.begin() + m.pair_offsets[i];
      std::sort(segment_begin, pair_j.end());
      std::uint32_t old_k = merge_old_list ? m.old_pair_offsets[i] : 0U;
      const std::uint32_t old_end = merge_old_list ? m.old_pair_offsets[i + 1] : 0U;
      std::uint32_t contacts = 0;
      for (auto it = segment_begin; it != pair_j.end(); ++it) {
        PairState state;
        if (merge_old_list) {
          while (old_k < old_end && m.pair_j[old_k] < *it) ++old_k;
          if (old_k < old_end && m.pair_j[old_k] == *it) {
            if (m.pair_states[old_k].active()) state = m.pair_states[old_k];
            ++old_k;
          }
          contacts += state.active() ? 1U : 0U;
          pair_states.push_back(state);
          continue;
        }
        while (carried_next < m.carried.size() &&
               (m.carried[carried_next].i < i ||
                (m.carried[carried_next].i == i && m.carried[carried_next].j < *it))) {
          ++carried_next;  // out of reach: history ends
        }
        if (carried_next < m.carried.size() && m.carried[carried_next].i == i &&
            m.carried[carried_next].j == *it) {
          state = m.carried[carried_next++].state;
        }
        contacts += state.active() ? 1U : 0U;
        pair_states.push_back(state);
      }
      m.contacts_at_build[i] = contacts;

      // 7. wall list: the triangles within reach plus skin, by mesh then triangle
      m.wall_list_offsets[i] = static_cast<std::uint32_t>(wall_mesh.size());  // local, as above
      const std::size_t wall_row = ti * wall_count;
      for (std::size_t mesh = 0; mesh < spec.meshes.size(); ++mesh) {
        const double reach = ri + m.wall_range_m[wall_row + planes + mesh] + m.skin;
        const double reach_squared = reach * reach;
        if (m.mesh_boxes[mesh].squaredExteriorDistance(xi) >= reach_squared) continue;
        const auto& boxes = m.mesh_triangle_boxes[mesh];
        const auto& triangles = m.mesh_triangles[mesh];
        for (std::size_t tri = 0; tri < boxes.size(); ++tri) {
          if (boxes[tri].squaredExteriorDistance(xi) >= reach_squared) continue;
          // The box of a belt's triangle is the whole belt: the box alone lists both triangles
          // for every sphere on it, and the force loop then finds the far one's closest point
          // out of reach at every step. Listed by the distance itself, it is looked at once a
          // build. The same contacts either way (a sphere moves at most the skin).
          const auto& vertices = triangles[tri].vertices_m;
          const ClosestPoint cp =
              closest_point_on_triangle(xi, vertices[0], vertices[1], vertices[2]);
          if ((xi - cp.point_m).squaredNorm() >= reach_squared) continue;
          wall_mesh.push_back(static_cast<std::uint32_t>(mesh));
          wall_triangle.push_back(static_cast<std::uint32_t>(tri));
        }
      }
    }
    pair_j.swap(m.build_pair_j[t]);
    pair_states.swap(m.build_pair_states[t]);
    wall_mesh.swap(m.build_wall_mesh[t]);
    wall_triangle.swap(m.build_wall_triangle[t]);
    // The old list is read until every thread has built its part.
#pragma omp barrier
#pragma omp single
    {
      size_joined_segments(m.build_pair_j, m.pair_offsets, m.pair_j, m.pair_states);
      m.pair_history.resize(m.pair_j.size());
      size_joined_segments(m.build_wall_mesh, m.wall_list_offsets, m.wall_list_mesh,
                           m.wall_list_triangle);
    }
    const std::size_t pairs_at =
        join_thread_segment(t, m.build_begin, m.build_pair_j, m.build_pair_states, m.pair_offsets,
                            m.pair_j, m.pair_states);
    const std::vector<PairState>& built_states = m.build_pair_states[t];
    for (std::size_t q = 0; q < built_states.size(); ++q) {
      m.pair_history[pairs_at + q] = built_states[q].active() ? 1U : 0U;
    }
    join_thread_segment(t, m.build_begin, m.build_wall_mesh, m.build_wall_triangle,
                        m.wall_list_offsets, m.wall_list_mesh, m.wall_list_triangle);
    std::copy(s.position_m.begin() + i_begin, s.position_m.begin() + i_end,
              m.build_position_m.begin() + i_begin);
  }
  m.mesh_moves_at_build = m.mesh_moves;

  // 6. thread ranges balanced by the contact loop's work. A listed pair is a distance test; one
  // that held contact at the build also runs its laws, about four tests' time; a listed
  // triangle is a closest-point search with its laws, about sixteen; each particle tests the
  // planes. Weighed by listed pairs alone, the thread holding the bottom of a pile (the floor,
  // the box's and the belt's triangles) was busy 1.8 times as long as the other; these weights
  // were fitted on that run until both waited about as long (docs/benchmarks.md).
  const std::size_t threads = static_cast<std::size_t>(m.active_threads);
  const auto work = [&m](std::uint32_t i) {
    constexpr double kContactWeight = 4.0;
    constexpr double kListedTriangleWeight = 16.0;
    constexpr double kPlanesWeight = 2.0;
    return static_cast<double>(m.pair_offsets[i + 1] - m.pair_offsets[i]) +
           kContactWeight * static_cast<double>(m.contacts_at_build[i]) +
           kListedTriangleWeight *
               static_cast<double>(m.wall_list_offsets[i + 1] - m.wall_list_offsets[i]) +
           kPlanesWeight;
  };
  double total = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) total += work(i);
  std::uint32_t i = 0;
  double done = 0.0;
  m.particle_begin[0] = 0;
  for (std::size_t t = 1; t < threads; ++t) {
    const double target = total * static_cast<double>(t) / static_cast<double>(threads);
    while (i < n && done < target) done += work(i++);
    m.particle_begin[t] = i;
  }
  m.particle_begin[threads] = static_cast<std::uint32_t>(n);

  if (m.prepared && m.forces_valid && list_capacity() != capacity_before) {
    ++stats_.neighbor_capacity_growths;
  }
  stats_.neighbor_pairs = m.pair_j.size();
  ++stats_.neighbor_rebuilds;
  m.rebuild_requested = false;
}

// --------------------------------------------------------------------------------- forces

void Simulation::compute_forces() {
  Impl& m = *impl_;
  State& s = state_;
  const ModelSpec& spec = model_->spec();
  const std::size_t n = s.size();
  const std::size_t planes = spec.planes.size();
  const std::size_t meshes = spec.meshes.size();
  const std::size_t wall_count = planes + meshes;
  const double dt = m.dt;

#pragma omp parallel num_threads(m.active_threads) if (m.active_threads > 1)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    Vec3* force = t == 0 ? s.force_n.data() : m.force_buffers[t].data();
    Vec3* torque = t == 0 ? s.torque_nm.data() : m.torque_buffers[t].data();
    // Thread 0 writes the state's arrays; each thread clears its equal share of them, the share
    // it sums and kicks after the force pass (so those lines stay in its core's cache), then
    // a barrier. Another thread's buffer is cleared from its lowest written index (bond_low)
    // only: below it the buffer is neither written nor read.
    const auto threads = static_cast<std::size_t>(m.active_threads);
    const auto [share_begin, share_end] = equal_share(n, t, threads);
    std::fill(s.force_n.begin() + static_cast<std::ptrdiff_t>(share_begin),
              s.force_n.begin() + static_cast<std::ptrdiff_t>(share_end), Vec3::Zero());
    std::fill(s.torque_nm.begin() + static_cast<std::ptrdiff_t>(share_begin),
              s.torque_nm.begin() + static_cast<std::ptrdiff_t>(share_end), Vec3::Zero());
    if (t > 0) {
      const std::size_t written_from = m.buffer_written_from(t, n);
      std::fill(force + written_from, force + n, Vec3::Zero());
      std::fill(torque + written_from, torque + n, Vec3::Zero());
    }
#pragma omp barrier
    Vec3* wall_force = m.wall_force_buffers[t].data();
    Vec3* wall_torque = m.wall_torque_buffers[t].data();
    std::fill(wall_force, wall_force + wall_count, Vec3::Zero());
    std::fill(wall_torque, wall_torque + wall_count, Vec3::Zero());
    ThreadTally tally;
    const Vec3* x = s.position_m.data();
    const Vec3* v = s.velocity_m_per_s.data();
    const Vec3* w = s.angular_velocity_rad_per_s.data();
    const double* radius = s.radius_m.data();
    const double* inv_mass = s.inverse_mass_per_kg.data();
    const std::uint32_t* type = s.type.data();
    const std::uint32_t i_begin = m.particle_begin[t];
    const std::uint32_t i_end = m.particle_begin[t + 1];

    // sphere-sphere contacts
    for (std::uint32_t i = i_begin; i < i_end; ++i) {
      const Vec3 xi = x[i];
      const Vec3 vi = v[i];
      const Vec3 wi = w[i];
      const double ri = radius[i];
      const double inv_mi = inv_mass[i];
      const std::size_t type_row = type[i] * m.type_count;
      Vec3 force_i = Vec3::Zero();
      Vec3 torque_i = Vec3::Zero();
      for (std::uint32_t k = m.pair_offsets[i]; k < m.pair_offsets[i + 1]; ++k) {
        const std::uint32_t j = m.pair_j[k];
        const std::size_t pair_type = type_row + type[j];
        const Vec3 d = xi - x[j];
        const double rj = radius[j];
        const double radius_sum = ri + rj;
        const double reach = radius_sum + m.pair_range_m[pair_type];
        const double distance_squared = d.squaredNorm();
        if (distance_squared >= reach * reach) {
          if (m.pair_history[k] != 0) {
            m.pair_states[k].reset();
            m.pair_history[k] = 0;
          }
          continue;
        }
        PairState& pair_state = m.pair_states[k];
        const double distance = std::sqrt(distance_squared);
        PairGeometry g;
        g.normal = d * (1.0 / distance);  // one division, not three
        g.overlap_m = radius_sum - distance;
        g.relative_velocity_m_per_s = vi - v[j] - (ri * wi + rj * w[j]).cross(g.normal);
        g.relative_angular_velocity_rad_per_s = wi - w[j];
        g.effective_radius_m = ri * rj / radius_sum;
        g.effective_mass_kg = 1.0 / (inv_mi + inv_mass[j]);
        g.timestep_s = dt;
        ForceAccumulator acc;
        m.interactions[pair_type]->contact_chain->compute(g, pair_state, acc);
        m.pair_history[k] = pair_state.active() ? 1U : 0U;
        if (!acc.touching) continue;
        const Vec3 tangential = acc.tangential_elastic_force_n + acc.tangential_damping_force_n;
        const Vec3 f = (acc.normal_force_n + acc.normal_damping_force_n) * g.normal + tangential;
        const Vec3 t_cross_n = tangential.cross(g.normal);
        force_i += f;
        force[j] -= f;
        torque_i += ri * t_cross_n + acc.torque_on_i_nm;
        torque[j] += rj * t_cross_n + acc.torque_on_j_nm;
        tally.contact_energy_j += acc.elastic_energy_j;
        ++tally.touching;
      }
      force[i] += force_i;
      torque[i] += torque_i;
    }

    // bonds: one batch per run of bonds with the same law (a body's bonds are contiguous)
    {
      BondBatch batch;
      batch.bonds = s.bonds.data();
      batch.states = s.bond_states.data();
      batch.position_m = x;
      batch.velocity_m_per_s = v;
      batch.angular_velocity_rad_per_s = w;
      batch.radius_m = radius;
      batch.force_n = force;
      batch.torque_nm = torque;
      batch.timestep_s = dt;
      batch.kernel = model_->spec().bond_kernel;
      const std::uint32_t bonds_end = m.bond_begin[t + 1];
      for (std::uint32_t k = m.bond_begin[t]; k < bonds_end;) {
        const BondLaw* law = m.bond_laws[k];
        std::uint32_t run_end = k + 1;
        while (run_end < bonds_end && m.bond_laws[run_end] == law) ++run_end;
        batch.begin = k;
        batch.end = run_end;
        tally.bond_broke = law->compute_batch(batch) || tally.bond_broke;
        k = run_end;
      }
    }

    // walls
    if (wall_count > 0) {
      // the wall list is built with the neighbour list, which every change of the particle
      // count rebuilds before forces; without it every mesh is searched in full
      const bool wall_list_valid = m.wall_list_offsets.size() == n + 1;
      std::uint64_t moved_meshes = 0;
      for (std::size_t mesh = 0; mesh < meshes; ++mesh) {
        if (!wall_list_valid || m.mesh_moves_at_build[mesh] != m.mesh_moves[mesh]) {
          moved_meshes |= wall_bit(planes + mesh);
        }
      }
      const bool visit_by_bits = wall_count < 64;
      std::array<std::uint32_t, 16> candidate_triangle{};
      std::array<ClosestPoint, 16> candidate_point{};
      for (std::uint32_t i = i_begin; i < i_end; ++i) {
        const Vec3 xi = x[i];
        const double ri = radius[i];
        const std::size_t wall_row = type[i] * wall_count;
        auto apply = [&](std::size_t wall, const Vec3& normal, double overlap, const Vec3& point,
                         PairState& pair_state) {
          const WallState& ws = s.walls[wall];
          const Vec3 moved_pivot = ws.pivot_m + ws.translation_m;
          const Vec3 surface =
              ws.surface_velocity_m_per_s - ws.surface_velocity_m_per_s.dot(normal) * normal;
          const Vec3 wall_velocity = ws.linear_velocity_m_per_s +
                                     ws.angular_velocity_rad_per_s.cross(point - moved_pivot) +
                                     surface;
          PairGeometry g;
          g.normal = normal;
          g.overlap_m = overlap;
          g.relative_velocity_m_per_s = v[i] - (ri * w[i]).cross(normal) - wall_velocity;
          g.relative_angular_velocity_rad_per_s = w[i] - ws.angular_velocity_rad_per_s;
          g.effective_radius_m = ri;
          g.effective_mass_kg = 1.0 / inv_mass[i];
          g.timestep_s = dt;
          ForceAccumulator acc;
          m.wall_interactions[wall_row + wall]->contact_chain->compute(g, pair_state, acc);
          if (!acc.touching) return;
          const Vec3 tangential = acc.tangential_elastic_force_n + acc.tangential_damping_force_n;
          const Vec3 on_particle =
              (acc.normal_force_n + acc.normal_damping_force_n) * normal + tangential;
          force[i] += on_particle;
          torque[i] += ri * tangential.cross(normal) + acc.torque_on_i_nm;
          // The reaction, applied at the contact point; a law's pure moment (rolling
          // resistance) acts back on the wall as well.
          wall_force[wall] -= on_particle;
          wall_torque[wall] -= (point - moved_pivot).cross(on_particle) + acc.torque_on_i_nm;
          tally.contact_energy_j += acc.elastic_energy_j;
        };
        std::uint64_t history = m.wall_history[i];
        std::uint64_t history_next = 0;
        std::uint32_t listed = wall_list_valid ? m.wall_list_offsets[i] : 0;
        const std::uint32_t listed_end = wall_list_valid ? m.wall_list_offsets[i + 1] : 0;
        // Meshes to visit: listed ones, moved ones and those holding history. With under 64
        // walls each has its own bit, and the other meshes (most, on a line) are skipped.
        std::uint64_t visit = moved_meshes | history;
        for (std::uint32_t e = listed; e < listed_end; ++e) {
          visit |= wall_bit(planes + m.wall_list_mesh[e]);
        }
        const auto next_mesh = [&](std::size_t from) -> std::size_t {
          if (!visit_by_bits) return from;
          const std::size_t bit_index = planes + from;
          if (bit_index >= 64) return meshes;
          const std::uint64_t rest = visit & (~std::uint64_t{0} << bit_index);
          return rest == 0 ? meshes : static_cast<std::size_t>(std::countr_zero(rest)) - planes;
        };
        for (std::size_t p = 0; p < planes; ++p) {
          const double gap = (xi - m.plane_point_m[p]).dot(m.plane_normal[p]);
          const double overlap = ri - gap;
          const std::uint64_t bit = wall_bit(p);
          if (overlap <= -m.wall_range_m[wall_row + p]) {
            if ((history & bit) != 0) m.plane_states[p][i].reset();
            continue;
          }
          history_next |= bit;
          apply(p, m.plane_normal[p], overlap, xi - gap * m.plane_normal[p], m.plane_states[p][i]);
        }
        for (std::size_t mesh = next_mesh(0); mesh < meshes; mesh = next_mesh(mesh + 1)) {
          const std::size_t wall = planes + mesh;
          const double reach = ri + m.wall_range_m[wall_row + wall];
          const std::uint64_t bit = wall_bit(wall);
          // squared distances: a square root per triangle was the wall loop's main cost
          const double reach_squared = reach * reach;
          // An unmoved mesh: the listed triangles, a superset of those in reach, in order.
          const bool unmoved = wall_list_valid && m.mesh_moves_at_build[mesh] == m.mesh_moves[mesh];
          std::uint32_t listed_begin = listed;
          while (listed < listed_end && m.wall_list_mesh[listed] == mesh) ++listed;
          const bool near = unmoved
                                ? listed > listed_begin
                                : m.mesh_boxes[mesh].squaredExteriorDistance(xi) < reach_squared;
          if (!near && (history & bit) == 0) continue;  // far, nothing to forget
          MeshSlot* slots = &m.mesh_slots[mesh][std::size_t{i} * kMeshSlots];
          int candidates = 0;
          if (near) {
            const auto& triangles = m.mesh_triangles[mesh];
            const auto& boxes = m.mesh_triangle_boxes[mesh];
            const std::size_t searched = unmoved ? listed - listed_begin : triangles.size();
            for (std::size_t k = 0; k < searched && candidates < 16; ++k) {
              const std::size_t tri = unmoved ? m.wall_list_triangle[listed_begin + k] : k;
              if (boxes[tri].squaredExteriorDistance(xi) >= reach_squared) continue;
              const auto& vertices = triangles[tri].vertices_m;
              const ClosestPoint cp =
                  closest_point_on_triangle(xi, vertices[0], vertices[1], vertices[2]);
              if ((xi - cp.point_m).squaredNorm() >= reach_squared) continue;
              candidate_triangle[static_cast<std::size_t>(candidates)] =
                  static_cast<std::uint32_t>(tri);
              candidate_point[static_cast<std::size_t>(candidates)] = cp;
              ++candidates;
            }
          }
          // A face contact makes edge/vertex contacts of neighbouring triangles redundant;
          // without one, an edge or vertex shared by several triangles counts once.
          bool any_face = false;
          for (int c = 0; c < candidates; ++c) {
            any_face = any_face || candidate_point[static_cast<std::size_t>(c)].feature ==
                                       TriangleFeature::kFace;
          }
          std::array<int, kMeshSlots> kept_candidate{};
          int kept = 0;
          for (int c = 0; c < candidates && kept < kMeshSlots; ++c) {
            const ClosestPoint& cp = candidate_point[static_cast<std::size_t>(c)];
            if (any_face && cp.feature != TriangleFeature::kFace) continue;
            bool duplicate = false;
            for (int e = 0; e < kept && !any_face; ++e) {
              const auto& other = candidate_point[static_cast<std::size_t>(
                  kept_candidate[static_cast<std::size_t>(e)])];
              duplicate = duplicate || (other.point_m - cp.point_m).squaredNorm() < 1e-18;
            }
            if (!duplicate) kept_candidate[static_cast<std::size_t>(kept++)] = c;
          }
          for (int q = 0; q < kMeshSlots; ++q) {  // history ends for triangles left
            bool still = false;
            for (int e = 0; e < kept; ++e) {
              still =
                  still || candidate_triangle[static_cast<std::size_t>(
                               kept_candidate[static_cast<std::size_t>(e)])] == slots[q].triangle;
            }
            if (!still) slots[q] = MeshSlot{};
          }
          if (kept > 0) history_next |= bit;
          for (int e = 0; e < kept; ++e) {
            const auto c = static_cast<std::size_t>(kept_candidate[static_cast<std::size_t>(e)]);
            const ClosestPoint& cp = candidate_point[c];
            const std::uint32_t tri = candidate_triangle[c];
            int slot = -1;
            for (int q = 0; q < kMeshSlots && slot < 0; ++q) {
              if (slots[q].triangle == tri) slot = q;
            }
            for (int q = 0; q < kMeshSlots && slot < 0; ++q) {
              if (slots[q].triangle == kNoTriangle) slot = q;
            }
            slots[slot].triangle = tri;
            const Vec3 offset = xi - cp.point_m;
            const double distance = offset.norm();
            if (distance == 0.0) continue;  // centre on the surface: no defined normal
            apply(wall, offset / distance, ri - distance, cp.point_m, slots[slot].state);
          }
        }
        m.wall_history[i] = history_next;
      }
    }
    m.tallies[t] = tally;
#pragma omp barrier
    if (m.active_threads > 1) {
      // Each thread sums its equal share, the one it cleared and kicks next: the sum is per
      // particle, the same bits for any split. Below a buffer's written_from it holds no
      // force: +0, which would change nothing (the sums start at +0 and never reach -0).
      for (std::size_t b = 1; b < threads; ++b) {
        for (std::size_t k = std::max(share_begin, m.buffer_written_from(b, n)); k < share_end;
             ++k) {
          s.force_n[k] += m.force_buffers[b][k];
          s.torque_nm[k] += m.torque_buffers[b][k];
        }
      }
    }
  }

  for (std::size_t wall = 0; wall < wall_count; ++wall) {
    Vec3 wall_force = Vec3::Zero();
    Vec3 wall_torque = Vec3::Zero();
    for (std::size_t t = 0; t < static_cast<std::size_t>(m.active_threads); ++t) {
      wall_force += m.wall_force_buffers[t][wall];
      wall_torque += m.wall_torque_buffers[t][wall];
    }
    s.wall_force_n[wall] = wall_force;
    s.wall_torque_nm[wall] = wall_torque;
  }

  double contact_energy = 0.0;
  std::size_t touching = 0;
  bool broke = false;
  for (std::size_t t = 0; t < static_cast<std::size_t>(m.active_threads); ++t) {
    const ThreadTally& tally = m.tallies[t];
    contact_energy += tally.contact_energy_j;
    touching += tally.touching;
    broke = broke || tally.bond_broke;
  }
  m.last_contact_energy_j = contact_energy;
  stats_.touching_pairs = touching;
  if (broke) {
    // The freed pair must be listed for contact before it can touch. A pair that was out of
    // contact reach plus skin when the list was built cannot touch before the skin trigger
    // rebuilds the list (the Verlet argument), so only a break within that reach forces a
    // rebuild now. Bonds torn at the separation limit (two contact radii) and diagonal bonds
    // are beyond it, so an impact that tears many bonds no longer rebuilds at each tear.
    m.partners_valid = false;
    const auto freed_pair_within_reach = [&m, &s](const Bond& bond) {
      const std::size_t pair_type = s.type[bond.i] * m.type_count + s.type[bond.j];
      const Interaction& interaction = *m.interactions[pair_type];
      // bonded pairs in contact are listed already, when in reach, like any other pair
      if (!interaction.has_contact() || interaction.contact_between_bonded) return false;
      const double reach = m.listing_reach_m(s.radius_m[bond.i], s.radius_m[bond.j], pair_type);
      return (m.build_position_m[bond.i] - m.build_position_m[bond.j]).squaredNorm() <
             reach * reach;
    };
    m.bond_break_handled.resize(s.bond_states.size(), 0);  // bonds added through the state
    std::size_t count = 0;
    for (std::size_t k = 0; k < s.bond_states.size(); ++k) {
      if (!s.bond_states[k].broken) continue;
      ++count;
      if (m.bond_break_handled[k] != 0) continue;
      m.bond_break_handled[k] = 1;
      m.rebuild_requested = m.rebuild_requested || freed_pair_within_reach(s.bonds[k]);
    }
    stats_.broken_bonds = count;
  }
}

// ---------------------------------------------------------------------------------- step

void Simulation::step(std::size_t count) {
  Impl& m = *impl_;
  if (!m.prepared) prepare();
  State& s = state_;
  const ModelSpec& spec = model_->spec();
  const std::size_t n = s.size();
  const double dt = m.dt;
  const double half_dt = 0.5 * dt;
  const Vec3 gravity = m.gravity;
  const double skin_squared = m.skin * m.skin;
  const bool wall_list_in_use = !spec.meshes.empty();
  bool walls_move = false;
  for (const WallState& w : s.walls) {
    walls_move = walls_move || !w.linear_velocity_m_per_s.isZero(0.0) ||
                 !w.angular_velocity_rad_per_s.isZero(0.0);
  }

  // The second half kick of a step and the first of the next use the same forces, so they run
  // in one pass over the particles (in the same order of operations, so the same bits): a
  // parallel region less per step, whose fork and join cost several times the kick's work
  // on a line of a thousand spheres. The last step's second half is applied before returning.
  bool second_half_pending = false;
  const auto half_kick = [&s, half_dt, gravity](std::size_t k) {
    s.velocity_m_per_s[k] += half_dt * (s.force_n[k] * s.inverse_mass_per_kg[k] + gravity);
    s.angular_velocity_rad_per_s[k] += half_dt * s.inverse_inertia_per_kg_m2[k] * s.torque_nm[k];
  };
  for (std::size_t iteration = 0; iteration < count; ++iteration) {
    const bool finish_previous = second_half_pending;
    // Displacements since the last build: the largest one's square and their bounding box.
    // Reduced by min and max, which round nothing, so the same for any thread count.
    constexpr double kInfinity = std::numeric_limits<double>::infinity();
    double largest_squared = 0.0;
    double low_x = kInfinity, low_y = kInfinity, low_z = kInfinity;
    double high_x = -kInfinity, high_y = -kInfinity, high_z = -kInfinity;
    // (unformatted: clang-format breaks the clauses inside their parentheses)
    // clang-format off
#pragma omp parallel num_threads(m.active_threads) if (m.active_threads > 1) \
    reduction(max : largest_squared, high_x, high_y, high_z) \
    reduction(min : low_x, low_y, low_z)
    // clang-format on
    {
      // Equal shares of particles: a kick costs the same for each, unlike the contact loop's
      // work, whose ranges (particle_begin) give the thread holding the bottom of a pile fewer
      // particles; on those ranges one thread waited for the other here. The share is the one
      // the thread cleared and summed in compute_forces. Each particle's update is its own,
      // so the split changes no bits.
      const auto t = static_cast<std::size_t>(omp_get_thread_num());
      const auto [begin, end] = equal_share(n, t, static_cast<std::size_t>(m.active_threads));
      for (std::size_t k = begin; k < end; ++k) {
        if (finish_previous) half_kick(k);
        half_kick(k);
        s.position_m[k] += dt * s.velocity_m_per_s[k];
        const Vec3 moved = s.position_m[k] - m.build_position_m[k];
        largest_squared = std::max(largest_squared, moved.squaredNorm());
        low_x = std::min(low_x, moved.x());
        low_y = std::min(low_y, moved.y());
        low_z = std::min(low_z, moved.z());
        high_x = std::max(high_x, moved.x());
        high_y = std::max(high_y, moved.y());
        high_z = std::max(high_z, moved.z());
      }
    }
    // The Verlet argument: a pair left out of the list was beyond its reach plus the skin at
    // the build, so it cannot touch while its relative displacement |d_i - d_j| stays within
    // the skin. Two bounds of it: twice the largest displacement (the usual half-skin rule)
    // and the diagonal of the displacements' box, which is what moved relative to what. A load
    // carried along as a whole widens the box by nothing; fillets falling past resting ones
    // widen it by their own displacement, half of what the half-skin rule counts. The wall list
    // holds the triangles within reach plus skin of each sphere, and the walls do not move with
    // the spheres: it holds while every sphere is within the skin of where it was built.
    const double box_diagonal_squared = (high_x - low_x) * (high_x - low_x) +
                                        (high_y - low_y) * (high_y - low_y) +
                                        (high_z - low_z) * (high_z - low_z);
    // (no particles: an empty box, and nothing moved)
    const bool pairs_may_touch =
        4.0 * largest_squared > skin_squared && box_diagonal_squared > skin_squared;
    const bool walls_may_touch = wall_list_in_use && largest_squared > skin_squared;
    const bool rebuild = m.rebuild_requested || pairs_may_touch || walls_may_touch;
    if (walls_move) {
      for (WallState& w : s.walls) {
        w.translation_m += dt * w.linear_velocity_m_per_s;
        const double angle = w.angular_velocity_rad_per_s.norm() * dt;
        if (angle > 0.0) {
          w.rotation = Eigen::Quaterniond(
                           Eigen::AngleAxisd(angle, w.angular_velocity_rad_per_s.normalized())) *
                       w.rotation;
          w.rotation.normalize();
        }
      }
      update_wall_geometry();
      // A moving mesh may approach particles faster than the skin allows for: fine here since
      // wall contacts are found every step without a list.
    }
    if (rebuild) rebuild_neighbors();
    compute_forces();
    second_half_pending = true;
    s.time_s += dt;
    ++s.step;
  }
  if (second_half_pending) {
#pragma omp parallel for num_threads(m.active_threads) if (m.active_threads > 1) schedule(static)
    for (std::size_t k = 0; k < n; ++k) half_kick(k);
  }
}

// ------------------------------------------------------------------------------- reports

EnergyReport Simulation::energy() const {
  const State& s = state_;
  EnergyReport report;
  const Vec3 gravity = impl_->gravity;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double mass = 1.0 / s.inverse_mass_per_kg[k];
    report.kinetic_translational_j += 0.5 * mass * s.velocity_m_per_s[k].squaredNorm();
    report.kinetic_rotational_j +=
        0.5 * s.angular_velocity_rad_per_s[k].squaredNorm() / s.inverse_inertia_per_kg_m2[k];
    report.gravitational_j -= mass * gravity.dot(s.position_m[k]);
  }
  report.contact_elastic_j = impl_->last_contact_energy_j;
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {  // from the bond states of the last step
    if (s.bond_states[k].broken) continue;
    const BondLaw& law = *model_->interaction(s.type[s.bonds[k].i], s.type[s.bonds[k].j]).bond_law;
    report.bond_elastic_j += law.elastic_energy_j(s.bond_states[k], s.bonds[k]);
  }
  return report;
}

TimestepReport Simulation::check_timestep() const {
  const State& s = state_;
  TimestepReport report;
  report.timestep_s = impl_->dt;
  report.rayleigh_time_s = std::numeric_limits<double>::infinity();
  report.bond_critical_step_s = std::numeric_limits<double>::infinity();
  report.contact_critical_step_s = std::numeric_limits<double>::infinity();
  std::vector<double> bond_stiffness(s.size(), 0.0);
  for (std::size_t k = 0; k < s.bonds.size(); ++k) {
    if (s.bond_states[k].broken) continue;
    const Bond& b = s.bonds[k];
    const BondLaw& law = *model_->interaction(s.type[b.i], s.type[b.j]).bond_law;
    const double stiffness =
        std::max(law.normal_stiffness_n_per_m(b), law.shear_stiffness_n_per_m(b));
    bond_stiffness[b.i] += stiffness;
    bond_stiffness[b.j] += stiffness;
  }
  for (std::size_t k = 0; k < s.size(); ++k) {
    const Material& material = model_->material_of_type(s.type[k]);
    report.rayleigh_time_s =
        std::min(report.rayleigh_time_s,
                 rayleigh_time_s(s.radius_m[k], material.density_kg_per_m3,
                                 material.youngs_modulus_pa, material.poisson_ratio));
    if (bond_stiffness[k] > 0.0) {
      // a particle held by all its bonds, neighbours fixed: omega^2 = sum k / m
      const double omega = std::sqrt(bond_stiffness[k] * s.inverse_mass_per_kg[k]);
      report.bond_critical_step_s = std::min(report.bond_critical_step_s, 2.0 / omega);
    }
    for (const auto& law : model_->interaction(s.type[k], s.type[k]).contact_laws) {
      // Hertz contact of two equal spheres at 10% radius overlap (a hard impact)
      const double stiffness =
          law->normal_stiffness_n_per_m(0.5 * s.radius_m[k], 0.1 * s.radius_m[k]);
      if (stiffness > 0.0) {
        const double omega = std::sqrt(stiffness * 2.0 * s.inverse_mass_per_kg[k]);
        report.contact_critical_step_s = std::min(report.contact_critical_step_s, 2.0 / omega);
      }
    }
  }
  report.rayleigh_fraction = report.timestep_s / report.rayleigh_time_s;
  std::ostringstream text;
  text << "timestep " << report.timestep_s << " s = " << 100.0 * report.rayleigh_fraction
       << "% of the Rayleigh time " << report.rayleigh_time_s << " s; bond critical step 2/omega "
       << report.bond_critical_step_s << " s; contact critical step (10% overlap) "
       << report.contact_critical_step_s << " s";
  // Limits: EDEM advises 20-40% of the Rayleigh time; an explicit oscillator needs dt < 2/omega
  // for stability and a fifth of it (over 15 steps per period) for a ~1% accurate period.
  if (report.rayleigh_fraction > 0.4) {
    report.ok = false;
    text << "; TOO LARGE: above 40% of the Rayleigh time";
  }
  if (report.timestep_s > 0.2 * report.bond_critical_step_s) {
    report.ok = false;
    text << "; TOO LARGE for the bonds: above 0.2 * " << report.bond_critical_step_s << " s";
  }
  if (report.timestep_s > 0.2 * report.contact_critical_step_s) {
    report.ok = false;
    text << "; TOO LARGE for the contact stiffness: above 0.2 * " << report.contact_critical_step_s
         << " s";
  }
  report.message = text.str();
  return report;
}

}  // namespace fl::dem
