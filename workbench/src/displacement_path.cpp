#include "displacement_path.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace fl::workbench::detail {
namespace {

// Rows whose rate, from neighbour to neighbour, carries the logger's noise at under this share
// of the loading rate are left as logged: the share the phases are read at.
constexpr double kPathRateNoiseShare = 0.01;

// Sums of one run of rows, about a fixed origin (long double: the prefix sums of a long trial
// are differenced for short runs, which a 53-bit double does not carry for 60,000 rows).
static_assert(std::numeric_limits<long double>::digits >= 64,
              "the path fit's prefix sums need an extended long double (x86-64, aarch64)");
struct RunSums {
  long double n = 0, t = 0, tt = 0, d = 0, dd = 0, td = 0;

  RunSums operator-(const RunSums& o) const {
    return {n - o.n, t - o.t, tt - o.tt, d - o.d, dd - o.dd, td - o.td};
  }
  // Residual sum of squares of the least-squares line through the run.
  [[nodiscard]] double line_rss() const {
    const long double stt = tt - t * t / n;
    const long double sdd = dd - d * d / n;
    const long double std = td - t * d / n;
    const long double rss = stt > 0 ? sdd - std * std / stt : sdd;
    return static_cast<double>(std::max<long double>(0, rss));
  }
};

// A run of at least kMinPieceRows rows is straight when its line's residual variance stays
// within three standard deviations of sigma^2 chi^2(n-2)/(n-2) above sigma^2.
constexpr std::size_t kMinPieceRows = 4;

// The noise is the median of the rows' offsets from their neighbours' line, and a corner
// spoils up to two of them: from 32 rows it stays the noise's for up to seven corners. A
// shorter log is a slow one by any measure and is followed as logged.
constexpr std::size_t kMinSmoothedRows = 32;

bool straight_within_noise(double rss, std::size_t rows, double noise_m) {
  const double dof = static_cast<double>(rows) - 2.0;
  return rss / dof <= noise_m * noise_m * (1.0 + 3.0 * std::sqrt(2.0 / dof));
}

// The rows where the pieces of a piecewise straight path meet, first and last row included:
// a run that is not straight within the noise is cut at the row where a line on each side
// leaves the least squares (the corner, for a ramp into a hold), and each side is judged
// again.
std::vector<std::size_t> piece_ends(const std::vector<double>& time_s,
                                    const std::vector<double>& displacement_m, double noise_m) {
  const std::size_t rows = time_s.size();
  std::vector<RunSums> prefix(rows + 1);
  const long double t0 = time_s.front();
  const long double d0 = displacement_m.front();
  for (std::size_t k = 0; k < rows; ++k) {
    const long double t = time_s[k] - t0;
    const long double d = displacement_m[k] - d0;
    const RunSums& p = prefix[k];
    prefix[k + 1] = {p.n + 1, p.t + t, p.tt + t * t, p.d + d, p.dd + d * d, p.td + t * d};
  }
  const auto run = [&prefix](std::size_t first, std::size_t last) {
    return prefix[last + 1] - prefix[first];
  };
  std::vector<std::size_t> ends{0, rows - 1};
  std::vector<std::pair<std::size_t, std::size_t>> pending{{0, rows - 1}};
  while (!pending.empty()) {
    const auto [first, last] = pending.back();
    pending.pop_back();
    const std::size_t n = last - first + 1;
    if (n < 2 * kMinPieceRows || straight_within_noise(run(first, last).line_rss(), n, noise_m)) {
      continue;
    }
    std::size_t cut = first + kMinPieceRows - 1;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t k = first + kMinPieceRows - 1; k + kMinPieceRows <= last; ++k) {
      const double rss = run(first, k).line_rss() + run(k + 1, last).line_rss();
      if (rss < best) {
        best = rss;
        cut = k;
      }
    }
    ends.push_back(cut);
    pending.emplace_back(first, cut);
    pending.emplace_back(cut, last);
  }
  std::sort(ends.begin(), ends.end());
  ends.erase(std::unique(ends.begin(), ends.end()), ends.end());
  return ends;
}

// A linear spline: values at knot times, straight between them.
struct LinearSpline {
  std::vector<double> knot_s;
  std::vector<double> value_m;
};

// The piece a row's time falls in (the last piece takes the last knot's time) and its share of
// the way through it, row by row: the rows' times are sorted, so one sweep finds them all.
template <typename Visit>
void for_each_row_in_pieces(const std::vector<double>& time_s, const std::vector<double>& knot_s,
                            const Visit& visit) {
  std::size_t piece = 0;
  for (std::size_t row = 0; row < time_s.size(); ++row) {
    while (piece + 2 < knot_s.size() && time_s[row] >= knot_s[piece + 1]) ++piece;
    const double u = (time_s[row] - knot_s[piece]) / (knot_s[piece + 1] - knot_s[piece]);
    visit(row, piece, u);
  }
}

