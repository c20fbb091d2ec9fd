#include "fl/workbench/calibrate.hpp"

#include <spdlog/spdlog.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>

#include "fl/report/svg_plot.hpp"
#include "fl/twin/dem/config.hpp"
#include "residuals.hpp"

namespace fl::workbench {
namespace {

constexpr std::size_t kMaxDesignPoints = 4096;

double parse_number(std::string_view text, const std::string& whole) {
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
    throw std::invalid_argument("calibrated parameter '" + whole + "': '" + std::string(text) +
                                "' is not a finite number");
  }
  return value;
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  for (;;) {
    const std::size_t at = text.find(separator, start);
    parts.push_back(text.substr(start, at - start));
    if (at == std::string::npos) return parts;
    start = at + 1;
  }
}

// The laws' parameter maps an address names, in the spec; empty when none has the key.
std::vector<dem::LawParameters*> resolve(dem::ModelSpec& spec, const std::string& address) {
  const std::vector<std::string> part = split(address, '.');
  std::vector<dem::LawParameters*> found;
  if (part.size() == 2 && part[0] == "bond") {
    for (dem::InteractionSpec& interaction : spec.interactions) {
      if (interaction.bond_law && interaction.bond_law->parameters.contains(part[1])) {
        found.push_back(&interaction.bond_law->parameters);
      }
    }
  } else if (part.size() == 3 && (part[0] == "fillet_equipment" || part[0] == "fillet_fillet")) {
    const bool equipment_pair = part[0] == "fillet_equipment";
    const std::uint32_t equipment = model_tests::equipment_type(spec);
    for (dem::InteractionSpec& interaction : spec.interactions) {
      // Types 0 and 1 are the fillet types (model_tests::CommonParams).
      const bool matches = equipment_pair ? model_tests::is_fillet_with(interaction, equipment)
                                          : model_tests::is_fillet_with(interaction, 0) ||
                                                model_tests::is_fillet_with(interaction, 1);
      if (!matches) continue;
      for (dem::LawSpec& law : interaction.contact_laws) {
        if (law.name == part[1] && law.parameters.contains(part[2])) {
          found.push_back(&law.parameters);
        }
      }
    }
  } else {
    throw std::invalid_argument("calibrated parameter '" + address +
                                "': not bond.KEY, fillet_equipment.LAW.KEY or "
                                "fillet_fillet.LAW.KEY");
  }
  if (found.empty()) {
    throw std::invalid_argument("calibrated parameter '" + address +
                                "': the DEM model has no such law and key");
  }
  return found;
}

double from_unit(const CalibratedParameter& p, double u) {
  return p.log ? p.min * std::pow(p.max / p.min, u) : p.min + u * (p.max - p.min);
}

double radical_inverse(unsigned base, std::size_t k) {
  double inverse = 0.0;
  double digit_weight = 1.0 / base;
  while (k > 0) {
    inverse += static_cast<double>(k % base) * digit_weight;
    k /= base;
    digit_weight /= base;
  }
  return inverse;
}

struct Evaluator {
  const Dataset* dataset = nullptr;
  const model_tests::CommonParams* base = nullptr;
  const std::vector<CalibratedParameter>* parameters = nullptr;
  std::vector<std::size_t> trials;

  // RMS of the judged channel at a point of the unit cube; throws what the twin throws.
  [[nodiscard]] double rmse(const std::vector<double>& unit_point) const {
    std::vector<double> values;
    for (std::size_t p = 0; p < parameters->size(); ++p) {
      values.push_back(from_unit((*parameters)[p], unit_point[p]));
    }
    model_tests::CommonParams common = *base;
    common.base_spec = with_calibrated(base->base_spec, *parameters, values);
    const detail::Residuals r = detail::residuals(*dataset, common, trials);
    return std::sqrt(r.rss / static_cast<double>(r.samples));
  }
};

}  // namespace

CalibratedParameter parse_calibrated_parameter(const std::string& text) {
  const std::size_t equals = text.find('=');
  if (equals == std::string::npos || equals == 0) {
    throw std::invalid_argument("calibrated parameter '" + text +
                                "': expected ADDRESS=MIN:MAX or ADDRESS=MIN:MAX:log");
  }
  CalibratedParameter p;
  p.address = text.substr(0, equals);
  const std::vector<std::string> box = split(text.substr(equals + 1), ':');
  if (box.size() < 2 || box.size() > 3 || (box.size() == 3 && box[2] != "log")) {
    throw std::invalid_argument("calibrated parameter '" + text +
                                "': expected MIN:MAX or MIN:MAX:log after '='");
  }
  p.min = parse_number(box[0], text);
  p.max = parse_number(box[1], text);
  p.log = box.size() == 3;
  if (!(p.min < p.max)) {
    throw std::invalid_argument("calibrated parameter '" + text + "': MIN must be below MAX");
  }
  if (p.log && p.min <= 0.0) {
    throw std::invalid_argument("calibrated parameter '" + text + "': a log box must be positive");
  }
  return p;
}

