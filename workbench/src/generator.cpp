#include "fl/workbench/generator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <memory>
#include <numbers>
#include <random>
#include <set>
#include <stdexcept>
#include <string_view>
#include <utility>

#include "fl/report/csv.hpp"
#include "fl/twin/dem/config.hpp"
#include "fl/workbench/twin_models.hpp"
#include "text.hpp"

namespace fl::workbench {
namespace {

struct ParameterRange {
  const char* name;
  double min;
  double max;
  bool log;  // drawn log-uniform (time constants, stiffnesses spanning decades)
};

struct EffectRange {
  const char* law;
  std::vector<ParameterRange> parameters;
};

// Physical ranges for the 7 mm block of the compress test (appendix B bonds, 1e6 N/m^3):
// a Maxwell arm from a third to twice the bond spring relaxing in 10 to 100 ms (the hold is
// 100 ms); a yield stress at 30 to 60 % of the ~170 Pa the bonds reach at the peak load.
const std::vector<EffectRange>& compress_effects() {
  static const std::vector<EffectRange> effects{
      {"bpm_viscoelastic",
       {{"relaxation_stiffness_n_per_m3", 3e5, 2e6, true}, {"relaxation_time_s", 0.01, 0.1, true}}},
      {"bpm_plastic", {{"normal_yield_strength_pa", 50.0, 100.0, false}}},
  };
  return effects;
}

// Physical ranges for the slide test's flexible fillet on steel (appendix B: coulomb mu 0.5;
// onset near 23 and 31 deg for the 144 and 172 mm variants). static_kinetic_friction: resting
// friction 40 to 80 % above the sliding one. A flexible fillet's contacts creep at mm/s while
// the plate tilts, so mu_s only acts where that creep counts as resting: the stick speed, 10
// to 50 mm/s, is part of the effect (below it the onset moves by under 1 deg, no test sees it;
// within these ranges it moves by 1 to 4 deg). wet_film: a wet plate's film takes 30 to 60 %
// of the friction load (onset 5 to 10 deg lower on wet trials). Its meniscus
// (surface_tension_n_per_m) stays 0: the onset angle cannot tell it from the lubrication
// (both only scale the friction load), so hiding both would hide what no slide test can find.
const std::vector<EffectRange>& slide_effects() {
  static const std::vector<EffectRange> effects{
      {"static_kinetic_friction",
       {{"static_friction_coefficient", 0.7, 0.9, false},
        {"stick_speed_m_per_s", 0.01, 0.05, true}}},
      {"wet_film", {{"lubrication", 0.3, 0.6, false}}},
  };
  return effects;
}

// Physical ranges for a flat drop of the 172x72x32 fillet (7 mm spheres, appendix B bonds)
// from 50 to 200 mm, tracked to 0.5 mm. A Maxwell arm of 3 to 10 times the bond spring
// (meat relaxes by 75 to 90 % of its instant stress) relaxing in 2 to 30 ms: it damps the
// flapping of the fillet's ends after the impact, the height falls 2.5 to 5 mm RMS below the
// undamped model's. Softer or slower arms change the height by less than 2 mm: no 70 % fall
// could show over a 0.5 mm noise. A yield stress of 0.8 to 2.5 kPa: the impacts load the
// bonds to a few kPa (no permanent set is left above 5 kPa), the fillet flattens and its
// height falls 3 to 7 mm RMS.
const std::vector<EffectRange>& drop_effects() {
  static const std::vector<EffectRange> effects{
      {"bpm_viscoelastic",
       {{"relaxation_stiffness_n_per_m3", 3e6, 1e7, true},
        {"relaxation_time_s", 0.002, 0.03, true}}},
      {"bpm_plastic", {{"normal_yield_strength_pa", 800.0, 2500.0, false}}},
  };
  return effects;
}

// Physical ranges for the bend test of the three variants (7 mm spheres, appendix B bonds): a
// stiffness graded with the local thickness, k (t / t_ref)^n, the base stiffness at a reference
// of 20 to 26 mm (the thin tip's) and rising from square to cubic with it (a plate's bending
// stiffness goes with t^3), so the thick rear stiffens: the mean angle falls 7 to 13 noise
// sigmas at 1 deg. Measured over a grid: with the reference at the fillet's mean thickness (30
// to 35 mm) the grading cancels on the angle for n up to 2 (under 3.5 sigmas, where no 70 %
// fall of the error is possible) and beyond it the tip curls under (over 20 sigmas). A Maxwell
// arm of the drop's ranges moves the mean angle by under 0.5 deg: not hidden here.
const std::vector<EffectRange>& bend_effects() {
  static const std::vector<EffectRange> effects{
      {"bpm_graded",
       {{"reference_thickness_m", 0.020, 0.026, false}, {"thickness_exponent", 2.0, 3.0, false}}},
  };
  return effects;
}

const std::vector<EffectRange>& effects_of(ExperimentType type) {
  // A belt's takt acceleration loads the same fillet-belt contact as a tilted plate: the slide's
  // contact effects and ranges. The sliding 0.5 lets a fillet slip at a 7 m/s^2 takt (mu g =
  // 4.9 m/s^2), some 30 mm behind the belt by the time it holds again; a resting 0.7 to 0.9
  // holds it all but fully. A wet film lets it slip at 4 m/s^2 too.
  if (type == ExperimentType::kSlide || type == ExperimentType::kLineTracks) {
    return slide_effects();
  }
  if (type == ExperimentType::kDrop) return drop_effects();
  if (type == ExperimentType::kBend) return bend_effects();
  return compress_effects();
}

std::vector<std::string> names_of(const std::vector<EffectRange>& effects) {
  std::vector<std::string> names;
  names.reserve(effects.size());
  for (const EffectRange& effect : effects) names.emplace_back(effect.law);
  return names;
}

// The thesis' three fillet sizes (table 3.1), in the order the generated trials take them.
constexpr const char* kVariants[] = {"144x72x40", "172x72x32", "176x72x40"};

// Trial k of a slide dataset: the variants in turn, each dry then wet; `repetitions` rows, the
// fillet re-laid for each or laid once for all.
Trial slide_trial(int k, int repetitions, bool relaid) {
  const std::string variant = kVariants[static_cast<std::size_t>(k / 2) % 3];
  const std::string surface = k % 2 == 0 ? "dry" : "wet";
  Trial trial;
  trial.id = "s" + variant + "_" + surface;
  if (k >= 6) trial.id += "_" + std::to_string(k / 6 + 1);  // the variants come round again
  trial.conditions["variant"] = variant;
  trial.conditions["mirrored"] = false;
  trial.conditions["surface"] = surface;
  trial.conditions["placement"] = std::string(relaid ? "relaid" : "laid_once");
  trial.data.channels = {{"onset_angle", *find_unit("deg"),
                          std::vector<double>(static_cast<std::size_t>(repetitions), 0.0)}};
  trial.data.lines.resize(static_cast<std::size_t>(repetitions));
  return trial;
}

// Trial k of a drop dataset: released at rest from 50 mm doubling with k; the height tracked
// every 5 ms from the release to 0.4 s after the impact (the free fall of the lowest point).
Trial drop_trial(int k) {
  constexpr double kRowS = 0.005;
  constexpr double kAfterImpactS = 0.4;
  constexpr double kGravityMps2 = 9.81;
  const double drop_height_m = 0.05 * std::pow(2.0, k);
  const double end_s = std::sqrt(2.0 * drop_height_m / kGravityMps2) + kAfterImpactS;
  Trial trial;
  trial.id = "h" + std::to_string(std::lround(drop_height_m * 1e3)) + "mm";
  std::vector<double> t;
  for (int row = 0; row * kRowS <= end_s; ++row) t.push_back(row * kRowS);
  trial.data.channels = {{"time", *find_unit("s"), t},
                         {"height", *find_unit("mm"), std::vector<double>(t.size(), 0.0)}};
  trial.data.lines.resize(t.size());
  trial.conditions["drop_height"] = drop_height_m;
  trial.conditions["variant"] = std::string("172x72x32");
  return trial;
}

// Trial k of a bend dataset: the variants in turn over the table edge by 60, 80 and 100 mm
// (about 40, 45 and 55 % of their lengths: the thesis' half), 10 mm more each time round;
// `repetitions` rows.
Trial bend_trial(int k, int repetitions) {
  const std::string variant = kVariants[static_cast<std::size_t>(k) % 3];
  const int overhang_mm = 60 + 20 * (k % 3) + 10 * (k / 3);
  Trial trial;
  trial.id = "b" + variant + "_" + std::to_string(overhang_mm) + "mm";
  trial.conditions["variant"] = variant;
  trial.conditions["overhang"] = overhang_mm * 1e-3;
  trial.data.channels = {{"bend_angle", *find_unit("deg"),
                          std::vector<double>(static_cast<std::size_t>(repetitions), 0.0)}};
  trial.data.lines.resize(static_cast<std::size_t>(repetitions));
  return trial;
}

// Trial k of a line-track dataset: fillets on a belt that starts, runs at 1.5 m/s and stops at a
// takt acceleration of 4 m/s^2 (trials 0, 1) or 7 m/s^2 (2, 3), each dry then wet,
// tracked at 50 frames/s for 1.2 s. The fillets lie 0.3 m apart along the belt, at random
// lateral offsets and headings; the first row of each is its true pose (filled in here), the
// others are what the twin answers.
Trial line_tracks_trial(int k, int fillets, std::mt19937_64& random) {
  constexpr double kSpeedMps = 1.5;
  constexpr double kStartS = 0.1, kStopS = 0.7, kEndS = 1.2, kFrameS = 0.02;
  const double acceleration = (k / 2) % 2 == 0 ? 4.0 : 7.0;
  const std::string surface = k % 2 == 0 ? "dry" : "wet";
  Trial trial;
  trial.id = "takt" + std::to_string(k + 1) + "_" + surface;
  trial.conditions["surface"] = surface;
  trial.conditions["variant"] = std::string("172x72x32");
  const double ramp_s = kSpeedMps / acceleration;
  Table commands;
  commands.channels = {
      {"time", *find_unit("s"), {0.0, kStartS, kStartS + ramp_s, kStopS, kStopS + ramp_s, kEndS}},
      {"belt_speed", *find_unit("m/s"), {0.0, 0.0, kSpeedMps, kSpeedMps, 0.0, 0.0}}};
  commands.lines.resize(6);
  trial.commands = commands;
  std::uniform_real_distribution<double> lateral(-0.05, 0.05);
  std::uniform_real_distribution<double> heading(-std::numbers::pi, std::numbers::pi);
  std::vector<std::array<double, 3>> first(static_cast<std::size_t>(fillets));
  for (std::size_t f = 0; f < first.size(); ++f) {
    first[f] = {0.3 * static_cast<double>(f), lateral(random), heading(random)};
  }
  std::vector<double> t, id, x, y, angle;
  for (int frame = 0; frame * kFrameS <= kEndS + 1e-9; ++frame) {
    for (std::size_t f = 0; f < first.size(); ++f) {
      t.push_back(frame * kFrameS);
      id.push_back(static_cast<double>(f + 1));
      x.push_back(frame == 0 ? first[f][0] : 0.0);
      y.push_back(frame == 0 ? first[f][1] : 0.0);
      angle.push_back(frame == 0 ? first[f][2] : 0.0);
    }
  }
  trial.data =
      line_tracks_table(std::move(t), std::move(id), std::move(x), std::move(y), std::move(angle));
  return trial;
}

// Trial k of a line-track dataset taken on the line (GeneratorOptions::line_tracks_on_line):
// `fillets` fillets appear 0.6 s apart (300 mm on the 0.5 m/s centring belt) at 2900 mm, 100 mm
// into the centring belt where camera 2 sees them, within 20 mm of the centre line at headings
// within 30 degrees of either direction, and are tracked every 25 ms (the multilane cameras'
// rate) for 2.4 s: over both multilane units (3400 to 4200 mm) onto the squeeze belt. Every
// belt runs at its nominal speed; each multilane unit's two belts differ by 0.16 m/s, the faster
// side swapping from trial to trial and, over 50 ms, halfway through. Dry then wet.
Trial line_run_trial(int k, int fillets, std::mt19937_64& random, const LineConfig& line) {
  constexpr double kFirstSMm = 2900.0, kApartS = 0.6, kTrackedS = 2.4, kFrameS = 0.025;
  constexpr double kDifferentialMps = 0.16, kSwapS = 0.05;
  const std::string surface = k % 2 == 0 ? "dry" : "wet";
  Trial trial;
  trial.id = "line" + std::to_string(k + 1) + "_" + surface;
  trial.conditions["surface"] = surface;
  trial.conditions["variant"] = std::string("172x72x32");
  trial.conditions["machine"] = std::string(kMachineLine);
  const double end_s = kApartS * (fillets - 1) + kTrackedS;
  const double swap_s = 0.5 * end_s;
  const std::vector<double> times{0.0, swap_s, swap_s + kSwapS, end_s};
  Table commands;
  commands.channels.push_back({"time", *find_unit("s"), times});
  const double first_sign = (k / 2) % 2 == 0 ? 1.0 : -1.0;
  for (std::size_t d = 0; d < kDriveCount; ++d) {
    const auto id = static_cast<DriveId>(d);
    if (id == DriveId::kBulk) continue;
    // A unit's right belt runs at its left one's section speed (line_config registers the
    // section on the left drive).
    const bool right = id == DriveId::kMultilane1Right || id == DriveId::kMultilane2Right;
    const bool left = id == DriveId::kMultilane1Left || id == DriveId::kMultilane2Left;
    // Rounded to the micrometre per second: the config's float, not its binary tail.
    const double nominal =
        std::round(static_cast<double>(line.sections[right ? d - 1 : d].nominal_speed_mps) * 1e6) /
        1e6;
    std::vector<double> speed(times.size(), nominal);
    if (left || right) {
      const double side = left ? 0.5 : -0.5;
      for (std::size_t row = 0; row < times.size(); ++row) {
        const double sign = row < 2 ? first_sign : -first_sign;
        speed[row] = std::round((nominal + side * sign * kDifferentialMps) * 1e6) / 1e6;
      }
    }
    commands.channels.push_back({std::string(kDriveNames[d]), *find_unit("m/s"), speed});
  }
  commands.lines.resize(times.size());
  trial.commands = commands;
  std::uniform_real_distribution<double> lateral(-0.02, 0.02);
  std::uniform_real_distribution<double> turn(-std::numbers::pi / 6.0, std::numbers::pi / 6.0);
  std::vector<double> t, id, x, y, angle;
  for (int f = 0; f < fillets; ++f) {
    const double start_s = kApartS * f;
    const double heading =
        turn(random) + (std::bernoulli_distribution(0.5)(random) ? std::numbers::pi : 0.0);
    const double offset = lateral(random);
    for (int frame = 0; frame * kFrameS <= kTrackedS + 1e-9; ++frame) {
      const bool first = frame == 0;
      t.push_back(start_s + frame * kFrameS);
      id.push_back(static_cast<double>(f + 1));
      x.push_back(first ? kFirstSMm * 1e-3 : 0.0);
      y.push_back(first ? offset : 0.0);
      angle.push_back(first ? heading : 0.0);
    }
  }
  trial.data =
      line_tracks_table(std::move(t), std::move(id), std::move(x), std::move(y), std::move(angle));
  return trial;
}

// Load to the peak travel over `ramp_s`, hold, unload over `ramp_s`; a row every `row_s`.
Trial compress_trial(const std::string& id, double ramp_s, double row_s) {
  constexpr double kPeakTravelM = 0.5e-3;  // 1.8 % of the 28 mm block: linear bonds
  constexpr double kHoldS = 0.1;
  Trial trial;
  trial.id = id;
  std::vector<double> t, d;
  const double end_s = 2.0 * ramp_s + kHoldS;
  const auto rows = static_cast<int>(std::lround(end_s / row_s));
  for (int k = 0; k <= rows; ++k) {
    const double time = row_s * k;
    double travel = kPeakTravelM;
    if (time < ramp_s) travel = kPeakTravelM * time / ramp_s;
    if (time > ramp_s + kHoldS) travel = kPeakTravelM * std::max(0.0, end_s - time) / ramp_s;
    t.push_back(time);
    d.push_back(travel);
  }
  trial.data.channels = {{"time", *find_unit("s"), t},
                         {"displacement", *find_unit("mm"), d},
                         {"force", *find_unit("N"), std::vector<double>(t.size(), 0.0)}};
  trial.data.lines.resize(t.size());
  trial.conditions["rate"] = kPeakTravelM / ramp_s;
  trial.conditions["sample_side"] = 0.07;     // 5 spheres of 14 mm
  trial.conditions["sample_height"] = 0.056;  // 4 layers
  return trial;
}

}  // namespace

std::vector<std::string> compress_effect_candidates() { return names_of(compress_effects()); }

std::vector<std::string> slide_effect_candidates() { return names_of(slide_effects()); }

std::vector<std::string> drop_effect_candidates() { return names_of(drop_effects()); }

std::vector<std::string> bend_effect_candidates() { return names_of(bend_effects()); }

dem::ModelSpec with_contact_effect(const dem::ModelSpec& base, const HiddenEffect& effect,
                                   const dem::LawRegistry& registry) {
  dem::ModelSpec spec = base;
  if (effect.law.empty()) return spec;
  if (registry.find_contact_law(effect.law) == nullptr) {
    throw std::invalid_argument("'" + effect.law + "' is not a contact law of the effect library");
  }
  const dem::ChainStage stage = registry.sample_contact_law(effect.law)->chain_stage();
  const auto stage_of = [&registry](const dem::LawSpec& law) {
    return registry.sample_contact_law(law.name)->chain_stage();
  };
  const std::uint32_t equipment = model_tests::equipment_type(spec);
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!model_tests::is_fillet_with(interaction, equipment)) continue;
    std::vector<dem::LawSpec>& laws = interaction.contact_laws;
    auto present = std::find_if(laws.begin(), laws.end(),
                                [&](const dem::LawSpec& law) { return law.name == effect.law; });
    if (present == laws.end()) {
      const auto later = std::find_if(
          laws.begin(), laws.end(), [&](const dem::LawSpec& law) { return stage_of(law) > stage; });
      const auto friction = std::find_if(laws.begin(), laws.end(), [&](const dem::LawSpec& law) {
        return stage_of(law) == dem::ChainStage::kFriction;
      });
      if (stage == dem::ChainStage::kFriction && friction != laws.end()) {
        dem::LawSpec law{effect.law, {}};
        const auto* info = registry.find_contact_law(effect.law);
        const bool has_kinetic =
            std::any_of(info->parameters.begin(), info->parameters.end(),
                        [](const auto& p) { return p.name == "kinetic_friction_coefficient"; });
        if (friction->name == "coulomb" && has_kinetic) {
          law.parameters["kinetic_friction_coefficient"] =
              friction->parameters.at("friction_coefficient");
        }
        *friction = law;
        present = friction;
      } else {
        present = laws.insert(later, dem::LawSpec{effect.law, {}});
      }
    }
    for (const auto& [key, value] : effect.parameters) present->parameters[key] = value;
    const auto kinetic = present->parameters.find("kinetic_friction_coefficient");
    const auto resting = present->parameters.find("static_friction_coefficient");
    if (kinetic != present->parameters.end() && resting != present->parameters.end() &&
        !effect.parameters.contains("kinetic_friction_coefficient")) {
      // A resting friction below the inherited sliding one is a lower friction throughout.
      kinetic->second = std::min(kinetic->second, resting->second);
    }
  }
  return spec;
}

