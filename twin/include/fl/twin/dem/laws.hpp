// Force laws of the DEM engine as composable named parts, in the spirit of LAMMPS styles.
//
// A type pair's contact behaviour is a chain of ContactLaw objects applied in order to one
// ForceAccumulator (e.g. "hertz_mindlin" -> "jkr" -> "coulomb"); a bonded pair uses one BondLaw
// ("bpm"). Laws are created by name from a LawRegistry, configured with named parameters and the
// pair's material (E*, G*).
//
// Adding an effect (visco-elastic bonds, plasticity, moisture-dependent friction, rolling
// resistance, graded stiffness: the built-in ones are bpm_viscoelastic, bpm_plastic,
// bpm_graded, wet_film, rolling_resistance, static_kinetic_friction) is one class and one
// registration line:
//
//   class SpeedWeakening final : public ContactLaw {          // 1. the class
//    public:
//     SpeedWeakening(const LawParameters& p, const PairMaterial&)
//         : drop_(p.at("friction_drop_per_m_per_s")) {}
//     void compute(const PairGeometry& g, PairState&, ForceAccumulator& f) const override {
//       if (f.touching) f.friction_normal_load_n /= 1.0 + drop_ *
//       g.relative_velocity_m_per_s.norm();
//     }
//     ChainStage chain_stage() const override { return ChainStage::kLoadModifier; }
//    private:
//     double drop_;
//   };
//   // 2. in register_builtin_laws() (twin/src/dem/laws.cpp):
//   registry.add_contact_law({"speed_weakening", "friction falling with sliding speed",
//                             {{"friction_drop_per_m_per_s", "s/m", 0.0, 100.0, std::nullopt,
//                               FitRange{0.01, 10.0, true}}},
//                             make_contact_law<SpeedWeakening>});
//
// The YAML reader (config.hpp) then accepts `speed_weakening: {friction_drop_per_m_per_s: 2}`
// in an interaction's contact chain (before coulomb) with strict range checks taken from the
// parameter list; its chain stage tells Model where in a chain the law may stand. The fit range
// makes it an effect: `linectl diagnose` fits it as a candidate on every dataset whose twin
// loads that kind of law (contact laws: slide and line tracks; bond laws: compress, drop,
// settle, bend), and places it in the chain by its stage.
//
// Units are SI (m, kg, s, N); names carry units where not obvious.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fl::dem {

using Vec3 = Eigen::Vector3d;

// Named law parameters, e.g. {"restitution", 1e-4}. Missing optional ones take their default.
using LawParameters = std::map<std::string, double, std::less<>>;

// Material properties of one interacting pair, derived once per type pair.
struct PairMaterial {
  double effective_youngs_modulus_pa = 0.0;  // E*: 1/E* = (1-nu1^2)/E1 + (1-nu2^2)/E2
  double effective_shear_modulus_pa = 0.0;   // G*: 1/G* = 2(2-nu1)(1+nu1)/E1 + 2(2-nu2)(1+nu2)/E2
  bool with_wall = false;                    // one side is a wall (infinite mass)
};

// Geometry and kinematics of one sphere-sphere or sphere-wall pair at this step.
struct PairGeometry {
  Vec3 normal = Vec3::UnitZ();  // unit, from j (or the wall) towards i
  double overlap_m = 0.0;       // r_i + r_j - distance (sphere-wall: r_i - distance); < 0: gap
  Vec3 relative_velocity_m_per_s = Vec3::Zero();            // i's contact point relative to j's
  Vec3 relative_angular_velocity_rad_per_s = Vec3::Zero();  // omega_i - omega_j (wall: 0)
  double effective_radius_m = 0.0;  // R* = r_i r_j / (r_i + r_j); r_i for a wall
  double effective_mass_kg = 0.0;   // m* = m_i m_j / (m_i + m_j); m_i for a wall
  double timestep_s = 0.0;
};

// History of one pair (kept while the pair stays in the neighbour list). Vectors are seen from
// i; the engine negates them when it swaps i and j (after a particle re-ordering).
struct PairState {
  Vec3 tangential_displacement_m = Vec3::Zero();  // Mindlin tangential spring
  std::array<double, 2> scalars{};                // free for laws with scalar history
  std::uint32_t flags = 0;                        // bit flags owned by laws (see kFlag*)

  static constexpr std::uint32_t kFlagAdhesiveNeck = 1U;  // jkr: neck formed, survives a gap
  static constexpr std::uint32_t kFlagSliding = 2U;       // static_kinetic_friction: kinetic phase
  void reset() { *this = PairState{}; }
  [[nodiscard]] bool active() const { return flags != 0 || !tangential_displacement_m.isZero(0.0); }
};