// The least-squares values at the knots: each row weighs on the two knots around it, so the
// normal equations are tridiagonal (solved by the Thomas algorithm; the matrix is symmetric
// positive definite while every piece holds rows).
std::vector<double> spline_values(const std::vector<double>& time_s,
                                  const std::vector<double>& displacement_m,
                                  const std::vector<double>& knot_s) {
  const std::size_t knots = knot_s.size();
  std::vector<double> diagonal(knots, 0.0), upper(knots, 0.0), rhs(knots, 0.0);
  for_each_row_in_pieces(time_s, knot_s, [&](std::size_t row, std::size_t piece, double u) {
    diagonal[piece] += (1.0 - u) * (1.0 - u);
    upper[piece] += u * (1.0 - u);
    diagonal[piece + 1] += u * u;
    rhs[piece] += (1.0 - u) * displacement_m[row];
    rhs[piece + 1] += u * displacement_m[row];
  });
  for (std::size_t j = 1; j < knots; ++j) {
    const double factor = upper[j - 1] / diagonal[j - 1];
    diagonal[j] -= factor * upper[j - 1];
    rhs[j] -= factor * rhs[j - 1];
  }
  std::vector<double> value(knots);
  value[knots - 1] = rhs[knots - 1] / diagonal[knots - 1];
  for (std::size_t j = knots - 1; j-- > 0;) {
    value[j] = (rhs[j] - upper[j] * value[j + 1]) / diagonal[j];
  }
  return value;
}

// How finely, and how far either side of its row, an inner knot's time is searched: a tenth
// of a row over three rows, since cutting into two separate lines places a corner to within a
// row or two, and a corner a row off leaves a ramp's row-to-row step (2 sigma at the generator's
// fastest rate) in the path.
constexpr int kKnotSearchStepsPerRow = 10;
constexpr int kKnotSearchRows = 3;

// Moves each inner knot to the time where the spline, its neighbours' values held, leaves the
// least squares over the two pieces it joins, each keeping two rows at least. The knots are
// moved in order, so the rows of the left piece start at its knot's new time.
void place_knots(const std::vector<double>& time_s, const std::vector<double>& displacement_m,
                 const std::vector<std::size_t>& knot_rows, LinearSpline& spline) {
  for (std::size_t j = 1; j + 1 < knot_rows.size(); ++j) {
    const std::size_t row = knot_rows[j];
    const auto first = static_cast<std::size_t>(
        std::lower_bound(time_s.begin(), time_s.end(), spline.knot_s[j - 1]) - time_s.begin());
    const std::size_t last = knot_rows[j + 1];
    const std::size_t lowest =
        std::max(first + 2, row - std::min<std::size_t>(row, kKnotSearchRows));
    const std::size_t highest = std::min(last - 2, row + kKnotSearchRows);
    if (lowest > highest) continue;
    const double left_s = spline.knot_s[j - 1];
    const double right_s = spline.knot_s[j + 1];
    const double left_m = spline.value_m[j - 1];
    const double right_m = spline.value_m[j + 1];
    double best_rss = std::numeric_limits<double>::infinity();
    for (std::size_t r = lowest; r <= highest; ++r) {
      for (int step = 0; step < kKnotSearchStepsPerRow; ++step) {
        if (r == highest && step > 0) break;
        const double knot_s =
            time_s[r] + (time_s[r + 1] - time_s[r]) * step / kKnotSearchStepsPerRow;
        // The path over the two pieces is a + w c for the knot's value c: solve for c.
        double ww = 0.0, wd = 0.0;
        const auto weigh = [&](std::size_t k, double& a, double& w) {
          if (time_s[k] < knot_s) {
            const double u = (time_s[k] - left_s) / (knot_s - left_s);
            a = (1.0 - u) * left_m;
            w = u;
          } else {
            const double u = (time_s[k] - knot_s) / (right_s - knot_s);
            a = u * right_m;
            w = 1.0 - u;
          }
        };
        for (std::size_t k = first; k <= last; ++k) {
          double a = 0.0, w = 0.0;
          weigh(k, a, w);
          ww += w * w;
          wd += w * (displacement_m[k] - a);
        }
        const double value = wd / ww;
        double rss = 0.0;
        for (std::size_t k = first; k <= last; ++k) {
          double a = 0.0, w = 0.0;
          weigh(k, a, w);
          const double residual = displacement_m[k] - a - w * value;
          rss += residual * residual;
        }
        if (rss < best_rss) {
          best_rss = rss;
          spline.knot_s[j] = knot_s;
          spline.value_m[j] = value;
        }
      }
    }
  }
}

