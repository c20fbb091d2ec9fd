#include "fl/workbench/compare.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <variant>

#include "displacement_path.hpp"
#include "text.hpp"

namespace fl::workbench {
namespace {

// Rows whose displacement rate is below this share of the trial's fastest are "hold": a
// test machine holding position still jitters by a few encoder counts.
constexpr double kHoldRateShare = 0.05;
// The displacement noise's share of the rate a compress row's phase is read from, at most:
// with the hold threshold at 5 % of the fastest rate, 1 % of the mean rate (never above the
// fastest) keeps noise five sigmas from flipping a label.
constexpr double kPhaseRateNoiseShare = 0.01;

// A drop's phases from its condition, not from the noisy track: released at rest, the fillet's
// lowest point meets the plate after sqrt(2 h / g); the landing (impact, rebound, the flapping
// of the ends) is the next 100 ms, then it settles.
constexpr double kGravityMps2 = 9.81;  // as config/dem.yaml
constexpr double kLandingS = 0.1;

std::vector<std::string> drop_phases(const Trial& trial) {
  const std::size_t rows = trial.data.rows();
  const auto height = trial.conditions.find("drop_height");
  if (height == trial.conditions.end()) return std::vector<std::string>(rows, "all");
  const double impact_s = std::sqrt(2.0 * std::get<double>(height->second) / kGravityMps2);
  const std::vector<double>& t = trial.data.at("time").values_si;
  std::vector<std::string> phase(rows);
  for (std::size_t k = 0; k < rows; ++k) {
    if (t[k] < impact_s) {
      phase[k] = "fall";
    } else {
      phase[k] = t[k] < impact_s + kLandingS ? "landing" : "settling";
    }
  }
  return phase;
}

struct Accumulator {
  std::size_t samples = 0;
  double sum_sq = 0.0;
  double sum = 0.0;
  double sum_sq_measured = 0.0;
  double max_abs = 0.0;
  double max_abs_time = 0.0;
  double sum_sq_spread = 0.0;
  // Sum of the squared residuals in the row's own sigma (noise and the model's spread at the
  // row); only when the noise is known.
  double sum_sq_standardised = 0.0;

