#pragma once
// Definitions of sid/torque_delay.hpp (see sid/config.hpp). The compiled library holds them in
// the same unit as identify_chain's, whose equation builders they share.

#include <sid/detail/golden_section.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/identify_chain-inl.hpp>
#include <sid/least_squares.hpp>
#include <sid/torque_delay.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {
namespace detail {

/// The runs' angles smoothed at `cutoff` and paired with the torque `delay` later. The torque,
/// filtered or not, is the runs' own (smooth_joint leaves it when not asked to filter it).
inline void smooth_delayed(std::vector<SmoothedChainRun>& runs, const Eigen::VectorXd& cutoff,
                           double delay) {
  for (auto& s : runs) {
    s.torque_delay = delay;
    for (Eigen::Index j = 0; j < cutoff.size(); ++j)
      s.smooth_joint(static_cast<int>(j), cutoff[j], false);
  }
}

/// The equations of `rows` (their joints, samples and torque) with the regressor of the angles
/// `delay` earlier. The rows stay those of no delay: rows left out at rest that moved with the
/// delay would move the residual by more than the delay's own effect.
inline std::vector<ChainEquations> delayed_equations(const ChainModel& model,
                                                     std::vector<SmoothedChainRun>& runs,
                                                     const std::vector<ChainEquations>& rows,
                                                     const std::vector<Eigen::Index>& columns,
                                                     const Eigen::VectorXd& cutoff, double delay) {
  smooth_delayed(runs, cutoff, delay);
  std::vector<ChainEquations> out = rows;
  for (std::size_t r = 0; r < runs.size(); ++r)
    out[r].x = regressor_on_rows(model, runs[r], rows[r], columns);
  return out;
}

/// The least-squares fit's mean squared residual with the torque `delay` behind the angles.
inline double delayed_mean_square_residual(const ChainModel& model,
                                           std::vector<SmoothedChainRun>& runs,
                                           const std::vector<ChainEquations>& rows,
                                           const std::vector<Eigen::Index>& columns,
                                           const Eigen::VectorXd& cutoff, double delay,
                                           const ChainIdentifyOptions& o) {
  const StackedChainEquations stacked =
      stack_equations(delayed_equations(model, runs, rows, columns, cutoff, delay));
  if (stacked.x.rows() <= stacked.x.cols()) return std::numeric_limits<double>::infinity();
  const LeastSquaresResult<double> fit = least_squares(stacked.x, stacked.y, 1, o.least_squares);
  if (!fit.ok()) return std::numeric_limits<double>::infinity();
  return fit.residual.squaredNorm() / static_cast<double>(stacked.y.size());
}

/// The delay's HAC standard deviation: the regression at `delay` linearised in the delay, whose
/// column is the derivative of the predicted torque (central difference over ±step).
inline double torque_delay_std_dev(const ChainModel& model, std::vector<SmoothedChainRun>& runs,
                                   const std::vector<ChainEquations>& rows,
                                   const std::vector<Eigen::Index>& columns,
                                   const Eigen::VectorXd& cutoff, double delay, double step,
                                   const ChainIdentifyOptions& o) {
  std::vector<ChainEquations> equations =
      delayed_equations(model, runs, rows, columns, cutoff, delay);
  const StackedChainEquations stacked = stack_equations(equations);
  const LeastSquaresResult<double> fit = least_squares(stacked.x, stacked.y, 1, o.least_squares);
  if (!fit.ok()) return std::nan("");
  const std::vector<ChainEquations> later =
      delayed_equations(model, runs, rows, columns, cutoff, delay + step);
  const std::vector<ChainEquations> earlier =
      delayed_equations(model, runs, rows, columns, cutoff, delay - step);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    ChainEquations& e = equations[r];
    e.x.conservativeResize(Eigen::NoChange, e.x.cols() + 1);
    e.x.col(e.x.cols() - 1) = (later[r].x - earlier[r].x) * fit.theta / (2.0 * step);
  }
  const StackedChainEquations augmented = stack_equations(equations);
  const LeastSquaresResult<double> linearised =
      least_squares(augmented.x, augmented.y, 1, o.least_squares);
  if (!linearised.ok()) return std::nan("");
  const Eigen::VectorXd ones = Eigen::VectorXd::Ones(augmented.y.size());
  return chain_hac_std_dev(equations, linearised, ones).tail(1)[0];
}

}  // namespace detail

