// The slide experiment in the workbench: the twin reproduces onset angles from a trial's
// conditions (a wet film acting on wet trials only; a fillet that never slides reported, not
// fatal), and the generator's hidden contact effects make the base model fail while the truth
// model sits at the noise level. One slide run of the 7 mm fillet takes about a second.
#include <gtest/gtest.h>

#include <algorithm>
#include <numbers>
#include <set>

#include "fl/workbench/generator.hpp"
#include "fl/workbench/twin_models.hpp"
#include "workbench_test_support.hpp"

namespace fl::workbench {
namespace {

using test::base_model;
using test::generate_slide;

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

double onset_deg(TwinSlideModel& model, const Dataset& data, std::size_t trial) {
  return model.run(data, data.trials[trial]).at("onset_angle").values_si.front() * kDegPerRad;
}

TEST(SlideTwin, WetFilmActsOnWetTrialsOnlyAndLowersTheOnset) {
  // Trials 0 and 1: the 144x72x40 variant dry, then wet.
  const Dataset data = generate_slide("none").dataset;
  TwinSlideModel base(base_model());
  model_tests::CommonParams filmed = base_model();
  filmed.base_spec = with_contact_effect(filmed.base_spec, {"wet_film", {{"lubrication", 0.5}}});
  TwinSlideModel wet(filmed);
  const double dry_base = onset_deg(base, data, 0);
  // The base model does not know the surface: dry and wet alike.
  EXPECT_DOUBLE_EQ(onset_deg(base, data, 1), dry_base);
  // The film is out of the chain on dry trials: the same run, the same angle.
  EXPECT_DOUBLE_EQ(onset_deg(wet, data, 0), dry_base);
  // Half the friction load: a block would go from atan 0.5 = 27 to atan 0.25 = 14 deg; the
  // fillet must fall by well over the 0.05 deg resolution, 3 deg is a tenth of that fall.
  EXPECT_LT(onset_deg(wet, data, 1), dry_base - 3.0);
  // Every row is a repetition of the same deterministic run.
  const Table rows = wet.run(data, data.trials[1]);
  EXPECT_EQ(rows.rows(), data.trials[1].data.rows());
}

TEST(SlideTwin, ATrialsTiltRateReachesThePlate) {
  // Trial 0 (144x72x40, dry) written as tilted at 10 deg/s: the twin tilts at that rate, the
  // same run as one told 10 deg/s for every trial, and not the 5 deg/s one (the plate passes
  // other angles at each step, so the onset read differs).
  Dataset data = generate_slide("none").dataset;
  data.trials.resize(1);
  Dataset tilted = data;
  tilted.trials[0].conditions["tilt_rate"] = 10.0 / kDegPerRad;
  TwinSlideModel by_condition(base_model());
  TwinSlideModel at_ten(base_model(), SlideSettings{10.0, 80.0});
  const double onset = onset_deg(by_condition, tilted, 0);
  EXPECT_DOUBLE_EQ(onset, onset_deg(at_ten, data, 0));
  EXPECT_NE(onset, onset_deg(by_condition, data, 0));
}

TEST(SlideTwin, AnEnsembleShowsTheScatterOfStickAndSlipAndNotOfCoulomb) {
  // Trial 0: the 144x72x40 variant, dry, at 5 deg/s. Four placements within +-5 deg.
  Dataset data = generate_slide("none").dataset;
  data.trials.resize(1);
  const SlideSettings four{5.0, 80.0, 4, 5.0};
  auto answer = [&](const model_tests::CommonParams& model, const SlideSettings& settings) {
    TwinSlideModel twin(model, settings);
    return twin.run(data, data.trials[0]);
  };
  auto spread_deg = [](const Table& table) {
    return table.at("onset_angle_spread").values_si.front() * kDegPerRad;
  };
  // Coulomb: the 144 mm fillet's onset turns on the placement's geometry only, smoothly and
  // little (0.0 deg in this channel, all four slide within one 0.05 deg sample; 0.03 to 0.04
  // deg RMS over nine placements within +-4 deg), under a third of the 0.3 deg noise.
  const Table coulomb = answer(base_model(), four);
  ASSERT_NE(coulomb.find("onset_angle_spread"), nullptr);
  EXPECT_LT(spread_deg(coulomb), 0.1);
  // Static against kinetic friction (mu_s 0.83 from the generator's range, its stick speed
  // 10.6 mm/s): where each contact sticks or slips turns on the placement, and the onset
  // scatters (this channel read 0.46 deg for mu_s 0.835 through linectl compare --ensemble 4):
  // over twice the coulomb bound.
  model_tests::CommonParams sticky = base_model();
  sticky.base_spec = with_contact_effect(
      sticky.base_spec, {"static_kinetic_friction",
                         {{"static_friction_coefficient", 0.83}, {"stick_speed_m_per_s", 0.0106}}});
  const Table stick_slip = answer(sticky, four);
  EXPECT_GT(spread_deg(stick_slip), 0.2);
  // Every row carries the mean and the spread (the rows are repetitions).
  EXPECT_EQ(stick_slip.at("onset_angle").values_si.size(), data.trials[0].data.rows());
  EXPECT_EQ(stick_slip.at("onset_angle_spread").values_si.size(), data.trials[0].data.rows());
  // One run a trial answers no spread and lays the fillet straight whatever the tolerance: the
  // run the twin made before ensembles, bit for bit.
  const Table one = answer(sticky, SlideSettings{});
  EXPECT_EQ(one.find("onset_angle_spread"), nullptr);
  EXPECT_EQ(answer(sticky, SlideSettings{5.0, 80.0, 1, 20.0}).at("onset_angle").values_si,
            one.at("onset_angle").values_si);
  // The ensemble is named in the model's description.
  EXPECT_NE(TwinSlideModel(sticky, four).describe().find("mean of 4 placements"),
            std::string::npos);
  // Settings that cannot run are refused, saying which: no run, a fillet across the tilt (by
  // the tolerance, or the turn and the tolerance), and an ensemble of one placement (the same
  // run four times, spread 0).
  auto refusal = [&](const SlideSettings& settings) {
    try {
      TwinSlideModel refused(sticky, settings);
    } catch (const std::invalid_argument& error) {
      return std::string(error.what());
    }
    return std::string();
  };
  EXPECT_NE(refusal({5.0, 80.0, 0, 5.0}).find("one run or more"), std::string::npos);
  EXPECT_NE(refusal({5.0, 80.0, 4, 60.0}).find("placement tolerance"), std::string::npos);
  EXPECT_NE(refusal({5.0, 80.0, 4, 0.0}).find("placement tolerance"), std::string::npos);
  // A turn of 42 deg with 5 of tolerance would lay some members across the tilt.
  EXPECT_NE(refusal({5.0, 80.0, 4, 5.0, -42.0}).find("within 45 deg"), std::string::npos);
  EXPECT_EQ(refusal({5.0, 80.0, 4, 5.0, 40.0}), "");
}

TEST(SlideTwin, AFilletThatNeverSlidesIsReportedNotFatal) {
  const Dataset all = generate_slide("none").dataset;
  Dataset data = all;
  data.trials = {all.trials[0], all.trials[2]};  // 144x72x40 and 172x72x32, dry
  // The base onsets are about 23 and 31 deg: a plate stopped at 27 deg, 4 deg from each,
  // sees the first fillet slide and not the second.
  TwinSlideModel model(base_model(), SlideSettings{5.0, 27.0});
  EXPECT_THROW((void)model.run(data, data.trials[1]), std::runtime_error);
  const CompareReport report = compare(data, model);
  ASSERT_EQ(report.failed_trials.size(), 1U);
  EXPECT_EQ(report.failed_trials.front().rfind(data.trials[1].id, 0), 0U)
      << report.failed_trials.front();
  EXPECT_NE(report.failed_trials.front().find("not slid"), std::string::npos);
  EXPECT_EQ(report.traces.size(), 1U);
}

TEST(SlideGenerator, DatasetRoundTripsThroughTheMeasurementFormat) {
  const GeneratedDataset made = generate_slide("none");
  const auto folder = std::filesystem::temp_directory_path() / "fl_slide_round_trip";
  std::filesystem::remove_all(folder);
  write_dataset(made.dataset, folder);
  const Dataset loaded = load_dataset(folder);
  EXPECT_EQ(loaded.experiment, ExperimentType::kSlide);
  ASSERT_EQ(loaded.trials.size(), 4U);  // the slide default: two variants, dry and wet
  EXPECT_NEAR(loaded.noise_si.at("onset_angle") * kDegPerRad, test::kAngleNoiseDeg, 1e-12);
  std::set<std::string> surfaces;
  for (std::size_t t = 0; t < loaded.trials.size(); ++t) {
    const Trial& a = made.dataset.trials[t];
    const Trial& b = loaded.trials[t];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.conditions, b.conditions);
    surfaces.insert(std::get<std::string>(b.conditions.at("surface")));
    const auto& x = a.data.at("onset_angle").values_si;
    const auto& y = b.data.at("onset_angle").values_si;
    ASSERT_EQ(x.size(), 10U);  // the default repetitions
    ASSERT_EQ(x.size(), y.size());
    // Written in degrees with 17 significant digits and read back: a rounding at most.
    for (std::size_t k = 0; k < x.size(); ++k) EXPECT_NEAR(x[k], y[k], 1e-14);
  }
  EXPECT_EQ(surfaces, (std::set<std::string>{"dry", "wet"}));
  std::filesystem::remove_all(folder);
}

TEST(SlideGenerator, EveryHiddenEffectFailsTheBaseModelAndNotTheTruth) {
  for (const std::string& effect : slide_effect_candidates()) {
    SCOPED_TRACE(effect);
    const GeneratedDataset made = generate_slide(effect);
    ASSERT_EQ(made.truth.law, effect);
    // The truth model leaves only the noise: RMS/sigma over 40 Gaussian angles is 1 within
    // about 1/sqrt(80) = 0.11 per sigma; 0.35 is three of those.
    EXPECT_NEAR(test::angle_score(made.dataset, made.truth), 1.0, 0.35);
    // The weakest effect in the generator's ranges moves the onset by about 1 deg, over 3
    // sigmas of 0.3 deg.
    EXPECT_GT(test::angle_score(made.dataset, {}), 3.0);
  }
}

TEST(SlideGenerator, WithoutAHiddenEffectTheBaseModelSitsAtTheNoise) {
  const GeneratedDataset made = generate_slide("none");
  EXPECT_TRUE(made.truth.law.empty());
  EXPECT_NEAR(test::angle_score(made.dataset, {}), 1.0, 0.35);  // as the truth model above
}

TEST(SlideGenerator, TiltRatesRepeatEveryTrialAtEachRate) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kSlide;
  options.common = base_model();
  options.effect = "none";
  options.angle_noise_deg = 0.0;
  options.repetitions = 1;
  options.trials = 4;  // the 144x72x40 fillet, dry and wet, each at 5 and 20 deg/s
  options.slide_tilt_rates_deg_per_s = {5.0, 20.0};
  const Dataset data = generate_dataset(options).dataset;
  ASSERT_EQ(data.trials.size(), 4U);
  EXPECT_EQ(data.trials[0].id, "s144x72x40_dry_5dps");
  EXPECT_EQ(data.trials[1].id, "s144x72x40_dry_20dps");
  EXPECT_EQ(data.trials[3].id, "s144x72x40_wet_20dps");
  EXPECT_DOUBLE_EQ(std::get<double>(data.trials[1].conditions.at("tilt_rate")), 20.0 / kDegPerRad);
  // Clean onsets: the 5 deg/s one is the twin's default run (23.0 deg), and at 20 deg/s the
  // plate tilts further while the fillet accelerates over its 10 mm (25.2 deg): 2.2 deg later;
  // 1 deg is half of that and twenty times the 0.05 deg a step of the slower tilt resolves.
  TwinSlideModel twin(base_model());
  Dataset at_default = data;
  at_default.trials[0].conditions.erase("tilt_rate");
  const auto onset = [](const Dataset& d, std::size_t k) {
    return d.trials[k].data.at("onset_angle").values_si.front() * kDegPerRad;
  };
  EXPECT_DOUBLE_EQ(onset(data, 0), onset_deg(twin, at_default, 0));
  EXPECT_GT(onset(data, 1), onset(data, 0) + 1.0);
  options.slide_tilt_rates_deg_per_s = {5.0, 200.0};
  EXPECT_THROW((void)generate_dataset(options), std::invalid_argument);
}

