// The proof issue 6 asks for, on slide data: a dataset made with a hidden contact effect gets
// that effect ranked first and proposed; adding it with the fitted parameters makes the error
// fall by 70 % or more and end within twice the noise; a dataset without a hidden effect gets
// nothing proposed. The candidates' bounds are the diagnosis' own (slide_candidates: decades
// wide), not the generator's ranges.
#include <gtest/gtest.h>

#include "fl/workbench/diagnose.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;

void expect_found(const std::string& effect, std::uint64_t seed) {
  SCOPED_TRACE(effect);
  const GeneratedDataset made = test::generate_slide(effect, seed);
  const Dataset& data = made.dataset;
  const Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  ASSERT_FALSE(diagnosis.ranked.empty());
  EXPECT_EQ(diagnosis.channel, "onset_angle");
  EXPECT_EQ(diagnosis.ranked.front().law, made.truth.law) << diagnosis.verdict;
  EXPECT_TRUE(diagnosis.ranked.front().proposed) << diagnosis.verdict;
  const double before = test::angle_score(data, {});
  const double after = test::angle_score(data, proposed_effect(diagnosis));
  EXPECT_LE(after, 0.3 * before) << "before " << before << ", after " << after;
  EXPECT_LE(after, 2.0) << "in noise sigmas";
}

// One test per effect, so each stays a few minutes and ctest can run them apart. The seeds
// draw parameters inside the generator's ranges; the effect is named so both are proven.
TEST(SlideDiagnose, FindsAHiddenWetFilm) { expect_found("wet_film", 21); }

TEST(SlideDiagnose, FindsHiddenStaticFriction) { expect_found("static_kinetic_friction", 22); }

TEST(SlideDiagnose, ProposesNothingWhenResidualsAreAtTheNoise) {
  const Dataset data = test::generate_slide("none", 23).dataset;
  const Diagnosis diagnosis = diagnose(data, base_model(), candidates_for(data.experiment));
  for (const CandidateResult& result : diagnosis.ranked) EXPECT_FALSE(result.proposed);
  EXPECT_TRUE(proposed_effect(diagnosis).law.empty());
  EXPECT_NE(diagnosis.verdict.find("nothing missing"), std::string::npos) << diagnosis.verdict;
}

}  // namespace
}  // namespace fl::workbench
