// Shared building blocks of the model tests (fl/twin/model_tests/fixtures.hpp).
#include "fl/twin/model_tests/fixtures.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <memory>
#include <mutex>
#include <numbers>
#include <stdexcept>
#include <string>
#include <thread>

#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/laws.hpp"
#include "fl/twin/dem/state.hpp"

namespace fl::model_tests {

dem::ModelSpec make_spec(const CommonParams& common) {
  dem::ModelSpec spec =
      common.base_spec.types.empty() ? dem::appendix_b_model_spec() : common.base_spec;
  if (spec.types.size() < 2 || spec.types[dem::kFilletTypeA].name != "fillet_a" ||
      spec.types[dem::kFilletTypeB].name != "fillet_b") {
    throw std::invalid_argument("model tests: engine types 0 and 1 must be fillet_a, fillet_b");
  }
  (void)equipment_type(spec);
  if (common.stiffness) set_bond_stiffness(spec, *common.stiffness);
  spec.planes.clear();
  spec.meshes.clear();
  spec.thread_count = std::max(1, common.thread_count);
  return spec;
}

namespace {

// The bond-law parameters the model tests' stiffness settings act on. Every bpm-family law of
// the library (bpm, bpm_graded, bpm_viscoelastic, bpm_plastic) has the first two; grading
// multiplies them bond by bond, so setting them sets the graded law's stiffness at its
// reference thickness, and the plastic law's yield is a stress, left as it is (as the
// strengths).
const std::string kNormalStiffness = "normal_stiffness_n_per_m3";
const std::string kShearStiffness = "shear_stiffness_n_per_m3";
// bpm_viscoelastic's Maxwell arm, in the normal direction beside the normal spring. It follows
// the normal stiffness by the same factor (k_m / k_n and the relaxation time kept): a "stiffer
// bond" is then the same standard linear solid scaled, both its relaxed stiffness k_n and its
// instantaneous one k_n + k_m by the factor, with the same relaxation in time.
const std::string kRelaxationStiffness = "relaxation_stiffness_n_per_m3";
const std::string kStiffnessUnit = "N/m^3";

bool has_bond_stiffness(const dem::LawParameters& parameters) {
  return parameters.contains(kNormalStiffness) && parameters.contains(kShearStiffness);
}

std::string type_name(const dem::ModelSpec& spec, std::uint32_t type) {
  return type < spec.types.size() ? "'" + spec.types[type].name + "'"
                                  : "type " + std::to_string(type);
}

bool is_fillet_interaction(const dem::InteractionSpec& interaction,
                           std::optional<std::uint32_t> other_type) {
  if (interaction.type_a > dem::kFilletTypeB && interaction.type_b > dem::kFilletTypeB) {
    return false;
  }
  return !other_type || is_fillet_with(interaction, *other_type);
}

}  // namespace

Stiffness spec_stiffness(const dem::ModelSpec& spec) {
  for (const auto& interaction : spec.interactions) {
    if (interaction.bond_law && has_bond_stiffness(interaction.bond_law->parameters)) {
      const auto& p = interaction.bond_law->parameters;
      return {p.at(kNormalStiffness), p.at(kShearStiffness)};
    }
  }
  return {};
}

double spec_disk_scale(const dem::ModelSpec& spec) {
  for (const auto& interaction : spec.interactions) {
    if (interaction.bond_law) {
      const auto found = interaction.bond_law->parameters.find("bonded_disk_scale");
      return found == interaction.bond_law->parameters.end() ? 1.0 : found->second;
    }
  }
  return 1.0;
}

void set_bond_stiffness(dem::ModelSpec& spec, const Stiffness& stiffness,
                        const dem::LawRegistry& registry) {
  for (auto& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    dem::LawSpec& law = *interaction.bond_law;
    const auto refusal = [&](const std::string& why) {
      return std::invalid_argument("model tests: bond law '" + law.name + "' between " +
                                   type_name(spec, interaction.type_a) + " and " +
                                   type_name(spec, interaction.type_b) + " " + why);
    };
    const dem::LawInfo<dem::BondLaw>* info = registry.find_bond_law(law.name);
    if (info == nullptr) {
      throw refusal("is not in the law library: no stiffness the tests could set");
    }
    bool normal = false;
    bool shear = false;
    for (const auto& parameter : info->parameters) {
      if (parameter.name == kNormalStiffness) {
        normal = true;
      } else if (parameter.name == kShearStiffness) {
        shear = true;
      } else if (parameter.unit == kStiffnessUnit && parameter.name != kRelaxationStiffness) {
        throw refusal("has a stiffness '" + parameter.name +
                      "' that the model tests do not know how to scale with the bond stiffness");
      }
    }
    if (!normal || !shear) {
      throw refusal("has no " + kNormalStiffness + " and " + kShearStiffness +
                    ": its bonds have no normal and shear stiffness for the model tests' stiffness "
                    "settings (bend stiffness_factors, impact and DOE stiffness sets) to set");
    }
    const auto relaxation = law.parameters.find(kRelaxationStiffness);
    if (relaxation != law.parameters.end()) {
      const auto old_normal = law.parameters.find(kNormalStiffness);
      if (old_normal == law.parameters.end() || !(old_normal->second > 0.0)) {
        throw refusal("has no positive " + kNormalStiffness + " to scale " + kRelaxationStiffness +
                      " with");
      }
      relaxation->second *= stiffness.normal_n_per_m3 / old_normal->second;
    }
    law.parameters[kNormalStiffness] = stiffness.normal_n_per_m3;
    law.parameters[kShearStiffness] = stiffness.shear_n_per_m3;
  }
}

bool is_fillet_with(const dem::InteractionSpec& interaction, std::uint32_t other_type) {
  const bool a_is_fillet = interaction.type_a <= dem::kFilletTypeB;
  const bool b_is_fillet = interaction.type_b <= dem::kFilletTypeB;
  return (a_is_fillet && interaction.type_b == other_type) ||
         (b_is_fillet && interaction.type_a == other_type);
}

void set_contact_parameter(dem::ModelSpec& spec, const std::string& law, const std::string& key,
                           double value, std::optional<std::uint32_t> other_type) {
  bool found = false;
  for (auto& interaction : spec.interactions) {
    if (!is_fillet_interaction(interaction, other_type)) continue;
    for (auto& spec_of_law : interaction.contact_laws) {
      if (spec_of_law.name == law) {
        spec_of_law.parameters[key] = value;
        found = true;
      }
    }
  }
  if (!found) {
    throw std::invalid_argument("model tests: no contact law '" + law + "' to set '" + key + "'");
  }
}

bool has_fillet_contact_law(const dem::ModelSpec& spec, std::string_view law,
                            std::uint32_t other_type) {
  return std::any_of(
      spec.interactions.begin(), spec.interactions.end(), [&](const dem::InteractionSpec& i) {
        return is_fillet_with(i, other_type) &&
               std::any_of(
                   i.contact_laws.begin(), i.contact_laws.end(),
                   [&](const dem::LawSpec& spec_of_law) { return spec_of_law.name == law; });
      });
}

void set_friction_coefficient(dem::ModelSpec& spec, double mu,
                              std::optional<std::uint32_t> other_type) {
  bool found = false;
  for (auto& interaction : spec.interactions) {
    if (!is_fillet_interaction(interaction, other_type)) continue;
    found = true;
    const std::string pair =
        type_name(spec, interaction.type_a) + "-" + type_name(spec, interaction.type_b);
    // Every friction law of the chain takes mu (a second one would otherwise cap the sweep).
    bool has_friction = false;
    for (auto& law : interaction.contact_laws) {
      auto& p = law.parameters;
      if (law.name == "coulomb") {
        p["friction_coefficient"] = mu;
        has_friction = true;
      } else if (law.name == "static_kinetic_friction") {
        // mu is the static coefficient, the one that decides when a resting body starts to
        // slide (atan(mu_s) on an incline); the kinetic one keeps its configured ratio to it,
        // so the law's mu_k <= mu_s holds at every mu.
        const auto mu_s = p.find("static_friction_coefficient");
        const auto mu_k = p.find("kinetic_friction_coefficient");
        if (mu_s == p.end() || mu_k == p.end()) {
          throw std::invalid_argument("model tests: static_kinetic_friction of " + pair +
                                      " needs static_ and kinetic_friction_coefficient");
        }
        const double kinetic_share = mu_s->second > 0.0 ? mu_k->second / mu_s->second : 1.0;
        mu_s->second = mu;
        mu_k->second = kinetic_share * mu;
        has_friction = true;
      }
    }
    if (!has_friction) {
      throw std::invalid_argument(
          "model tests: the contact laws of " + pair +
          " have no friction law (coulomb or static_kinetic_friction) to take the friction "
          "coefficient");
    }
  }
  if (!found) {
    throw std::invalid_argument("model tests: no interaction of a fillet type" +
                                (other_type ? " with " + type_name(spec, *other_type) : "") +
                                " to set the friction coefficient on");
  }
}

std::uint32_t equipment_type(const dem::ModelSpec& spec) {
  for (std::size_t k = 0; k < spec.types.size(); ++k) {
    if (spec.types[k].name == "equipment") return static_cast<std::uint32_t>(k);
  }
  throw std::invalid_argument("model tests: the engine model has no type 'equipment'");
}

dem::FilletTemplate make_fillet(const CommonParams& common, double scale) {
  return make_fillet_template(common.fillet_mesh.get(), common.sub_particle_radius_m,
                              common.variant, scale);
}

std::vector<dem::BodyBond> body_bonds(const dem::FilletTemplate& fillet) {
  std::vector<dem::BodyBond> bonds;
  bonds.reserve(fillet.bonds.size());
  for (const auto& b : fillet.bonds) bonds.push_back({b.i, b.j, b.contact_radius_m, b.thickness_m});
  return bonds;
}

dem::FilletTemplate make_block(double radius_m, int nx, int ny, int nz) {
  if (nx < 1 || ny < 1 || nz < 2 || !(radius_m > 0.0)) {
    throw std::invalid_argument("model tests: block needs nx, ny >= 1, nz >= 2, radius > 0");
  }
  dem::FilletTemplate block;
  block.name = "block";
  const double pitch = 2.0 * radius_m;
  const Vec3 centre(0.5 * (nx - 1) * pitch, 0.5 * (ny - 1) * pitch, 0.5 * (nz - 1) * pitch);
  auto index = [&](int x, int y, int z) {
    return static_cast<std::uint32_t>(x + nx * (y + ny * z));
  };
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        block.positions_m.push_back(Vec3(x * pitch, y * pitch, z * pitch) - centre);
        block.radii_m.push_back(radius_m);
        block.types.push_back((x + y + z) % 2 == 0 ? dem::kFilletTypeA : dem::kFilletTypeB);
      }
    }
  }
  const double contact_radius = radius_m * std::sqrt(3.0);  // the fillet raster's (3.3.1)
  const double thickness = nz * pitch;                      // bottom to top of the spheres
  for (int z = 0; z < nz; ++z) {
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        // A cut sample is as thick everywhere as it is high.
        if (x + 1 < nx) {
          block.bonds.push_back({index(x, y, z), index(x + 1, y, z), contact_radius, thickness});
        }
        if (y + 1 < ny) {
          block.bonds.push_back({index(x, y, z), index(x, y + 1, z), contact_radius, thickness});
        }
        if (z + 1 < nz) {
          block.bonds.push_back({index(x, y, z), index(x, y, z + 1), contact_radius, thickness});
        }
      }
    }
  }
  block.half_extent_m = centre + Vec3::Constant(radius_m);
  return block;
}

