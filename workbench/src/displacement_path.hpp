// A compress trial's displacement column as the workbench reads it: its noise, the window that
// takes the noise out of a rate, and the crosshead's path with the logger's noise taken out
// (what the twin's plate follows). Shared by compare's phases and the compress twin.
#pragma once

#include <optional>
#include <vector>

#include "fl/workbench/dataset.hpp"

namespace fl::workbench::detail {

// The displacement noise (1 sigma, m) the dataset's manifest states; none if it states none.
// Where stated it replaces the rows' own estimate, for the phases and the plate path alike.
std::optional<double> stated_displacement_noise_m(const Dataset& dataset);

// The displacement noise of a trial, 1 sigma, from its own rows: the median offset of each
// row from the straight line through its two neighbours, in time (a ramp's is zero, a corner
// spoils one or two of many), scaled to a white noise's sigma. 0 for fewer than three rows.
double displacement_noise_m(const std::vector<double>& time_s,
                            const std::vector<double>& displacement_m);

// The trial's loading rate: the fastest displacement rate over spans of 1 % of the rows,
// which averages the noise out and still fits inside any ramp. 0 for a still trial.
double loading_rate_m_per_s(const std::vector<double>& time_s,
                            const std::vector<double>& displacement_m);

// The half-width of a time window whose rate, (d(t + h) - d(t - h)) / 2h, has the trial's own
// displacement noise at `rate_noise_share` of its loading rate: sqrt(2) sigma / (2 h) =
// share x rate. 0 for a clean or still trial.
// The noise is `known_noise_m` when given, else the rows' own estimate.
double rate_window_half_s(const std::vector<double>& time_s,
                          const std::vector<double>& displacement_m, double rate_noise_share,
                          std::optional<double> known_noise_m = std::nullopt);

// The crosshead's path with the logger's noise taken out, row for row: a continuous,
// piecewise straight path (a test machine's ramps and holds), fitted by least squares. The
// rows are cut where two straight lines fit them best until every piece is straight to within
// the trial's own displacement noise; the pieces then meet at their ends (a linear spline, so
// the plate never jumps). A curved path becomes as many pieces as its noise asks for. A trial
// whose rows are already quiet (a clean one, or a slow logger: the rate noise over the
// neighbouring rows under 1 % of the loading rate) or short (under 32 rows) is returned
// unchanged, bit for bit. Throws std::invalid_argument for columns of different lengths, a
// value that is not finite or a time not later than the one before.
// `known_noise_m`, when given (the manifest's displacement noise), replaces the rows' own
// estimate, which a filtering logger's correlated noise leaves too low.
std::vector<double> smoothed_displacement_m(const std::vector<double>& time_s,
                                            const std::vector<double>& displacement_m,
                                            std::optional<double> known_noise_m = std::nullopt);

}  // namespace fl::workbench::detail