// What the chain builds for one pair. Force on i = (normal_force_n + normal_damping_force_n) *
// normal + tangential forces; force on j is the opposite. Tangential forces act at the contact
// point and so also give torques (added by the engine); torque_on_* are extra moments.
struct ForceAccumulator {
  double normal_force_n = 0.0;          // elastic + adhesive; > 0 pushes i away from j
  double normal_damping_force_n = 0.0;  // dissipative normal part
  double friction_normal_load_n = 0.0;  // load that Coulomb's mu multiplies (JKR raises it)
  Vec3 tangential_elastic_force_n = Vec3::Zero();
  Vec3 tangential_damping_force_n = Vec3::Zero();
  double tangential_stiffness_n_per_m = 0.0;  // of the tangential spring, for Coulomb's rescale
  Vec3 torque_on_i_nm = Vec3::Zero();
  Vec3 torque_on_j_nm = Vec3::Zero();
  double elastic_energy_j = 0.0;  // stored energy where a law defines it
  bool touching = false;          // some law produced a force this step
};

// Where a contact law belongs in its chain. The laws of a chain run in order on one
// accumulator, each reading what the laws before it wrote, so a chain lists its laws by stage
// (laws of one stage keep the order given; friction and moments only read the load, so those
// two may come in either order). Model refuses a chain out of this order (see
// check_contact_chain): a friction law placed before the normal law, for one, would find no
// load and leave the contact frictionless without a word.
enum class ChainStage {
  kNormal,        // the normal force and the friction load from the overlap (hertz_mindlin)
  kAdhesion,      // replaces part of that normal force (jkr)
  kLoadModifier,  // changes the normal force or the friction load (wet_film)
  kFriction,      // limits the tangential force by the load (coulomb, static_kinetic_friction)
  kMoment,        // moments that scale with the load (rolling_resistance)
};
[[nodiscard]] std::string_view chain_stage_name(ChainStage stage);

class ContactLaw {
 public:
  virtual ~ContactLaw() = default;
  virtual void compute(const PairGeometry& geometry, PairState& state,
                       ForceAccumulator& force) const = 0;
  [[nodiscard]] virtual ChainStage chain_stage() const = 0;
  // The registered name of the law whose force this one replaces in part, which must come
  // earlier in the chain (jkr takes hertz_mindlin's Hertz force out); empty if none.
  [[nodiscard]] virtual std::string_view replaces_part_of() const { return {}; }
  // Largest gap (m) at which the law still acts, for a pair of this effective radius
  // (adhesion necks); 0 for laws that act only on overlap.
  [[nodiscard]] virtual double range_m(double effective_radius_m) const {
    (void)effective_radius_m;
    return 0.0;
  }
  // Contact stiffness scale (N/m) at this overlap, for the timestep check; 0 if none.
  [[nodiscard]] virtual double normal_stiffness_n_per_m(double effective_radius_m,
                                                        double overlap_m) const {
    (void)effective_radius_m;
    (void)overlap_m;
    return 0.0;
  }
};

// A type pair's contact laws applied in order, as one call per pair (the step loop's entry).
// make_contact_chain() fuses the usual built-in chains (hertz_mindlin [+ jkr] [+ coulomb]) so
// that their code inlines into one function; any other chain runs law by law through
// ContactLaw::compute. Both give the same forces: a fused chain is an optimisation only.
class ContactChain {
 public:
  virtual ~ContactChain() = default;
  virtual void compute(const PairGeometry& geometry, PairState& state,
                       ForceAccumulator& force) const = 0;
  [[nodiscard]] virtual bool fused() const = 0;
};

// Checks a chain before it runs: one normal-force law, first; the others in stage order; no
// law twice; a law that replaces part of another's force after that law. Throws
// std::invalid_argument naming `where` (e.g. the interaction's types), the law and the rule.
// `names` are the laws' registered names, in the order of `laws`.
void check_contact_chain(std::string_view where, const std::vector<std::string>& names,
                         const std::vector<std::unique_ptr<ContactLaw>>& laws);

// The laws must outlive the chain (the Model owns both).
std::unique_ptr<ContactChain> make_contact_chain(
    const std::vector<std::unique_ptr<ContactLaw>>& laws);

struct BondGeometry {
  Vec3 normal = Vec3::UnitZ();  // unit, from j towards i
  double distance_m = 0.0;
  double rest_length_m = 0.0;                     // distance when the bond formed
  double bond_radius_m = 0.0;                     // smaller particle radius (before disk scale)
  double break_distance_m = 0.0;                  // sum of the two contact radii
  double thickness_m = 0.0;                       // the body's local thickness; 0: not given
  Vec3 relative_velocity_m_per_s = Vec3::Zero();  // i's bond point relative to j's
  double timestep_s = 0.0;
};

