// Built-in force laws (hertz_mindlin, coulomb, jkr, bpm) and the law registry.
#include "fl/twin/dem/laws.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <tuple>
#include <type_traits>
#include <utility>

#include "bpm_vector_kernel.hpp"
#include "fl/twin/dem/model.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::dem {
namespace {

constexpr double kPi = std::numbers::pi;
const double kSqrtFiveSixths = std::sqrt(5.0 / 6.0);

// Keeps a history vector in the current tangent plane at its old length (the pair rotated).
// Per step the plane turns by a tiny angle, so the length correction 1/sqrt(1 - r) with
// r = (v.n)^2 / |v|^2 is taken from its series 1 + r/2 + 3r^2/8 while r < 1e-4 (the next
// term, 5r^3/16, is under 3.2e-13 relative): no square root in the bond and contact loops,
// where it cost about 7 % of the bonded benchmark's time (docs/benchmarks.md). Forced inline:
// GCC kept it out of line in the bond batch, which then spilled the bond's geometry to the
// stack (9 % of the bonded race in the call alone).
[[gnu::always_inline]] inline void rotate_into_tangent_plane(Vec3& vector, const Vec3& normal) {
  // Component by component: written with Eigen expressions, GCC moved the subtraction out of
  // line in the bond batch.
  double x = vector.x();
  double y = vector.y();
  double z = vector.z();
  const double old_squared = x * x + y * y + z * z;
  if (old_squared == 0.0) {
    return;
  }
  const double along = x * normal.x() + y * normal.y() + z * normal.z();
  x -= along * normal.x();
  y -= along * normal.y();
  z -= along * normal.z();
  const double removed = along * along;
  double scale = 1.0;
  if (removed < detail::kTangentSeriesLimit * old_squared) {
    const double r = removed / old_squared;
    scale = 1.0 + r * (0.5 + 0.375 * r);
  } else {
    const double new_squared = x * x + y * y + z * z;
    if (new_squared > 0.0) scale = std::sqrt(old_squared / new_squared);
  }
  vector = Vec3(x * scale, y * scale, z * scale);
}

// Eq. 3.1 with the damping of eqs. 3.2-3.3 (EDEM / LIGGGHTS Hertz-Mindlin):
//   S_n = 2 E* sqrt(R* d),  F_n = 4/3 E* sqrt(R*) d^1.5,   F_n^d = -2 sqrt(5/6) beta sqrt(S_n m*)
//   v_n S_t = 8 G* sqrt(R* d),  F_t = -S_t xi (xi: tangential spring history), F_t^d = -2 sqrt(5/6)
//   beta sqrt(S_t m*) v_t,  beta = -ln e / sqrt(ln^2 e + pi^2).
// The tangential spring is not limited here (see coulomb).
class HertzMindlin final : public ContactLaw {
 public:
  HertzMindlin(const LawParameters& parameters, const PairMaterial& material)
      : youngs_pa_(material.effective_youngs_modulus_pa),
        shear_pa_(material.effective_shear_modulus_pa),
        damping_factor_(2.0 * kSqrtFiveSixths *
                        restitution_damping_factor(parameters.at("restitution"))),
        // sqrt(S_t m*) = sqrt(S_t / S_n) sqrt(S_n m*) and S_t / S_n = 4 G* / E*: one sqrt less
        tangential_to_normal_damping_(std::sqrt(4.0 * shear_pa_ / youngs_pa_)) {}

  void compute(const PairGeometry& g, PairState& state, ForceAccumulator& f) const override {
    if (g.overlap_m <= 0.0) {
      state.tangential_displacement_m.setZero();
      return;
    }
    const double sqrt_radius_overlap = std::sqrt(g.effective_radius_m * g.overlap_m);
    const double normal_stiffness = 2.0 * youngs_pa_ * sqrt_radius_overlap;  // S_n
    const double elastic_normal = (2.0 / 3.0) * normal_stiffness * g.overlap_m;
    const double normal_velocity = g.relative_velocity_m_per_s.dot(g.normal);
    const double normal_damping_coefficient =
        damping_factor_ * std::sqrt(normal_stiffness * g.effective_mass_kg);
    const double damping_normal = -normal_damping_coefficient * normal_velocity;

    const Vec3 tangential_velocity = g.relative_velocity_m_per_s - normal_velocity * g.normal;
    Vec3& xi = state.tangential_displacement_m;
    rotate_into_tangent_plane(xi, g.normal);
    xi += tangential_velocity * g.timestep_s;
    const double tangential_stiffness = 8.0 * shear_pa_ * sqrt_radius_overlap;  // S_t

    f.normal_force_n += elastic_normal;
    f.normal_damping_force_n += damping_normal;
    f.friction_normal_load_n += elastic_normal + damping_normal;
    f.tangential_elastic_force_n -= tangential_stiffness * xi;
    f.tangential_damping_force_n -=
        normal_damping_coefficient * tangential_to_normal_damping_ * tangential_velocity;
    f.tangential_stiffness_n_per_m = tangential_stiffness;
    // Hertz: integral of F_n = 8/15 E* sqrt(R*) d^2.5 = 2/5 F_n d; Mindlin spring: S_t xi^2 / 2.
    f.elastic_energy_j +=
        0.4 * elastic_normal * g.overlap_m + 0.5 * tangential_stiffness * xi.squaredNorm();
    f.touching = true;
  }

  [[nodiscard]] double normal_stiffness_n_per_m(double effective_radius_m,
                                                double overlap_m) const override {
    return 2.0 * youngs_pa_ * std::sqrt(effective_radius_m * overlap_m);
  }
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kNormal; }

 private:
  double youngs_pa_;
  double shear_pa_;
  double damping_factor_;  // 2 sqrt(5/6) beta
  double tangential_to_normal_damping_;
};