std::vector<std::vector<double>> full_factorial_design(std::size_t dimensions, int levels) {
  if (dimensions == 0 || levels < 1) {
    throw std::invalid_argument("full factorial design: one dimension and one level or more");
  }
  std::size_t count = 1;
  for (std::size_t d = 0; d < dimensions; ++d) {
    count *= static_cast<std::size_t>(levels);
    if (count > kMaxDesignPoints) {
      throw std::invalid_argument("full factorial design: more than 4096 points");
    }
  }
  const auto level_value = [levels](std::size_t level) {
    return levels == 1 ? 0.5 : static_cast<double>(level) / static_cast<double>(levels - 1);
  };
  std::vector<std::vector<double>> points(count, std::vector<double>(dimensions));
  for (std::size_t k = 0; k < count; ++k) {
    std::size_t rest = k;
    for (std::size_t d = 0; d < dimensions; ++d) {
      points[k][d] = level_value(rest % static_cast<std::size_t>(levels));
      rest /= static_cast<std::size_t>(levels);
    }
  }
  return points;
}

std::vector<std::vector<double>> hammersley_design(std::size_t dimensions, int points) {
  static constexpr std::array<unsigned, 7> kBases{2, 3, 5, 7, 11, 13, 17};
  if (dimensions == 0 || dimensions > kBases.size() + 1 || points < 1 ||
      static_cast<std::size_t>(points) > kMaxDesignPoints) {
    throw std::invalid_argument("Hammersley design: 1 to 8 dimensions and 1 to 4096 points");
  }
  std::vector<std::vector<double>> design(static_cast<std::size_t>(points),
                                          std::vector<double>(dimensions));
  for (std::size_t k = 0; k < design.size(); ++k) {
    design[k][0] = static_cast<double>(k) / static_cast<double>(points);
    for (std::size_t d = 1; d < dimensions; ++d) design[k][d] = radical_inverse(kBases[d - 1], k);
  }
  return design;
}

dem::ModelSpec with_calibrated(const dem::ModelSpec& spec,
                               const std::vector<CalibratedParameter>& parameters,
                               const std::vector<double>& values) {
  if (values.size() != parameters.size()) {
    throw std::invalid_argument("with_calibrated: one value per parameter is needed");
  }
  dem::ModelSpec calibrated = spec;
  for (std::size_t p = 0; p < parameters.size(); ++p) {
    const std::string key = split(parameters[p].address, '.').back();
    for (dem::LawParameters* law : resolve(calibrated, parameters[p].address)) {
      (*law)[key] = values[p];
    }
  }
  return calibrated;
}

