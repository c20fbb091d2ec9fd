// Calibration fixtures shared by the calibrate tests (workbench_tests) and the profile tests
// (workbench_diagnose_tests, slow).
#pragma once

#include <string>

#include "fl/workbench/calibrate.hpp"
#include "fl/workbench/generator.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench::test {

// A compression dataset measured with bonds 1.8 times appendix B's normal stiffness and no
// effect, at the tests' force noise: what a calibration must find.
inline constexpr double kTruthStiffness = 1.8e6;
inline Dataset stiffer_bonds_compression() {
  GeneratorOptions options;
  options.effect = "none";
  options.force_noise_n = kNoiseN;
  options.common = base_model();
  options.common.base_spec =
      with_calibrated(options.common.base_spec,
                      {{"bond.normal_stiffness_n_per_m3", 1.0, 2.0, false}}, {kTruthStiffness});
  return generate_dataset(options).dataset;
}

// The normal stiffness (3e5 to 1e7, log) calibrated together with `other`: 8 Hammersley points
// and at most 20 local evaluations, as a quick two-parameter fit.
inline Calibration calibrate_stiffness_and(const Dataset& data, const std::string& other,
                                           int profile_fit_evaluations = 0) {
  CalibrationOptions calibration;
  calibration.profile_fit_evaluations = profile_fit_evaluations;
  calibration.hammersley_points = 8;
  calibration.max_local_evaluations = 20;
  return calibrate(data, base_model(),
                   {parse_calibrated_parameter("bond.normal_stiffness_n_per_m3=3e5:1e7:log"),
                    parse_calibrated_parameter(other)},
                   calibration);
}

}  // namespace fl::workbench::test
