#pragma once
// Definitions of sid/cvode/instrumental_variables.hpp (see sid/config.hpp).

#include <sid/cvode/instrumental_variables.hpp>

#include <cstddef>

namespace sid {

namespace detail {

SID_INLINE void fill_iv_statistics(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                                   const Eigen::MatrixXd& w, const Eigen::VectorXd& scale,
                                   const Eigen::VectorXd& theta, LeastSquaresResult<double>& fit,
                                   int joints) {
  const Eigen::Index m = x.rows(), p = x.cols(), per_joint = m / joints;
  fit.status = LeastSquaresStatus::Success;
  fit.theta = theta;
  fit.residual = y - x * theta;
  fit.residual_rms.resize(joints);
  fit.sigma2_per_joint.resize(joints);
  const double dof_share = static_cast<double>(m - p) / joints;
  for (int j = 0; j < joints; ++j) {
    const double rss = fit.residual.segment(j * per_joint, per_joint).squaredNorm();
    fit.residual_rms[j] = std::sqrt(rss / static_cast<double>(per_joint));
    fit.sigma2_per_joint[j] = rss / dof_share;
  }
  fit.sigma2 = fit.residual.squaredNorm() / static_cast<double>(m - p);
  // In scaled coordinates: cov = σ² (WᵀX)⁻¹ WᵀW (XᵀW)⁻¹, then undo the column scaling.
  const Eigen::MatrixXd xs = x * scale.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd ws = w * scale.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd wtx = ws.transpose() * xs;
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(wtx);
  const Eigen::MatrixXd a = lu.inverse();
  const Eigen::MatrixXd cov_scaled = fit.sigma2 * a * (ws.transpose() * ws) * a.transpose();
  fit.covariance =
      scale.cwiseInverse().asDiagonal() * cov_scaled * scale.cwiseInverse().asDiagonal();
  fit.std_dev = fit.covariance.diagonal().cwiseSqrt();
  fit.relative_std_dev = 100.0 * fit.std_dev.cwiseQuotient(theta.cwiseAbs());
  const Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::NoQRPreconditioner> svd(wtx);  // square
  const auto& s = svd.singularValues();
  fit.condition_number =
      s[s.size() - 1] > 0.0 ? s[0] / s[s.size() - 1] : std::numeric_limits<double>::infinity();
  fit.rank = lu.rank();
  fit.column_scale = scale;
  fit.dependent_columns.clear();
}

/// Throws std::invalid_argument, with its reason, on input refine_instrumental_variables refuses.
SID_INLINE void check_iv_inputs(const Kinematics<double>& k,
                                const LeastSquaresResult<double>& first,
                                const InstrumentalVariableOptions& options, const char* who) {
  const Eigen::Index n = k.size();
  if (first.theta.size() != 7 || !first.ok())
    throw std::invalid_argument(std::string(who) +
                                ": the first fit must be a successful 7-parameter fit");
  if (n < 8 || k.q.rows() != n || k.qd.rows() != n || k.qdd.rows() != n || k.tau.rows() != n)
    throw std::invalid_argument(std::string(who) +
                                ": kinematics need at least 8 samples with equal lengths");
  if (options.max_iterations < 1)
    throw std::invalid_argument(std::string(who) + ": max_iterations must be >= 1");
  if (!(options.segment > 0.0))
    throw std::invalid_argument(std::string(who) + ": segment must be > 0");
  if (!(options.tolerance > 0.0))
    throw std::invalid_argument(std::string(who) + ": tolerance must be > 0");
}

SID_INLINE bool solve_iv(const Eigen::MatrixXd& w, const Eigen::MatrixXd& x_scaled,
                         const Eigen::VectorXd& y, const Eigen::VectorXd& scale, const char* who,
                         int it, Eigen::VectorXd& next, InstrumentalVariableResult& result) {
  const Eigen::MatrixXd w_scaled = w * scale.cwiseInverse().asDiagonal();
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(w_scaled.transpose() * x_scaled);
  if (qr.rank() < x_scaled.cols()) {
    result.failed = true;
    result.message = std::string(who) + ": the instruments of iteration " + std::to_string(it) +
                     " are not correlated with every regressor column (W^T X is singular)";
    return false;
  }
  next = qr.solve(w_scaled.transpose() * y).cwiseQuotient(scale);
  if (!next.allFinite()) {
    result.failed = true;
    result.message =
        std::string(who) + ": iteration " + std::to_string(it) + " gave a non-finite estimate";
    return false;
  }
  return true;
}

/// What the instrument simulations of the runs need: each run's drive (its measured torque
/// smoothed by GCV), the simulated states at its samples (times and drive filled in) and the
/// samples' positions in them.
struct IvSimulations {
  std::vector<JointSamples<double, Eigen::Dynamic>> drives;
  std::vector<ChainKinematics<double>> simulated;
  std::vector<std::vector<Eigen::Index>> every;
};

SID_INLINE IvSimulations iv_simulations(const std::vector<ChainKinematics<double>>& runs,
                                        const std::vector<std::vector<Eigen::Index>>& samples,
                                        int joints) {
  IvSimulations out;
  out.simulated.resize(runs.size());
  out.every.resize(runs.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    out.drives.push_back(smoothed_torque(runs[r]));
    const auto count = static_cast<Eigen::Index>(samples[r].size());
    ChainKinematics<double>& s = out.simulated[r];
    s.t.resize(count);
    s.tau.resize(count, joints);
    for (Eigen::Index a = 0; a < count; ++a) {
      s.t[a] = runs[r].t[samples[r][static_cast<std::size_t>(a)]];
      s.tau.row(a) = out.drives[r].row(samples[r][static_cast<std::size_t>(a)]);
      out.every[r].push_back(a);
    }
    s.q.resize(count, joints);
    s.qd.resize(count, joints);
    s.qdd.resize(count, joints);
  }
  return out;
}

/// The states of the arm's `body` at the times of `samples`, driven by `drive`, and their
/// accelerations; each segment starts from k's state. False, with the failure in result, if a
/// simulation failed.
SID_INLINE bool simulate_iv_states(const Arm& arm, const Eigen::VectorXd& body,
                                   const ChainKinematics<double>& k,
                                   const JointSamples<double, Eigen::Dynamic>& drive,
                                   const std::vector<Eigen::Index>& samples,
                                   const IvSettings& settings, const char* who, int it,
                                   ChainKinematics<double>& simulated,
                                   InstrumentalVariableResult& result) {
  using Vector = Arm::Vector;
  const int n = arm.joints();
  const auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                       Eigen::Map<Eigen::VectorXd>& xdot) {
    const Vector q = x.head(n), qd = x.tail(n);
    xdot.head(n) = qd;
    xdot.tail(n) = arm.forward_dynamics(body, q, qd, drive_at(k.t, drive, time));
  };
  const bool simulated_ok = simulate_segments(
      rhs,
      [&](Eigen::Index begin) {
        const Eigen::Index at = samples[static_cast<std::size_t>(begin)];
        Eigen::VectorXd start(2 * n);
        start << k.q.row(at).transpose(), k.qd.row(at).transpose();
        return start;
      },
      settings.segment, settings.simulator, who, it, simulated, result);
  if (!simulated_ok) return false;
  for (Eigen::Index a = 0; a < simulated.size(); ++a) {
    const Vector q = simulated.q.row(a).transpose(), qd = simulated.qd.row(a).transpose(),
                 tau = simulated.tau.row(a).transpose();
    simulated.qdd.row(a) = arm.forward_dynamics(body, q, qd, tau).transpose();
  }
  return true;
}

/// The change from theta to next that the convergence test compares with the tolerance.
SID_INLINE double iv_change(const Eigen::VectorXd& theta, const Eigen::VectorXd& next,
                            const Eigen::VectorXd& scale, IvConvergence convergence) {
  if (convergence == IvConvergence::Relative)
    return (next - theta).cwiseQuotient(theta).cwiseAbs().maxCoeff();
  const Eigen::VectorXd scaled_next = next.cwiseProduct(scale);
  return (scaled_next - theta.cwiseProduct(scale)).cwiseAbs().maxCoeff() /
         std::max(scaled_next.cwiseAbs().maxCoeff(), 1e-300);
}

SID_INLINE InstrumentalVariableResult iterate_instrumental_variables(
    const Arm& arm, const std::vector<ChainKinematics<double>>& runs,
    const std::vector<std::vector<Eigen::Index>>& samples, const LeastSquaresResult<double>& first,
    const IvSettings& settings, const char* who) {
  const ChainRegression measured = stacked_regression(arm, runs, samples);
  if (measured.x.rows() <= measured.x.cols())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(measured.x.rows()) +
                                " equations for " + std::to_string(measured.x.cols()) +
                                " parameters");
  const Eigen::VectorXd scale = measured.x.colwise().norm().cwiseMax(1e-300).transpose();
  const Eigen::MatrixXd x_scaled = measured.x * scale.cwiseInverse().asDiagonal();
  IvSimulations sims = iv_simulations(runs, samples, arm.joints());

