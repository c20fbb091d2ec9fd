// dem::Model: what stays fixed during a run (MuJoCo's mjModel): materials, particle types, the
// law chains per type pair, wall geometry, gravity, timestep, domain and solver settings.
// Everything that changes (particles, bonds, wall poses and belt speeds, contact history) is in
// dem::State / dem::Simulation. Defaults follow the thesis' appendix B (config.hpp,
// config/dem.yaml).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fl/twin/dem/laws.hpp"

namespace fl::dem {

struct Material {
  std::string name;
  double youngs_modulus_pa = 3.7e5;
  double poisson_ratio = 0.37;
  double density_kg_per_m3 = 940.0;
};

struct ParticleType {
  std::string name;
  std::uint32_t material = 0;  // index into ModelSpec::materials
};

struct LawSpec {
  std::string name;
  LawParameters parameters;
};

// Interaction of two particle types (order free; also particle type vs a wall's type).
struct InteractionSpec {
  std::uint32_t type_a = 0;
  std::uint32_t type_b = 0;
  std::vector<LawSpec> contact_laws;    // applied in order, e.g. hertz_mindlin, jkr, coulomb
  std::optional<LawSpec> bond_law;      // laws for bonds between these types (bpm)
  bool contact_between_bonded = false;  // bonded pairs also get contact forces
};

struct Triangle {
  std::array<Vec3, 3> vertices_m;
};

struct PlaneWallSpec {
  std::string name;
  std::uint32_t type = 0;  // particle type whose material the wall has
  Vec3 point_m = Vec3::Zero();
  Vec3 normal = Vec3::UnitZ();  // side the particles are on
};

struct MeshWallSpec {
  std::string name;
  std::uint32_t type = 0;
  std::vector<Triangle> triangles;  // two-sided
};

// An axis-aligned box as a closed mesh wall: two triangles a face, counter-clockwise seen from
// outside (the engine treats them two-sided anyway).
MeshWallSpec box_mesh_wall(const std::string& name, std::uint32_t type, const Vec3& min_m,
                           const Vec3& max_m);

struct Domain {  // particles leaving it are kept and clamped into the edge cells
  Vec3 lower_m = Vec3(-0.5, -0.5, -0.1);
  Vec3 upper_m = Vec3(0.5, 0.5, 0.5);
};

struct ModelSpec {
  std::vector<Material> materials;
  std::vector<ParticleType> types;
  std::vector<InteractionSpec> interactions;
  std::vector<PlaneWallSpec> planes;
  std::vector<MeshWallSpec> meshes;
  Vec3 gravity_m_per_s2 = Vec3(0.0, 0.0, -9.81);
  double timestep_s = 1.678512e-4;
  Domain domain;
  double neighbor_skin_m = 0.001;  // Verlet skin (rebuild rule: simulation.hpp)
  int thread_count = 1;            // at most; results are bit-identical for a fixed count
  // Threads only pay once each has this many particles: below, a fork/join and the barrier
  // spin cost more than the work (a 400-sphere line ran 3x slower on 2 threads than on 1).
  int min_particles_per_thread = 2048;
  int sort_every_rebuilds = 20;  // re-order particles by cell every n-th rebuild; 0: never
  BondKernel bond_kernel = BondKernel::kAuto;  // same results from each; for A/B and tests
};

// A type pair resolved for the step loop.
struct Interaction {
  PairMaterial material;
  std::vector<std::unique_ptr<ContactLaw>> contact_laws;
  std::unique_ptr<ContactChain> contact_chain;  // the laws above as one call (make_contact_chain)
  std::unique_ptr<BondLaw> bond_law;
  bool contact_between_bonded = false;
  [[nodiscard]] bool has_contact() const { return !contact_laws.empty(); }
};

PairMaterial make_pair_material(const Material& a, const Material& b, bool with_wall);

class Model {
 public:
  // Resolves law names through the registry; throws std::invalid_argument on bad input.
  explicit Model(ModelSpec spec, const LawRegistry& registry = LawRegistry::builtin());

  [[nodiscard]] const ModelSpec& spec() const { return spec_; }
  [[nodiscard]] std::size_t type_count() const { return spec_.types.size(); }
  [[nodiscard]] const Interaction& interaction(std::uint32_t type_a, std::uint32_t type_b) const {
    return table_[type_a * type_count() + type_b];
  }
  [[nodiscard]] const Material& material_of_type(std::uint32_t type) const {
    return spec_.materials[spec_.types[type].material];
  }
  // Largest gap at which any law acts for radius-R spheres (adhesion range).
  [[nodiscard]] double max_range_m(double max_radius_m) const;
  [[nodiscard]] std::optional<std::uint32_t> find_type(std::string_view name) const;

 private:
  ModelSpec spec_;
  std::vector<Interaction> table_;  // type_count^2, symmetric (each entry its own instance)
};

// Rayleigh time of a sphere (as EDEM and rayleigh.py): T = pi R sqrt(rho/G) /
// (0.1631 nu + 0.8766), G = E / (2 (1 + nu)). The default timestep is 15% of it (appendix B).
double rayleigh_time_s(double radius_m, double density_kg_per_m3, double youngs_modulus_pa,
                       double poisson_ratio);
inline constexpr double kDefaultRayleighFraction = 0.15;
double default_timestep_s(double radius_m, double density_kg_per_m3, double youngs_modulus_pa,
                          double poisson_ratio);

}  // namespace fl::dem