struct BondState {
  double normal_force_n = 0.0;        // > 0 pushes i away from j (compression)
  Vec3 shear_force_n = Vec3::Zero();  // on i, perpendicular to the normal
  std::array<double, 2> scalars{};    // free for laws with scalar history
  bool broken = false;
};

struct BondForce {
  double normal_force_n = 0.0;         // on i along the normal
  Vec3 shear_force_n = Vec3::Zero();   // on i, acts at the bond point (torque added by engine)
  Vec3 torque_on_i_nm = Vec3::Zero();  // bending/twisting moments (none in bpm)
  Vec3 torque_on_j_nm = Vec3::Zero();
  double elastic_energy_j = 0.0;
};

struct Bond;  // state.hpp

// Which code runs the default bonded law ("bpm"): one bond at a time, or four bonds at once in
// AVX2 registers. Both give the same bits: the vector code evaluates the scalar code's
// expressions in the same order, and the forces are summed in bond order. kAuto (and
// kAvx2Vector) take the vector code where the CPU runs it, else the scalar one.
enum class BondKernel { kAuto, kScalar, kAvx2Vector };
// Whether this build and CPU run BondKernel::kAvx2Vector.
bool avx2_bond_kernel_available();

// One thread's share of a run of bonds that use the same law: the engine's arrays and the
// thread's force and torque buffers. A law's compute_batch() handles bonds [begin, end).
struct BondBatch {
  const Bond* bonds = nullptr;
  BondState* states = nullptr;
  std::uint32_t begin = 0;
  std::uint32_t end = 0;
  const Vec3* position_m = nullptr;
  const Vec3* velocity_m_per_s = nullptr;
  const Vec3* angular_velocity_rad_per_s = nullptr;
  const double* radius_m = nullptr;
  Vec3* force_n = nullptr;
  Vec3* torque_nm = nullptr;
  double timestep_s = 0.0;
  BondKernel kernel = BondKernel::kAuto;
};

class BondLaw {
 public:
  virtual ~BondLaw() = default;
  // Updates the state and the force; sets state.broken (and leaves no force) when it breaks.
  virtual void compute(const BondGeometry& geometry, BondState& state, BondForce& force) const = 0;
  // The step loop's entry: every unbroken bond of the batch (geometry, compute, forces and
  // torques on both particles); returns true if a bond broke. The default calls compute() per
  // bond; a law overrides it with run_bond_batch() (laws.cpp) so that its per-bond code inlines
  // (one virtual call per run of bonds instead of one per bond, as a LAMMPS bond style).
  virtual bool compute_batch(const BondBatch& batch) const;
  // Elastic energy held in a bond's state (energy reports; kept out of the step loop).
  [[nodiscard]] virtual double elastic_energy_j(const BondState& state, const Bond& bond) const = 0;
  // Spring constants (N/m) of this bond, for the timestep check: the stiffness a stretch within
  // one step meets (a visco-elastic law's relaxing arm included).
  [[nodiscard]] virtual double normal_stiffness_n_per_m(const Bond& bond) const = 0;
  // The normal spring constant left once every relaxing part has relaxed (the long-time one);
  // the same as normal_stiffness_n_per_m for an elastic law.
  [[nodiscard]] virtual double relaxed_normal_stiffness_n_per_m(const Bond& bond) const {
    return normal_stiffness_n_per_m(bond);
  }
  [[nodiscard]] virtual double shear_stiffness_n_per_m(const Bond& bond) const = 0;
  // Whether the law reads each bond's thickness_m (graded stiffness): the engine then refuses
  // bonds added without one rather than guess.
  [[nodiscard]] virtual bool needs_bond_thickness() const { return false; }
};

// Where a fit searches a parameter when its law is tried as a missing effect (the workbench's
// diagnose): a range any fillet on any machine stays inside, searched on a log scale where it
// spans decades. Not the law's allowed range, which only keeps the physics defined.
struct FitRange {
  double min = 0.0;
  double max = 0.0;
  bool log_scale = false;
};

// A parameter a law accepts, with its allowed closed range, optional default and, for an effect
// diagnose may propose, the range a fit searches. A law with any fitted parameter is an effect;
// its other parameters keep their configured, default or inherited values during the fit.
struct LawParameterInfo {
  std::string name;
  std::string unit;
  double min = 0.0;
  double max = 0.0;
  std::optional<double> default_value;
  std::optional<FitRange> fit_range = std::nullopt;
};