double bond_critical_step_s(const dem::ModelSpec& spec, const dem::FilletTemplate& fillet,
                            bool relaxed) {
  // The bond law of the fillet types as the engine builds it, asked for each bond's spring
  // constants: a graded law's differ from bond to bond, and every bpm variant counts.
  const dem::InteractionSpec* bonded = nullptr;
  for (const auto& interaction : spec.interactions) {
    if (interaction.bond_law) {
      bonded = &interaction;
      break;
    }
  }
  double step = std::numeric_limits<double>::infinity();
  if (bonded == nullptr) return step;
  const dem::Material& material = spec.materials[spec.types[dem::kFilletTypeA].material];
  const std::unique_ptr<dem::BondLaw> law = dem::LawRegistry::builtin().create_bond_law(
      bonded->bond_law->name, bonded->bond_law->parameters,
      dem::make_pair_material(material, material, false));
  // Per sphere, the springs of all its bonds in parallel.
  std::vector<double> stiffness_n_per_m(fillet.positions_m.size(), 0.0);
  for (const auto& b : fillet.bonds) {
    dem::Bond bond;
    bond.bond_radius_m = std::min(fillet.radii_m[b.i], fillet.radii_m[b.j]);
    bond.thickness_m = b.thickness_m;
    const double normal =
        relaxed ? law->relaxed_normal_stiffness_n_per_m(bond) : law->normal_stiffness_n_per_m(bond);
    const double k = std::max(normal, law->shear_stiffness_n_per_m(bond));
    stiffness_n_per_m[b.i] += k;
    stiffness_n_per_m[b.j] += k;
  }
  for (std::size_t k = 0; k < stiffness_n_per_m.size(); ++k) {
    if (stiffness_n_per_m[k] <= 0.0) continue;
    const double r = fillet.radii_m[k];
    const double mass = material.density_kg_per_m3 * 4.0 / 3.0 * std::numbers::pi * r * r * r;
    step = std::min(step, 2.0 / std::sqrt(stiffness_n_per_m[k] / mass));
  }
  return step;
}