dem::ModelSpec with_bond_effect(const dem::ModelSpec& base, const HiddenEffect& effect,
                                const dem::LawRegistry& registry) {
  dem::ModelSpec spec = base;
  if (effect.law.empty()) return spec;
  if (registry.find_bond_law(effect.law) == nullptr) {
    throw std::invalid_argument("'" + effect.law + "' is not a bond law of the effect library");
  }
  for (dem::InteractionSpec& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    interaction.bond_law->name = effect.law;
    for (const auto& [key, value] : effect.parameters) {
      interaction.bond_law->parameters[key] = value;
    }
  }
  return spec;
}

bool loads_contacts(ExperimentType experiment) {
  return experiment == ExperimentType::kSlide || experiment == ExperimentType::kLineTracks;
}

dem::ModelSpec with_experiment_effect(const dem::ModelSpec& base, ExperimentType experiment,
                                      const HiddenEffect& effect,
                                      const dem::LawRegistry& registry) {
  return loads_contacts(experiment) ? with_contact_effect(base, effect, registry)
                                    : with_bond_effect(base, effect, registry);
}

std::string effect_config_snippet(const dem::ModelSpec& base, ExperimentType experiment,
                                  const HiddenEffect& effect) {
  if (effect.law.empty()) return {};
  const dem::ModelSpec spec = with_experiment_effect(base, experiment, effect);
  // Seven significant digits: a fitted value is known to far fewer, and the text stays short.
  const auto values = [](const dem::LawParameters& parameters, std::string_view separator) {
    std::string text;
    for (const auto& [key, value] : parameters) {
      text += std::string(separator) + key + ": " + detail::significant(value, 7);
    }
    return text;
  };
  if (experiment == ExperimentType::kSlide || experiment == ExperimentType::kLineTracks) {
    // The list's items, to go under the config's own key (config/dem.yaml anchors it): one
    // list when every fillet-equipment chain is the same, else one per pair, named.
    const std::uint32_t equipment = model_tests::equipment_type(spec);
    const auto type_name = [&spec](std::uint32_t type) {
      return type < spec.types.size() ? spec.types[type].name : std::to_string(type);
    };
    std::vector<std::pair<std::string, std::string>> chains;  // pair, items
    for (const dem::InteractionSpec& interaction : spec.interactions) {
      if (!model_tests::is_fillet_with(interaction, equipment)) continue;
      std::string items;
      for (const dem::LawSpec& law : interaction.contact_laws) {
        items += "      - {law: " + law.name + values(law.parameters, ", ") + "}\n";
      }
      chains.emplace_back(type_name(interaction.type_a) + " - " + type_name(interaction.type_b),
                          items);
    }
    if (chains.empty()) {
      throw std::invalid_argument("the model has no fillet-equipment interaction to add " +
                                  effect.law + " to");
    }
    const bool all_same = std::all_of(chains.begin(), chains.end(), [&chains](const auto& c) {
      return c.second == chains.front().second;
    });
    if (all_same) return chains.front().second;
    std::string snippet;
    for (const auto& [pair, items] : chains) snippet += "    # " + pair + "\n" + items;
    return snippet;
  }
  for (const dem::InteractionSpec& interaction : spec.interactions) {
    if (!interaction.bond_law) continue;
    return "    bond_law:\n      law: " + interaction.bond_law->name +
           values(interaction.bond_law->parameters, "\n      ") + "\n";
  }
  throw std::invalid_argument("the model has no bond law to change to " + effect.law);
}

