#pragma once
/// @file
/// @brief Whether a logged signal lies on a grid (an encoder's counts, a fixed number of logged
/// decimals), and its step.
///
/// Methods that assume white measurement noise (GCV smoothing, the noise floors of simulated
/// logs) take a quantised signal's error for signal: it is a deterministic, slowly varying
/// function of the signal itself. A real log's angles are nearly always quantised, a simulated
/// log's with Gaussian noise never are, so the grid tells the two apart without asking.

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace sid {

/// @brief The step of the grid x lies on, or 0 when it does not.
///
/// The step is one of the three smallest non-zero differences between consecutive samples that
/// recur (three times within 1e-6 of each other), or a half, third or quarter of it; x is on
/// its grid when at least `share` of the non-zero differences are whole multiples of it (within
/// 5 % of a step, which floating-point decimals and scaled counts keep far inside). A continuous
/// signal with noise passes this by chance for about a tenth of its differences. Fewer than 20
/// non-zero differences say nothing: 0.
inline double quantisation_step(const Eigen::Ref<const Eigen::VectorXd>& x, double share = 0.95) {
  std::vector<double> steps;
  steps.reserve(static_cast<std::size_t>(std::max<Eigen::Index>(x.size() - 1, 0)));
  for (Eigen::Index i = 1; i < x.size(); ++i) {
    const double d = std::abs(x[i] - x[i - 1]);
    if (d > 0.0 && std::isfinite(d)) steps.push_back(d);
  }
  if (steps.size() < 20) return 0.0;
  // The smallest differences that recur: a glitch or a resampled value is off the grid, an
  // encoder's step recurs; a continuous signal's differences never do. A signal that moves
  // several steps per sample may never move by one: a candidate may be a few steps.
  std::sort(steps.begin(), steps.end());
  std::vector<double> candidates;
  for (std::size_t i = 0, same = 1; i + 1 < steps.size() && candidates.size() < 3; ++i) {
    same = steps[i + 1] - steps[i] <= 1e-6 * steps[i + 1] ? same + 1 : 1;
    if (same == 3) candidates.push_back(steps[i + 1]);
  }
  for (const double candidate : candidates)
    for (int divisor = 1; divisor <= 4; ++divisor) {
      const double step = candidate / divisor;
      std::size_t whole = 0;
      for (const double d : steps) {
        const double multiple = d / step;
        if (std::abs(multiple - std::round(multiple)) < 0.05) ++whole;
      }
      if (static_cast<double>(whole) >= share * static_cast<double>(steps.size())) return step;
    }
  return 0.0;
}

/// @brief The median of |x[i] − x[i−1]| / step over consecutive samples (those that do not move
/// included): how many steps of its grid a quantised signal moves per sample. Below about two
/// it moves as a staircase, its error is a slow sawtooth rather than white noise, and GCV
/// follows the stairs. NaN for fewer than 2 samples or a step that is not > 0.
inline double median_move_in_steps(const Eigen::Ref<const Eigen::VectorXd>& x, double step) {
  if (x.size() < 2 || !(step > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  std::vector<double> moves(static_cast<std::size_t>(x.size() - 1));
  for (Eigen::Index i = 1; i < x.size(); ++i)
    moves[static_cast<std::size_t>(i - 1)] = std::abs(x[i] - x[i - 1]) / step;
  const auto middle = moves.begin() + static_cast<std::ptrdiff_t>(moves.size() / 2);
  std::nth_element(moves.begin(), middle, moves.end());
  return *middle;
}

}  // namespace sid
