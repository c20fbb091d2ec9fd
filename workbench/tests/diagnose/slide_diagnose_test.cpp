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

// One test per effect, so each stays a few minutes and ctest can run them apart. The seeds
// draw parameters inside the generator's ranges; the effect is named so both are proven.
TEST(SlideDiagnose, FindsAHiddenWetFilm) {
  test::expect_hidden_effect_found(test::generate_slide("wet_film", 21), "onset_angle",
                                   test::angle_score);
}

TEST(SlideDiagnose, FindsHiddenStaticFriction) {
  test::expect_hidden_effect_found(test::generate_slide("static_kinetic_friction", 22),
                                   "onset_angle", test::angle_score);
}

TEST(SlideDiagnose, ProposesNothingWhenResidualsAreAtTheNoise) {
  test::expect_nothing_proposed(test::generate_slide("none", 23).dataset);
}

}  // namespace
}  // namespace fl::workbench