// Coulomb limit of the tangential force: |F_t| <= mu * |load|. While sliding, the spring is
// shortened to the limit and the tangential damping dropped (EDEM / LIGGGHTS behaviour), so a
// resting contact keeps its static friction up to mu * load.
class Coulomb final : public ContactLaw {
 public:
  Coulomb(const LawParameters& parameters, const PairMaterial&)
      : friction_coefficient_(parameters.at("friction_coefficient")) {}
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kFriction; }

  void compute(const PairGeometry&, PairState& state, ForceAccumulator& f) const override {
    if (!f.touching) {
      return;
    }
    const double limit = friction_coefficient_ * std::abs(f.friction_normal_load_n);
    const double limit_squared = limit * limit;
    const double elastic_squared = f.tangential_elastic_force_n.squaredNorm();
    if (elastic_squared > limit_squared) {
      const double scale = limit / std::sqrt(elastic_squared);  // elastic_squared > 0 here
      f.tangential_elastic_force_n *= scale;
      state.tangential_displacement_m *= scale;
      f.tangential_damping_force_n.setZero();
    } else if ((f.tangential_elastic_force_n + f.tangential_damping_force_n).squaredNorm() >
               limit_squared) {
      f.tangential_damping_force_n.setZero();  // sticking spring, damping beyond the limit
    }
  }

 private:
  double friction_coefficient_;
};

// JKR adhesion (formulas at jkr_force_n in laws.hpp). Replaces the chain's elastic normal force
// by the JKR force for the same overlap; the neck forms on touching and survives a gap down to
// delta_c. Friction load is |F + 2 F_c| (as LAMMPS' granular jkr). Uses PairState::scalars[0]
// to warm-start the contact-radius solve.
class Jkr final : public ContactLaw {
 public:
  Jkr(const LawParameters& parameters, const PairMaterial& material)
      : work_of_adhesion_(parameters.at("surface_energy_j_per_m2")),
        youngs_pa_(material.effective_youngs_modulus_pa),
        c_(std::sqrt(2.0 * kPi * work_of_adhesion_ / youngs_pa_)),
        adhesion_factor_(std::sqrt(8.0 * kPi * work_of_adhesion_ * youngs_pa_)) {}

  void compute(const PairGeometry& g, PairState& state, ForceAccumulator& f) const override {
    if (work_of_adhesion_ <= 0.0) {
      return;
    }
    const double radius = g.effective_radius_m;
    const RadiusTerms& terms = radius_terms(radius);
    if (g.overlap_m > 0.0) {
      state.flags |= PairState::kFlagAdhesiveNeck;
    } else if ((state.flags & PairState::kFlagAdhesiveNeck) == 0U ||
               g.overlap_m <= terms.break_overlap_m) {
      state.flags &= ~PairState::kFlagAdhesiveNeck;
      state.scalars[0] = 0.0;
      return;
    }
    // Newton on x = sqrt(a): f(x) = x^4 - R c x - R delta, c = sqrt(2 pi w / E*). f is convex
    // for x > 0, so Newton from any x on the stable branch (f' > 0) converges monotonically.
    const double rc = terms.rc;
    const double x_turn = terms.turn;  // f'(x_turn) = 0
    double x = state.scalars[0];
    if (!(x > x_turn * 1.0000001)) {
      x = terms.start + std::sqrt(std::sqrt(radius * std::abs(g.overlap_m)));
    }
    for (int iteration = 0; iteration < 40; ++iteration) {
      const double x3 = x * x * x;
      const double value = x3 * x - rc * x - radius * g.overlap_m;
      const double slope = 4.0 * x3 - rc;
      const double step = value / slope;
      x -= step;
      if (x < x_turn) {
        x = x_turn;
        continue;
      }
      // Newton's next step would be about f''/(2 f') step^2 = 6 x^2 step^2 / slope: stop when
      // that is under 1e-13 x. A warm start then takes two divisions, not three (the third only
      // confirmed convergence; the divisions were a fifth of the law's time in the bulk pile).
      if (6.0 * x * step * step <= 1e-13 * slope) {
        break;
      }
    }
    state.scalars[0] = x;
    // F = 4 E* a^3 / (3 R*) - sqrt(8 pi w E*) a^1.5 with a = x^2 (jkr_force_n's terms)
    const double x3 = x * x * x;
    const double force = terms.elastic_factor * (x3 * x3) - adhesion_factor_ * x3;
    // d^1.5 as d sqrt(d): std::pow was about 2.5 % of the thesis' bulk run
    const double hertz =
        g.overlap_m > 0.0 ? terms.hertz_factor * (g.overlap_m * std::sqrt(g.overlap_m)) : 0.0;
    f.normal_force_n += force - hertz;  // replace the Hertz part of an earlier hertz_mindlin
    f.friction_normal_load_n = std::abs(force + 2.0 * terms.pull_off_n);
    f.touching = true;
  }

  [[nodiscard]] double range_m(double effective_radius_m) const override {
    return work_of_adhesion_ > 0.0
               ? -jkr_break_overlap_m(work_of_adhesion_, effective_radius_m, youngs_pa_)
               : 0.0;
  }
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kAdhesion; }
  // the Hertz force it takes out of the normal force (compute) is hertz_mindlin's
  [[nodiscard]] std::string_view replaces_part_of() const override { return "hertz_mindlin"; }

 private:
  // The terms that depend on the pair's radius only: the cube roots that start and bound the
  // Newton solve, the break overlap, the force factors. A scene's pairs share one or a few
  // radii and materials, so each thread keeps the last ones (keyed by value: the A-A, A-B and
  // B-B interactions are separate laws with the same numbers). Two cube roots per contact and
  // step were about 3 % of a line run, the break overlap's cube root and square root as much.
  struct RadiusTerms {
    double radius = -1.0;
    double work_of_adhesion = 0.0;
    double youngs = 0.0;
    double rc = 0.0;               // R c
    double turn = 0.0;             // cbrt(R c / 4)
    double start = 0.0;            // cbrt(R c)
    double break_overlap_m = 0.0;  // delta_c
    double elastic_factor = 0.0;   // 4 E* / (3 R*)
    double hertz_factor = 0.0;     // 4/3 E* sqrt(R*)
    double pull_off_n = 0.0;       // F_c
  };
  const RadiusTerms& radius_terms(double radius) const {
    thread_local RadiusTerms last;
    if (last.radius != radius || last.work_of_adhesion != work_of_adhesion_ ||
        last.youngs != youngs_pa_) {
      last.radius = radius;
      last.work_of_adhesion = work_of_adhesion_;
      last.youngs = youngs_pa_;
      last.rc = radius * c_;
      last.turn = std::cbrt(last.rc / 4.0);
      last.start = std::cbrt(last.rc);
      last.break_overlap_m = jkr_break_overlap_m(work_of_adhesion_, radius, youngs_pa_);
      last.elastic_factor = 4.0 * youngs_pa_ / (3.0 * radius);
      last.hertz_factor = (4.0 / 3.0) * youngs_pa_ * std::sqrt(radius);
      last.pull_off_n = jkr_pull_off_force_n(work_of_adhesion_, radius);
    }
    return last;
  }

  double work_of_adhesion_;
  double youngs_pa_;
  double c_;                // sqrt(2 pi w / E*)
  double adhesion_factor_;  // sqrt(8 pi w E*)
};

