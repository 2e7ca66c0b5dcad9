#pragma once
// Definitions of sid/study/chain_montecarlo.hpp (see sid/config.hpp).

#include <sid/detail/format.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/study/chain_montecarlo.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

namespace detail {

/// The window every method but css_tcv fits: [t0 + skip, t_end - skip_end] of the true samples
/// (filtered: filtered_skip at the start).
inline std::pair<double, double> chain_study_window(StudyMethod method,
                                                    const ChainKinematics<double>& truth,
                                                    const IdentifyOptions& k) {
  const double skip = method == StudyMethod::Filtered ? k.filtered_skip : k.skip;
  return {truth.t[0] + skip, truth.t[truth.size() - 1] - k.skip_end};
}

/// Each joint's angle error variance: the noise's and the encoder's rounding's (step² / 12).
inline Eigen::VectorXd angle_error_variance(const ChainModel& model, double sigma_q2,
                                            const LoggedSensors& sensors) {
  const Eigen::VectorXd steps = encoder_steps(sensors, model.chain(), "sid::run_chain_monte_carlo");
  return (sigma_q2 + steps.array().square() / 12.0).matrix();
}

/// sid_identify --robot's pipeline on the run: cutoffs chosen by held-out torque prediction,
/// torque filtered alike, equations at rest left out; the torque's delay estimated if asked.
inline ChainStudyFit identify_study_run(const ChainModel& model, const BaseParameters<double>& base,
                                        const ChainTrajectory<double>& measured,
                                        const ChainMonteCarloOptions& options) {
  ChainIdentifyOptions identify = options.identify;
  std::optional<double> delay;
  if (options.estimate_torque_delay) {
    delay =
        estimate_torque_delay(model, {measured}, identify, *options.estimate_torque_delay).delay;
    identify.torque_delay = *delay;
  }
  const ChainIdentification id = identify_chain(model, {measured}, identify);
  if (id.base.independent != base.independent)
    throw std::invalid_argument("sid::fit_chain_study_method: the run leaves " +
                                std::to_string(base.rank() - id.base.rank()) +
                                " base parameters undetermined");
  return {id.fit, {}, delay};
}

}  // namespace detail

SID_INLINE ChainStudyFit fit_chain_study_method(StudyMethod method, const ChainModel& model,
                                                const BaseParameters<double>& base,
                                                const ChainKinematics<double>& truth,
                                                const ChainTrajectory<double>& measured,
                                                double sigma_q2,
                                                const ChainMonteCarloOptions& options) {
  const char* who = "sid::fit_chain_study_method";
  LeastSquaresOptions ls = options.least_squares;
  if (method == StudyMethod::CssIv && !options.refine)
    throw std::invalid_argument(
        std::string(who) +
        ": css_iv needs the IV step (sid::chain_instrumental_variable_step() "
        "from sid/cvode/chain_instrumental_variables.hpp)");
  if (method == StudyMethod::CssTorqueCv)
    return detail::identify_study_run(model, base, measured, options);
  const ChainKinematics<double> k = detail::method_kinematics(
      method, truth, measured, detail::angle_error_variance(model, sigma_q2, options.sensors),
      options.kinematics, kChainInstrumentalVariableLambdaScale);
  const auto [from, to] = detail::chain_study_window(method, truth, options.kinematics);
  const ChainKinematics<double> kept = detail::window_rows(k, from, to);
  const std::vector<Eigen::Index> samples =
      chain_regression_samples(kept.t, options.identify.regression_rate_hz);
  const ChainRegression r = chain_regression(model, base.independent, kept, samples);
  if (r.x.rows() <= r.x.cols())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(r.x.rows()) +
                                " equations for " + std::to_string(r.x.cols()) +
                                " base parameters; the window is too short");
  const auto joints = static_cast<Eigen::Index>(model.joints());
  LeastSquaresResult<double> fit = least_squares(r.x, r.y, joints, ls);
  if (method == StudyMethod::CssIv && fit.ok()) {
    try {
      return {options.refine(model, base, kept, samples, fit), {}, {}};
    } catch (const RefinementDeclined& e) {
      return {std::move(fit), e.what(), {}};
    }
  }
  if (method != StudyMethod::CssWls || !fit.ok() || !(fit.sigma2_per_joint.array() > 0.0).all())
    return {std::move(fit), {}, {}};
  // Gautier's IDIM-WLS, as fit_two_link_weighted: each joint's rows by 1/σ̂_j² of a first fit.
  const Eigen::Index m = r.y.size() / joints;
  Eigen::VectorXd weights(r.y.size());
  for (Eigen::Index j = 0; j < joints; ++j)
    weights.segment(j * m, m).setConstant(1.0 / fit.sigma2_per_joint[j]);
  return {weighted_least_squares(r.x, r.y, weights, joints, ls), {}, {}};
}

