// The proof issue 6 asks for, on compression data: a dataset made with a hidden effect gets
// that effect ranked first and proposed; adding it with the fitted parameters makes the error
// fall by 70 % or more and end within twice the noise; a dataset without a hidden effect gets
// nothing proposed. The candidates' bounds are the diagnosis' own (decades wide), not the
// generator's ranges.
#include "fl/workbench/diagnose.hpp"

#include <gtest/gtest.h>

#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

TEST(Diagnose, FindsEachHiddenEffectAndTheErrorFalls) {
  // Seeds 11 and 12 draw different parameters for each effect; the effect is named, so both
  // candidates are proven whatever the random choice would pick.
  for (const auto& [effect, seed] : {std::pair{std::string("bpm_viscoelastic"), 11},
                                     std::pair{std::string("bpm_plastic"), 12}}) {
    SCOPED_TRACE(effect);
    const GeneratedDataset made = test::generate(effect, static_cast<std::uint64_t>(seed));
    const Dataset& data = made.dataset;
    const Diagnosis diagnosis = diagnose(data, base_model(), compress_candidates());
    ASSERT_FALSE(diagnosis.ranked.empty());
    EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
    EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
    const double before = test::force_score(data, {});
    const double after = test::force_score(data, proposed_effect(diagnosis));
    EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
    EXPECT_LE(after, 2.0) << "in noise sigmas";
  }
}

TEST(Diagnose, ProposesNothingWhenResidualsAreAtTheNoise) {
  const Dataset data = test::generate("none", 13).dataset;
  const Diagnosis diagnosis = diagnose(data, base_model(), compress_candidates());
  for (const CandidateResult& result : diagnosis.ranked) EXPECT_FALSE(result.proposed);
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  EXPECT_NE(diagnosis.verdict.find("nothing missing"), std::string::npos) << diagnosis.verdict;
}

TEST(Diagnose, RefusesWhatItCannotJudge) {
  GeneratorOptions options;
  options.effect = "none";
  options.trials = 1;
  options.common = base_model();
  const Dataset one_trial = generate_dataset(options).dataset;
  EXPECT_THROW((void)diagnose(one_trial, base_model(), compress_candidates()),
               std::invalid_argument);
}

}  // namespace
}  // namespace fl::workbench