// Bonded particle model (Potyondy & Cundall 2004; thesis eqs. 3.4-3.5, EDEM bondingV2 without
// torque feedback): A = pi (disk_scale R_b)^2,
//   normal: dF_n = -v_n S_n A dt, i.e. F_n = -S_n A (d - d0) (its exact integral, no drift),
//   shear:  dF_t = -v_t S_t A dt, history rotated with the bond.
// No damping, no bending or twisting moment. Breaks when the tensile normal stress -F_n/A
// exceeds normal_strength_pa, the shear stress |F_t|/A exceeds shear_strength_pa, or the
// centres separate beyond the sum of the contact radii.
// The batch loop shared by all bond laws: bond geometry at the bond point (between the centres
// in proportion to the radii), the law's per-bond update, forces and torques on both particles.
// kMoments: whether the law returns bending/twisting moments (the bpm family does not, so
// their zero moments are not added per bond). The geometry is written component by component
// so that it stays in registers (with Eigen expressions GCC spilled it to the stack).
template <bool kMoments = true, typename PerBond>
bool run_bond_batch(const BondBatch& b, PerBond&& per_bond) {
  bool broke = false;
  for (std::uint32_t k = b.begin; k < b.end; ++k) {
    BondState& state = b.states[k];
    if (state.broken) continue;
    const Bond& bond = b.bonds[k];
    const std::uint32_t i = bond.i;
    const std::uint32_t j = bond.j;
    const Vec3& position_i = b.position_m[i];
    const Vec3& position_j = b.position_m[j];
    const double dx = position_i.x() - position_j.x();
    const double dy = position_i.y() - position_j.y();
    const double dz = position_i.z() - position_j.z();
    BondGeometry g;
    g.distance_m = std::sqrt(dx * dx + dy * dy + dz * dz);
    const double inverse_distance = 1.0 / g.distance_m;
    const double nx = dx * inverse_distance;
    const double ny = dy * inverse_distance;
    const double nz = dz * inverse_distance;
    g.normal = Vec3(nx, ny, nz);
    const double ri = b.radius_m[i];
    const double rj = b.radius_m[j];
    const double arm_i = g.distance_m * ri / (ri + rj);
    const double arm_j = g.distance_m - arm_i;
    const Vec3& spin_i = b.angular_velocity_rad_per_s[i];
    const Vec3& spin_j = b.angular_velocity_rad_per_s[j];
    const double ox = arm_i * spin_i.x() + arm_j * spin_j.x();
    const double oy = arm_i * spin_i.y() + arm_j * spin_j.y();
    const double oz = arm_i * spin_i.z() + arm_j * spin_j.z();
    const Vec3& velocity_i = b.velocity_m_per_s[i];
    const Vec3& velocity_j = b.velocity_m_per_s[j];
    g.relative_velocity_m_per_s = Vec3(velocity_i.x() - velocity_j.x() - (oy * nz - oz * ny),
                                       velocity_i.y() - velocity_j.y() - (oz * nx - ox * nz),
                                       velocity_i.z() - velocity_j.z() - (ox * ny - oy * nx));
    g.rest_length_m = bond.rest_length_m;
    g.bond_radius_m = bond.bond_radius_m;
    g.break_distance_m = bond.break_distance_m;
    g.thickness_m = bond.thickness_m;
    g.timestep_s = b.timestep_s;
    BondForce f;
    per_bond(g, state, f);
    if (state.broken) {
      broke = true;
      continue;
    }
    const double fn = f.normal_force_n;
    const Vec3& shear = f.shear_force_n;
    const Vec3 force(fn * nx + shear.x(), fn * ny + shear.y(), fn * nz + shear.z());
    const Vec3 t_cross_n(shear.y() * nz - shear.z() * ny, shear.z() * nx - shear.x() * nz,
                         shear.x() * ny - shear.y() * nx);
    b.force_n[i] += force;
    b.force_n[j] -= force;
    if constexpr (kMoments) {
      b.torque_nm[i] += arm_i * t_cross_n + f.torque_on_i_nm;
      b.torque_nm[j] += arm_j * t_cross_n + f.torque_on_j_nm;
    } else {
      b.torque_nm[i] += arm_i * t_cross_n;
      b.torque_nm[j] += arm_j * t_cross_n;
    }
  }
  return broke;
}

// How a bond's normal force follows its stretch: the part the bpm variants differ in.
// force_n: the normal force (> 0 compression) for this step, updating the policy's history in
// the bond state; normal_energy_j: the energy stored in the normal direction.
struct ElasticNormal {  // bpm: F_n = -k A (d - d0), eq. 3.4 integrated exactly
  explicit ElasticNormal(const LawParameters&) {}
  double force_n(const BondGeometry& g, BondState&, double stiffness_n_per_m, double) const {
    return -stiffness_n_per_m * (g.distance_m - g.rest_length_m);
  }
  [[nodiscard]] double normal_energy_j(const BondState& state, double stiffness_n_per_m,
                                       double) const {
    return state.normal_force_n * state.normal_force_n / (2.0 * stiffness_n_per_m);
  }
};