GeneratedDataset generate_dataset(const GeneratorOptions& options) {
  const ExperimentType experiment = options.experiment;
  if (experiment == ExperimentType::kBulkFlow) {
    throw std::invalid_argument(
        "the generator makes compress, slide, bend, drop and line_tracks datasets, not bulk_flow");
  }
  if (experiment == ExperimentType::kSettle) {
    // Measured on the 7 mm twin: a Maxwell arm of the drop's range moves the centre of a fillet
    // released at rest by 0.07 mm RMS, a yield stress not at all (its own weight never yields a
    // bond), against a camera's 0.5 mm. A settle dataset hides nothing a camera could find.
    throw std::invalid_argument(
        "the generator makes no settle datasets: no bond effect in its ranges moves a fillet "
        "released at rest by more than 0.1 mm; a drop dataset shows them");
  }
  const bool slide = experiment == ExperimentType::kSlide;
  const bool drop = experiment == ExperimentType::kDrop;
  const bool bend = experiment == ExperimentType::kBend;
  const bool tracks = experiment == ExperimentType::kLineTracks;
  double noise_si = options.force_noise_n;
  if (tracks) noise_si = options.position_noise_mm * 1e-3;
  if (slide) noise_si = options.angle_noise_deg * std::numbers::pi / 180.0;
  if (bend) noise_si = options.bend_angle_noise_deg * std::numbers::pi / 180.0;
  if (drop) noise_si = options.height_noise_mm * 1e-3;
  const double track_angle_noise_si = options.track_angle_noise_deg * std::numbers::pi / 180.0;
  const double displacement_noise_si = options.displacement_noise_um * 1e-6;
  if (options.trials < 0 || options.repetitions < 1 || options.fillets_per_trial < 1 ||
      !(noise_si >= 0.0) || !(track_angle_noise_si >= 0.0) || !(displacement_noise_si >= 0.0)) {
    throw std::invalid_argument(
        "generator: trials must be >= 0, repetitions and fillets >= 1 and the noise >= 0");
  }
  if (!(options.compress_row_s > 0.0 && options.compress_row_s <= 0.005)) {
    throw std::invalid_argument(
        "generator: the compress row interval must be above 0 and at most 5 ms, a tenth of the "
        "third trial's 50 ms ramp");
  }
  if (options.line_tracks_on_line && !tracks) {
    throw std::invalid_argument("generator: tracks on the line are for line_tracks datasets only");
  }
  if (options.slide_relaid && !slide) {
    throw std::invalid_argument("generator: re-laying the fillet is for slide datasets only");
  }
  for (const double rate : options.slide_tilt_rates_deg_per_s) {
    if (!(rate >= 0.1 && rate <= 90.0)) {
      throw std::invalid_argument("generator: a slide tilt rate must be 0.1 to 90 deg/s, not " +
                                  detail::significant(rate, 6));
    }
  }
  const auto rates_per_trial =
      static_cast<int>(std::max<std::size_t>(1, options.slide_tilt_rates_deg_per_s.size()));
  const int trials =
      options.trials > 0 ? options.trials : (slide ? 4 * rates_per_trial : (tracks ? 4 : 3));
  std::mt19937_64 random(options.seed);
  GeneratedDataset made;
  const std::vector<EffectRange>& effects = effects_of(options.experiment);
  const EffectRange* chosen = nullptr;
  if (options.effect == "random") {
    chosen = &effects[std::uniform_int_distribution<std::size_t>(0, effects.size() - 1)(random)];
  } else if (options.effect != "none") {
    for (const EffectRange& effect : effects) {
      if (options.effect == effect.law) chosen = &effect;
    }
    if (chosen == nullptr) {
      throw std::invalid_argument("generator: '" + options.effect + "' is not random, none or a " +
                                  std::string(to_string(options.experiment)) + " effect");
    }
  }
  if (chosen != nullptr) {
    made.truth.law = chosen->law;
    for (const ParameterRange& p : chosen->parameters) {
      const double u = std::uniform_real_distribution<double>(0.0, 1.0)(random);
      made.truth.parameters[p.name] =
          p.log ? p.min * std::pow(p.max / p.min, u) : p.min + u * (p.max - p.min);
    }
  }

  model_tests::CommonParams truth_common = options.common;
  if (truth_common.base_spec.materials.empty()) {
    truth_common.base_spec = dem::appendix_b_model_spec();
  }
  truth_common.base_spec =
      with_experiment_effect(truth_common.base_spec, options.experiment, made.truth);
  TwinSettings truth_settings;
  truth_settings.line_tracks.line = options.line_tracks_line;
  truth_settings.line_tracks.plant = options.line_tracks_plant;
  const std::unique_ptr<TrialModel> truth =
      make_twin_model(options.experiment, truth_common, truth_settings);
  const LineConfig line =
      options.line_tracks_line ? *options.line_tracks_line : default_line_config();

  Dataset& data = made.dataset;
  data.name = "synthetic " + std::string(to_string(options.experiment)) + ", seed " +
              std::to_string(options.seed);
  data.description = "made by the workbench generator; the truth is in a separate file";
  data.experiment = options.experiment;
  std::string channel = "force";
  if (slide) channel = "onset_angle";
  if (bend) channel = "bend_angle";
  if (drop) channel = "height";
  if (tracks) channel = "x";
  data.noise_si[channel] = noise_si;
  if (tracks) {
    data.noise_si["y"] = noise_si;
    data.noise_si["angle"] = track_angle_noise_si;
  }
  const bool noisy_displacement =
      options.experiment == ExperimentType::kCompress && displacement_noise_si > 0.0;
  if (noisy_displacement) data.noise_si["displacement"] = displacement_noise_si;
  std::normal_distribution<double> noise(0.0, noise_si);
  for (int k = 0; k < trials; ++k) {
    // Compress: ramps of 0.2, 0.1, 0.05 s, ...: the rate dependence shows.
    Trial trial;
    if (slide) {
      const std::vector<double>& rates = options.slide_tilt_rates_deg_per_s;
      if (rates.empty()) {
        trial = slide_trial(k, options.repetitions, options.slide_relaid);
      } else {
        const auto per_trial = static_cast<int>(rates.size());
        const double rate = rates[static_cast<std::size_t>(k % per_trial)];
        trial = slide_trial(k / per_trial, options.repetitions, options.slide_relaid);
        trial.id += "_" + detail::significant(rate, 3) + "dps";
        trial.conditions["tilt_rate"] = rate * std::numbers::pi / 180.0;
      }
    } else if (drop) {
      trial = drop_trial(k);
    } else if (bend) {
      trial = bend_trial(k, options.repetitions);
    } else if (tracks) {
      trial = options.line_tracks_on_line
                  ? line_run_trial(k, options.fillets_per_trial, random, line)
                  : line_tracks_trial(k, options.fillets_per_trial, random);
    } else {
      trial = compress_trial("rate" + std::to_string(k + 1), 0.2 / std::pow(2.0, k),
                             options.compress_row_s);
    }
    if (tracks) {
      // A fillet's first row is where the camera first saw it, noise and all: the truth starts
      // there (as any twin must), its later rows are the truth's answer plus noise.
      // Each fillet's first row in the file is where the camera first saw it.
      const std::vector<double>& fillet_of_row = trial.data.at("fillet").values_si;
      std::vector<bool> first_of_fillet(fillet_of_row.size(), false);
      std::set<double> seen_fillets;
      for (std::size_t row = 0; row < fillet_of_row.size(); ++row) {
        first_of_fillet[row] = seen_fillets.insert(fillet_of_row[row]).second;
      }
      std::normal_distribution<double> angle_noise(0.0, track_angle_noise_si);
      const auto first_row = [&first_of_fillet](std::size_t row) { return first_of_fillet[row]; };
      const std::array<std::pair<std::size_t, std::normal_distribution<double>*>, 3> noisy{
          {{2, &noise}, {3, &noise}, {4, &angle_noise}}};  // x, y, angle
      // From the true pose, the truth starts clean and every row gets its noise below.
      const bool seen_after_start = options.truth_starts_at_true_pose;
      if (!seen_after_start) {
        for (const auto& [column, distribution] : noisy) {
          std::vector<double>& values = trial.data.channels[column].values_si;
          for (std::size_t row = 0; row < values.size(); ++row) {
            if (first_row(row) && distribution->stddev() > 0.0) {
              values[row] += (*distribution)(random);
            }
          }
        }
      }
      const Table response = truth->run(data, trial);
      for (const auto& [column, distribution] : noisy) {
        std::vector<double>& values = trial.data.channels[column].values_si;
        const std::vector<double>& modelled =
            response.at(trial.data.channels[column].name).values_si;
        for (std::size_t row = 0; row < values.size(); ++row) {
          if (first_row(row) && !seen_after_start) continue;
          values[row] = modelled[row];
          if (distribution->stddev() > 0.0) values[row] += (*distribution)(random);
        }
      }
      data.trials.push_back(std::move(trial));
      continue;
    }
    std::vector<double>& measured = trial.data.channels.back().values_si;
    if (slide && options.slide_relaid) {
      // Each row its own slide, the fillet turned anew.
      TwinSettings relaid;
      std::uniform_real_distribution<double> turn_deg(-relaid.slide.placement_tolerance_deg,
                                                      relaid.slide.placement_tolerance_deg);
      for (double& value : measured) {
        relaid.slide.placement_yaw_deg = turn_deg(random);
        value = make_twin_model(options.experiment, truth_common, relaid)
                    ->run(data, trial)
                    .at(channel)
                    .values_si.front();
      }
    } else {
      measured = truth->run(data, trial).at(channel).values_si;
    }
    if (noise_si > 0.0) {
      for (double& value : measured) value += noise(random);
    }
    if (noisy_displacement) {
      // The truth ran on the true path; the log shows the encoder's reading of it.
      std::normal_distribution<double> displacement_noise(0.0, displacement_noise_si);
      for (Channel& logged : trial.data.channels) {
        if (logged.name != "displacement") continue;
        for (double& value : logged.values_si) value += displacement_noise(random);
      }
    }
    data.trials.push_back(std::move(trial));
  }
  return made;
}

