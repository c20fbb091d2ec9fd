// Diagnose's candidates come from the effect library's registrations: a law registered with fit
// ranges is a candidate on every experiment whose twin loads its kind of law, placed in the
// model by what its class declares, with no list in the workbench to edit (issue 6: adding an
// effect is one class and one registration line).
#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "fl/twin/dem/config.hpp"
#include "fl/twin/dem/model.hpp"
#include "fl/workbench/diagnose.hpp"
#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

std::vector<std::string> laws_of(const std::vector<EffectCandidate>& candidates) {
  std::vector<std::string> laws;
  laws.reserve(candidates.size());
  for (const EffectCandidate& candidate : candidates) laws.push_back(candidate.law);
  std::sort(laws.begin(), laws.end());
  return laws;
}

const EffectCandidate* find(const std::vector<EffectCandidate>& candidates, std::string_view law) {
  const auto found = std::find_if(candidates.begin(), candidates.end(),
                                  [&](const EffectCandidate& c) { return c.law == law; });
  return found == candidates.end() ? nullptr : &*found;
}

// The example of laws.hpp's header: friction falling with sliding speed, a load modifier.
class SpeedWeakening final : public dem::ContactLaw {
 public:
  SpeedWeakening(const dem::LawParameters& p, const dem::PairMaterial& /*material*/)
      : drop_(p.at("friction_drop_per_m_per_s")) {}
  void compute(const dem::PairGeometry& g, dem::PairState& /*state*/,
               dem::ForceAccumulator& f) const override {
    if (f.touching) f.friction_normal_load_n /= 1.0 + drop_ * g.relative_velocity_m_per_s.norm();
  }
  [[nodiscard]] dem::ChainStage chain_stage() const override {
    return dem::ChainStage::kLoadModifier;
  }

 private:
  double drop_;
};

// The built-in effects, by where each experiment's twin loads the fillet: the contact laws
// where it touches the machine, the bond laws where it deforms; the thickness-graded bonds only
// where the specimen is a fillet (compress's block has no thickness profile).
TEST(EffectCandidates, EachExperimentGetsTheLibrarysEffectsOfTheKindItsTwinLoads) {
  const std::vector<std::string> contact{"rolling_resistance", "static_kinetic_friction",
                                         "wet_film"};
  EXPECT_EQ(laws_of(candidates_for(ExperimentType::kSlide)), contact);
  EXPECT_EQ(laws_of(candidates_for(ExperimentType::kLineTracks)), contact);
  const std::vector<std::string> block{"bpm_plastic", "bpm_viscoelastic"};
  EXPECT_EQ(laws_of(candidates_for(ExperimentType::kCompress)), block);
  const std::vector<std::string> fillet{"bpm_graded", "bpm_plastic", "bpm_viscoelastic"};
  for (const ExperimentType type :
       {ExperimentType::kBend, ExperimentType::kDrop, ExperimentType::kSettle}) {
    EXPECT_EQ(laws_of(candidates_for(type)), fillet) << to_string(type);
  }
  EXPECT_THROW((void)candidates_for(ExperimentType::kBulkFlow), std::invalid_argument);

  // A candidate searches exactly the parameters with a fit range, over that range: the wet
  // film's lubrication, not its surface tension (a default of 0 the fit leaves alone).
  const std::vector<EffectCandidate> slide = candidates_for(ExperimentType::kSlide);
  const EffectCandidate* film = find(slide, "wet_film");
  ASSERT_NE(film, nullptr);
  ASSERT_EQ(film->parameters.size(), 1U);
  const dem::LawInfo<dem::ContactLaw>& info =
      *dem::LawRegistry::builtin().find_contact_law("wet_film");
  const auto lubrication = std::find_if(info.parameters.begin(), info.parameters.end(),
                                        [](const auto& p) { return p.name == "lubrication"; });
  ASSERT_NE(lubrication, info.parameters.end());
  EXPECT_EQ(film->parameters[0].name, "lubrication");
  EXPECT_EQ(film->parameters[0].min, lubrication->fit_range->min);
  EXPECT_EQ(film->parameters[0].max, lubrication->fit_range->max);
  EXPECT_EQ(film->parameters[0].log, lubrication->fit_range->log_scale);
}

