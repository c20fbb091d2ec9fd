// Building blocks shared by the model tests (thesis 3.4): the engine model with a chosen bond
// stiffness, one fillet meta-particle of a table-3.1 variant, bonded blocks, box-shaped walls,
// a timestep that is safe for the bonds, bond bookkeeping and a small parallel loop.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "fl/twin/dem/fillet_template.hpp"
#include "fl/twin/dem/laws.hpp"
#include "fl/twin/dem/simulation.hpp"
#include "fl/twin/model_tests/fillet_source.hpp"

namespace fl::model_tests {

using dem::Vec3;

// Bond stiffnesses of the bpm law (thesis eqs. 3.4-3.5; appendix B: 1e6 / 6e4 N/m^3), and of
// its effect-library variants (set_bond_stiffness).
struct Stiffness {
  double normal_n_per_m3 = 1e6;
  double shear_n_per_m3 = 6e4;
};

// What every model test needs. The engine model comes from config/dem.yaml (or appendix B);
// its types 0, 1 must be fillet_a, fillet_b and it must have a type named "equipment".
struct CommonParams {
  dem::ModelSpec base_spec = dem::ModelSpec{};  // empty: dem::appendix_b_model_spec()
  // Base fillet mesh (metres; load_fillet_mesh); null: dem::make_fillet_mesh().
  std::shared_ptr<const dem::TriangleMesh> fillet_mesh;
  double sub_particle_radius_m = 0.007;  // thesis sizes 3..7 mm; 7 mm is the fast one
  std::size_t variant = 2;               // thesis_fillet_variants(): 172x72x32 mm, left
  double rayleigh_fraction = 0.15;       // appendix B: 15% of the Rayleigh time
  // The timestep is also kept below this share of the bond critical step 2/omega, so that an
  // instability seen is the model's, not the integrator's (0: no such limit, as EDEM).
  double bond_step_fraction = 0.2;
  int thread_count = 1;                // engine threads of one simulation
  std::uint32_t seed = 1;              // random drop orientations
  std::optional<Stiffness> stiffness;  // bond stiffness; empty: the base spec's
};

// The base spec with the stiffness applied to every bond law, walls removed, threads set.
dem::ModelSpec make_spec(const CommonParams& common);
// Stiffness of the first bond law in the spec that has one (appendix B when there is none).
Stiffness spec_stiffness(const dem::ModelSpec& spec);
double spec_disk_scale(const dem::ModelSpec& spec);
// Sets the normal and shear stiffness of every bond law in the spec: bpm and each effect
// variant (bpm_graded: its stiffness at the reference thickness; bpm_viscoelastic: its Maxwell
// arm's stiffness scaled by the same factor as the normal one; bpm_plastic: its yield stress
// kept). Throws std::invalid_argument naming a law that has no such stiffness, or another
// stiffness it would not know how to scale (looked up in `registry`).
void set_bond_stiffness(dem::ModelSpec& spec, const Stiffness& stiffness,
                        const dem::LawRegistry& registry = dem::LawRegistry::builtin());
// Sets a contact-law parameter (e.g. coulomb friction_coefficient) on every interaction of a
// fillet type with `other_type` (std::nullopt: with every type).
void set_contact_parameter(dem::ModelSpec& spec, const std::string& law, const std::string& key,
                           double value, std::optional<std::uint32_t> other_type);
// Whether some interaction of a fillet type with `other_type` has the contact law `law` in its
// chain (a model without adhesion has no jkr).
bool has_fillet_contact_law(const dem::ModelSpec& spec, std::string_view law,
                            std::uint32_t other_type);
// Sets the friction coefficient of the friction laws in the contact laws of every interaction
// of a fillet type with `other_type` (std::nullopt: with every type): coulomb's
// friction_coefficient, and static_kinetic_friction's static coefficient with the kinetic one
// kept at its configured ratio mu_k / mu_s. Throws std::invalid_argument naming the types of an
// interaction without a friction law.
void set_friction_coefficient(dem::ModelSpec& spec, double mu,
                              std::optional<std::uint32_t> other_type);
std::uint32_t equipment_type(const dem::ModelSpec& spec);
// Whether the interaction is between a fillet type and `other_type`.
bool is_fillet_with(const dem::InteractionSpec& interaction, std::uint32_t other_type);

// One fillet of the chosen variant filled with spheres of the chosen radius, then scaled by
// `scale` (positions, radii and contact radii: the same particles, as the thesis' scaling).
dem::FilletTemplate make_fillet(const CommonParams& common, double scale = 1.0);
std::vector<dem::BodyBond> body_bonds(const dem::FilletTemplate& fillet);
// A bonded block of nx x ny x nz spheres on a cubic raster of pitch 2r, types alternating
// A/B, face neighbours bonded with contact radius r sqrt(3) (as the fillet raster).
dem::FilletTemplate make_block(double radius_m, int nx, int ny, int nz);

// Bond critical step 2/omega of the stiffest particle: omega^2 = bonds x max(k_n, k_t) / m
// with k = S pi (disk_scale r)^2 (the engine's check_timestep formula). k_n is the stiffness a
// stretch within one step meets (a visco-elastic arm included), or with `relaxed` the
// long-time one.
double bond_critical_step_s(const dem::ModelSpec& spec, const dem::FilletTemplate& fillet,
                            bool relaxed = false);
// rayleigh_fraction x Rayleigh time of the template's spheres, limited to
// bond_step_fraction x the relaxed bond critical step, then halved until it is within
// bond_step_fraction of the (instantaneous) bond critical step too. Halving, rather than
// following the arm's stiffness, keeps the step of a visco-elastic law constant over ranges of
// its arm stiffness: a fit over it sees a smooth objective, not one whose every point is
// integrated with its own step (a drop's impacts are chaotic enough to show the difference).
double choose_timestep_s(const CommonParams& common, const dem::ModelSpec& spec,
                         const dem::FilletTemplate& fillet);

dem::PlaneWallSpec floor_plane(std::uint32_t type);

// Adds the fillet at `orientation` with its lowest sphere bottom at `bottom_z_m` and its
// centroid at x, y; returns the body number.
std::uint32_t add_fillet(dem::Simulation& sim, const dem::FilletTemplate& fillet,
                         const Eigen::Quaterniond& orientation, double x_m, double y_m,
                         double bottom_z_m, const Vec3& velocity_m_per_s = Vec3::Zero());

// Share (0..1) of bonds not broken; 1 when there are none.
double intact_bond_share(const dem::State& state);
double kinetic_energy_j(const dem::EnergyReport& energy);
Vec3 centroid_m(const dem::State& state);

// Uniformly random rotation (Shoemake 1992).
Eigen::Quaterniond random_orientation(std::mt19937& rng);
// Yaw about z, then pitch about y, then roll about x (intrinsic z-y'-x'').
Eigen::Quaterniond yaw_pitch_roll(double yaw_rad, double pitch_rad, double roll_rad);
// Point k of an n-point Hammersley set in [0,1)^3: (k/n, radical inverse base 2, base 3).
std::array<double, 3> hammersley3(std::size_t k, std::size_t n);

// Runs body(k) for k in [0, count) on `threads` std::threads (each simulation single-threaded
// inside); calls progress(done, count) from the calling thread's view after each item. The
// first exception is rethrown after all threads stopped.
void parallel_for(std::size_t count, int threads, const std::function<void(std::size_t)>& body,
                  const std::function<void(std::size_t, std::size_t)>& progress = {});

// Appendix C levels: mantissas x 10^k for `decades` decades from `first`, plus the end value.
std::vector<double> log_levels(double first, int decades, const std::vector<double>& mantissas);

}  // namespace fl::model_tests