namespace {

// Values in each channel's file unit, as a lab would write them.
void write_table(const Table& data, const std::filesystem::path& file) {
  std::vector<std::string> header;
  std::vector<std::vector<double>> columns;
  for (const Channel& channel : data.channels) {
    header.push_back(channel.name + " [" + std::string(channel.unit.symbol) + "]");
    std::vector<double>& column = columns.emplace_back();
    for (const double value : channel.values_si) column.push_back(value / channel.unit.to_si);
  }
  report::CsvTable table(std::move(header));
  table.add_columns(columns);
  table.write(file);
}

}  // namespace

void write_dataset(const Dataset& dataset, const std::filesystem::path& folder) {
  std::filesystem::create_directories(folder);
  std::ofstream manifest(folder / "manifest.yaml");
  manifest << "format: fillet-measurements/1\nname: \"" << dataset.name << "\"\n"
           << "description: \"" << dataset.description
           << "\"\nexperiment: " << to_string(dataset.experiment) << "\n";
  if (!dataset.noise_si.empty()) {
    manifest << "noise:\n";
    for (const auto& [channel, sigma] : dataset.noise_si) {
      // Written in the channel's file unit, as a lab would.
      const Unit unit = dataset.trials.empty() ? *find_unit(si_unit(Quantity::kDimensionless))
                                               : dataset.trials[0].data.at(channel).unit;
      manifest << "  " << channel << ": " << report::format_double(sigma / unit.to_si) << " "
               << unit.symbol << "\n";
    }
  }
  manifest << "trials:\n";
  for (const Trial& trial : dataset.trials) {
    const std::string file = trial.id + ".csv";
    manifest << "  - id: " << trial.id << "\n    file: " << file << "\n";
    if (!trial.conditions.empty()) manifest << "    conditions:\n";
    for (const auto& [name, value] : trial.conditions) {
      manifest << "      " << name << ": ";
      if (const auto* label = std::get_if<std::string>(&value)) manifest << *label;
      if (const auto* flag = std::get_if<bool>(&value)) manifest << (*flag ? "true" : "false");
      if (const auto* si = std::get_if<double>(&value)) {
        // SI with the unit of the condition's quantity.
        Quantity quantity = Quantity::kDimensionless;
        for (const ConditionRule& rule : schema_of(dataset.experiment).conditions) {
          if (rule.name == name) quantity = rule.quantity;
        }
        manifest << report::format_double(*si) << " " << si_unit(quantity);
      }
      manifest << "\n";
    }
    write_table(trial.data, folder / file);
    if (trial.commands) {
      const std::string commands_file = trial.id + "_commands.csv";
      manifest << "    commands: " << commands_file << "\n";
      write_table(*trial.commands, folder / commands_file);
    }
  }
  if (!manifest) throw std::runtime_error("cannot write " + (folder / "manifest.yaml").string());
}

void write_truth(const HiddenEffect& truth, const std::filesystem::path& file) {
  std::ofstream out(file);
  out << "# The hidden effect of a generated dataset: for checking a diagnosis, not for it.\n"
      << "effect: " << (truth.law.empty() ? "none" : truth.law) << "\nparameters:\n";
  if (truth.parameters.empty()) out << "  {}\n";
  for (const auto& [key, value] : truth.parameters) {
    out << "  " << key << ": " << report::format_double(value) << "\n";
  }
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

}  // namespace fl::workbench