  void add(double measured, double model, double spread, double noise, double time) {
    const double residual = model - measured;
    ++samples;
    sum_sq += residual * residual;
    sum_sq_spread += spread * spread;
    const double variance = noise * noise + spread * spread;
    if (variance > 0.0) sum_sq_standardised += residual * residual / variance;
    sum += residual;
    sum_sq_measured += measured * measured;
    if (std::abs(residual) >= max_abs) {
      max_abs = std::abs(residual);
      max_abs_time = time;
    }
  }
};

ErrorCell make_cell(const std::string& channel, std::string group, std::string trial,
                    std::string phase, const Accumulator& a, double noise_si) {
  ErrorCell cell;
  cell.channel = channel;
  cell.group = std::move(group);
  cell.trial = std::move(trial);
  cell.phase = std::move(phase);
  cell.samples = a.samples;
  const double n = static_cast<double>(std::max<std::size_t>(a.samples, 1));
  cell.rmse_si = std::sqrt(a.sum_sq / n);
  cell.bias_si = a.sum / n;
  cell.max_abs_si = a.max_abs;
  cell.max_abs_time_s = a.max_abs_time;
  cell.noise_si = noise_si;
  cell.model_spread_si = std::sqrt(a.sum_sq_spread / n);
  if (noise_si > 0.0) {
    cell.score = std::sqrt(a.sum_sq_standardised / n);
  } else {
    const double scale = std::sqrt(a.sum_sq_measured / n);
    cell.score = scale > 0.0 ? cell.rmse_si / scale : cell.rmse_si;
  }
  return cell;
}

// A condition's value as a group's name: a label or flag as written, a number in its SI unit
// (rate=0.002 m/s), so trials at the same rate or tilt rate share a cell.
std::string condition_text(ExperimentType type, const std::string& name,
                           const ConditionValue& value) {
  if (const auto* label = std::get_if<std::string>(&value)) return *label;
  if (const auto* flag = std::get_if<bool>(&value)) return *flag ? "true" : "false";
  std::string unit;
  for (const ConditionRule& rule : schema_of(type).conditions) {
    if (rule.name == name) unit = std::string(si_unit(rule.quantity));
  }
  const std::string number = detail::significant(std::get<double>(value), 4);
  return unit.empty() || unit == "1" ? number : number + " " + unit;
}

// Line tracks on one belt: "takt" where the logged belt speed changes at the row's time (the
// belt accelerating or braking, where a fillet slips), "steady belt" elsewhere. Tracks on the
// line, or without a log, have no phases: which belt a fillet is on is the line's geometry.
std::vector<std::string> belt_phases(const Trial& trial) {
  const std::size_t rows = trial.data.rows();
  std::vector<std::string> phase(rows, "all");
  if (runs_on_line(trial.conditions) || !trial.commands || trial.commands->channels.size() < 2) {
    return phase;
  }
  const std::vector<double>& log_t = trial.commands->at("time").values_si;
  const Channel* speed = belt_log_speed(*trial.commands);
  if (speed == nullptr || log_t.size() < 2) return phase;
  // A belt changing speed by under a hundredth of g is steady: a drive's ripple, not a takt.
  constexpr double kSteadyMps2 = 0.1;
  const std::vector<double>& t = trial.data.at("time").values_si;
  for (std::size_t k = 0; k < rows; ++k) {
    const auto after = std::upper_bound(log_t.begin(), log_t.end(), t[k]);
    bool changing = false;
    if (after != log_t.begin() && after != log_t.end()) {
      const auto j = static_cast<std::size_t>(after - log_t.begin());
      const double slope =
          (speed->values_si[j] - speed->values_si[j - 1]) / (log_t[j] - log_t[j - 1]);
      changing = std::abs(slope) > kSteadyMps2;
    }
    phase[k] = changing ? "takt" : "steady belt";
  }
  return phase;
}

}  // namespace

std::vector<std::string_view> response_channels(ExperimentType type) {
  switch (type) {
    case ExperimentType::kSlide:
      return {"onset_angle"};
    case ExperimentType::kBend:
      return {"bend_angle"};
    case ExperimentType::kSettle:
    case ExperimentType::kDrop:
      return {"height"};
    case ExperimentType::kCompress:
      return {"force"};
    case ExperimentType::kLineTracks:
      return {"x", "y", "angle"};
    case ExperimentType::kBulkFlow:
      return {"outflow"};
  }
  return {};
}

std::vector<std::string> phases_of(ExperimentType type, const Trial& trial,
                                   std::optional<double> stated_displacement_noise_m) {
  const std::size_t rows = trial.data.rows();
  if (type == ExperimentType::kDrop) return drop_phases(trial);
  if (type == ExperimentType::kLineTracks) return belt_phases(trial);
  std::vector<std::string> phase(rows, "all");
  if (type != ExperimentType::kCompress || rows < 2) return phase;
  const std::vector<double>& t = trial.data.at("time").values_si;
  const std::vector<double>& d = trial.data.at("displacement").values_si;
  // The rate over the neighbouring rows, or over a window wide enough to bring the trial's own
  // displacement noise under kPhaseRateNoiseShare of its loading rate: from neighbouring rows, a
  // fast logger's noise made loading rows flicker between loading, unloading and hold, while a
  // window of fixed length blurred a short ramp before a long hold. The rate noise of a window
  // of +-h is sqrt(2) sigma / (2 h). A stated noise wins over the rows' own estimate, which
  // a filtering logger's correlated noise leaves too low (the window then too short).
  const double half_window_s =
      detail::rate_window_half_s(t, d, kPhaseRateNoiseShare, stated_displacement_noise_m);
  std::vector<double> rate(rows, 0.0);
  double fastest = 0.0;
  std::size_t first = 0;  // the first row in the window, then the last (times increase)
  std::size_t last = 0;
  for (std::size_t k = 0; k < rows; ++k) {
    while (first < k && t[first] < t[k] - half_window_s) ++first;
    while (last + 1 < rows && t[last + 1] <= t[k] + half_window_s) ++last;
    const std::size_t a = k == 0 ? 0 : std::min(first, k - 1);
    const std::size_t b = std::max(last, std::min(k + 1, rows - 1));
    rate[k] = (d[b] - d[a]) / (t[b] - t[a]);
    fastest = std::max(fastest, std::abs(rate[k]));
  }
  for (std::size_t k = 0; k < rows; ++k) {
    if (std::abs(rate[k]) <= kHoldRateShare * fastest) {
      phase[k] = "hold";
    } else {
      phase[k] = rate[k] > 0.0 ? "loading" : "unloading";
    }
  }
  return phase;
}

const ErrorCell& CompareReport::overall(std::string_view channel) const {
  for (const ErrorCell& cell : cells) {
    if (cell.channel == channel && cell.group == "all") return cell;
  }
  throw std::out_of_range("no overall error for channel '" + std::string(channel) + "'");
}

CompareReport compare(const Dataset& dataset, TrialModel& model) {
  CompareReport report;
  report.dataset = dataset.name;
  report.experiment = dataset.experiment;
  report.model = model.describe();
  const std::vector<std::string_view> channels = response_channels(dataset.experiment);

  // Accumulators per (channel, group key); the key orders the cells before ranking.
  struct Group {
    std::string group, trial, phase;
    Accumulator acc;
  };
  std::map<std::string, Group> groups;
  // The dataset's 1-sigma noise of a channel; 0 when not given.
  const auto noise_of = [&dataset](std::string_view channel) {
    const auto noise = dataset.noise_si.find(channel);
    return noise == dataset.noise_si.end() ? 0.0 : noise->second;
  };
  const auto add = [&](std::string_view channel, const std::string& key, const std::string& trial,
                       const std::string& phase, double measured, double model_value, double spread,
                       double noise, double time) {
    Group& g = groups[std::string(channel) + "\n" + key];
    g.group = key;
    g.trial = trial;
    g.phase = phase;
    g.acc.add(measured, model_value, spread, noise, time);
  };
  std::set<std::string> varying_conditions;
  for (const Trial& trial : dataset.trials) {
    for (const auto& [name, value] : trial.conditions) {
      const std::string text = condition_text(dataset.experiment, name, value);
      for (const Trial& other : dataset.trials) {
        const auto found = other.conditions.find(name);
        if (found == other.conditions.end() ||
            condition_text(dataset.experiment, name, found->second) != text) {
          varying_conditions.insert(name);
        }
      }
    }
  }

  // A number's groups are kept where two trials or more share a value (one trial's own rate
  // adds nothing to that trial's cell); a label names the condition even for one trial.
  std::erase_if(varying_conditions, [&dataset](const std::string& name) {
    std::map<std::string, int> trials_with;
    bool number = false;
    for (const Trial& trial : dataset.trials) {
      const auto found = trial.conditions.find(name);
      if (found == trial.conditions.end()) continue;
      number = number || std::holds_alternative<double>(found->second);
      ++trials_with[condition_text(dataset.experiment, name, found->second)];
    }
    return number && std::none_of(trials_with.begin(), trials_with.end(),
                                  [](const auto& entry) { return entry.second > 1; });
  });

  for (std::size_t index = 0; index < dataset.trials.size(); ++index) {
    const Trial& trial = dataset.trials[index];
    spdlog::info("compare: trial {} of {} ({})", index + 1, dataset.trials.size(), trial.id);
    Table modelled;
    try {
      modelled = model.run(dataset, trial);
    } catch (const std::exception& error) {
      report.failed_trials.push_back(trial.id + ": " + error.what());
      spdlog::warn("compare: trial {} not run: {}", trial.id, error.what());
      continue;
    }
    TrialTrace trace;
    trace.trial = trial.id;
    std::optional<std::vector<std::string>> known = model.row_phases(dataset, trial);
    trace.phase =
        known && known->size() == trial.data.rows()
            ? std::move(*known)
            : phases_of(dataset.experiment, trial, detail::stated_displacement_noise_m(dataset));
    // Line tracks: each fillet's own cell, so that the one the model loses stands out.
    const Channel* fillet = trial.data.find("fillet");
    const Channel* time = trial.data.find("time");
    const Channel* opening = trial.data.find("opening");
    if (time == nullptr) {
      trace.x_label = opening != nullptr ? "opening (" + std::string(opening->unit.symbol) + ")"
                                         : std::string("repetition");
    }
    for (std::size_t k = 0; k < trial.data.rows(); ++k) {
      if (time != nullptr) {
        trace.time_s.push_back(time->values_si[k]);
      } else if (opening != nullptr) {
        trace.time_s.push_back(opening->values_si[k] / opening->unit.to_si);
      } else {
        trace.time_s.push_back(static_cast<double>(k));
      }
    }
    bool usable = true;
    for (const std::string_view name : channels) {
      const Channel& measured = trial.data.at(name);
      const Channel* predicted = modelled.find(name);
      if (predicted == nullptr || predicted->values_si.size() != measured.values_si.size()) {
        report.failed_trials.push_back(trial.id + ": the model gave no '" + std::string(name) +
                                       "' at the trial's " + std::to_string(trial.data.rows()) +
                                       " rows");
        usable = false;
        break;
      }
      ChannelTrace channel{
          std::string(name), measured.unit, measured.values_si, predicted->values_si, {}};
      const Channel* spread = modelled.find(std::string(name) + "_spread");
      if (spread != nullptr && spread->values_si.size() == measured.values_si.size()) {
        channel.model_spread_si = spread->values_si;
      }
      trace.channels.push_back(std::move(channel));
    }
    if (!usable) continue;
    for (const ChannelTrace& c : trace.channels) {
      const double noise = noise_of(c.channel);
      for (std::size_t k = 0; k < c.measured_si.size(); ++k) {
        const double m = c.measured_si[k];
        const double p = c.model_si[k];
        const double s = c.model_spread_si.empty() ? 0.0 : c.model_spread_si[k];
        const double t = trace.time_s[k];
        add(c.channel, "all", "", "", m, p, s, noise, t);
        add(c.channel, "trial " + trial.id, trial.id, "", m, p, s, noise, t);
        if (trace.phase[k] != "all") {
          add(c.channel, "phase " + trace.phase[k], "", trace.phase[k], m, p, s, noise, t);
          add(c.channel, "trial " + trial.id + ", " + trace.phase[k], trial.id, trace.phase[k], m,
              p, s, noise, t);
        }
        if (fillet != nullptr) {
          add(c.channel,
              "trial " + trial.id + ", fillet " + detail::significant(fillet->values_si[k], 6),
              trial.id, "", m, p, s, noise, t);
        }
        for (const std::string& name : varying_conditions) {
          const auto found = trial.conditions.find(name);
          if (found == trial.conditions.end()) continue;
          add(c.channel, name + "=" + condition_text(dataset.experiment, name, found->second), "",
              "", m, p, s, noise, t);
        }
      }
    }
    report.traces.push_back(std::move(trace));
  }
  if (report.traces.empty()) {
    std::string reasons;
    for (const std::string& failure : report.failed_trials) reasons += "\n  " + failure;
    throw std::runtime_error("compare: the model ran none of the trials of '" + dataset.name +
                             "':" + reasons);
  }
  for (const auto& [key, g] : groups) {
    const std::string channel = key.substr(0, key.find('\n'));
    report.cells.push_back(make_cell(channel, g.group, g.trial, g.phase, g.acc, noise_of(channel)));
  }
  std::stable_sort(report.cells.begin(), report.cells.end(),
                   [](const ErrorCell& a, const ErrorCell& b) { return a.score > b.score; });
  return report;
}

}  // namespace fl::workbench