TEST(SlideGenerator, ReLayingTheFilletScattersTheRowsByStickAndSlipOnly) {
  // Noise-free repetitions of the 144x72x40 fillet, dry, at the twin's 5 deg/s.
  GeneratorOptions options;
  options.experiment = ExperimentType::kSlide;
  options.common = base_model();
  options.angle_noise_deg = 0.0;
  options.repetitions = 6;
  options.trials = 1;
  const auto onsets_deg = [&](const std::string& effect, bool relaid) {
    options.effect = effect;
    options.seed = 5;  // static friction mu_s 0.835, stick speed 10.6 mm/s: a chaotic onset
    options.slide_relaid = relaid;
    const Dataset data = generate_dataset(options).dataset;
    std::vector<double> onsets;
    for (const double rad : data.trials[0].data.at("onset_angle").values_si) {
      onsets.push_back(rad * kDegPerRad);
    }
    return onsets;
  };
  const auto spread_deg = [](const std::vector<double>& values) {
    const auto [low, high] = std::minmax_element(values.begin(), values.end());
    return *high - *low;
  };
  // Laid once, the rows repeat one slide exactly.
  EXPECT_EQ(spread_deg(onsets_deg("static_kinetic_friction", false)), 0.0);
  // Re-laid within +-5 deg, stick and slip moves the onset by 0.37 to 0.6 deg RMS (measured on
  // this fillet, nine placements): six rows span more than 0.3 deg, half that RMS.
  EXPECT_GT(spread_deg(onsets_deg("static_kinetic_friction", true)), 0.3);
  // Under the base coulomb the same turns leave this fillet's onset within the 0.05 deg step
  // the tilt resolves (measured: all six equal): the scatter is the friction's, not the
  // generator's.
  EXPECT_LT(spread_deg(onsets_deg("none", true)), 0.1);
  options.experiment = ExperimentType::kDrop;
  EXPECT_THROW((void)generate_dataset(options), std::invalid_argument);
}