double choose_timestep_s(const CommonParams& common, const dem::ModelSpec& spec,
                         const dem::FilletTemplate& fillet) {
  const dem::Material& m = spec.materials[spec.types[dem::kFilletTypeA].material];
  const double radius = *std::min_element(fillet.radii_m.begin(), fillet.radii_m.end());
  double dt = common.rayleigh_fraction * dem::rayleigh_time_s(radius, m.density_kg_per_m3,
                                                              m.youngs_modulus_pa, m.poisson_ratio);
  if (common.bond_step_fraction > 0.0) {
    dt = std::min(dt, common.bond_step_fraction * bond_critical_step_s(spec, fillet, true));
    const double limit_s = common.bond_step_fraction * bond_critical_step_s(spec, fillet);
    while (dt > limit_s) dt *= 0.5;
  }
  return dt;
}

dem::PlaneWallSpec floor_plane(std::uint32_t type) {
  return {"floor", type, Vec3::Zero(), Vec3::UnitZ()};
}

std::uint32_t add_fillet(dem::Simulation& sim, const dem::FilletTemplate& fillet,
                         const Eigen::Quaterniond& orientation, double x_m, double y_m,
                         double bottom_z_m, const Vec3& velocity_m_per_s) {
  double lowest = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < fillet.positions_m.size(); ++k) {
    lowest = std::min(lowest, (orientation * fillet.positions_m[k]).z() - fillet.radii_m[k]);
  }
  dem::BodyPose pose;
  pose.position_m = Vec3(x_m, y_m, bottom_z_m - lowest);
  pose.orientation = orientation;
  pose.velocity_m_per_s = velocity_m_per_s;
  const auto bonds = body_bonds(fillet);
  return sim.add_body(fillet.positions_m, fillet.radii_m, fillet.types, bonds, pose);
}