TEST(EffectCandidates, ALawRegisteredWithAFitRangeIsACandidateWithNoOtherChange) {
  dem::LawRegistry registry;
  dem::register_builtin_laws(registry);
  registry.add_contact_law({"speed_weakening",
                            "friction falling with sliding speed",
                            {{"friction_drop_per_m_per_s", "s/m", 0.0, 100.0, std::nullopt,
                              dem::FitRange{0.01, 10.0, true}}},
                            dem::make_contact_law<SpeedWeakening>});
  // A bond effect under a new name, on the Maxwell law's class.
  dem::LawInfo<dem::BondLaw> creep = *registry.find_bond_law("bpm_viscoelastic");
  creep.name = "bpm_creep";
  registry.add_bond_law(creep);

  const std::vector<EffectCandidate> slide = candidates_for(ExperimentType::kSlide, registry);
  const EffectCandidate* weakening = find(slide, "speed_weakening");
  ASSERT_NE(weakening, nullptr);
  ASSERT_EQ(weakening->parameters.size(), 1U);
  EXPECT_EQ(weakening->parameters[0].name, "friction_drop_per_m_per_s");
  EXPECT_EQ(weakening->parameters[0].min, 0.01);
  EXPECT_EQ(weakening->parameters[0].max, 10.0);
  EXPECT_TRUE(weakening->parameters[0].log);
  EXPECT_EQ(find(slide, "bpm_creep"), nullptr);
  const std::vector<EffectCandidate> compress = candidates_for(ExperimentType::kCompress, registry);
  EXPECT_NE(find(compress, "bpm_creep"), nullptr);
  EXPECT_EQ(find(compress, "speed_weakening"), nullptr);

  // Placed by its stage: a load modifier goes after the normal and adhesion laws and before
  // the friction law it feeds, in every fillet-equipment chain; the model builds with it.
  const dem::ModelSpec base = test::base_model().base_spec;
  const dem::ModelSpec spec = with_contact_effect(
      base, HiddenEffect{"speed_weakening", {{"friction_drop_per_m_per_s", 2.0}}}, registry);
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  int chains = 0;
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    std::vector<std::string> names;
    for (const dem::LawSpec& law : interaction.contact_laws) names.push_back(law.name);
    if (!model_tests::is_fillet_with(interaction, equipment)) {
      EXPECT_EQ(std::count(names.begin(), names.end(), "speed_weakening"), 0);
      continue;
    }
    ++chains;
    const std::vector<std::string> expected{"hertz_mindlin", "jkr", "speed_weakening", "coulomb"};
    EXPECT_EQ(names, expected);
  }
  EXPECT_EQ(chains, 2);  // fillet types A and B with the equipment
  EXPECT_NO_THROW(dem::Model(spec, registry));
  const dem::ModelSpec bonded =
      with_bond_effect(base, HiddenEffect{"bpm_creep", {{"relaxation_time_s", 0.1}}}, registry);
  EXPECT_NO_THROW(dem::Model(
      with_bond_effect(bonded, HiddenEffect{"bpm_creep", {{"relaxation_stiffness_n_per_m3", 1e6}}},
                       registry),
      registry));

  // A law the library does not have, or of the other kind, is refused by name.
  try {
    (void)with_contact_effect(base, HiddenEffect{"speed_weakening", {}});  // builtin registry
    ADD_FAILURE() << "an unregistered law was placed";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("'speed_weakening'"), std::string::npos);
  }
  EXPECT_THROW((void)with_bond_effect(base, HiddenEffect{"wet_film", {}}), std::invalid_argument);
}

// What the run history records beside the error: the effects in the model, each once though
// both fillet types carry it, with its parameters; the base laws are not effects.
TEST(EffectCandidates, TheHistoryNamesTheEffectsInTheModelOnce) {
  const dem::ModelSpec base = test::base_model().base_spec;
  EXPECT_EQ(model_effects(base), "none");
  const dem::ModelSpec wet = with_contact_effect(base, {"wet_film", {{"lubrication", 0.3}}});
  EXPECT_EQ(model_effects(wet), "wet_film (lubrication 0.3)");  // as configured: defaults unsaid
  const dem::ModelSpec both =
      with_bond_effect(wet, {"bpm_plastic", {{"normal_yield_strength_pa", 40.0}}});
  const std::string effects = model_effects(both);
  EXPECT_NE(effects.find("wet_film ("), std::string::npos) << effects;
  EXPECT_NE(effects.find("bpm_plastic ("), std::string::npos) << effects;
  EXPECT_NE(effects.find("normal_yield_strength_pa 40"), std::string::npos) << effects;
  EXPECT_EQ(effects.find("hertz_mindlin"), std::string::npos) << effects;
}

}  // namespace
}  // namespace fl::workbench