SID_INLINE TorqueDelayEstimate
estimate_torque_delay(const ChainModel& model, const std::vector<ChainTrajectory<double>>& runs,
                      const ChainIdentifyOptions& options, const TorqueDelaySearch& search) {
  const char* who = "sid::estimate_torque_delay";
  ChainIdentifyOptions o = options;
  o.torque_delay = 0.0;
  detail::check_chain_options(o, model.joints(), who);
  if (!(search.max_delay > 0.0 && search.max_delay <= std::min(o.skip, o.skip_end) + 1e-12))
    throw std::invalid_argument(std::string(who) +
                                ": max_delay must be > 0 and within the skips (" +
                                std::to_string(std::min(o.skip, o.skip_end)) + " s)");
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  const int n = model.joints();
  std::vector<detail::SmoothedChainRun> smoothed = detail::smoothed_runs(model, runs, o, who);
  const BaseParameters<double> base =
      detail::runs_base_parameters(model, chain_base_parameters(model, o), smoothed, o);
  const std::vector<Eigen::Index>& columns = base.independent;

  TorqueDelayEstimate out;
  Eigen::VectorXd cutoff;
  if (o.cutoff_hz.empty()) {
    double score = 0.0;
    cutoff = Eigen::VectorXd::Constant(
        n, detail::choose_shared_cutoff(model, smoothed, columns, o, score));
  } else {
    cutoff = detail::expand_cutoffs(o.cutoff_hz, n);
  }
  out.cutoff_hz = cutoff.mean();

  // The residual varies over a quarter period of the cutoff (4 ms at 64 Hz): a coarse grid of
  // 33 delays finds its valley, the golden-section search the bottom.
  const Eigen::Index points = 16;
  const double step = search.max_delay / static_cast<double>(points);
  out.delays = Eigen::VectorXd::LinSpaced(2 * points + 1, -search.max_delay, search.max_delay);
  out.mean_square_residual.resize(out.delays.size());
  // The torque does not move with the delay: filtered once. The rows are those of no delay.
  for (auto& s : smoothed)
    for (int j = 0; j < n; ++j) s.smooth_joint(j, cutoff[j], o.filter_torque);
  const std::vector<detail::ChainEquations> rows =
      detail::all_equations(model, smoothed, columns, o.rest_fraction);
  const auto residual_at = [&](double delay) {
    return detail::delayed_mean_square_residual(model, smoothed, rows, columns, cutoff, delay, o);
  };
  // Each delay on a copy of the runs of its thread's: the profile does not depend on the count.
  const int threads = detail::thread_count(o.threads);
  std::vector<std::vector<detail::SmoothedChainRun>> copies(static_cast<std::size_t>(threads),
                                                            smoothed);
  detail::for_each_index(out.delays.size(), threads, [&](Eigen::Index k, int worker) {
    out.mean_square_residual[k] = detail::delayed_mean_square_residual(
        model, copies[static_cast<std::size_t>(worker)], rows, columns, cutoff, out.delays[k], o);
  });
  copies.clear();
  Eigen::Index best = 0;
  for (Eigen::Index k = 0; k < out.delays.size(); ++k)
    if (out.mean_square_residual[k] < out.mean_square_residual[best]) best = k;
  if (!std::isfinite(out.mean_square_residual[best]))
    throw std::invalid_argument(std::string(who) +
                                ": no delay gives a fit; the runs do not excite the model's base "
                                "parameters");
  out.at_bound = best == 0 || best == out.delays.size() - 1;

  // Golden-section search between the best grid point's neighbours.
  out.delay = detail::golden_section_minimum(
      residual_at, out.delays[std::max<Eigen::Index>(best - 1, 0)],
      out.delays[std::min<Eigen::Index>(best + 1, out.delays.size() - 1)], 1e-2 * step);
  // The derivative's difference stays inside the skips.
  const double difference =
      std::min(0.25 * step, std::min(o.skip, o.skip_end) - std::abs(out.delay));
  if (difference > 1e-3 * step)
    out.std_dev = detail::torque_delay_std_dev(model, smoothed, rows, columns, cutoff, out.delay,
                                               difference, o);
  return out;
}

}  // namespace sid