namespace {

// A tenth of the box either way, as ParameterSensitivity describes.
constexpr double kSensitivityStep = 0.1;
// chi-square with one degree of freedom at 95 %: the likelihood-ratio test's threshold.
constexpr double kChiSquare95OneParameter = 3.841;

// The likelihood-ratio test's rise of the residual sum of squares at 95 %: 3.84 sigma^2, sigma
// the dataset's noise or, where it gives none, the calibrated residual's own with the
// parameters' degrees of freedom taken off.
double likelihood_threshold(const Calibration& result, std::size_t dimensions) {
  const auto n = static_cast<double>(result.samples);
  const double free_samples = std::max(1.0, n - static_cast<double>(dimensions));
  const double variance = result.noise_si > 0.0 ? result.noise_si * result.noise_si
                                                : result.rmse * result.rmse * n / free_samples;
  return kChiSquare95OneParameter * variance;
}

std::vector<ParameterSensitivity> sensitivities(const Evaluator& evaluator,
                                                const std::vector<CalibratedParameter>& parameters,
                                                const std::vector<double>& best_unit,
                                                const Calibration& result,
                                                const std::vector<std::vector<double>>& unit_points,
                                                int slices, bool factorial, int threads,
                                                std::vector<std::vector<double>>& correlation) {
  const std::size_t dimensions = parameters.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // The moves, run on every core: 2 per parameter (a move past the box is not made), then one
  // per pair of parameters moved together, each the way its own up move went where it could.
  std::vector<std::vector<double>> moves;
  std::vector<bool> made;  // inside the box: evaluated and judged
  for (std::size_t p = 0; p < dimensions; ++p) {
    for (const double direction : {-1.0, 1.0}) {
      std::vector<double> point = best_unit;
      point[p] += direction * kSensitivityStep;
      made.push_back(point[p] >= 0.0 && point[p] <= 1.0);
      moves.push_back(std::move(point));
    }
  }
  std::vector<int> sign(dimensions);
  for (std::size_t p = 0; p < dimensions; ++p) sign[p] = made[2 * p + 1] ? 1 : -1;
  for (std::size_t p = 0; p < dimensions; ++p) {
    for (std::size_t q = p + 1; q < dimensions; ++q) {
      std::vector<double> point = best_unit;
      point[p] += sign[p] * kSensitivityStep;
      point[q] += sign[q] * kSensitivityStep;
      made.push_back(point[p] >= 0.0 && point[p] <= 1.0 && point[q] >= 0.0 && point[q] <= 1.0);
      moves.push_back(std::move(point));
    }
  }
  std::vector<double> moved_rmse(moves.size(), nan);
  model_tests::parallel_for(
      moves.size(), std::max(1, threads),
      [&](std::size_t k) {
        if (!made[k]) return;
        moved_rmse[k] = detail::guarded_value(
            [&](const std::vector<double>& point) { return evaluator.rmse(point); }, moves[k],
            "calibrate: sensitivity");
        if (moved_rmse[k] >= 1e300) moved_rmse[k] = nan;
      },
      [](std::size_t, std::size_t) {});

  const auto n = static_cast<double>(result.samples);
  const double threshold = likelihood_threshold(result, dimensions);
  const auto rss = [&](double rmse) { return n * rmse * rmse; };
  std::vector<ParameterSensitivity> out(dimensions);
  for (std::size_t p = 0; p < dimensions; ++p) {
    ParameterSensitivity& s = out[p];
    s.value_down = from_unit(parameters[p], std::max(0.0, best_unit[p] - kSensitivityStep));
    s.value_up = from_unit(parameters[p], std::min(1.0, best_unit[p] + kSensitivityStep));
    s.rmse_down = moved_rmse[2 * p];
    s.rmse_up = moved_rmse[2 * p + 1];
    int moves_made = 0;
    int significant = 0;
    for (std::size_t side = 0; side < 2; ++side) {
      if (!made[2 * p + side]) continue;
      ++moves_made;
      const double rmse = moved_rmse[2 * p + side];
      // A refused point counts as significant: the model cannot even run there.
      if (std::isnan(rmse) || n * (rmse * rmse - result.rmse * result.rmse) > threshold) {
        ++significant;
      }
    }
    s.determined = moves_made > 0 && significant == moves_made;
    const auto [low_u, high_u] =
        detail::quadratic_interval(rss(s.rmse_down), rss(result.rmse), rss(s.rmse_up), best_unit[p],
                                   kSensitivityStep, threshold);
    s.interval_low = std::isnan(low_u) ? nan : from_unit(parameters[p], std::max(0.0, low_u));
    s.interval_high = std::isnan(high_u) ? nan : from_unit(parameters[p], std::min(1.0, high_u));
    std::vector<double> sum(static_cast<std::size_t>(slices), 0.0);
    std::vector<int> count(static_cast<std::size_t>(slices), 0);
    for (std::size_t k = 0; k < unit_points.size(); ++k) {
      if (!result.design[k].failure.empty()) continue;
      const auto slice = static_cast<std::size_t>(
          std::min(slices - 1, static_cast<int>(unit_points[k][p] * slices)));
      sum[slice] += result.design[k].rmse;
      ++count[slice];
    }
    for (std::size_t slice = 0; slice < sum.size(); ++slice) {
      const double index = static_cast<double>(slice);
      const double u = !factorial    ? (index + 0.5) / slices
                       : slices == 1 ? 0.5
                                     : index / (slices - 1);
      s.main_effect_values.push_back(from_unit(parameters[p], u));
      s.main_effect_rmse.push_back(count[slice] > 0 ? sum[slice] / count[slice] : nan);
    }
  }

  // The joint intervals from the whole curvature matrix.
  std::vector<double> rss_down(dimensions);
  std::vector<double> rss_up(dimensions);
  for (std::size_t p = 0; p < dimensions; ++p) {
    rss_down[p] = rss(moved_rmse[2 * p]);
    rss_up[p] = rss(moved_rmse[2 * p + 1]);
  }
  std::vector<double> rss_pairs;
  for (std::size_t k = 2 * dimensions; k < moves.size(); ++k) {
    rss_pairs.push_back(rss(moved_rmse[k]));
  }
  const detail::JointIntervals joint =
      detail::joint_intervals(detail::curvature_matrix(rss_down, rss_up, rss_pairs, sign,
                                                       rss(result.rmse), kSensitivityStep),
                              best_unit, threshold);
  for (std::size_t p = 0; p < dimensions; ++p) {
    ParameterSensitivity& s = out[p];
    s.joint_interval_low = s.joint_interval_high = nan;
    if (joint.intervals.empty()) continue;
    s.joint_interval_low = from_unit(parameters[p], std::max(0.0, joint.intervals[p].first));
    s.joint_interval_high = from_unit(parameters[p], std::min(1.0, joint.intervals[p].second));
  }
  correlation = joint.correlation;
  return out;
}

// One side of parameter p's profile (ParameterSensitivity): steps of kSensitivityStep
// towards the box's edge, the other coordinates re-fitted at each, continued from the step
// before (they follow the valley), until the rise over rss_best passes the threshold. A step
// that overshoots it by far (or that the twin refused) is halved and tried again, down to
// kMinProfileStep, so a well-determined parameter is traced where it bends, not across.
// The bound is interpolated linearly in sqrt(rise) between the last two steps: exact for a
// parabola about the calibrated point, which a linear rise is not.
constexpr double kMinProfileStep = kSensitivityStep / 64.0;
constexpr double kOvershootRise = 16.0;  // in thresholds: the bound in the step's first quarter

struct ProfileSide {
  std::vector<std::pair<double, double>> points;  // (u, re-fitted RMS; NaN: refused), any order
  double bound_u = std::numeric_limits<double>::quiet_NaN();
  bool open = false;  // the edge reached with the rise under the threshold
  int evaluations = 0;
};

ProfileSide trace_profile_side(const Evaluator& evaluator, std::size_t p, double direction,
                               const std::vector<double>& best_unit, double rmse_best,
                               double samples, double threshold, int fit_evaluations) {
  ProfileSide side;
  std::vector<double> others_before;
  for (std::size_t q = 0; q < best_unit.size(); ++q) {
    if (q != p) others_before.push_back(best_unit[q]);
  }
  const double edge = direction > 0.0 ? 1.0 : 0.0;
  const double rss_best = samples * rmse_best * rmse_best;
  double u_before = best_unit[p];
  double root_rise_before = 0.0;
  double step = kSensitivityStep;
  // Ten steps cross the box; each of the six halvings adds a few.
  for (int attempt = 0; attempt < 64; ++attempt) {
    if (std::abs(u_before - edge) < 1e-9) {
      side.bound_u = edge;
      side.open = true;
      break;
    }
    double u = u_before + direction * step;
    if (direction * (u - edge) > -1e-9) u = edge;  // the last step lands on the edge
    std::vector<double> others = others_before;
    const detail::UnitBoxObjective at_step = [&](const std::vector<double>& rest) {
      ++side.evaluations;
      std::vector<double> point;
      for (std::size_t q = 0, r = 0; q < best_unit.size(); ++q) {
        point.push_back(q == p ? u : rest[r++]);
      }
      return evaluator.rmse(point);
    };
    double rmse = detail::guarded_value(at_step, others, "calibrate: profile");
    if (!others.empty()) {
      rmse = detail::minimise_in_unit_box(at_step, others, rmse, 0.5 * kSensitivityStep,
                                          fit_evaluations, "calibrate: profile");
    }
    const bool refused = !(rmse < 1e300);
    side.points.emplace_back(u, refused ? std::numeric_limits<double>::quiet_NaN() : rmse);
    const double rise = refused ? 0.0 : samples * rmse * rmse - rss_best;
    const bool closer = step > kMinProfileStep * 1.5;
    if (refused || rise > threshold) {
      if (closer && (refused || rise > kOvershootRise * threshold)) {
        step *= 0.5;
        continue;
      }
      if (refused) {  // the model does not run past here: the region ends where it last ran
        side.bound_u = u_before;
        break;
      }
      const double root_rise = std::sqrt(rise);
      side.bound_u = u_before + (u - u_before) * (std::sqrt(threshold) - root_rise_before) /
                                    (root_rise - root_rise_before);
      break;
    }
    u_before = u;
    root_rise_before = std::sqrt(std::max(0.0, rise));
    others_before = others;
  }
  if (std::isnan(side.bound_u) && !side.open) {
    spdlog::warn(
        "calibrate: profile of parameter {} ({} side) not ended after 64 steps at {:.4g} "
        "of its box: no bound reported that way",
        p + 1, direction > 0.0 ? "upper" : "lower", u_before);
  }
  return side;
}

// Every parameter's profile, both sides at once on the cores; fills the profile fields.
int trace_profiles(const Evaluator& evaluator, const std::vector<CalibratedParameter>& parameters,
                   const std::vector<double>& best_unit, const Calibration& result,
                   int fit_evaluations, int threads, std::vector<ParameterSensitivity>& out) {
  const std::size_t dimensions = parameters.size();
  const double threshold = likelihood_threshold(result, dimensions);
  const auto samples = static_cast<double>(result.samples);
  std::vector<ProfileSide> sides(2 * dimensions);
  model_tests::parallel_for(
      sides.size(), std::max(1, threads),
      [&](std::size_t k) {
        sides[k] = trace_profile_side(evaluator, k / 2, k % 2 == 0 ? -1.0 : 1.0, best_unit,
                                      result.rmse, samples, threshold, fit_evaluations);
      },
      [&](std::size_t done, std::size_t total) {
        spdlog::info("calibrate: profile {} of {} traced", done, total);
      });
  int evaluations = 0;
  for (std::size_t p = 0; p < dimensions; ++p) {
    const ProfileSide& down = sides[2 * p];
    const ProfileSide& up = sides[2 * p + 1];
    ParameterSensitivity& s = out[p];
    const auto value = [&](double u) {
      return std::isnan(u) ? u : from_unit(parameters[p], std::clamp(u, 0.0, 1.0));
    };
    s.profile_interval_low = value(down.bound_u);
    s.profile_interval_high = value(up.bound_u);
    s.profile_low_open = down.open;
    s.profile_high_open = up.open;
    std::vector<std::pair<double, double>> points = down.points;
    points.insert(points.end(), up.points.begin(), up.points.end());
    points.emplace_back(best_unit[p], result.rmse);
    std::sort(points.begin(), points.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    s.profile_values.clear();
    s.profile_rmse.clear();
    for (const auto& [u, rmse] : points) {
      s.profile_values.push_back(value(u));
      s.profile_rmse.push_back(rmse);
    }
    evaluations += down.evaluations + up.evaluations;
  }
  return evaluations;
}

}  // namespace

namespace {

// a of rss(u) = rss_best + a (u - u0)^2 along one axis: the moves' second difference, or one
// move's rise over step^2 where the other is missing (NaN); NaN without either move.
double axis_curvature(double rss_down, double rss_best, double rss_up, double step) {
  if (std::isfinite(rss_down) && std::isfinite(rss_up)) {
    return (rss_down - 2.0 * rss_best + rss_up) / (2.0 * step * step);
  }
  if (std::isfinite(rss_down) || std::isfinite(rss_up)) {
    return ((std::isfinite(rss_down) ? rss_down : rss_up) - rss_best) / (step * step);
  }
  return std::numeric_limits<double>::quiet_NaN();
}

}  // namespace

std::pair<double, double> detail::quadratic_interval(double rss_down, double rss_best,
                                                     double rss_up, double u_best, double step,
                                                     double threshold) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!std::isfinite(rss_best) || !(step > 0.0) || !(threshold > 0.0)) return {nan, nan};
  const double curvature = axis_curvature(rss_down, rss_best, rss_up, step);
  if (!(curvature > 0.0)) return {nan, nan};
  const double half_width = std::sqrt(threshold / curvature);
  return {u_best - half_width, u_best + half_width};
}