// Standard linear solid: the bpm spring in parallel with a Maxwell arm (spring k_m A, dashpot
// of relaxation time tau). A step stretch first meets k + k_m, then relaxes to k with time
// constant tau: visco-elastic relaxation and rate-dependent stiffness in compression (thesis
// 4.3). The arm's force is integrated exactly over a step: F_m <- F_m e^(-dt/tau) - k_m A dx.
// History: scalars[0] = the arm's force.
struct MaxwellNormal {
  explicit MaxwellNormal(const LawParameters& p)
      : arm_stiffness_n_per_m3(p.at("relaxation_stiffness_n_per_m3")),
        relaxation_time_s(p.at("relaxation_time_s")) {}
  double force_n(const BondGeometry& g, BondState& state, double stiffness_n_per_m,
                 double area_m2) const {
    const double stretch_rate = g.relative_velocity_m_per_s.dot(g.normal);  // d(distance)/dt
    double& arm = state.scalars[0];
    arm = arm * std::exp(-g.timestep_s / relaxation_time_s) -
          arm_stiffness_n_per_m3 * area_m2 * stretch_rate * g.timestep_s;
    return -stiffness_n_per_m * (g.distance_m - g.rest_length_m) + arm;
  }
  [[nodiscard]] double normal_energy_j(const BondState& state, double stiffness_n_per_m,
                                       double area_m2) const {
    const double arm = state.scalars[0];
    const double spring = state.normal_force_n - arm;
    return spring * spring / (2.0 * stiffness_n_per_m) +
           arm * arm / (2.0 * arm_stiffness_n_per_m3 * area_m2);
  }
  double arm_stiffness_n_per_m3;
  double relaxation_time_s;
};

// Perfectly plastic beyond a yield stress: the rest length moves so that |F_n| stays at
// sigma_y A; unloading is elastic from the new rest length, which leaves a permanent set
// (thesis 4.3: permanent strain after compression). History: scalars[1] = rest length shift.
struct PlasticNormal {
  explicit PlasticNormal(const LawParameters& p)
      : yield_strength_pa(p.at("normal_yield_strength_pa")) {}
  double force_n(const BondGeometry& g, BondState& state, double stiffness_n_per_m,
                 double area_m2) const {
    double& shift = state.scalars[1];
    const double elastic_stretch = g.distance_m - g.rest_length_m - shift;
    const double yield_stretch = yield_strength_pa * area_m2 / stiffness_n_per_m;
    if (elastic_stretch > yield_stretch) {
      shift += elastic_stretch - yield_stretch;
    } else if (elastic_stretch < -yield_stretch) {
      shift += elastic_stretch + yield_stretch;
    }
    return -stiffness_n_per_m * (g.distance_m - g.rest_length_m - shift);
  }
  [[nodiscard]] double normal_energy_j(const BondState& state, double stiffness_n_per_m,
                                       double) const {
    return state.normal_force_n * state.normal_force_n / (2.0 * stiffness_n_per_m);
  }
  double yield_strength_pa;
};

// How a bond's stiffnesses vary from bond to bond: the factor on both spring constants.
struct UniformStiffness {  // bpm and its normal-force variants: one stiffness everywhere
  static constexpr bool kNeedsThickness = false;
  explicit UniformStiffness(const LawParameters&) {}
  [[nodiscard]] double scale(double /*thickness_m*/) const { return 1.0; }
};

// Stiffness graded with the fillet's local thickness, k(t) = k (t / t_ref)^n: one stiffness
// for the whole fillet made the thesis's tip too flexible and its rear too rigid (6.3, 7.2).
// n > 0 stiffens the thick rear against the thin tip, n < 0 the reverse; t_ref is where the
// base stiffness holds. Strengths stay stresses: grading moves stiffness, not failure.
struct ThicknessGradedStiffness {
  static constexpr bool kNeedsThickness = true;
  explicit ThicknessGradedStiffness(const LawParameters& p)
      : reference_thickness_m(p.at("reference_thickness_m")),
        thickness_exponent(p.at("thickness_exponent")) {}
  [[nodiscard]] double scale(double thickness_m) const {
    return std::pow(thickness_m / reference_thickness_m, thickness_exponent);
  }
  double reference_thickness_m;
  double thickness_exponent;
};

// Bonded particle model (see above) with a normal-force policy: "bpm" (ElasticNormal),
// "bpm_viscoelastic" (MaxwellNormal), "bpm_plastic" (PlasticNormal); and a stiffness grading:
// "bpm_graded" (ElasticNormal, ThicknessGradedStiffness).
template <typename Normal, typename Grading = UniformStiffness>
class BondedParticleModel final : public BondLaw {
 public:
  BondedParticleModel(const LawParameters& parameters, const PairMaterial&)
      : normal_stiffness_(parameters.at("normal_stiffness_n_per_m3")),
        shear_stiffness_(parameters.at("shear_stiffness_n_per_m3")),
        normal_strength_(parameters.at("normal_strength_pa")),
        shear_strength_(parameters.at("shear_strength_pa")),
        disk_scale_(parameters.at("bonded_disk_scale")),
        normal_(parameters),
        grading_(parameters) {}

  void compute(const BondGeometry& g, BondState& state, BondForce& f) const override {
    update(g, state, f);
    if (!state.broken) f.elastic_energy_j = energy_j(state, g.bond_radius_m, g.thickness_m);
  }

  bool compute_batch(const BondBatch& batch) const override {
    bool broke = false;
    BondBatch rest = batch;
    if constexpr (std::is_same_v<Normal, ElasticNormal> &&
                  std::is_same_v<Grading, UniformStiffness>) {
      // the default law: groups of four bonds in vector registers, the remainder below
      const detail::BpmElasticConstants constants{normal_stiffness_, shear_stiffness_,
                                                  normal_strength_, shear_strength_, disk_scale_};
      rest.begin = detail::bpm_elastic_vector_batch(batch, constants, broke);
    }
    // update() sets no moments (the bpm has none)
    return run_bond_batch<false>(rest, [this](const BondGeometry& g, BondState& state,
                                              BondForce& f) { update(g, state, f); }) ||
           broke;
  }

  [[nodiscard]] double elastic_energy_j(const BondState& state, const Bond& bond) const override {
    return energy_j(state, bond.bond_radius_m, bond.thickness_m);
  }

