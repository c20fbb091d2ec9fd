// A contact chain's laws run in order on one accumulator, so their order is physics: Model
// refuses a chain whose order would silently drop or double a force.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "dem_test_support.hpp"

namespace fl::dem {
namespace {

LawSpec jkr() { return {"jkr", {{"surface_energy_j_per_m2", 0.055}}}; }  // appendix B
LawSpec wet_film() { return {"wet_film", {{"lubrication", 0.5}}}; }
LawSpec static_kinetic() {
  return {"static_kinetic_friction",
          {{"static_friction_coefficient", 0.6}, {"kinetic_friction_coefficient", 0.4}}};
}
LawSpec rolling() { return {"rolling_resistance", {{"rolling_friction", 0.1}}}; }

// The model's error for this ball-ball and ball-wall chain, or "" when it builds.
std::string refusal(const std::vector<LawSpec>& chain,
                    const LawRegistry& registry = LawRegistry::builtin()) {
  try {
    const Model model(test::ball_model(chain, 1e-5), registry);
  } catch (const std::invalid_argument& error) {
    return error.what();
  }
  return "";
}

TEST(DemChainOrder, TheShippedAndTheWorkbenchChainsBuild) {
  // config/dem.yaml's chain, and the longest the workbench makes (a wet film, static friction
  // in coulomb's place, rolling resistance last), and one with a coulomb kept after the static
  // friction (a user's config may do so; the two friction laws must still chain)
  EXPECT_EQ(refusal({test::hertz(1e-4), jkr(), test::coulomb(0.5)}), "");
  EXPECT_EQ(refusal({test::hertz(1e-4), jkr(), wet_film(), static_kinetic(), rolling()}), "");
  EXPECT_EQ(refusal({test::hertz(1e-4), jkr(), wet_film(), static_kinetic(), test::coulomb(0.6),
                     rolling()}),
            "");
  EXPECT_EQ(refusal({}), "");  // no contact at all
}

TEST(DemChainOrder, AFrictionLawBeforeTheNormalLawIsRefused) {
  // coulomb first would see no load at every step: a frictionless contact, silently
  const std::string error = refusal({test::coulomb(0.5), test::hertz(1e-4)});
  EXPECT_NE(error.find("interaction ball-ball"), std::string::npos) << error;
  EXPECT_NE(error.find("'coulomb' (friction)"), std::string::npos) << error;
  EXPECT_NE(error.find("no normal force"), std::string::npos) << error;
}

TEST(DemChainOrder, LawsOutOfStageOrderAreRefused) {
  // jkr after coulomb: the friction limit would use the load before adhesion raised it
  std::string error = refusal({test::hertz(1e-4), test::coulomb(0.5), jkr()});
  EXPECT_NE(error.find("'jkr' (adhesion) after 'coulomb' (friction)"), std::string::npos) << error;
  // wet_film before jkr: jkr sets the friction load anew and the film's lubrication is lost
  error = refusal({test::hertz(1e-4), wet_film(), jkr(), test::coulomb(0.5)});
  EXPECT_NE(error.find("'jkr' (adhesion) after 'wet_film' (load modifier)"), std::string::npos)
      << error;
  error = refusal({test::hertz(1e-4), test::coulomb(0.5), rolling(), wet_film()});
  EXPECT_NE(error.find("'wet_film' (load modifier) after 'rolling_resistance' (moment)"),
            std::string::npos)
      << error;
}

TEST(DemChainOrder, FrictionAndMomentsComeInEitherOrder) {
  // both only read the load: the rolling torque and the friction limit do not depend on which
  // runs first (DemEffects' rolling-resistance test lists rolling_resistance before coulomb)
  EXPECT_EQ(refusal({test::hertz(1e-4), rolling(), test::coulomb(0.5)}), "");
  EXPECT_EQ(refusal({test::hertz(1e-4), test::coulomb(0.5), rolling()}), "");
}

TEST(DemChainOrder, ALawTwiceIsRefused) {
  // two hertz_mindlin would double the normal force; two jkr take the Hertz force out twice
  EXPECT_NE(refusal({test::hertz(1e-4), test::hertz(0.5)}).find("second normal-force law"),
            std::string::npos);
  EXPECT_NE(refusal({test::hertz(1e-4), jkr(), jkr()}).find("name 'jkr' twice"), std::string::npos);
}

// A linear normal spring registered beside the built-in laws, as a user would add one: jkr
// after it has no Hertz force to take out, and would leave an adhesive pull where the spring
// should push.
class LinearSpring final : public ContactLaw {
 public:
  LinearSpring(const LawParameters& parameters, const PairMaterial&)
      : stiffness_(parameters.at("stiffness_n_per_m")) {}
  void compute(const PairGeometry& g, PairState&, ForceAccumulator& f) const override {
    if (g.overlap_m <= 0.0) return;
    f.normal_force_n += stiffness_ * g.overlap_m;
    f.friction_normal_load_n += stiffness_ * g.overlap_m;
    f.touching = true;
  }
  [[nodiscard]] ChainStage chain_stage() const override { return ChainStage::kNormal; }

 private:
  double stiffness_;
};

TEST(DemChainOrder, AdhesionWithoutTheLawItCorrectsIsRefused) {
  LawRegistry registry;
  register_builtin_laws(registry);
  registry.add_contact_law({"linear_spring",
                            "normal force proportional to the overlap",
                            {{"stiffness_n_per_m", "N/m", 0.0, 1e9, std::nullopt}},
                            make_contact_law<LinearSpring>});
  const LawSpec spring{"linear_spring", {{"stiffness_n_per_m", 100.0}}};
  EXPECT_EQ(refusal({spring, test::coulomb(0.5)}, registry), "");
  const std::string error = refusal({spring, jkr(), test::coulomb(0.5)}, registry);
  EXPECT_NE(error.find("'jkr' (adhesion) without 'hertz_mindlin' before it"), std::string::npos)
      << error;
}

}  // namespace
}  // namespace fl::dem

namespace fl::dem {
namespace {

// What places an effect in a chain before any model exists (the workbench's diagnose) asks a
// sampled law its stage: every registered law must build from its representative parameters,
// and each answers the stage its class declares.
TEST(DemChainOrder, EveryRegisteredLawCanBeAskedItsStageBeforeAModelExists) {
  const LawRegistry& registry = LawRegistry::builtin();
  for (const std::string& name : registry.contact_law_names()) {
    EXPECT_NO_THROW((void)registry.sample_contact_law(name)) << name;
  }
  for (const std::string& name : registry.bond_law_names()) {
    EXPECT_NO_THROW((void)registry.sample_bond_law(name)) << name;
  }
  EXPECT_EQ(registry.sample_contact_law("hertz_mindlin")->chain_stage(), ChainStage::kNormal);
  EXPECT_EQ(registry.sample_contact_law("wet_film")->chain_stage(), ChainStage::kLoadModifier);
  EXPECT_EQ(registry.sample_contact_law("static_kinetic_friction")->chain_stage(),
            ChainStage::kFriction);
  EXPECT_TRUE(registry.sample_bond_law("bpm_graded")->needs_bond_thickness());
  EXPECT_FALSE(registry.sample_bond_law("bpm")->needs_bond_thickness());
  EXPECT_THROW((void)registry.sample_contact_law("no_such_law"), std::invalid_argument);
  EXPECT_THROW((void)registry.sample_bond_law("coulomb"), std::invalid_argument);
}

}  // namespace
}  // namespace fl::dem