std::vector<std::vector<double>> detail::curvature_matrix(const std::vector<double>& rss_down,
                                                          const std::vector<double>& rss_up,
                                                          const std::vector<double>& rss_pairs,
                                                          const std::vector<int>& sign,
                                                          double rss_best, double step) {
  const std::size_t dimensions = rss_down.size();
  if (rss_up.size() != dimensions || sign.size() != dimensions ||
      rss_pairs.size() != dimensions * (dimensions - 1) / 2 || !std::isfinite(rss_best) ||
      !(step > 0.0)) {
    return {};
  }
  std::vector<std::vector<double>> a(dimensions, std::vector<double>(dimensions, 0.0));
  // rss of parameter p moved alone the way the pair moves go
  std::vector<double> rss_signed(dimensions);
  for (std::size_t p = 0; p < dimensions; ++p) {
    const double down = rss_down[p];
    const double up = rss_up[p];
    a[p][p] = axis_curvature(down, rss_best, up, step);
    if (std::isnan(a[p][p])) return {};
    rss_signed[p] = sign[p] > 0 ? up : down;
    if (!std::isfinite(rss_signed[p])) return {};
  }
  // rss(sp h, sq h) - rss(sp h) - rss(sq h) + rss_best = 2 A_pq sp sq h^2
  std::size_t k = 0;
  for (std::size_t p = 0; p < dimensions; ++p) {
    for (std::size_t q = p + 1; q < dimensions; ++q, ++k) {
      if (!std::isfinite(rss_pairs[k])) return {};
      const double mixed = rss_pairs[k] - rss_signed[p] - rss_signed[q] + rss_best;
      a[p][q] = a[q][p] = mixed * sign[p] * sign[q] / (2.0 * step * step);
    }
  }
  return a;
}