  [[nodiscard]] double normal_stiffness_n_per_m(const Bond& bond) const override {
    double stiffness_n_per_m3 = normal_stiffness_;
    // A Maxwell arm is a spring too until its dashpot gives: a stretch within one step meets
    // k + k_m, which is what an explicit step has to resolve.
    if constexpr (requires { normal_.arm_stiffness_n_per_m3; }) {
      stiffness_n_per_m3 += normal_.arm_stiffness_n_per_m3;
    }
    return stiffness_n_per_m3 * grading_.scale(bond.thickness_m) * area_m2(bond.bond_radius_m);
  }
  [[nodiscard]] double relaxed_normal_stiffness_n_per_m(const Bond& bond) const override {
    return normal_stiffness_ * grading_.scale(bond.thickness_m) * area_m2(bond.bond_radius_m);
  }
  [[nodiscard]] double shear_stiffness_n_per_m(const Bond& bond) const override {
    return shear_stiffness_ * grading_.scale(bond.thickness_m) * area_m2(bond.bond_radius_m);
  }
  [[nodiscard]] bool needs_bond_thickness() const override { return Grading::kNeedsThickness; }

 private:
  [[nodiscard]] double energy_j(const BondState& state, double bond_radius_m,
                                double thickness_m) const {
    const double area = area_m2(bond_radius_m);
    const double scale = grading_.scale(thickness_m);
    return normal_.normal_energy_j(state, normal_stiffness_ * scale * area, area) +
           state.shear_force_n.squaredNorm() / (2.0 * shear_stiffness_ * scale * area);
  }

  [[nodiscard]] double area_m2(double bond_radius_m) const {
    const double radius = disk_scale_ * bond_radius_m;
    return kPi * radius * radius;
  }

  void update(const BondGeometry& g, BondState& state, BondForce& f) const {
    if (g.distance_m > g.break_distance_m) {
      state.broken = true;
      return;
    }
    const double area = area_m2(g.bond_radius_m);
    const double scale = grading_.scale(g.thickness_m);
    state.normal_force_n = normal_.force_n(g, state, normal_stiffness_ * scale * area, area);
    rotate_into_tangent_plane(state.shear_force_n, g.normal);
    // dF_t = -S_t A dt v_t, with v_t the relative velocity less its normal part (component by
    // component, as in run_bond_batch, to keep it in registers)
    const Vec3& n = g.normal;
    const Vec3& v = g.relative_velocity_m_per_s;
    const double normal_velocity = v.x() * n.x() + v.y() * n.y() + v.z() * n.z();
    const double shear_gain = shear_stiffness_ * scale * area * g.timestep_s;
    Vec3& shear = state.shear_force_n;
    shear = Vec3(shear.x() - shear_gain * (v.x() - normal_velocity * n.x()),
                 shear.y() - shear_gain * (v.y() - normal_velocity * n.y()),
                 shear.z() - shear_gain * (v.z() - normal_velocity * n.z()));
    const double shear_limit_n = shear_strength_ * area;
    if (-state.normal_force_n > normal_strength_ * area ||
        shear.x() * shear.x() + shear.y() * shear.y() + shear.z() * shear.z() >
            shear_limit_n * shear_limit_n) {
      state.broken = true;
      return;
    }
    f.normal_force_n = state.normal_force_n;
    f.shear_force_n = state.shear_force_n;
  }

  double normal_stiffness_;
  double shear_stiffness_;
  double normal_strength_;
  double shear_strength_;
  double disk_scale_;
  Normal normal_;
  Grading grading_;
};

// ---- effects (issue 6's effect library): off unless an interaction's chain names them

// Rolling resistance, constant directional torque (EDEM's "type A"): a moment
// -mu_r R* |load| omega_rel / |omega_rel| against the relative rolling, limited so that it can
// stop the rolling within a step but not reverse it. A ball rolling on a plane decelerates at
// 5/7 mu_r g. Needs a normal law before it in the chain.
class RollingResistance final : public ContactLaw {
 public:
  RollingResistance(const LawParameters& parameters, const PairMaterial&)
      : rolling_friction_(parameters.at("rolling_friction")) {}
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kMoment; }

  void compute(const PairGeometry& g, PairState&, ForceAccumulator& f) const override {
    if (!f.touching) return;
    const Vec3& omega = g.relative_angular_velocity_rad_per_s;
    const double speed = omega.norm();
    if (speed == 0.0) return;
    const double inertia = 0.4 * g.effective_mass_kg * g.effective_radius_m * g.effective_radius_m;
    const double torque =
        std::min(rolling_friction_ * g.effective_radius_m * std::abs(f.friction_normal_load_n),
                 inertia * speed / g.timestep_s);
    const Vec3 moment = -torque / speed * omega;
    f.torque_on_i_nm += moment;
    f.torque_on_j_nm -= moment;
  }

 private:
  double rolling_friction_;
};

// Static against kinetic friction (replaces coulomb): a resting contact holds up to mu_s times
// the load; once it slips the limit drops to mu_k until the contact points move slower than
// stick_speed again. A block on an incline stays at rest below atan(mu_s) and, once sliding,
// accelerates at g (sin theta - mu_k cos theta).
class StaticKineticFriction final : public ContactLaw {
 public:
  StaticKineticFriction(const LawParameters& parameters, const PairMaterial&)
      : static_(parameters.at("static_friction_coefficient")),
        kinetic_(parameters.at("kinetic_friction_coefficient")),
        stick_speed_(parameters.at("stick_speed_m_per_s")) {
    if (kinetic_ > static_) {
      throw std::invalid_argument(
          "law 'static_kinetic_friction': kinetic_friction_coefficient above the static one");
    }
  }
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kFriction; }

  void compute(const PairGeometry& g, PairState& state, ForceAccumulator& f) const override {
    if (!f.touching) {
      state.flags &= ~PairState::kFlagSliding;
      return;
    }
    const double load = std::abs(f.friction_normal_load_n);
    bool sliding = (state.flags & PairState::kFlagSliding) != 0U;
    if (sliding) {
      const Vec3 tangential_velocity =
          g.relative_velocity_m_per_s - g.relative_velocity_m_per_s.dot(g.normal) * g.normal;
      if (tangential_velocity.squaredNorm() < stick_speed_ * stick_speed_) sliding = false;
    }
    const double elastic_squared = f.tangential_elastic_force_n.squaredNorm();
    const double limit = (sliding ? kinetic_ : static_) * load;
    if (elastic_squared > limit * limit) sliding = true;
    if (sliding) {
      const double kinetic_limit = kinetic_ * load;
      if (elastic_squared > kinetic_limit * kinetic_limit) {
        const double scale = kinetic_limit / std::sqrt(elastic_squared);
        f.tangential_elastic_force_n *= scale;
        state.tangential_displacement_m *= scale;
      }
      f.tangential_damping_force_n.setZero();
      state.flags |= PairState::kFlagSliding;
    } else {
      state.flags &= ~PairState::kFlagSliding;
      if ((f.tangential_elastic_force_n + f.tangential_damping_force_n).squaredNorm() >
          limit * limit) {
        f.tangential_damping_force_n.setZero();
      }
    }
  }

 private:
  double static_;
  double kinetic_;
  double stick_speed_;
};