namespace detail {

SID_INLINE void check_chain_monte_carlo_input(const ChainModel& model, const Eigen::VectorXd& theta,
                                              const ChainKinematics<double>& truth,
                                              const ChainMonteCarloOptions& options) {
  const char* who = "sid::run_chain_monte_carlo";
  check_study_settings(options, who);
  (void)encoder_steps(options.sensors, model.chain(), who);
  const double reach = std::min(options.identify.skip, options.identify.skip_end);
  if (options.estimate_torque_delay && !(options.estimate_torque_delay->max_delay > 0.0 &&
                                         options.estimate_torque_delay->max_delay <= reach))
    throw std::invalid_argument(
        std::string(who) + ": the torque delay's search reaches max_delay within (0, " +
        detail::format_number("%g", reach) + "] s, the identification's skips");
  for (StudyMethod m : options.methods)
    if (m == StudyMethod::CssIv && !options.refine)
      throw std::invalid_argument(std::string(who) +
                                  ": method css_iv needs the IV step "
                                  "(sid::chain_instrumental_variable_step() from "
                                  "sid/cvode/chain_instrumental_variables.hpp)");
  if (theta.size() != model.parameters() || !theta.allFinite())
    throw std::invalid_argument(std::string(who) + ": theta must hold " +
                                std::to_string(model.parameters()) +
                                " finite values, the model's parameters");
  const Eigen::Index n = truth.size();
  if (n < 4 || truth.q.rows() != n || truth.qd.rows() != n || truth.qdd.rows() != n ||
      truth.tau.rows() != n)
    throw std::invalid_argument(std::string(who) +
                                ": truth needs at least 4 samples and columns of equal length");
  for (const auto* m : {&truth.q, &truth.qd, &truth.qdd, &truth.tau})
    if (m->cols() != model.joints())
      throw std::invalid_argument(std::string(who) + ": truth has " + std::to_string(m->cols()) +
                                  " joint columns, the model " + std::to_string(model.joints()));
}

}  // namespace detail

