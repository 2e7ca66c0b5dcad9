#pragma once
// The definitions of <sid/cvode/identify_robot.hpp>: included by it in header-only mode, compiled
// once into sid::cvode_compiled otherwise.

#include <sid/cvode/identify_robot.hpp>

#include <sid/cvode/chain_instrumental_variables.hpp>

#include <sid/detail/format.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace sid {

namespace detail {

/// With validate_fraction, the single run's last part becomes the first held-out run.
inline void hold_back_run_end(std::vector<NamedChainRun>& runs,
                              std::vector<NamedChainRun>& held_out, double fraction) {
  const char* who = "sid::identify_robot";
  if (!(fraction >= 0.0 && fraction < 1.0))
    throw std::invalid_argument(std::string(who) + ": validate_fraction must be in [0, 1), not " +
                                format_number("%g", fraction));
  if (fraction == 0.0) return;
  if (runs.size() != 1)
    throw std::invalid_argument(std::string(who) +
                                ": validate_fraction splits one run; give one run, not " +
                                std::to_string(runs.size()));
  NamedChainRun& run = runs.front();
  try {
    auto [first, last] = split_run(run.data, 1.0 - fraction);
    held_out.insert(
        held_out.begin(),
        {run.name + " (last " + format_number("%.3g", 100.0 * fraction) + " %)", std::move(last)});
    run.data = std::move(first);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(run.name + ": " + e.what());
  }
}

/// IDIM-IV from the least-squares fit's base parameters. When its estimate is used, it replaces
/// id's values and their (IV) standard deviations, and id.fitted becomes the first run's
/// prediction (iv.runs has every run's).
inline ChainIvRefinement refine_robot_by_iv(const ChainModel& model,
                                            const std::vector<NamedChainRun>& runs,
                                            const std::vector<ChainTrajectory<double>>& data,
                                            const RobotIdentifyOptions& options,
                                            ChainIdentification& id) {
  ChainInstrumentalVariableOptions iv_options;
  iv_options.prior = description_prior(model, options.description);
  ChainIvIdentification refined;
  try {
    refined = identify_chain_iv(model, id.base, data, options.fit, iv_options);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("estimator iv: ") + e.what());
  }
  ChainIvRefinement iv;
  iv.used = true;
  iv.iterations = refined.iv.iterations;
  iv.converged = refined.iv.converged;
  iv.residual_ratio = refined.residual_ratio;
  iv.least_squares = refined.least_squares.theta;
  if (!refined.iv.ok()) {
    iv.message = "the IV step failed (" + refined.iv.message + ")";
    return iv;
  }
  if (!refined.iv.converged) {
    iv.message = "the IV iteration did not converge (" + refined.iv.message +
                 "): the simulated motion does not follow the measured one closely enough";
    return iv;
  }
  if (!(refined.residual_ratio <= options.weak_instruments)) {
    iv.message = "the IV estimate leaves " + format_number("%.3g", refined.residual_ratio) +
                 " times least squares' residual (more than " +
                 format_number("%.3g", options.weak_instruments) +
                 "): the simulated motion does not follow the measured one, the instruments "
                 "are weak";
    return iv;
  }
  iv.applied = true;
  const double condition_number = id.fit.condition_number;
  id.fit = refined.iv.fit;
  id.fit.condition_number = condition_number;
  id.std_dev = id.fit.std_dev;
  id.relative_std_dev = 100.0 * id.std_dev.array() / id.fit.theta.array().abs();
  id.jackknife_std_dev.resize(0);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    iv.runs.push_back(predict_chain(model, id, data[r], options.fit));
    iv.runs.back().source = runs[r].name;
  }
  id.fitted = iv.runs.front();
  return iv;
}