// A wet film between the surfaces (thesis 6.3: water made the belt slip under the mailbox):
// it lubricates, so the friction load is reduced by the factor (1 - lubrication), and its
// meniscus pulls the surfaces together with the capillary force 2 pi R* gamma while they touch.
// Place it after the normal laws and before the friction law.
class WetFilm final : public ContactLaw {
 public:
  WetFilm(const LawParameters& parameters, const PairMaterial&)
      : lubrication_(parameters.at("lubrication")),
        surface_tension_(parameters.at("surface_tension_n_per_m")) {}
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kLoadModifier; }

  void compute(const PairGeometry& g, PairState&, ForceAccumulator& f) const override {
    if (!f.touching) return;
    const double capillary = 2.0 * kPi * g.effective_radius_m * surface_tension_;
    f.normal_force_n -= capillary;
    f.friction_normal_load_n =
        (std::abs(f.friction_normal_load_n) + capillary) * (1.0 - lubrication_);
  }

 private:
  double lubrication_;
  double surface_tension_;
};

// Any chain, law by law.
class GenericChain final : public ContactChain {
 public:
  explicit GenericChain(const std::vector<std::unique_ptr<ContactLaw>>& laws) {
    for (const auto& law : laws) laws_.push_back(law.get());
  }
  void compute(const PairGeometry& g, PairState& state, ForceAccumulator& f) const override {
    for (const ContactLaw* law : laws_) law->compute(g, state, f);
  }
  [[nodiscard]] bool fused() const override { return false; }

 private:
  std::vector<const ContactLaw*> laws_;
};

// A chain of final built-in classes: each call is direct and inlined. Flattened: GCC kept
// hertz_mindlin and jkr out of line (their calls were 4 % of the thesis' bulk pile).
template <typename... Laws>
class FusedChain final : public ContactChain {
 public:
  explicit FusedChain(std::tuple<const Laws*...> laws) : laws_(laws) {}
  [[gnu::flatten]] void compute(const PairGeometry& g, PairState& state,
                                ForceAccumulator& f) const override {
    std::apply([&](const Laws*... law) { (law->Laws::compute(g, state, f), ...); }, laws_);
  }
  [[nodiscard]] bool fused() const override { return true; }

  // The chain if `laws` are exactly Laws... in this order, else null.
  static std::unique_ptr<ContactChain> match(const std::vector<std::unique_ptr<ContactLaw>>& laws) {
    if (laws.size() != sizeof...(Laws)) return nullptr;
    const auto typed = [&]<std::size_t... k>(std::index_sequence<k...>) {
      return std::tuple<const Laws*...>{dynamic_cast<const Laws*>(laws[k].get())...};
    }
    (std::index_sequence_for<Laws...>{});
    const bool all =
        std::apply([](const Laws*... law) { return ((law != nullptr) && ...); }, typed);
    return all ? std::make_unique<FusedChain>(typed) : nullptr;
  }

 private:
  std::tuple<const Laws*...> laws_;
};

template <typename Law>
LawParameters complete_parameters(const LawInfo<Law>& info, const LawParameters& given) {
  LawParameters complete;
  for (const auto& [name, value] : given) {
    const std::string& wanted = name;  // a lambda captures no structured binding in clang 14
    const auto known = std::find_if(info.parameters.begin(), info.parameters.end(),
                                    [&](const LawParameterInfo& p) { return p.name == wanted; });
    if (known == info.parameters.end()) {
      throw std::invalid_argument("law '" + info.name + "': unknown parameter '" + name + "'");
    }
    if (!(value >= known->min && value <= known->max)) {
      throw std::invalid_argument(
          "law '" + info.name + "': parameter '" + name + "' = " + std::to_string(value) +
          " outside [" + std::to_string(known->min) + ", " + std::to_string(known->max) + "]");
    }
    complete[name] = value;
  }
  for (const LawParameterInfo& p : info.parameters) {
    if (complete.count(p.name) == 0) {
      if (!p.default_value) {
        throw std::invalid_argument("law '" + info.name + "': missing parameter '" + p.name + "'");
      }
      complete[p.name] = *p.default_value;
    }
  }
  return complete;
}

template <typename Map>
std::vector<std::string> keys_of(const Map& map) {
  std::vector<std::string> names;
  names.reserve(map.size());
  for (const auto& entry : map) {
    names.push_back(entry.first);
  }
  return names;
}

}  // namespace

std::string_view chain_stage_name(ChainStage stage) {
  switch (stage) {
    case ChainStage::kNormal:
      return "normal force";
    case ChainStage::kAdhesion:
      return "adhesion";
    case ChainStage::kLoadModifier:
      return "load modifier";
    case ChainStage::kFriction:
      return "friction";
    case ChainStage::kMoment:
      return "moment";
  }
  return "unknown";
}

namespace {
// Friction and moments both read the load and neither writes what the other reads: one rank.
int chain_rank(ChainStage stage) {
  return stage == ChainStage::kMoment ? static_cast<int>(ChainStage::kFriction)
                                      : static_cast<int>(stage);
}
}  // namespace