detail::JointIntervals detail::joint_intervals(const std::vector<std::vector<double>>& curvature,
                                               const std::vector<double>& u_best,
                                               double threshold) {
  const std::size_t dimensions = curvature.size();
  if (dimensions == 0 || u_best.size() != dimensions || !(threshold > 0.0)) return {};
  Eigen::MatrixXd a(dimensions, dimensions);
  for (std::size_t p = 0; p < dimensions; ++p) {
    if (curvature[p].size() != dimensions) return {};
    for (std::size_t q = 0; q < dimensions; ++q) {
      a(static_cast<Eigen::Index>(p), static_cast<Eigen::Index>(q)) = curvature[p][q];
    }
  }
  if (!a.allFinite()) return {};
  const Eigen::LLT<Eigen::MatrixXd> cholesky(a);
  if (cholesky.info() != Eigen::Success) return {};
  const Eigen::MatrixXd inverse = cholesky.solve(Eigen::MatrixXd::Identity(a.rows(), a.cols()));
  // Positive definite by rounding only (a trade-off the moves cannot resolve): no interval.
  if (!inverse.allFinite() || (inverse.diagonal().array() <= 0.0).any()) return {};
  JointIntervals out;
  out.correlation.assign(dimensions, std::vector<double>(dimensions, 0.0));
  for (std::size_t p = 0; p < dimensions; ++p) {
    const auto pi = static_cast<Eigen::Index>(p);
    const double half_width = std::sqrt(threshold * inverse(pi, pi));
    out.intervals.emplace_back(u_best[p] - half_width, u_best[p] + half_width);
    for (std::size_t q = 0; q < dimensions; ++q) {
      const auto qi = static_cast<Eigen::Index>(q);
      out.correlation[p][q] = inverse(pi, qi) / std::sqrt(inverse(pi, pi) * inverse(qi, qi));
    }
  }
  return out;
}