/// RobotIdentification::consistent_cross_validation.
inline ConsistentCrossValidation cross_validate_consistency(
    const ChainModel& model, const std::vector<ChainTrajectory<double>>& runs,
    const Eigen::VectorXd& prior, const RobotIdentifyOptions& o, const RobotIdentification& out) {
  ConsistentCrossValidation cv;
  if (o.consistency_folds == 0) return cv;
  if (out.iv.applied) {
    cv.skipped = "the estimate is IV's, which the folds do not refit";
    return cv;
  }
  const ChainIdentification& id = out.identification;
  const Eigen::VectorXd inflation =
      id.std_dev.cwiseQuotient(id.fit.std_dev).unaryExpr([](double v) {
        return std::isfinite(v) ? v : 1.0;
      });
  std::vector<ChainFold> folds;
  try {
    folds = chain_folds(model, id, runs, o.fit, o.consistency_folds);
  } catch (const std::invalid_argument& e) {
    cv.skipped = e.what();
    return cv;
  }
  double consistent = 0.0, estimate = 0.0, yy = 0.0;
  for (std::size_t f = 0; f < folds.size(); ++f) {
    ChainFold& fold = folds[f];
    const std::string which = "fold " + std::to_string(f + 1) + "'s ";
    if (!fold.fit.fit.ok()) {
      cv.skipped = which + "fit failed (" + fold.fit.fit.message + ")";
      return cv;
    }
    fold.fit.std_dev = fold.fit.fit.std_dev.cwiseProduct(inflation);
    const ChainConsistentFit c = consistent_chain_parameters(model, fold.fit, prior);
    if (!c.converged) {
      cv.skipped = which + "consistent fit did not converge";
      return cv;
    }
    estimate += fold.residual_sum_of_squares(fold.fit.fit.theta);
    consistent += fold.residual_sum_of_squares(c.beta);
    yy += fold.y.squaredNorm();
  }
  cv.folds = o.consistency_folds;
  cv.consistent = std::sqrt(consistent / std::max(yy, 1e-300));
  cv.estimate = std::sqrt(estimate / std::max(yy, 1e-300));
  return cv;
}

}  // namespace detail

SID_INLINE RobotIdentification identify_robot(const ChainModel& model,
                                              std::vector<NamedChainRun> runs,
                                              std::vector<NamedChainRun> held_out,
                                              const RobotIdentifyOptions& options) {
  if (runs.empty()) throw std::invalid_argument("sid::identify_robot: no run given");
  if (options.consistency_folds < 0 || options.consistency_folds == 1)
    throw std::invalid_argument(
        "sid::identify_robot: consistency_folds must be 0 (none) or >= 2, not " +
        std::to_string(options.consistency_folds));
  detail::hold_back_run_end(runs, held_out, options.validate_fraction);
  RobotIdentifyOptions o = options;
  o.fit.weighted = options.estimator == ChainEstimator::WeightedLeastSquares;
  RobotIdentification out;
  std::vector<ChainTrajectory<double>> data;
  for (auto& r : runs) data.push_back(std::move(r.data));
  if (o.estimate_torque_delay) {
    out.torque_delay_estimate = estimate_torque_delay(model, data, o.fit, *o.estimate_torque_delay);
    o.fit.torque_delay = out.torque_delay_estimate->delay;
    if (out.torque_delay_estimate->at_bound)
      out.warnings.push_back(
          "the torque's delay behind the angles was found at the search's edge (" +
          detail::format_number(1e3 * o.fit.torque_delay) +
          " ms): it may be larger; search further");
  }
  out.torque_delay = o.fit.torque_delay;
  ChainIdentification& id = out.identification;
  id = identify_chain(model, data, o.fit);
  if (!id.fit.ok())
    throw std::invalid_argument("the base parameters cannot be identified from these runs: " +
                                id.fit.message);
  id.fitted.source = runs.size() == 1 ? runs.front().name : "all runs";
  if (o.estimator == ChainEstimator::InstrumentalVariables) {
    out.iv = detail::refine_robot_by_iv(model, runs, data, o, id);
    if (!out.iv.applied) out.warnings.push_back(out.iv.message);
  }
  for (const auto& r : held_out) {
    try {
      out.validation.push_back(predict_chain(model, id, r.data, o.fit));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(r.name + ": " + e.what());
    }
    out.validation.back().source = r.name;
  }
  const Eigen::VectorXd prior = description_prior(model, o.description);
  out.consistent = consistent_chain_parameters(model, id, prior);
  if (held_out.empty())
    out.consistent_cross_validation =
        detail::cross_validate_consistency(model, data, prior, o, out);
  ChainIdentification physical = id;
  physical.fit.theta = out.consistent.beta;
  for (const auto& r : held_out) {
    out.consistent_validation.push_back(predict_chain(model, physical, r.data, o.fit));
    out.consistent_validation.back().source = r.name;
  }
  if (id.fit.ill_conditioned) out.warnings.push_back(id.fit.message);
  for (std::size_t r = 0; r < runs.size(); ++r)
    out.fitted_runs.push_back({std::move(runs[r].name), std::move(data[r])});
  out.held_out_runs = std::move(held_out);
  return out;
}