void check_contact_chain(std::string_view where, const std::vector<std::string>& names,
                         const std::vector<std::unique_ptr<ContactLaw>>& laws) {
  const auto refuse = [&](const std::string& what) {
    throw std::invalid_argument(std::string(where) + ": contact laws " + what +
                                " (a chain runs: normal force, adhesion, load modifiers, then "
                                "friction and moments)");
  };
  const auto described = [&](std::size_t k) {
    return "'" + names[k] + "' (" + std::string(chain_stage_name(laws[k]->chain_stage())) + ")";
  };
  for (std::size_t k = 0; k < laws.size(); ++k) {
    const ChainStage stage = laws[k]->chain_stage();
    if (k == 0 && stage != ChainStage::kNormal) {
      refuse("start with " + described(k) + ": it has no normal force to act on");
    }
    if (k > 0 && stage == ChainStage::kNormal) {
      refuse("hold a second normal-force law, " + described(k) + " after '" + names[0] + "'");
    }
    if (k > 0 && chain_rank(stage) < chain_rank(laws[k - 1]->chain_stage())) {
      refuse("list " + described(k) + " after " + described(k - 1) + ": put it before");
    }
    const auto earlier_end = names.begin() + static_cast<std::ptrdiff_t>(k);
    if (std::find(names.begin(), earlier_end, names[k]) != earlier_end) {
      refuse("name '" + names[k] + "' twice");
    }
    const std::string_view replaced = laws[k]->replaces_part_of();
    if (!replaced.empty() && std::find(names.begin(), earlier_end, replaced) == earlier_end) {
      refuse("list " + described(k) + " without '" + std::string(replaced) +
             "' before it, whose force it replaces in part");
    }
  }
}

std::unique_ptr<ContactChain> make_contact_chain(
    const std::vector<std::unique_ptr<ContactLaw>>& laws) {
  for (auto* match :
       {&FusedChain<HertzMindlin, Coulomb>::match, &FusedChain<HertzMindlin, Jkr, Coulomb>::match,
        &FusedChain<HertzMindlin>::match, &FusedChain<HertzMindlin, Jkr>::match}) {
    if (auto chain = match(laws)) return chain;
  }
  return std::make_unique<GenericChain>(laws);
}

bool BondLaw::compute_batch(const BondBatch& batch) const {
  return run_bond_batch(batch, [this](const BondGeometry& g, BondState& state, BondForce& f) {
    compute(g, state, f);
  });
}

double restitution_damping_factor(double restitution) {
  if (restitution >= 1.0) {
    return 0.0;
  }
  const double log_e = std::log(restitution);
  return -log_e / std::sqrt(log_e * log_e + kPi * kPi);
}

double jkr_pull_off_force_n(double work_of_adhesion_j_per_m2, double effective_radius_m) {
  return 1.5 * kPi * work_of_adhesion_j_per_m2 * effective_radius_m;
}

double jkr_break_overlap_m(double work_of_adhesion_j_per_m2, double effective_radius_m,
                           double effective_youngs_modulus_pa) {
  const double a = std::cbrt(kPi * work_of_adhesion_j_per_m2 * effective_radius_m *
                             effective_radius_m / (8.0 * effective_youngs_modulus_pa));
  return a * a / effective_radius_m -
         std::sqrt(2.0 * kPi * work_of_adhesion_j_per_m2 * a / effective_youngs_modulus_pa);
}

double jkr_contact_radius_m(double work_of_adhesion_j_per_m2, double effective_radius_m,
                            double effective_youngs_modulus_pa, double overlap_m) {
  const double rc = effective_radius_m *
                    std::sqrt(2.0 * kPi * work_of_adhesion_j_per_m2 / effective_youngs_modulus_pa);
  double x = std::cbrt(rc) + std::sqrt(std::sqrt(effective_radius_m * std::abs(overlap_m)));
  for (int iteration = 0; iteration < 200; ++iteration) {
    const double step =
        (x * x * x * x - rc * x - effective_radius_m * overlap_m) / (4.0 * x * x * x - rc);
    x -= step;
    if (std::abs(step) <= 1e-15 * x) {
      break;
    }
  }
  return x * x;
}

double jkr_force_n(double work_of_adhesion_j_per_m2, double effective_radius_m,
                   double effective_youngs_modulus_pa, double contact_radius_m) {
  const double a3 = contact_radius_m * contact_radius_m * contact_radius_m;
  return 4.0 * effective_youngs_modulus_pa * a3 / (3.0 * effective_radius_m) -
         std::sqrt(8.0 * kPi * work_of_adhesion_j_per_m2 * effective_youngs_modulus_pa * a3);
}

const LawRegistry& LawRegistry::builtin() {
  static const LawRegistry registry = [] {
    LawRegistry r;
    register_builtin_laws(r);
    return r;
  }();
  return registry;
}

void LawRegistry::add_contact_law(LawInfo<ContactLaw> info) {
  std::string name = info.name;
  contact_laws_.insert_or_assign(std::move(name), std::move(info));
}
void LawRegistry::add_bond_law(LawInfo<BondLaw> info) {
  std::string name = info.name;
  bond_laws_.insert_or_assign(std::move(name), std::move(info));
}

const LawInfo<ContactLaw>* LawRegistry::find_contact_law(std::string_view name) const {
  const auto found = contact_laws_.find(name);
  return found == contact_laws_.end() ? nullptr : &found->second;
}
const LawInfo<BondLaw>* LawRegistry::find_bond_law(std::string_view name) const {
  const auto found = bond_laws_.find(name);
  return found == bond_laws_.end() ? nullptr : &found->second;
}
std::vector<std::string> LawRegistry::contact_law_names() const { return keys_of(contact_laws_); }
std::vector<std::string> LawRegistry::bond_law_names() const { return keys_of(bond_laws_); }

std::unique_ptr<ContactLaw> LawRegistry::create_contact_law(std::string_view name,
                                                            const LawParameters& parameters,
                                                            const PairMaterial& material) const {
  const LawInfo<ContactLaw>* info = find_contact_law(name);
  if (info == nullptr) {
    throw std::invalid_argument("unknown contact law '" + std::string(name) + "'");
  }
  return info->factory(complete_parameters(*info, parameters), material);
}

std::unique_ptr<BondLaw> LawRegistry::create_bond_law(std::string_view name,
                                                      const LawParameters& parameters,
                                                      const PairMaterial& material) const {
  const LawInfo<BondLaw>* info = find_bond_law(name);
  if (info == nullptr) {
    throw std::invalid_argument("unknown bond law '" + std::string(name) + "'");
  }
  return info->factory(complete_parameters(*info, parameters), material);
}