Calibration calibrate(const Dataset& dataset, const model_tests::CommonParams& base,
                      const std::vector<CalibratedParameter>& parameters,
                      const CalibrationOptions& options) {
  if (parameters.empty()) throw std::invalid_argument("calibrate: no parameter to calibrate");
  if (options.profile_fit_evaluations < 0) {
    throw std::invalid_argument("calibrate: profile_fit_evaluations must not be negative");
  }
  Calibration result;
  result.channel = std::string(detail::judged_channel(dataset.experiment));
  result.parameters = parameters;
  const auto noise = dataset.noise_si.find(result.channel);
  result.noise_si = noise == dataset.noise_si.end() ? 0.0 : noise->second;
  model_tests::CommonParams model = base;
  if (model.base_spec.materials.empty()) model.base_spec = dem::appendix_b_model_spec();
  for (const CalibratedParameter& p : parameters) {
    dem::ModelSpec probe = model.base_spec;  // resolve() throws for an address not in it
    result.base_values.push_back(
        resolve(probe, p.address).front()->at(split(p.address, '.').back()));
  }
  const std::vector<std::vector<double>> unit_points =
      options.design == DesignKind::kFullFactorial
          ? full_factorial_design(parameters.size(), options.factorial_levels)
          : hammersley_design(parameters.size(), options.hammersley_points);

  Evaluator evaluator{&dataset, &model, &parameters, {}};
  for (std::size_t k = 0; k < dataset.trials.size(); ++k) evaluator.trials.push_back(k);
  {
    const detail::Residuals r = detail::residuals(dataset, model, evaluator.trials);
    result.base_rmse = std::sqrt(r.rss / static_cast<double>(r.samples));
    result.samples = r.samples;
  }
  spdlog::info("calibrate: base model RMS {:.4g} (SI); {} design points of {} parameters",
               result.base_rmse, unit_points.size(), parameters.size());

  // The design in parallel: each point runs its own twins, nothing shared but the inputs.
  result.design.resize(unit_points.size());
  model_tests::parallel_for(
      unit_points.size(), std::max(1, options.threads),
      [&](std::size_t index) {
        DesignRun& run = result.design[index];
        for (std::size_t p = 0; p < parameters.size(); ++p) {
          run.values.push_back(from_unit(parameters[p], unit_points[index][p]));
        }
        try {
          run.rmse = evaluator.rmse(unit_points[index]);
          if (!std::isfinite(run.rmse)) run.failure = "the twin's answer is not finite";
        } catch (const std::exception& error) {
          run.failure = error.what();
        }
      },
      [](std::size_t done, std::size_t total) {
        if (done % 8 == 0 || done == total) {
          spdlog::info("calibrate: design point {} of {}", done, total);
        }
      });
  result.evaluations = static_cast<int>(unit_points.size()) + 1;

  std::optional<std::size_t> best;
  for (std::size_t k = 0; k < result.design.size(); ++k) {
    if (!result.design[k].failure.empty()) continue;
    if (!best || result.design[k].rmse < result.design[*best].rmse) best = k;
  }
  if (!best) {
    throw std::runtime_error("calibrate: the twin ran no design point; the first failed with: " +
                             result.design.front().failure);
  }
  std::vector<double> x = unit_points[*best];
  double best_rmse = result.design[*best].rmse;

  if (options.max_local_evaluations > 0) {
    const auto dimensions = static_cast<unsigned>(parameters.size());
    int evaluations = 0;
    // A step of a design cell's half: the design has located the basin, not the minimum.
    const double cell = 1.0 / std::pow(static_cast<double>(unit_points.size()),
                                       1.0 / static_cast<double>(dimensions));
    best_rmse = detail::minimise_in_unit_box(
        [&](const std::vector<double>& point) {
          ++evaluations;
          return evaluator.rmse(point);
        },
        x, best_rmse, std::clamp(0.5 * cell, 0.01, 0.25), options.max_local_evaluations,
        "calibrate");
    result.evaluations += evaluations;
  }
  for (std::size_t p = 0; p < parameters.size(); ++p) {
    result.best.push_back(from_unit(parameters[p], x[p]));
  }
  result.rmse = best_rmse;
  // Factorial designs slice by their levels; a Hammersley set is sliced in quarters.
  const bool factorial = options.design == DesignKind::kFullFactorial;
  const int slices = factorial ? std::max(1, options.factorial_levels) : 4;
  result.sensitivity = sensitivities(evaluator, parameters, x, result, unit_points, slices,
                                     factorial, options.threads, result.correlation);
  result.evaluations +=
      static_cast<int>(2 * parameters.size() + parameters.size() * (parameters.size() - 1) / 2);
  if (options.profile_fit_evaluations > 0) {
    result.evaluations +=
        trace_profiles(evaluator, parameters, x, result, options.profile_fit_evaluations,
                       options.threads, result.sensitivity);
  }
  spdlog::info("calibrate: RMS {:.4g} -> {:.4g} (SI) in {} twin evaluations", result.base_rmse,
               result.rmse, result.evaluations);
  return result;
}

