// dem::Simulation: the DEM engine. Owns a State, shares an immutable Model, and advances the
// state with velocity Verlet (translation and rotation; spheres with scalar inertia).
//
// Per step: half kick, drift, wall motion, neighbour-list check (Verlet skin: rebuild when two
// particles may have closed by more than the skin since the build, a particle moved more than
// the skin where meshes are listed, or a bond broke within reach), forces (pairs, bonds, walls),
// half kick.
//
// Threads: up to `ModelSpec::thread_count` OpenMP threads, one per
// `ModelSpec::min_particles_per_thread` particles. Each thread owns a contiguous range of
// particles (pairs i<j are listed under i) and of bonds, and accumulates into its own force
// buffer; buffers are summed in thread order. Results are bit-identical for a fixed thread count.
//
// Allocation: add_* and reserve() allocate; step() does not, once the neighbour list has
// reached its working size (stats().neighbor_capacity_growths counts growths during steps).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fl/twin/dem/model.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {

struct SphereSpec {
  Vec3 position_m = Vec3::Zero();
  double radius_m = 0.004;
  std::uint32_t type = 0;
  Vec3 velocity_m_per_s = Vec3::Zero();
  Vec3 angular_velocity_rad_per_s = Vec3::Zero();
};

// One bond of a body: sphere indices within the body and the contact radius of each sphere;
// the bond breaks when the centres separate beyond 2 * contact_radius_m (the sum of both).
struct BodyBond {
  std::uint32_t i = 0;
  std::uint32_t j = 0;
  double contact_radius_m = 0.0;
  double thickness_m = 0.0;  // the body's local thickness there; 0: not given
};

struct BodyPose {
  Vec3 position_m = Vec3::Zero();  // where the body frame's origin (template centroid) goes
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();
  Vec3 velocity_m_per_s = Vec3::Zero();
  Vec3 angular_velocity_rad_per_s = Vec3::Zero();  // rigid spin about position_m
};

struct EnergyReport {
  double kinetic_translational_j = 0.0;
  double kinetic_rotational_j = 0.0;
  double gravitational_j = 0.0;    // -m g . x (zero at the origin)
  double contact_elastic_j = 0.0;  // Hertz normal + tangential springs (not JKR)
  double bond_elastic_j = 0.0;
  [[nodiscard]] double total_j() const {
    return kinetic_translational_j + kinetic_rotational_j + gravitational_j + contact_elastic_j +
           bond_elastic_j;
  }
};

struct SimulationStats {
  std::uint64_t neighbor_rebuilds = 0;
  std::uint64_t particle_sorts = 0;
  std::uint64_t neighbor_capacity_growths = 0;  // during step(); 0 after warm-up is the goal
  std::size_t neighbor_pairs = 0;
  std::size_t touching_pairs = 0;  // last force evaluation, sphere-sphere
  std::size_t broken_bonds = 0;
  // bonds are computed in runs of one law (per thread); the vector kernel works on whole runs
  std::size_t bond_law_runs = 0;
};

// Timestep check against the Rayleigh time and the stiffest bonded particle.
struct TimestepReport {
  double timestep_s = 0.0;
  double rayleigh_time_s = 0.0;          // smallest particle's
  double rayleigh_fraction = 0.0;        // timestep / rayleigh_time
  double bond_critical_step_s = 0.0;     // 2 / omega of the stiffest particle (sum over bonds)
  double contact_critical_step_s = 0.0;  // 2 / omega of a Hertz contact at 10% radius overlap
  bool ok = true;
  std::string message;  // the numbers and, when not ok, what is too large
};

class Simulation {
 public:
  explicit Simulation(std::shared_ptr<const Model> model);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // ---- setup (may allocate)
  void reserve(std::size_t particles, std::size_t bonds);
  std::uint32_t add_sphere(const SphereSpec& sphere);
  // Adds a body of spheres (positions relative to the body origin, radii, model type indices)
  // bonded by `bonds`, placed at `pose`; returns the body number. Rest lengths are the
  // placed distances.
  std::uint32_t add_body(std::span<const Vec3> positions_m, std::span<const double> radii_m,
                         std::span<const std::uint8_t> types, std::span<const BodyBond> bonds,
                         const BodyPose& pose);
  // Takes the particles of the given bodies (add_body/add_sphere numbers; unknown ones are
  // ignored) and their bonds out of the run. The others keep their state, bond states and
  // contact history; body numbers and ids stay, particle and bond indices shift down.
  // Returns the number of particles removed.
  std::size_t remove_bodies(std::span<const std::uint32_t> bodies);
  // Builds the neighbour list and the first forces; step() calls it when needed.
  void prepare();

  // ---- run
  void step(std::size_t count = 1);

  // ---- access
  [[nodiscard]] const Model& model() const { return *model_; }
  [[nodiscard]] const State& state() const { return state_; }
  // For commanding walls (belt speed, flip plate rotation) and setting velocities. Changing
  // positions, radii or the particle count requires prepare() (called by step() on add_*).
  [[nodiscard]] State& mutable_state() { return state_; }
  [[nodiscard]] WallState& wall(std::string_view name);
  // The wall's index in State::walls, wall_force_n and wall_torque_nm (planes first, then
  // meshes). Throws std::invalid_argument for an unknown name.
  [[nodiscard]] std::size_t wall_index(std::string_view name) const;

  // Energy of the current state (recomputes the elastic parts without changing history).
  [[nodiscard]] EnergyReport energy() const;
  [[nodiscard]] const SimulationStats& stats() const { return stats_; }
  [[nodiscard]] TimestepReport check_timestep() const;
  [[nodiscard]] int thread_count() const;         // at most (ModelSpec::thread_count)
  [[nodiscard]] int active_thread_count() const;  // for the current particle count

 private:
  struct Impl;
  void update_wall_geometry();
  void rebuild_neighbors();
  void sort_particles();
  void sort_bonds();
  void assign_bond_laws();
  void gather_particles(const std::vector<std::uint32_t>& order);
  void compute_forces();
  std::shared_ptr<const Model> model_;
  State state_;
  SimulationStats stats_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fl::dem