namespace {

// The parameters sample_*_law builds a law with (see laws.hpp).
template <typename Law>
LawParameters representative_parameters(const LawInfo<Law>& info) {
  LawParameters parameters;
  for (const LawParameterInfo& p : info.parameters) {
    if (p.default_value) continue;
    if (p.fit_range) {
      const FitRange& range = *p.fit_range;
      parameters[p.name] =
          range.log_scale ? std::sqrt(range.min * range.max) : 0.5 * (range.min + range.max);
    } else {
      // The weakest allowed setting: a law's cross-checks bound a parameter from above by
      // another (mu_k <= mu_s), never from below.
      parameters[p.name] = p.min;
    }
  }
  return parameters;
}

// The engine's default material (the fillet's, appendix B) on itself.
PairMaterial sample_material() { return make_pair_material(Material{}, Material{}, false); }

}  // namespace

std::unique_ptr<ContactLaw> LawRegistry::sample_contact_law(std::string_view name) const {
  const LawInfo<ContactLaw>* info = find_contact_law(name);
  if (info == nullptr) {
    throw std::invalid_argument("unknown contact law '" + std::string(name) + "'");
  }
  return create_contact_law(name, representative_parameters(*info), sample_material());
}

std::unique_ptr<BondLaw> LawRegistry::sample_bond_law(std::string_view name) const {
  const LawInfo<BondLaw>* info = find_bond_law(name);
  if (info == nullptr) throw std::invalid_argument("unknown bond law '" + std::string(name) + "'");
  return create_bond_law(name, representative_parameters(*info), sample_material());
}

// One line per law: adding a law is its class plus one line here.
void register_builtin_laws(LawRegistry& registry) {
  constexpr double kHuge = 1e308;
  registry.add_contact_law({"hertz_mindlin",
                            "Hertz normal, Mindlin tangential spring, eqs. 3.1-3.3 damping",
                            {{"restitution", "-", 1e-12, 1.0, std::nullopt}},
                            make_contact_law<HertzMindlin>});
  registry.add_contact_law({"coulomb",
                            "tangential force limited to mu times the normal load",
                            {{"friction_coefficient", "-", 0.0, 100.0, std::nullopt}},
                            make_contact_law<Coulomb>});
  registry.add_contact_law({"jkr",
                            "JKR adhesion from the work of adhesion",
                            {{"surface_energy_j_per_m2", "J/m^2", 0.0, 1e3, std::nullopt}},
                            make_contact_law<Jkr>});
  const std::vector<LawParameterInfo> bpm_parameters = {
      {"normal_stiffness_n_per_m3", "N/m^3", 1e-30, kHuge, std::nullopt},
      {"shear_stiffness_n_per_m3", "N/m^3", 1e-30, kHuge, std::nullopt},
      {"normal_strength_pa", "Pa", 0.0, kHuge, 1e300},
      {"shear_strength_pa", "Pa", 0.0, kHuge, 1e300},
      {"bonded_disk_scale", "-", 1e-6, 1e3, 1.0}};
  const auto with = [&](std::vector<LawParameterInfo> extra) {
    extra.insert(extra.begin(), bpm_parameters.begin(), bpm_parameters.end());
    return extra;
  };
  registry.add_bond_law({"bpm", "bonded particle model, eqs. 3.4-3.5, no damping, no moments",
                         bpm_parameters, make_bond_law<BondedParticleModel<ElasticNormal>>});
  // Effects (off unless configured): see the classes for the physics. Their fit ranges are
  // wide enough for any fillet, not a generator's: a Maxwell arm over four decades of
  // stiffness and relaxation times from a millisecond impact to a ten-second hold; a yield
  // stress over four decades; grading referred to a thickness from the tip's 15 mm to the
  // rear's 45 mm, from uniform to cubic (a plate's bending stiffness goes with t^3); resting
  // friction 0.1 to 3 (slide onset 6 to 72 deg) with contacts counted as resting below 0.1 to
  // 100 mm/s; a film taking none to 95 % of the friction load; rolling friction over three
  // decades up to 1.
  registry.add_bond_law(
      {"bpm_viscoelastic", "bpm with a Maxwell arm in the normal direction (relaxation)",
       with({{"relaxation_stiffness_n_per_m3", "N/m^3", 1e-30, kHuge, std::nullopt,
              FitRange{1e4, 1e8, true}},
             {"relaxation_time_s", "s", 1e-9, 1e9, std::nullopt, FitRange{1e-3, 10.0, true}}}),
       make_bond_law<BondedParticleModel<MaxwellNormal>>});
  registry.add_bond_law({"bpm_plastic", "bpm, perfectly plastic beyond a normal yield stress",
                         with({{"normal_yield_strength_pa", "Pa", 1e-30, kHuge, std::nullopt,
                                FitRange{1.0, 1e4, true}}}),
                         make_bond_law<BondedParticleModel<PlasticNormal>>});
  registry.add_bond_law(
      {"bpm_graded", "bpm with stiffnesses graded by the fillet's local thickness (t/t_ref)^n",
       with({{"reference_thickness_m", "m", 1e-4, 1.0, std::nullopt, FitRange{0.015, 0.045, false}},
             {"thickness_exponent", "-", -4.0, 4.0, std::nullopt, FitRange{0.0, 3.0, false}}}),
       make_bond_law<BondedParticleModel<ElasticNormal, ThicknessGradedStiffness>>});
  registry.add_contact_law(
      {"rolling_resistance",
       "constant directional rolling torque mu_r R* |load|",
       {{"rolling_friction", "-", 0.0, 10.0, std::nullopt, FitRange{1e-3, 1.0, true}}},
       make_contact_law<RollingResistance>});
  registry.add_contact_law(
      {"static_kinetic_friction",
       "friction limit mu_s at rest and mu_k while slipping",
       {{"static_friction_coefficient", "-", 0.0, 100.0, std::nullopt, FitRange{0.1, 3.0, true}},
        {"kinetic_friction_coefficient", "-", 0.0, 100.0, std::nullopt},
        {"stick_speed_m_per_s", "m/s", 1e-9, 10.0, 1e-3, FitRange{1e-4, 0.1, true}}},
       make_contact_law<StaticKineticFriction>});
  registry.add_contact_law(
      {"wet_film",
       "lubricating wet film with capillary attraction",
       {{"lubrication", "-", 0.0, 1.0, std::nullopt, FitRange{0.0, 0.95, false}},
        {"surface_tension_n_per_m", "N/m", 0.0, 1.0, 0.0}},
       make_contact_law<WetFilm>});
}

}  // namespace fl::dem