SID_INLINE std::vector<DriveTermKind> robot_drive_term_kinds(
    const std::vector<DriveTermKind>& added) {
  std::vector<DriveTermKind> kinds = {DriveTermKind::Viscous, DriveTermKind::Armature};
  for (const DriveTermKind kind : added)
    if (std::find(kinds.begin(), kinds.end(), kind) == kinds.end()) kinds.push_back(kind);
  std::sort(kinds.begin(), kinds.end());
  return kinds;
}

SID_INLINE std::string ConsistentCost::measured_on() const {
  if (held_out) return "held-out runs";
  if (folds > 0)
    return std::to_string(folds) +
           " blocks of the fitted equations, each predicted from the others";
  return "fitted equations";
}

SID_INLINE ConsistentCost consistent_cost(const RobotIdentification& result) {
  ConsistentCost cost;
  if (result.validation.empty() ||
      result.consistent_validation.size() != result.validation.size()) {
    const ConsistentCrossValidation& cv = result.consistent_cross_validation;
    if (cv.folds > 0) {
      cost.consistent = cv.consistent;
      cost.estimate = cv.estimate;
      cost.folds = cv.folds;
      return cost;
    }
    cost.consistent = result.consistent.relative_residual;
    cost.estimate = result.consistent.least_squares_relative_residual;
    return cost;
  }
  cost.held_out = true;
  for (std::size_t r = 0; r < result.validation.size(); ++r) {
    cost.consistent += result.consistent_validation[r].relative_residual;
    cost.estimate += result.validation[r].relative_residual;
  }
  const auto runs = static_cast<double>(result.validation.size());
  cost.consistent /= runs;
  cost.estimate /= runs;
  return cost;
}

SID_INLINE std::string consistent_links_problem(const RobotIdentification& result,
                                                const ConsistentLinksPolicy& policy) {
  const ChainConsistentFit& c = result.consistent;
  if (!c.converged)
    return "the physically consistent fit did not converge in " + std::to_string(c.iterations) +
           " Newton steps; its links would not be a result";
  if (policy.strict && !c.fits_estimate)
    return "real bodies do not reproduce the estimate (misfit " +
           detail::format_number("%.3g", c.misfit) + " where noise alone gives at most " +
           detail::format_number("%.3g", c.misfit_limit) +
           "; a drive term the data have may be missing from the effects)";
  const ConsistentCost cost = consistent_cost(result);
  if (!(cost.extra() <= policy.max_extra_error))
    return "the nearest real bodies predict the torque (" + cost.measured_on() + ") with " +
           detail::format_number("%.3g", 100.0 * cost.consistent) +
           " % error against the "
           "estimate's " +
           detail::format_number("%.3g", 100.0 * cost.estimate) + " % (" +
           detail::format_number("%.0f", 100.0 * cost.extra()) + " % more, above the " +
           detail::format_number("%.0f", 100.0 * policy.max_extra_error) +
           " % allowed; a drive term the data have may be missing from the effects)";
  return {};
}

}  // namespace sid