std::string calibration_json(const Calibration& calibration) {
  nlohmann::json out;
  out["channel"] = calibration.channel;
  out["base_rmse_si"] = calibration.base_rmse;
  out["rmse_si"] = calibration.rmse;
  out["noise_si"] = calibration.noise_si;
  out["evaluations"] = calibration.evaluations;
  out["samples"] = calibration.samples;
  for (std::size_t p = 0; p < calibration.parameters.size(); ++p) {
    const CalibratedParameter& parameter = calibration.parameters[p];
    out["parameters"].push_back({{"address", parameter.address},
                                 {"min", parameter.min},
                                 {"max", parameter.max},
                                 {"log", parameter.log},
                                 {"base", calibration.base_values[p]},
                                 {"calibrated", calibration.best[p]}});
    if (p < calibration.sensitivity.size()) {
      const ParameterSensitivity& s = calibration.sensitivity[p];
      // NaN (a move not made, a point refused) is written as null.
      const auto number = [](double value) {
        return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
      };
      nlohmann::json main_effect = nlohmann::json::array();
      for (const double rmse : s.main_effect_rmse) main_effect.push_back(number(rmse));
      nlohmann::json profile_rmse = nlohmann::json::array();
      for (const double rmse : s.profile_rmse) profile_rmse.push_back(number(rmse));
      out["parameters"].back()["sensitivity"] = {
          {"value_down", s.value_down},
          {"rmse_down_si", number(s.rmse_down)},
          {"value_up", s.value_up},
          {"rmse_up_si", number(s.rmse_up)},
          {"determined", s.determined},
          {"main_effect_rmse_si", main_effect},
          {"interval_95", {number(s.interval_low), number(s.interval_high)}},
          {"joint_interval_95", {number(s.joint_interval_low), number(s.joint_interval_high)}},
          {"profile_interval_95",
           {number(s.profile_interval_low), number(s.profile_interval_high)}},
          {"profile_open", {s.profile_low_open, s.profile_high_open}},
          {"profile_values", s.profile_values},
          {"profile_rmse_si", profile_rmse}};
    }
  }
  // empty (null) when the parameters are not determined together
  out["correlation"] = calibration.correlation.empty() ? nlohmann::json(nullptr)
                                                       : nlohmann::json(calibration.correlation);
  out["design"] = nlohmann::json::array();
  for (const DesignRun& run : calibration.design) {
    nlohmann::json point{{"values", run.values}};
    if (run.failure.empty()) {
      point["rmse_si"] = run.rmse;
    } else {
      point["failure"] = run.failure;
    }
    out["design"].push_back(point);
  }
  return out.dump(1);
}