TEST(SlideGenerator, RandomChoiceIsSeededAndCoversTheCandidates) {
  GeneratorOptions options;
  options.experiment = ExperimentType::kSlide;
  options.common = base_model();
  options.trials = 1;
  options.repetitions = 1;
  std::set<std::string> chosen;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    options.seed = seed;
    const GeneratedDataset a = generate_dataset(options);
    const GeneratedDataset b = generate_dataset(options);
    EXPECT_EQ(a.truth.law, b.truth.law);
    EXPECT_EQ(a.truth.parameters, b.truth.parameters);
    chosen.insert(a.truth.law);
  }
  // 8 fair draws of 2 candidates miss one with probability 2 / 2^8: seeded, so fixed here.
  EXPECT_EQ(chosen.size(), slide_effect_candidates().size());
}

TEST(SlideGenerator, ContactEffectsTakeTheirPlaceInTheChain) {
  const dem::ModelSpec base = base_model().base_spec;
  const std::uint32_t equipment = model_tests::equipment_type(base);
  const auto chain = [&](const dem::ModelSpec& spec) {
    std::vector<std::string> names;
    for (const dem::InteractionSpec& interaction : spec.interactions) {
      if (interaction.type_b != equipment) continue;
      for (const dem::LawSpec& law : interaction.contact_laws) names.push_back(law.name);
      break;
    }
    return names;
  };
  const dem::ModelSpec sticky = with_contact_effect(
      base, {"static_kinetic_friction", {{"static_friction_coefficient", 0.8}}});
  EXPECT_EQ(chain(sticky),
            (std::vector<std::string>{"hertz_mindlin", "jkr", "static_kinetic_friction"}));
  const dem::ModelSpec filmed = with_contact_effect(base, {"wet_film", {{"lubrication", 0.4}}});
  EXPECT_EQ(chain(filmed),
            (std::vector<std::string>{"hertz_mindlin", "jkr", "wet_film", "coulomb"}));
  const dem::ModelSpec rolling =
      with_contact_effect(filmed, {"rolling_resistance", {{"rolling_friction", 0.1}}});
  EXPECT_EQ(chain(rolling), (std::vector<std::string>{"hertz_mindlin", "jkr", "wet_film", "coulomb",
                                                      "rolling_resistance"}));
  // The replaced coulomb's 0.5 stays the sliding friction.
  for (const dem::InteractionSpec& interaction : sticky.interactions) {
    if (interaction.type_b != equipment) continue;
    EXPECT_DOUBLE_EQ(interaction.contact_laws[2].parameters.at("kinetic_friction_coefficient"),
                     0.5);
  }
  EXPECT_THROW((void)with_contact_effect(base, {"bpm_plastic", {}}), std::invalid_argument);
}

}  // namespace
}  // namespace fl::workbench