SID_INLINE ChainMonteCarloResult run_chain_monte_carlo(const ChainModel& model,
                                                       const Eigen::VectorXd& theta,
                                                       const ChainKinematics<double>& truth,
                                                       const ChainMonteCarloOptions& options) {
  const char* who = "sid::run_chain_monte_carlo";
  detail::check_chain_monte_carlo_input(model, theta, truth, options);
  const auto start = std::chrono::steady_clock::now();
  const BaseParameters<double> base = chain_base_parameters(model, options.identify);
  ChainMonteCarloResult result;
  result.parameter_names = base_parameter_names(base, model.parameter_names(), 6);
  result.parameter_combinations = base_parameter_names(base, model.parameter_names(), 0);
  result.theta = theta;
  result.beta = base.beta(theta);
  result.runs = options.runs;
  result.seed = options.seed;
  // Relative figures only where the truth is not zero: a combination that vanishes in exact
  // arithmetic is left with rounding noise by the regrouping.
  const double largest = result.beta.cwiseAbs().maxCoeff();
  Eigen::VectorXd relative_to = result.beta;
  for (Eigen::Index k = 0; k < relative_to.size(); ++k) {
    const bool zero = !(std::abs(relative_to[k]) > 1e-9 * largest);
    result.zero_in_truth.push_back(zero);
    if (zero) relative_to[k] = 0.0;
  }

  // The true torque at the true motion over the widest window (the prediction each estimate is
  // scored on): the same equations for every method.
  const double t0 = truth.t[0], t_end = truth.t[truth.size() - 1];
  const ChainKinematics<double> scored =
      detail::window_rows(truth, t0 + options.kinematics.skip, t_end - options.kinematics.skip_end);
  const ChainRegression exact =
      chain_regression(model, base.independent, scored,
                       chain_regression_samples(scored.t, options.identify.regression_rate_hz));
  if (exact.x.rows() <= exact.x.cols())
    throw std::invalid_argument(
        "sid::run_chain_monte_carlo: the window [skip, end - skip_end] "
        "leaves " +
        std::to_string(exact.x.rows()) + " equations for " + std::to_string(exact.x.cols()) +
        " base parameters");
  result.equations = exact.x.rows();
  const double exact_norm = exact.y.norm();

  result.levels = detail::empty_levels(options, base.rank());
  for (auto& level : result.levels)
    for (auto& summary : level.methods) {
      summary.torque_error_pct =
          Eigen::VectorXd::Constant(options.runs, std::numeric_limits<double>::quiet_NaN());
      summary.declined.assign(static_cast<std::size_t>(options.runs), std::string());
    }
  const ChainTrajectory<double> exact_run{truth.t, truth.q, truth.tau};
  const Eigen::VectorXd steps = encoder_steps(options.sensors, model.chain(), who);
  // The delay shifts the torque, not its noise: logged = delayed truth + the same draws.
  const Eigen::MatrixXd torque_shift =
      delayed_channel(truth.t, truth.tau, options.sensors.torque_delay) - truth.tau;
  const auto tcv =
      std::find(options.methods.begin(), options.methods.end(), StudyMethod::CssTorqueCv);
  if (options.estimate_torque_delay && tcv != options.methods.end())
    result.torque_delays.assign(
        options.sigma_q2_levels.size(),
        Eigen::VectorXd::Constant(options.runs, std::numeric_limits<double>::quiet_NaN()));
  result.threads_used = detail::run_study_jobs(
      options, result.levels,
      [&](std::size_t l, int run, const std::function<void(std::size_t, std::string)>& fail) {
        const double sigma_q2 = options.sigma_q2_levels[l];
        std::mt19937_64 rng = run_generator(options.seed, l, run);
        const ChainTrajectory<double> noisy = add_measurement_noise(
            exact_run, MeasurementNoise<double>{sigma_q2, options.sigma_tau2}, rng);
        ChainTrajectory<double> logged = noisy;
        if (options.sensors.torque_delay != 0.0) logged.tau += torque_shift;
        round_to_encoders(steps, logged.q);
        for (std::size_t m = 0; m < options.methods.size(); ++m) {
          MethodSummary& summary = result.levels[l].methods[m];
          const StudyMethod method = options.methods[m];
          std::string failure;
          try {
            ChainStudyFit study_fit = fit_chain_study_method(
                method, model, base, truth, method == StudyMethod::Oracle ? noisy : logged,
                sigma_q2, options);
            const LeastSquaresResult<double>& fit = study_fit.fit;
            summary.declined[static_cast<std::size_t>(run)] = std::move(study_fit.declined);
            if (study_fit.torque_delay && !result.torque_delays.empty())
              result.torque_delays[l][run] = *study_fit.torque_delay;
            if (fit.ok() && fit.theta.allFinite()) {
              summary.estimates.row(run) = fit.theta.transpose();
              summary.torque_error_pct[run] =
                  100.0 * (exact.x * fit.theta - exact.y).norm() / exact_norm;
            } else {
              failure = fit.ok() ? "the estimate is not finite" : fit.message;
            }
          } catch (const std::exception& e) {
            failure = e.what();
          }
          if (!failure.empty()) fail(m, std::move(failure));
        }
      });
  for (auto& level : result.levels)
    for (auto& summary : level.methods) detail::summarize_estimates(summary, relative_to);
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace sid
