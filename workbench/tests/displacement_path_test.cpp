// The crosshead path the compress twin's plate follows: the logger's noise taken out, corners
// kept, curves followed, clean rows untouched.
#include "displacement_path.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <vector>

namespace fl::workbench::detail {
namespace {

// The generator's fastest compress trial: 0.5 mm in 50 ms (10 mm/s), a 0.1 s hold, back in
// 50 ms.
constexpr double kPeakM = 0.5e-3;
constexpr double kRampS = 0.05;
constexpr double kHoldS = 0.1;
constexpr double kEndS = 2.0 * kRampS + kHoldS;
// A crosshead encoder's noise as an outside lab's 10 kHz log showed it.
constexpr double kNoiseM = 0.5e-6;

double true_path_m(double t) {
  if (t < kRampS) return kPeakM * t / kRampS;
  if (t > kRampS + kHoldS) return kPeakM * std::max(0.0, kEndS - t) / kRampS;
  return kPeakM;
}

struct Log {
  std::vector<double> time_s, true_m, logged_m;
};

// Rows every `row_s`, each time shifted by up to `jitter_share` of a row (an irregular logger).
Log make_log(double row_s, double noise_m, double jitter_share, unsigned seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, noise_m > 0.0 ? noise_m : 1.0);
  std::uniform_real_distribution<double> jitter(-jitter_share, jitter_share);
  Log log;
  const auto rows = static_cast<int>(std::lround(kEndS / row_s));
  for (int k = 0; k <= rows; ++k) {
    const double t = row_s * (k + (k > 0 && k < rows ? jitter(random) : 0.0));
    log.time_s.push_back(t);
    log.true_m.push_back(true_path_m(t));
    log.logged_m.push_back(log.true_m.back() + (noise_m > 0.0 ? noise(random) : 0.0));
  }
  return log;
}

double rms(const std::vector<double>& values) {
  double sum = 0.0;
  for (const double v : values) sum += v * v;
  return std::sqrt(sum / static_cast<double>(values.size()));
}

TEST(DisplacementPath, CleanRowsComeBackBitForBit) {
  // A clean log's noise estimate is rounding (1e-19 m): its rows are already quieter than any
  // target, so the twin's plate follows exactly what it did before the smoothing existed.
  const Log log = make_log(1e-4, 0.0, 0.0, 1);
  EXPECT_EQ(smoothed_displacement_m(log.time_s, log.logged_m), log.logged_m);
}

TEST(DisplacementPath, TakesOutAFastLoggersNoiseAndKeepsTheCorners) {
  const Log log = make_log(1e-4, kNoiseM, 0.0, 2);
  const std::vector<double> path = smoothed_displacement_m(log.time_s, log.logged_m);
  ASSERT_EQ(path.size(), log.time_s.size());
  std::vector<double> error_m, speed_error_mps, corner_error_m;
  for (std::size_t k = 0; k < path.size(); ++k) {
    error_m.push_back(path[k] - log.true_m[k]);
    const double t = log.time_s[k];
    const double to_corner_s =
        std::min({std::abs(t - kRampS), std::abs(t - kRampS - kHoldS), std::abs(t - kEndS)});
    if (to_corner_s <= 0.002) corner_error_m.push_back(error_m.back());
    if (k == 0) continue;
    const double dt = log.time_s[k] - log.time_s[k - 1];
    speed_error_mps.push_back((path[k] - path[k - 1]) / dt -
                              (log.true_m[k] - log.true_m[k - 1]) / dt);
  }
  // Three straight pieces of 500, 1000 and 500 rows: a line's value through 500 rows is good
  // to sigma / sqrt(500) = 0.05 sigma; the knots' placement adds a little (0.04 to 0.36 sigma
  // over the rows within 2 ms of a corner, twelve seeds): a third of sigma overall.
  EXPECT_LT(rms(error_m), kNoiseM / 3.0);
  // Row to row the logged speed's noise is sqrt(2) 0.5 um / 0.1 ms = 7 mm/s, 70 % of the
  // loading rate; the plate's is to be a tenth of the loading rate (1 mm/s).
  EXPECT_LT(rms(speed_error_mps), 1e-3);
  // Within 2 ms of a corner a centred moving window of +-3.5 ms (the rate window) is off by
  // up to rate x h / 4 = 8.8 um (17 sigma), and cutting at the best row alone left a row's
  // ramp step (2 sigma) there; with the knot placed between rows every corner row stays under
  // a sigma (0.05 to 0.49 sigma at worst over twelve seeds).
  ASSERT_FALSE(corner_error_m.empty());
  for (const double e : corner_error_m) EXPECT_LT(std::abs(e), kNoiseM);
}

TEST(DisplacementPath, ACurvedPathIsFollowedPieceByPiece) {
  // A crosshead driven as a 1 Hz sine of 0.25 mm amplitude plus a creep of 0.2 mm with a
  // 0.3 s time constant, 2 s at 10 kHz: no straight piece fits it for long, so it is cut until
  // each piece is straight within the noise (0.31 to 0.36 sigma RMS, 1.38 sigma at worst over
  // five seeds).
  std::mt19937 random(4);
  std::normal_distribution<double> noise(0.0, kNoiseM);
  std::vector<double> time_s, true_m, logged_m;
  for (int k = 0; k <= 20000; ++k) {
    const double t = 1e-4 * k;
    time_s.push_back(t);
    true_m.push_back(0.25e-3 * (1.0 - std::cos(2.0 * std::numbers::pi * t)) +
                     0.2e-3 * (1.0 - std::exp(-t / 0.3)));
    logged_m.push_back(true_m.back() + noise(random));
  }
  const std::vector<double> path = smoothed_displacement_m(time_s, logged_m);
  std::vector<double> error_m;
  for (std::size_t k = 0; k < path.size(); ++k) error_m.push_back(path[k] - true_m[k]);
  EXPECT_LT(rms(error_m), kNoiseM / 2.0);
  for (const double e : error_m) EXPECT_LT(std::abs(e), 2.0 * kNoiseM);
}

TEST(DisplacementPath, IrregularRowTimesAreFittedInTime) {
  // A logger whose rows come up to 30 % of a row early or late: the lines are fitted against
  // the rows' own times, so the path is as good as on a regular grid.
  const Log log = make_log(1e-4, kNoiseM, 0.3, 3);
  const std::vector<double> path = smoothed_displacement_m(log.time_s, log.logged_m);
  std::vector<double> error_m;
  for (std::size_t k = 0; k < path.size(); ++k) error_m.push_back(path[k] - log.true_m[k]);
  EXPECT_LT(rms(error_m), kNoiseM / 3.0);
}

TEST(DisplacementPath, AShortCleanLogComesBackUnchanged) {
  // Nine rows a second apart, corners between rows: most offsets from the neighbours' lines are
  // corners, so the median read them as 30 um of noise and the peak was moved from 0.25 to
  // 0.284 mm. Under 32 rows a log is followed as logged.
  const std::vector<double> time_s{0, 1, 2, 3, 4, 5, 6, 7, 8};
  const std::vector<double> logged_m{0.0, 1e-4, 2e-4, 2.5e-4, 2.5e-4, 2.5e-4, 2e-4, 1e-4, 0.0};
  EXPECT_EQ(smoothed_displacement_m(time_s, logged_m), logged_m);
}

TEST(DisplacementPath, AFilteringLoggersNoiseNeedsItsStatedSigma) {
  // A 10 mm/s ramp, 3 s at 10 kHz, whose 0.5 um of noise the logger has averaged over 8 rows:
  // neighbours move together, so the rows' own estimate is far too low, every piece is cut
  // short and the path follows the noise (0.95 sigma RMS over four seeds). With the manifest's
  // sigma the ramp is one piece: 0.02 to 0.03 sigma.
  std::mt19937 random(5);
  std::normal_distribution<double> white(0.0, kNoiseM);
  constexpr int kRows = 30001;
  constexpr int kAveraged = 8;
  std::vector<double> draws(kRows + kAveraged);
  for (double& draw : draws) draw = white(random);
  std::vector<double> time_s, true_m, logged_m;
  for (int k = 0; k < kRows; ++k) {
    double filtered = 0.0;
    for (int j = 0; j < kAveraged; ++j) filtered += draws[static_cast<std::size_t>(k + j)];
    time_s.push_back(1e-4 * k);
    true_m.push_back(1e-2 * time_s.back());
    logged_m.push_back(true_m.back() + filtered / std::sqrt(double{kAveraged}));
  }
  const auto error_rms = [&](const std::vector<double>& path) {
    std::vector<double> error_m;
    for (std::size_t k = 0; k < path.size(); ++k) error_m.push_back(path[k] - true_m[k]);
    return rms(error_m);
  };
  EXPECT_GT(error_rms(smoothed_displacement_m(time_s, logged_m)), 0.5 * kNoiseM);
  EXPECT_LT(error_rms(smoothed_displacement_m(time_s, logged_m, kNoiseM)), 0.1 * kNoiseM);
}

TEST(DisplacementPath, BadColumnsAreRefused) {
  const std::vector<double> time_s{0.0, 1e-4, 2e-4};
  EXPECT_THROW((void)smoothed_displacement_m(time_s, {0.0, 1e-6}), std::invalid_argument);
  EXPECT_THROW((void)smoothed_displacement_m(time_s, {0.0, std::nan(""), 0.0}),
               std::invalid_argument);
  EXPECT_THROW((void)smoothed_displacement_m({0.0, 1e-4, 1e-4}, {0.0, 1e-6, 2e-6}),
               std::invalid_argument);
}

}  // namespace
}  // namespace fl::workbench::detail
