// Building blocks of the model tests: levels, sampling, walls, blocks, timestep choice and the
// parallel loop.
#include "fl/twin/model_tests/fixtures.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <string>

#include "fl/twin/dem/config.hpp"

namespace fl::model_tests {
namespace {

// Appendix C: 1..9 x 10^k over three decades plus the end value = 28 levels.
TEST(ModelTestsFixtures, AppendixCLevels) {
  const auto levels = log_levels(1e4, 3, {1, 2, 3, 4, 5, 6, 7, 8, 9});
  ASSERT_EQ(levels.size(), 28U);
  EXPECT_DOUBLE_EQ(levels[0], 1e4);
  EXPECT_DOUBLE_EQ(levels[9], 1e5);
  EXPECT_DOUBLE_EQ(levels[10], 2e5);
  EXPECT_DOUBLE_EQ(levels.back(), 1e7);
}

// Hammersley: first coordinate k/n, second the base-2 radical inverse (0, 1/2, 1/4, 3/4).
TEST(ModelTestsFixtures, HammersleyPoints) {
  EXPECT_DOUBLE_EQ(hammersley3(1, 4)[1], 0.5);
  EXPECT_DOUBLE_EQ(hammersley3(2, 4)[1], 0.25);
  EXPECT_DOUBLE_EQ(hammersley3(3, 4)[1], 0.75);
  EXPECT_DOUBLE_EQ(hammersley3(3, 4)[0], 0.75);
  EXPECT_DOUBLE_EQ(hammersley3(1, 4)[2], 1.0 / 3.0);
}

// A 3x3x2 block: 18 spheres, face bonds 2*3*2 (x) + 3*2*2 (y) + 9 (z) = 33, all A-B.
TEST(ModelTestsFixtures, BlockHasFaceBondsBetweenTypes) {
  const auto block = make_block(0.004, 3, 3, 2);
  EXPECT_EQ(block.positions_m.size(), 18U);
  EXPECT_EQ(block.bonds.size(), 33U);
  for (const auto& b : block.bonds) {
    EXPECT_NE(block.types[b.i], block.types[b.j]);
    EXPECT_NEAR((block.positions_m[b.i] - block.positions_m[b.j]).norm(), 0.008, 1e-12);
  }
}

// The bond critical step matches the engine's check_timestep for the same body.
TEST(ModelTestsFixtures, BondCriticalStepMatchesEngine) {
  CommonParams common;
  const dem::ModelSpec spec = make_spec(common);
  const auto block = make_block(0.007, 3, 3, 3);
  dem::Simulation sim(std::make_shared<dem::Model>(spec));
  const auto bonds = body_bonds(block);
  sim.add_body(block.positions_m, block.radii_m, block.types, bonds, dem::BodyPose{});
  sim.prepare();
  EXPECT_NEAR(bond_critical_step_s(spec, block), sim.check_timestep().bond_critical_step_s, 1e-12);
}

// The spec's bond laws as bpm_viscoelastic with an arm of `arm_share` times the normal
// stiffness and a relaxation time far longer than a step (the arm a spring within it).
dem::ModelSpec with_maxwell_arm(dem::ModelSpec spec, double arm_share) {
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    dem::LawSpec& law = *interaction.bond_law;
    law.name = "bpm_viscoelastic";
    law.parameters["relaxation_stiffness_n_per_m3"] =
        arm_share * law.parameters.at("normal_stiffness_n_per_m3");
    law.parameters["relaxation_time_s"] = 0.05;
  }
  return spec;
}

// A visco-elastic bond's arm is a spring within a step: the critical step is the one of
// k_n + k_m, in the engine's check as in the model tests' step chooser, and the step chosen is
// the elastic one halved until it resolves that (so it is the same over a range of arms).
TEST(ModelTestsFixtures, AViscoelasticArmShortensTheStepInHalvings) {
  CommonParams common;
  const dem::ModelSpec elastic = make_spec(common);
  const auto block = make_block(0.007, 3, 3, 3);
  const double elastic_critical_s = bond_critical_step_s(elastic, block);
  const double elastic_step_s = choose_timestep_s(common, elastic, block);
  // The appendix B block's step is the Rayleigh time's (15 %), 0.61 of the bonds' limit (0.2 of
  // their critical step). The limit with an arm is 1/sqrt(1 + k_m/k_n) of that: up to 1.7 k_n
  // the step stays; 2.5 and 5 k_n (limits 0.88 and 0.67 of the step) take half of it, 20 k_n
  // (0.36) a quarter.
  ASSERT_NEAR(elastic_step_s / (common.bond_step_fraction * elastic_critical_s), 0.61, 0.01);
  for (const auto& [arm_share, halvings] :
       {std::pair{0.5, 0}, std::pair{2.5, 1}, std::pair{5.0, 1}, std::pair{20.0, 2}}) {
    SCOPED_TRACE(arm_share);
    const dem::ModelSpec viscoelastic = with_maxwell_arm(elastic, arm_share);
    const double critical_s = bond_critical_step_s(viscoelastic, block);
    EXPECT_NEAR(critical_s, elastic_critical_s / std::sqrt(1.0 + arm_share),
                1e-12 * elastic_critical_s);
    EXPECT_NEAR(bond_critical_step_s(viscoelastic, block, true), elastic_critical_s,
                1e-12 * elastic_critical_s);
    dem::Simulation sim(std::make_shared<dem::Model>(viscoelastic));
    sim.add_body(block.positions_m, block.radii_m, block.types, body_bonds(block), dem::BodyPose{});
    sim.prepare();
    EXPECT_NEAR(sim.check_timestep().bond_critical_step_s, critical_s, 1e-12 * critical_s);
    const double step_s = choose_timestep_s(common, viscoelastic, block);
    EXPECT_EQ(step_s, elastic_step_s / static_cast<double>(1 << halvings));
    EXPECT_LE(step_s, common.bond_step_fraction * critical_s);
  }
}

TEST(ModelTestsFixtures, ParallelForRunsEveryItemAndRethrows) {
  std::atomic<int> sum{0};
  parallel_for(100, 3, [&](std::size_t k) { sum += static_cast<int>(k); });
  EXPECT_EQ(sum.load(), 4950);
  EXPECT_THROW(parallel_for(10, 2,
                            [](std::size_t k) {
                              if (k == 3) throw std::runtime_error("item 3");
                            }),
               std::runtime_error);
}

TEST(ModelTestsFixtures, BadVariantAndRadiusAreRejected) {
  CommonParams common;
  common.variant = 6;  // table 3.1 has six variants, 0..5
  EXPECT_THROW((void)make_fillet(common), std::invalid_argument);
  common.variant = 0;
  common.sub_particle_radius_m = 0.0;
  EXPECT_THROW((void)make_fillet(common), std::invalid_argument);
}

// ---------------------------------------------------------------- stiffness and friction setters

// config/dem.yaml (appendix B: bpm 1e6 / 6e4 N/m^3, coulomb on every chain) with the fillet
// bond law renamed to `law` and given `own` parameters on top of the bpm ones.
dem::ModelSpec dem_yaml_with_bond_law(const std::string& law, const dem::LawParameters& own) {
  dem::ModelSpec spec = dem::load_model_spec(FL_SOURCE_DIR "/config/dem.yaml");
  for (auto& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    interaction.bond_law->name = law;
    interaction.bond_law->parameters.insert(own.begin(), own.end());
  }
  return spec;
}

const dem::LawSpec& fillet_bond_law(const dem::ModelSpec& spec) {
  for (const auto& interaction : spec.interactions) {
    if (interaction.bond_law) return *interaction.bond_law;
  }
  throw std::logic_error("no bond law");
}

// The stiffness settings reach every bond law of the effect library. 2e6 / 1.2e5 is twice
// appendix B, so the viscoelastic Maxwell arm (5e5, half the normal spring) doubles to 1e6
// with the normal spring; the laws' other parameters (grading, relaxation time, yield stress,
// the bpm strengths) are not stiffnesses and stay as configured (the values below are
// arbitrary but distinct, so a mix-up shows).
TEST(ModelTestsFixtures, BondStiffnessIsSetOnEveryBondLawOfTheLibrary) {
  const Stiffness doubled{2e6, 1.2e5};
  {
    dem::ModelSpec spec = dem_yaml_with_bond_law(
        "bpm_viscoelastic", {{"relaxation_stiffness_n_per_m3", 5e5}, {"relaxation_time_s", 0.05}});
    set_bond_stiffness(spec, doubled);
    const auto& p = fillet_bond_law(spec).parameters;
    EXPECT_DOUBLE_EQ(p.at("normal_stiffness_n_per_m3"), 2e6);
    EXPECT_DOUBLE_EQ(p.at("shear_stiffness_n_per_m3"), 1.2e5);
    EXPECT_DOUBLE_EQ(p.at("relaxation_stiffness_n_per_m3"), 1e6);
    EXPECT_DOUBLE_EQ(p.at("relaxation_time_s"), 0.05);
  }
  {
    dem::ModelSpec spec = dem_yaml_with_bond_law(
        "bpm_graded", {{"reference_thickness_m", 0.025}, {"thickness_exponent", 1.5}});
    set_bond_stiffness(spec, doubled);
    const auto& p = fillet_bond_law(spec).parameters;
    EXPECT_DOUBLE_EQ(p.at("normal_stiffness_n_per_m3"), 2e6);
    EXPECT_DOUBLE_EQ(p.at("shear_stiffness_n_per_m3"), 1.2e5);
    EXPECT_DOUBLE_EQ(p.at("reference_thickness_m"), 0.025);
    EXPECT_DOUBLE_EQ(p.at("thickness_exponent"), 1.5);
  }
  {
    dem::ModelSpec spec =
        dem_yaml_with_bond_law("bpm_plastic", {{"normal_yield_strength_pa", 3e4}});
    set_bond_stiffness(spec, doubled);
    const auto& p = fillet_bond_law(spec).parameters;
    EXPECT_DOUBLE_EQ(p.at("normal_stiffness_n_per_m3"), 2e6);
    EXPECT_DOUBLE_EQ(p.at("shear_stiffness_n_per_m3"), 1.2e5);
    EXPECT_DOUBLE_EQ(p.at("normal_yield_strength_pa"), 3e4);
    EXPECT_DOUBLE_EQ(p.at("normal_strength_pa"), 1e300);  // config/dem.yaml's, unbreakable
  }
  // make_spec applies CommonParams::stiffness the same way, and spec_stiffness (the base of
  // demlab's sweeps) reads a variant's stiffness, not appendix B's default: 3e6 / 2e5 differ
  // from both appendix B and `doubled`.
  CommonParams common;
  common.base_spec = dem_yaml_with_bond_law(
      "bpm_graded", {{"reference_thickness_m", 0.025}, {"thickness_exponent", 1.5}});
  common.stiffness = Stiffness{3e6, 2e5};
  const Stiffness read = spec_stiffness(make_spec(common));
  EXPECT_DOUBLE_EQ(read.normal_n_per_m3, 3e6);
  EXPECT_DOUBLE_EQ(read.shear_n_per_m3, 2e5);
}

// A bond law with no normal and shear stiffness, or with a stiffness the tests cannot place,
// is refused with its name and the reason. No library law is like that, so a test registry
// adds two (their factories are never called: setting stiffness only reads the tables).
TEST(ModelTestsFixtures, BondLawWithoutStiffnessIsRefusedByName) {
  dem::LawRegistry registry;
  dem::register_builtin_laws(registry);
  const auto no_factory = [](const dem::LawParameters&, const dem::PairMaterial&) {
    return std::unique_ptr<dem::BondLaw>();
  };
  registry.add_bond_law(
      {"glue", "strength only", {{"normal_strength_pa", "Pa", 0.0, 1e300, 1e300}}, no_factory});
  registry.add_bond_law({"bpm_bending",
                         "bpm plus a bending spring",
                         {{"normal_stiffness_n_per_m3", "N/m^3", 1e-30, 1e300, std::nullopt},
                          {"shear_stiffness_n_per_m3", "N/m^3", 1e-30, 1e300, std::nullopt},
                          {"bending_stiffness_n_per_m3", "N/m^3", 1e-30, 1e300, std::nullopt}},
                         no_factory});
  const auto message = [&](const std::string& law) {
    dem::ModelSpec spec = dem_yaml_with_bond_law(law, {});
    try {
      set_bond_stiffness(spec, Stiffness{}, registry);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("not refused");
  };
  const std::string glue = message("glue");
  EXPECT_NE(glue.find("'glue'"), std::string::npos) << glue;
  EXPECT_NE(glue.find("has no normal_stiffness_n_per_m3"), std::string::npos) << glue;
  const std::string bending = message("bpm_bending");
  EXPECT_NE(bending.find("'bending_stiffness_n_per_m3'"), std::string::npos) << bending;
  const std::string unknown = message("no_such_law");
  EXPECT_NE(unknown.find("'no_such_law'"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("not in the law library"), std::string::npos) << unknown;
}

// The slide test's friction coefficient: coulomb's mu; with static_kinetic_friction the static
// coefficient, the kinetic one kept at its configured ratio (0.4 / 0.5 = 0.8, so 0.6 -> 0.48);
// a chain without a friction law is refused, naming its types.
TEST(ModelTestsFixtures, FrictionCoefficientSetsTheChainsFrictionLaw) {
  dem::ModelSpec spec = dem::load_model_spec(FL_SOURCE_DIR "/config/dem.yaml");
  const std::uint32_t equipment = equipment_type(spec);
  for (auto& interaction : spec.interactions) {
    if (!is_fillet_with(interaction, equipment)) continue;
    for (auto& law : interaction.contact_laws) {
      if (law.name != "coulomb") continue;
      law = {"static_kinetic_friction",
             {{"static_friction_coefficient", 0.5}, {"kinetic_friction_coefficient", 0.4}}};
    }
  }
  set_friction_coefficient(spec, 0.6, equipment);
  int checked = 0;
  for (const auto& interaction : spec.interactions) {
    for (const auto& law : interaction.contact_laws) {
      if (is_fillet_with(interaction, equipment)) {
        if (law.name != "static_kinetic_friction") continue;
        EXPECT_DOUBLE_EQ(law.parameters.at("static_friction_coefficient"), 0.6);
        EXPECT_DOUBLE_EQ(law.parameters.at("kinetic_friction_coefficient"), 0.48);
        ++checked;
      } else if (law.name == "coulomb") {
        // fillet-fillet is not the plate's: config/dem.yaml's 0.1 stays
        EXPECT_DOUBLE_EQ(law.parameters.at("friction_coefficient"), 0.1);
      }
    }
  }
  EXPECT_EQ(checked, 2);  // fillet_a-equipment and fillet_b-equipment
  // The engine accepts what was set (it refuses mu_k > mu_s).
  EXPECT_NO_THROW(dem::Model{spec});

  dem::ModelSpec coulomb_spec = dem::load_model_spec(FL_SOURCE_DIR "/config/dem.yaml");
  set_friction_coefficient(coulomb_spec, 0.7, equipment);
  for (const auto& interaction : coulomb_spec.interactions) {
    if (!is_fillet_with(interaction, equipment)) continue;
    EXPECT_DOUBLE_EQ(interaction.contact_laws.back().parameters.at("friction_coefficient"), 0.7);
  }

  for (auto& interaction : coulomb_spec.interactions) {
    std::erase_if(interaction.contact_laws,
                  [](const dem::LawSpec& law) { return law.name == "coulomb"; });
  }
  try {
    set_friction_coefficient(coulomb_spec, 0.5, equipment);
    ADD_FAILURE() << "a chain without a friction law was not refused";
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'fillet_a'-'equipment'"), std::string::npos) << what;
    EXPECT_NE(what.find("no friction law"), std::string::npos) << what;
  }
}

}  // namespace
}  // namespace fl::model_tests
