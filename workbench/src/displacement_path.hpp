// A compress trial's displacement column as the workbench reads it: its noise, the window that
// takes the noise out of a rate, and the crosshead's path with the logger's noise taken out
// (what the twin's plate follows). Shared by compare's phases and the compress twin.
#pragma once

#include <vector>

namespace fl::workbench::detail {

// The displacement noise of a trial, 1 sigma, from its own rows: the median absolute second
// difference (a ramp's is zero, a corner's one row of many) is 0.6745 sqrt(6) sigma for white
// noise. 0 for fewer than three rows.
double displacement_noise_m(const std::vector<double>& displacement_m);

// The trial's loading rate: the fastest displacement rate over spans of 1 % of the rows,
// which averages the noise out and still fits inside any ramp. 0 for a still trial.
double loading_rate_m_per_s(const std::vector<double>& time_s,
                            const std::vector<double>& displacement_m);

// The half-width of a time window whose rate, (d(t + h) - d(t - h)) / 2h, has the trial's own
// displacement noise at `rate_noise_share` of its loading rate: sqrt(2) sigma / (2 h) =
// share x rate. 0 for a clean or still trial.
double rate_window_half_s(const std::vector<double>& time_s,
                          const std::vector<double>& displacement_m, double rate_noise_share);

// The crosshead's path with the logger's noise taken out, row for row: a continuous,
// piecewise straight path (a test machine's ramps and holds), fitted by least squares. The
// rows are cut where two straight lines fit them best until every piece is straight to within
// the trial's own displacement noise; the pieces then meet at their ends (a linear spline, so
// the plate never jumps). A curved path becomes as many pieces as its noise asks for. A trial
// whose rows are already quiet (a clean one, or a slow logger: the rate noise of neighbouring
// rows under 1 % of the loading rate) is returned unchanged, bit for bit.
std::vector<double> smoothed_displacement_m(const std::vector<double>& time_s,
                                            const std::vector<double>& displacement_m);

}  // namespace fl::workbench::detail
