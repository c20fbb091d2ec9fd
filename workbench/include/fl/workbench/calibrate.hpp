// Calibration of the base model against a dataset, before any effect is blamed (issue 6): the
// parameters the thesis tuned (bond stiffnesses, friction, surface energy, restitution) fitted
// by a design of experiments over their box, sampled as the thesis sampled its parameter
// spaces (a full factorial grid, or a Hammersley sequence, appendix C), every point a twin run
// of every trial on both cores, then a bounded local fit (NLopt) from the best point.
//
//   const auto parameters =
//   parse_calibrated_parameters({"bond.normal_stiffness_n_per_m3=3e5:3e6:log"}); const Calibration
//   result = calibrate(dataset, base, parameters, {}); spec = with_calibrated(base.base_spec,
//   parameters, result.best);
#pragma once

#include <filesystem>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "fl/twin/model_tests/fixtures.hpp"
#include "fl/workbench/dataset.hpp"

namespace fl::workbench {

// One parameter of the base model and its box. The address names where it sits in the DEM
// model: "bond.KEY" (the bond law of every bonded pair), "fillet_equipment.LAW.KEY" and
// "fillet_fillet.LAW.KEY" (the contact law LAW between fillet types and the equipment, or
// between fillet types), for example "fillet_equipment.coulomb.friction_coefficient".
struct CalibratedParameter {
  std::string address;
  double min = 0.0;
  double max = 0.0;
  bool log = false;  // sampled and searched on a log scale (stiffnesses span decades)
};

// "ADDRESS=MIN:MAX" or "ADDRESS=MIN:MAX:log", as the command line takes them. Throws
// std::invalid_argument naming the text for a malformed one, a box that is empty or not
// finite, or a log box that is not positive.
CalibratedParameter parse_calibrated_parameter(const std::string& text);

enum class DesignKind { kFullFactorial, kHammersley };

struct CalibrationOptions {
  DesignKind design = DesignKind::kHammersley;
  int hammersley_points = 16;
  int factorial_levels = 3;        // per parameter: levels^parameters points
  int max_local_evaluations = 60;  // the local fit after the design; 0: design only
  int threads = 2;                 // design points run at once
  // Trace each parameter's profile (see ParameterSensitivity): steps of a tenth of the box
  // from the calibrated point, the others re-fitted at each with at most this many twin
  // evaluations. 0: not traced (the local and joint intervals only).
  int profile_fit_evaluations = 0;
};

// Points of a design in the unit cube [0, 1]^dimensions: a full factorial grid with `levels`
// levels per dimension (0 and 1 included; 1 level: the middle), or the first `points` points of
// a Hammersley set (k / n, then radical inverses in bases 2, 3, 5, ...: up to 8 dimensions).
std::vector<std::vector<double>> full_factorial_design(std::size_t dimensions, int levels);
std::vector<std::vector<double>> hammersley_design(std::size_t dimensions, int points);

struct DesignRun {
  std::vector<double> values;  // one per parameter, in its unit
  double rmse = 0.0;           // of the judged channel over every trial, SI
  std::string failure;         // non-empty: the twin could not run this point (why)
};

// How well the dataset pins one calibrated parameter down around the calibrated point. Locally:
// the RMS with that parameter alone moved a tenth of its box down and up (a tenth of the
// decades for a log box), and whether each move raises the residual sum of squares by more
// than the noise explains: a likelihood-ratio test at 95 % for one parameter, n (RMS_moved^2 -
// RMS^2) > 3.84 sigma^2, with sigma the dataset's noise or, where it gives none, the calibrated
// residual's own (RSS / (n - parameters)). Over the design: the main effect, the mean RMS of
// the design points in each slice of the box.
struct ParameterSensitivity {
  // The moved values and the RMS there; a move at an edge of the box is not made (NaN), and a
  // point the twin refused has a NaN RMS.
  double value_down = 0.0;
  double value_up = 0.0;
  double rmse_down = 0.0;
  double rmse_up = 0.0;
  // Every move made raises the error beyond the noise: the data determine the parameter here.
  bool determined = false;
  // A conditional 95 % confidence interval (profile likelihood with the other parameters held
  // at their calibrated values, so correlated parameters have wider joint intervals): where
  // the residual sum of squares, a parabola about the calibrated point (the fit's minimum)
  // with the moves' curvature, rises 3.84 sigma^2; clipped to the box. NaN when the moves do
  // not bound it (no upward curvature, no finite move).
  double interval_low = 0.0;
  double interval_high = 0.0;
  // The joint (marginal) 95 % interval: the same threshold, with every other parameter
  // re-fitted along the way, from the whole curvature matrix of the residual sum of squares
  // (the moves above plus one move of each pair of parameters together). Wider than the
  // conditional one where parameters trade off (k_n against the bond's disk scale in a
  // compression); NaN for every parameter when the matrix is not positive definite: then the
  // data do not pin the parameters down together, whatever each alone says.
  double joint_interval_low = 0.0;
  double joint_interval_high = 0.0;
  // The profile 95 % interval (CalibrationOptions::profile_fit_evaluations > 0, else NaN): the
  // parameter stepped away from the calibrated point a tenth of its box at a time, the other
  // parameters re-fitted at each step (continued from the step before), until the residual
  // sum of squares rises 3.84 sigma^2 over the calibrated one; the bound is interpolated
  // between the last two steps, linearly in sqrt(rise) (exact for a parabola). A step that
  // overshoots by far, or that the twin refuses, is halved and tried again (down to 1/64). Unlike
  // the joint interval it follows a curved valley and exists where the curvature matrix is
  // singular. A bound the rise never reached inside the box is the box's edge, flagged open: the
  // data do not bound the parameter that way. A side whose trace has not ended after 64 steps
  // has a NaN bound (and a warning in the log).
  double profile_interval_low = std::numeric_limits<double>::quiet_NaN();
  double profile_interval_high = std::numeric_limits<double>::quiet_NaN();
  bool profile_low_open = false;
  bool profile_high_open = false;
  // The traced profile, by value: each step's value and the re-fitted RMS there (the
  // calibrated point included).
  std::vector<double> profile_values;
  std::vector<double> profile_rmse;
  // Design points by slice of the box (factorial: one per level; Hammersley: quarters), the
  // mean RMS of those the twin ran; NaN for a slice without any. The values: each slice's
  // level or middle, in the parameter's unit.
  std::vector<double> main_effect_values;
  std::vector<double> main_effect_rmse;
};

struct Calibration {
  std::string channel;
  std::vector<CalibratedParameter> parameters;
  std::vector<double> base_values;  // the model's own values before calibration
  double base_rmse = 0.0;
  std::vector<DesignRun> design;                  // in design order
  std::vector<double> best;                       // calibrated values, one per parameter
  double rmse = 0.0;                              // with `best`
  double noise_si = 0.0;                          // the dataset's, when given
  int evaluations = 0;                            // twin evaluations in all (every trial each)
  std::size_t samples = 0;                        // rows of the judged channel over every trial
  std::vector<ParameterSensitivity> sensitivity;  // one per parameter
  // Correlation of the calibrated parameters (search coordinates), row by row, from the
  // inverse curvature matrix; empty when it is not positive definite (see the joint interval).
  std::vector<std::vector<double>> correlation;
};

// The spec with each parameter set to its value. Throws std::invalid_argument naming the
// address when the spec has no such law or key (a parameter that is not in the model cannot
// be calibrated; adding a law is an effect's job).
dem::ModelSpec with_calibrated(const dem::ModelSpec& spec,
                               const std::vector<CalibratedParameter>& parameters,
                               const std::vector<double>& values);

// Runs the design and the local fit. Throws std::invalid_argument for no parameters, a
// dataset type the twin does not reproduce, an address not in the model, or a design of more
// than 4096 points; a design point the twin cannot run is recorded as failed, not fatal.
Calibration calibrate(const Dataset& dataset, const model_tests::CommonParams& base,
                      const std::vector<CalibratedParameter>& parameters,
                      const CalibrationOptions& options);

// The calibration as JSON (the design, the best values, errors before and after, and each
// parameter's sensitivity).
std::string calibration_json(const Calibration& calibration);

// One SVG per parameter in `folder` (sensitivity_<k>.svg, k from 1): the design's RMS against
// the parameter's value (points), its main effect (line), the local moves around the
// calibrated value, and the noise and the calibrated value as reference lines. Returns the
// files written; throws fl::report::ReportError naming a file that cannot be written.
std::vector<std::filesystem::path> write_sensitivity_plots(const Calibration& calibration,
                                                           const std::filesystem::path& folder);

namespace detail {

// The interval of ParameterSensitivity in the search coordinate u: rss_at(u) for u0 - step,
// u0, u0 + step (NaN for a move not made or refused), the likelihood-ratio threshold
// (3.84 sigma^2). The parabola is centred on u0, the fit's minimum: the moves' second
// difference gives its curvature (one move: its rise over step^2). A three-point vertex
// would be pulled off the minimum by the error's asymmetry over a tenth of the box (a
// stiffness on a log scale). Returns {NaN, NaN} without upward curvature.
std::pair<double, double> quadratic_interval(double rss_down, double rss_best, double rss_up,
                                             double u_best, double step, double threshold);

// The curvature matrix A of rss(u) ~ rss_best + (u - u0)^T A (u - u0) from the moves, in the
// search coordinate: rss_down/rss_up per parameter as quadratic_interval takes them, and per
// pair p < q (row by row: (0,1), (0,2), ..., (1,2), ...) the rss with both moved together, p
// by sign[p] step and q by sign[q] step, sign +1 where p's up move was made, else -1. Exact for
// a quadratic. Returns an empty matrix when a needed value is not finite.
std::vector<std::vector<double>> curvature_matrix(const std::vector<double>& rss_down,
                                                  const std::vector<double>& rss_up,
                                                  const std::vector<double>& rss_pairs,
                                                  const std::vector<int>& sign, double rss_best,
                                                  double step);

// Joint 95 % intervals (in u) and the correlation matrix from A: half width
// sqrt(threshold (A^-1)_pp) about u0. Empty results when A is empty or not positive definite.
struct JointIntervals {
  std::vector<std::pair<double, double>> intervals;
  std::vector<std::vector<double>> correlation;
};
JointIntervals joint_intervals(const std::vector<std::vector<double>>& curvature,
                               const std::vector<double>& u_best, double threshold);

}  // namespace detail

}  // namespace fl::workbench