// The least-squares linear spline with a knot at each of the rows `knot_rows` (first and last
// row among them), the inner knots then placed between rows, read at every row.
std::vector<double> linear_spline_fit(const std::vector<double>& time_s,
                                      const std::vector<double>& displacement_m,
                                      const std::vector<std::size_t>& knot_rows) {
  LinearSpline spline;
  for (const std::size_t row : knot_rows) spline.knot_s.push_back(time_s[row]);
  spline.value_m = spline_values(time_s, displacement_m, spline.knot_s);
  const std::vector<double> knots_at_rows_s = spline.knot_s;
  place_knots(time_s, displacement_m, knot_rows, spline);
  // Every piece must keep rows for the normal equations: should a placement ever break that,
  // the knots stay at their rows.
  std::size_t first_in_piece = 0;
  for (std::size_t j = 1; j < spline.knot_s.size(); ++j) {
    const bool ordered = spline.knot_s[j] > spline.knot_s[j - 1];
    while (first_in_piece < time_s.size() && time_s[first_in_piece] < spline.knot_s[j - 1]) {
      ++first_in_piece;
    }
    if (!ordered || first_in_piece >= time_s.size() || time_s[first_in_piece] >= spline.knot_s[j]) {
      spline.knot_s = knots_at_rows_s;
      break;
    }
  }
  spline.value_m = spline_values(time_s, displacement_m, spline.knot_s);
  std::vector<double> path(time_s.size());
  for_each_row_in_pieces(time_s, spline.knot_s, [&](std::size_t row, std::size_t piece, double u) {
    path[row] = (1.0 - u) * spline.value_m[piece] + u * spline.value_m[piece + 1];
  });
  return path;
}

// The upper middle of the values (0 for none); reorders them.
double median_of(std::vector<double>& values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

double median_row_interval_s(const std::vector<double>& time_s) {
  std::vector<double> intervals;
  intervals.reserve(time_s.size());
  for (std::size_t k = 1; k < time_s.size(); ++k) intervals.push_back(time_s[k] - time_s[k - 1]);
  return median_of(intervals);
}

}  // namespace

double displacement_noise_m(const std::vector<double>& time_s,
                            const std::vector<double>& displacement_m) {
  const std::vector<double>& t = time_s;
  const std::vector<double>& d = displacement_m;
  const std::size_t rows = std::min(t.size(), d.size());
  if (rows < 3) return 0.0;
  // Each middle row against the line through its neighbours, in time: d1 - (w0 d0 + w2 d2)
  // has a white noise's sigma times sqrt(1 + w0^2 + w2^2).
  std::vector<double> off(rows - 2);
  for (std::size_t k = 0; k + 2 < rows; ++k) {
    const double span = t[k + 2] - t[k];
    const double w0 = (t[k + 2] - t[k + 1]) / span;
    const double w2 = (t[k + 1] - t[k]) / span;
    off[k] = std::abs(d[k + 1] - w0 * d[k] - w2 * d[k + 2]) / std::sqrt(1.0 + w0 * w0 + w2 * w2);
  }
  return median_of(off) / 0.6745;
}

double loading_rate_m_per_s(const std::vector<double>& time_s,
                            const std::vector<double>& displacement_m) {
  const std::size_t rows = std::min(time_s.size(), displacement_m.size());
  const std::size_t span = std::max<std::size_t>(1, rows / 100);
  double rate = 0.0;
  for (std::size_t k = 0; k + span < rows; ++k) {
    rate = std::max(rate, std::abs(displacement_m[k + span] - displacement_m[k]) /
                              (time_s[k + span] - time_s[k]));
  }
  return rate;
}

std::optional<double> stated_displacement_noise_m(const Dataset& dataset) {
  const auto noise = dataset.noise_si.find("displacement");
  if (noise == dataset.noise_si.end()) return std::nullopt;
  return noise->second;
}

double rate_window_half_s(const std::vector<double>& time_s,
                          const std::vector<double>& displacement_m, double rate_noise_share,
                          std::optional<double> known_noise_m) {
  const double rate = loading_rate_m_per_s(time_s, displacement_m);
  if (!(rate > 0.0)) return 0.0;
  const double noise_m =
      known_noise_m ? *known_noise_m : displacement_noise_m(time_s, displacement_m);
  return std::sqrt(2.0) * noise_m / (2.0 * rate_noise_share * rate);
}

std::vector<double> smoothed_displacement_m(const std::vector<double>& time_s,
                                            const std::vector<double>& displacement_m,
                                            std::optional<double> known_noise_m) {
  if (time_s.size() != displacement_m.size()) {
    throw std::invalid_argument("smoothed_displacement_m: " + std::to_string(time_s.size()) +
                                " times for " + std::to_string(displacement_m.size()) +
                                " displacements");
  }
  for (std::size_t k = 0; k < time_s.size(); ++k) {
    if (!std::isfinite(time_s[k]) || !std::isfinite(displacement_m[k]) ||
        (k > 0 && !(time_s[k] > time_s[k - 1]))) {
      throw std::invalid_argument("smoothed_displacement_m: row " + std::to_string(k) +
                                  " is not finite or not later than the row before");
    }
  }
  if (time_s.size() < kMinSmoothedRows) return displacement_m;
  const double noise_m =
      known_noise_m ? *known_noise_m : displacement_noise_m(time_s, displacement_m);
  const double half_s = rate_window_half_s(time_s, displacement_m, kPathRateNoiseShare, noise_m);
  // Rows already quieter than the target (a clean trial, a slow logger) stay as measured.
  if (!(noise_m > 0.0) || !(half_s >= median_row_interval_s(time_s))) return displacement_m;
  return linear_spline_fit(time_s, displacement_m, piece_ends(time_s, displacement_m, noise_m));
}

}  // namespace fl::workbench::detail