  // The body of each estimate is weighed by the first fit's residual (its triangular factor),
  // whatever the estimate.
  LeastSquaresResult<double> estimate = first;
  const double relative_residual = first.residual.norm() / std::max(measured.y.norm(), 1e-300);

  InstrumentalVariableResult result;
  result.fit = first;
  for (int it = 1; it <= settings.max_iterations; ++it) {
    estimate.theta = result.fit.theta;
    const Eigen::VectorXd body =
        arm.simulatable(estimate, relative_residual, settings.prior, settings.consistency);
    for (std::size_t r = 0; r < runs.size(); ++r)
      if (!simulate_iv_states(arm, body, runs[r], sims.drives[r], samples[r], settings, who, it,
                              sims.simulated[r], result))
        return result;
    const ChainRegression instruments = stacked_regression(arm, sims.simulated, sims.every);
    Eigen::VectorXd next;
    if (!solve_iv(instruments.x, x_scaled, measured.y, scale, who, it, next, result)) return result;
    const double change = iv_change(result.fit.theta, next, scale, settings.convergence);
    fill_iv_statistics(measured.x, measured.y, instruments.x, scale, next, result.fit,
                       arm.joints());
    result.fit.message.clear();
    result.fit.ill_conditioned = false;
    result.iterations = it;
    if (change < settings.tolerance) {
      result.converged = true;
      return result;
    }
  }
  result.message = std::string(who) + ": the estimate still changed by more than the tolerance " +
                   "after " + std::to_string(settings.max_iterations) + " iterations";
  return result;
}

}  // namespace detail