double intact_bond_share(const dem::State& state) {
  if (state.bond_states.empty()) return 1.0;
  std::size_t intact = 0;
  for (const auto& b : state.bond_states) intact += b.broken ? 0U : 1U;
  return static_cast<double>(intact) / static_cast<double>(state.bond_states.size());
}

double kinetic_energy_j(const dem::EnergyReport& energy) {
  return energy.kinetic_translational_j + energy.kinetic_rotational_j;
}

Vec3 centroid_m(const dem::State& state) {
  Vec3 sum = Vec3::Zero();
  for (const auto& p : state.position_m) sum += p;
  return state.size() > 0 ? Vec3(sum / static_cast<double>(state.size())) : sum;
}

Eigen::Quaterniond random_orientation(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double u1 = u(rng), u2 = u(rng), u3 = u(rng);
  const double a = std::sqrt(1.0 - u1), b = std::sqrt(u1);
  const double tau = 2.0 * std::numbers::pi;
  return Eigen::Quaterniond(a * std::sin(tau * u2), a * std::cos(tau * u2), b * std::sin(tau * u3),
                            b * std::cos(tau * u3))
      .normalized();
}

Eigen::Quaterniond yaw_pitch_roll(double yaw_rad, double pitch_rad, double roll_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Vec3::UnitZ()) *
                            Eigen::AngleAxisd(pitch_rad, Vec3::UnitY()) *
                            Eigen::AngleAxisd(roll_rad, Vec3::UnitX()));
}

std::array<double, 3> hammersley3(std::size_t k, std::size_t n) {
  auto radical_inverse = [](std::size_t i, std::size_t base) {
    double inverse = 0.0, f = 1.0 / static_cast<double>(base);
    for (double factor = f; i > 0; i /= base, factor *= f) {
      inverse += factor * static_cast<double>(i % base);
    }
    return inverse;
  };
  return {static_cast<double>(k) / static_cast<double>(n), radical_inverse(k, 2),
          radical_inverse(k, 3)};
}

void parallel_for(std::size_t count, int threads, const std::function<void(std::size_t)>& body,
                  const std::function<void(std::size_t, std::size_t)>& progress) {
  std::atomic<std::size_t> next{0};
  std::atomic<std::size_t> done{0};
  std::mutex mutex;
  std::exception_ptr error;
  auto worker = [&] {
    for (std::size_t k = next++; k < count; k = next++) {
      try {
        body(k);
      } catch (...) {
        std::lock_guard lock(mutex);
        if (!error) error = std::current_exception();
        next = count;  // stop handing out work
      }
      const std::size_t finished = ++done;
      if (progress) {
        std::lock_guard lock(mutex);
        progress(finished, count);
      }
    }
  };
  const auto n = static_cast<std::size_t>(std::max(1, threads));
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < std::min(n, count); ++t) pool.emplace_back(worker);
  worker();
  for (auto& thread : pool) thread.join();
  if (error) std::rethrow_exception(error);
}

std::vector<double> log_levels(double first, int decades, const std::vector<double>& mantissas) {
  std::vector<double> levels;
  for (int d = 0; d < decades; ++d) {
    for (const double m : mantissas) levels.push_back(first * m * std::pow(10.0, d));
  }
  levels.push_back(first * std::pow(10.0, decades));
  return levels;
}

}  // namespace fl::model_tests