template <typename Law>
struct LawInfo {
  std::string name;
  std::string description;
  std::vector<LawParameterInfo> parameters;
  std::function<std::unique_ptr<Law>(const LawParameters&, const PairMaterial&)> factory;

  // An effect: a law diagnose fits (some parameter has a fit range), not a base law.
  [[nodiscard]] bool is_effect() const {
    return std::any_of(parameters.begin(), parameters.end(),
                       [](const LawParameterInfo& p) { return p.fit_range.has_value(); });
  }
};

template <typename Law, typename Impl>
std::unique_ptr<Law> make_law(const LawParameters& parameters, const PairMaterial& material) {
  return std::make_unique<Impl>(parameters, material);
}
template <typename Impl>
std::unique_ptr<ContactLaw> make_contact_law(const LawParameters& p, const PairMaterial& m) {
  return make_law<ContactLaw, Impl>(p, m);
}
template <typename Impl>
std::unique_ptr<BondLaw> make_bond_law(const LawParameters& p, const PairMaterial& m) {
  return make_law<BondLaw, Impl>(p, m);
}

// Name -> factory. builtin() holds the laws of this engine (register_builtin_laws).
class LawRegistry {
 public:
  static const LawRegistry& builtin();

  void add_contact_law(LawInfo<ContactLaw> info);
  void add_bond_law(LawInfo<BondLaw> info);

  [[nodiscard]] const LawInfo<ContactLaw>* find_contact_law(std::string_view name) const;
  [[nodiscard]] const LawInfo<BondLaw>* find_bond_law(std::string_view name) const;
  [[nodiscard]] std::vector<std::string> contact_law_names() const;
  [[nodiscard]] std::vector<std::string> bond_law_names() const;

  // Creates a law; throws std::invalid_argument naming an unknown law, an unknown or missing
  // parameter or one out of range.
  [[nodiscard]] std::unique_ptr<ContactLaw> create_contact_law(std::string_view name,
                                                               const LawParameters& parameters,
                                                               const PairMaterial& material) const;
  [[nodiscard]] std::unique_ptr<BondLaw> create_bond_law(std::string_view name,
                                                         const LawParameters& parameters,
                                                         const PairMaterial& material) const;

  // A law built with representative parameters (its defaults, the middle of its fit ranges,
  // else its allowed minimum) on the default fillet material, to ask what the
  // class declares before any model exists: a contact law's chain stage, whether a bond law
  // reads bond thickness. Throws std::invalid_argument for an unknown name.
  [[nodiscard]] std::unique_ptr<ContactLaw> sample_contact_law(std::string_view name) const;
  [[nodiscard]] std::unique_ptr<BondLaw> sample_bond_law(std::string_view name) const;

 private:
  std::map<std::string, LawInfo<ContactLaw>, std::less<>> contact_laws_;
  std::map<std::string, LawInfo<BondLaw>, std::less<>> bond_laws_;
};

void register_builtin_laws(LawRegistry& registry);

// JKR theory (Johnson, Kendall & Roberts 1971, Proc. R. Soc. A 324:301; as written in
// Johnson, Contact Mechanics, 1985, sec. 5.5), with w the work of adhesion (J/m^2; the
// "interfacial surface energy" of the configuration):
//   F(a) = 4 E* a^3 / (3 R*) - sqrt(8 pi w E* a^3),  delta(a) = a^2 / R* - sqrt(2 pi w a / E*)
// Pull-off force (load controlled): F_c = 1.5 pi w R*. The neck breaks (displacement
// controlled) at a^3 = pi w R*^2 / (8 E*), i.e. at the most negative overlap delta_c.
double jkr_pull_off_force_n(double work_of_adhesion_j_per_m2, double effective_radius_m);
double jkr_break_overlap_m(double work_of_adhesion_j_per_m2, double effective_radius_m,
                           double effective_youngs_modulus_pa);
// Contact radius a on the stable branch for a given overlap (>= delta_c), and its force.
double jkr_contact_radius_m(double work_of_adhesion_j_per_m2, double effective_radius_m,
                            double effective_youngs_modulus_pa, double overlap_m);
double jkr_force_n(double work_of_adhesion_j_per_m2, double effective_radius_m,
                   double effective_youngs_modulus_pa, double contact_radius_m);

// Damping ratio factor of eqs. 3.2-3.3: beta = -ln(e) / sqrt(ln^2(e) + pi^2).
double restitution_damping_factor(double restitution);

}  // namespace fl::dem