SID_INLINE InstrumentalVariableResult
refine_instrumental_variables(const Kinematics<double>& k, const LeastSquaresResult<double>& first,
                              const InstrumentalVariableOptions& options) {
  const char* who = "sid::refine_instrumental_variables";
  detail::check_iv_inputs(k, first, options, who);
  ChainKinematics<double> run;
  run.t = k.t;
  run.q = k.q;
  run.qd = k.qd;
  run.qdd = k.qdd;
  run.tau = k.tau;
  std::vector<Eigen::Index> every(static_cast<std::size_t>(k.size()));
  for (std::size_t i = 0; i < every.size(); ++i) every[i] = static_cast<Eigen::Index>(i);
  const detail::IvSettings settings{
      options.max_iterations, options.tolerance, detail::IvConvergence::Relative, options.segment,
      options.simulator,      Eigen::VectorXd(), ChainConsistencyOptions()};
  return detail::iterate_instrumental_variables(paper_arm(options.gravity), {run}, {every}, first,
                                                settings, who);
}

SID_INLINE std::function<LeastSquaresResult<double>(const Kinematics<double>&,
                                                    const LeastSquaresResult<double>&)>
instrumental_variable_step(const InstrumentalVariableOptions& options) {
  return [options](const Kinematics<double>& k, const LeastSquaresResult<double>& first) {
    InstrumentalVariableResult iv = refine_instrumental_variables(k, first, options);
    if (!iv.ok()) throw std::runtime_error(iv.message);
    return std::move(iv.fit);
  };
}

}  // namespace sid
