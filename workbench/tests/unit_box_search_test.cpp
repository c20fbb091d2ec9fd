// The local search diagnose and calibrate fit with (detail::minimise_in_unit_box), on
// objectives with a known minimum: no twin runs.
#include <gtest/gtest.h>

#include <stdexcept>
#include <vector>

#include "residuals.hpp"

namespace fl::workbench::detail {
namespace {

// A bowl with its floor at (0.3, 0.7), `floor` deep: a deviance's floor can lie far below 0.
UnitBoxObjective bowl(double floor, int& evaluations) {
  return [floor, &evaluations](const std::vector<double>& x) {
    ++evaluations;
    return floor + 50.0 * (x[0] - 0.3) * (x[0] - 0.3) + 50.0 * (x[1] - 0.7) * (x[1] - 0.7);
  };
}

TEST(UnitBoxSearch, FindsTheFloorOfANegativeObjectiveWithAnAbsoluteRestartGain) {
  int evaluations = 0;
  const UnitBoxObjective objective = bowl(-1000.0, evaluations);
  std::vector<double> x{0.5, 0.5};
  const double found = minimise_in_unit_box(objective, x, objective(x), 0.25, 200, "test", 1.0);
  // BOBYQA's quadratic model is exact on a bowl: the floor to well under the 1 of restart gain.
  EXPECT_NEAR(found, -1000.0, 1e-3);
  EXPECT_NEAR(x[0], 0.3, 1e-2);
  EXPECT_NEAR(x[1], 0.7, 1e-2);
  EXPECT_LE(evaluations, 201);  // the budget and the start point
}

TEST(UnitBoxSearch, ASumOfSquaresRestartsOnItsRelativeGain) {
  int evaluations = 0;
  const UnitBoxObjective objective = bowl(2.0, evaluations);
  std::vector<double> x{0.9, 0.1};
  const double found = minimise_in_unit_box(objective, x, objective(x), 0.25, 200, "test");
  EXPECT_NEAR(found, 2.0, 1e-3);
}

TEST(UnitBoxSearch, APointTheObjectiveRefusesIsAVeryBadOneNotTheEnd) {
  // Refused beyond 0.8 in the first coordinate (an engine refusing an unstable timestep).
  int evaluations = 0;
  const UnitBoxObjective inner = bowl(-5.0, evaluations);
  const UnitBoxObjective objective = [&](const std::vector<double>& x) {
    if (x[0] > 0.8) throw std::runtime_error("unstable");
    return inner(x);
  };
  std::vector<double> x{0.5, 0.5};
  EXPECT_NEAR(minimise_in_unit_box(objective, x, objective(x), 0.25, 200, "test", 1.0), -5.0, 1e-3);
}

}  // namespace
}  // namespace fl::workbench::detail