namespace {

// A line through the points whose RMS is finite (a slice without runs, a refused point: none).
void add_finite_line(report::Plot& plot, std::string label, const std::vector<double>& values,
                     const std::vector<double>& rmse) {
  report::Series line;
  line.label = std::move(label);
  line.style = report::SeriesStyle::kLineAndMarkers;
  for (std::size_t k = 0; k < values.size() && k < rmse.size(); ++k) {
    if (!std::isfinite(rmse[k])) continue;
    line.x.push_back(values[k]);
    line.y.push_back(rmse[k]);
  }
  if (!line.x.empty()) plot.series.push_back(std::move(line));
}

}  // namespace

std::vector<std::filesystem::path> write_sensitivity_plots(const Calibration& calibration,
                                                           const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> written;
  for (std::size_t p = 0; p < calibration.parameters.size() && p < calibration.sensitivity.size();
       ++p) {
    const CalibratedParameter& parameter = calibration.parameters[p];
    const ParameterSensitivity& s = calibration.sensitivity[p];
    report::Plot plot;
    plot.title = parameter.address +
                 (s.determined ? ": determined by the data" : ": not determined by the data");
    plot.x.label = parameter.address;
    plot.x.log = parameter.log;
    plot.y.label = "RMS of " + calibration.channel + " (SI)";
    report::Series design;
    design.label = "design points";
    design.style = report::SeriesStyle::kScatter;
    for (const DesignRun& run : calibration.design) {
      if (!run.failure.empty()) continue;
      design.x.push_back(run.values[p]);
      design.y.push_back(run.rmse);
    }
    if (!design.x.empty()) plot.series.push_back(std::move(design));
    add_finite_line(plot, "main effect", s.main_effect_values, s.main_effect_rmse);
    add_finite_line(plot, "moved 1/10 of box", {s.value_down, calibration.best[p], s.value_up},
                    {s.rmse_down, calibration.rmse, s.rmse_up});
    add_finite_line(plot, "profile (others re-fitted)", s.profile_values, s.profile_rmse);
    plot.references.push_back(
        {.vertical = true, .value = calibration.best[p], .label = "calibrated"});
    for (const double bound : {s.interval_low, s.interval_high}) {
      if (std::isfinite(bound)) {
        plot.references.push_back({.vertical = true, .value = bound, .label = "95 % interval"});
      }
    }
    for (const double bound : {s.joint_interval_low, s.joint_interval_high}) {
      if (std::isfinite(bound)) {
        plot.references.push_back({.vertical = true, .value = bound, .label = "95 % joint"});
      }
    }
    for (const auto& [bound, open] : {std::pair{s.profile_interval_low, s.profile_low_open},
                                      std::pair{s.profile_interval_high, s.profile_high_open}}) {
      if (std::isfinite(bound) && !open) {
        plot.references.push_back({.vertical = true, .value = bound, .label = "95 % profile"});
      }
    }
    if (calibration.noise_si > 0.0) {
      plot.references.push_back({false, calibration.noise_si, "noise"});
    }
    const std::filesystem::path file = folder / ("sensitivity_" + std::to_string(p + 1) + ".svg");
    report::write_svg(plot, file);
    written.push_back(file);
  }
  return written;
}

}  // namespace fl::workbench
