#pragma once
// Definitions of sid/cvode/instrumental_variables.hpp (see sid/config.hpp).

#include <sid/cvode/instrumental_variables.hpp>

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

/// Kinematics at k's times, driven by `drive`, with room for the simulated states.
SID_INLINE Kinematics<double> instrument_kinematics(const Kinematics<double>& k,
                                                    const MatrixX2<double>& drive) {
  const Eigen::Index n = k.size();
  Kinematics<double> simulated;
  simulated.t = k.t;
  simulated.q.resize(n, 2);
  simulated.qd.resize(n, 2);
  simulated.qdd.resize(n, 2);
  simulated.tau = drive;
  return simulated;
}

/// Simulates the arm at θ, driven by `drive`, into simulated.q and qd. False, with the failure
/// in result (`it` numbers the iteration), if a simulation failed.
SID_INLINE bool simulate_states(const Kinematics<double>& k, const MatrixX2<double>& drive,
                                const TwoLinkParameters<double>& theta,
                                const InstrumentalVariableOptions& options, const char* who, int it,
                                Kinematics<double>& simulated, InstrumentalVariableResult& result) {
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    const Vector2<double> q = x.head<2>(), qd = x.tail<2>();
    xdot.head<2>() = qd;
    xdot.tail<2>() =
        two_link_forward_dynamics(theta, q, qd, drive_at(k.t, drive, time), options.gravity);
  };
  // Each segment starts from the smoothed state.
  return simulate_segments(
      rhs,
      [&](Eigen::Index begin) {
        Eigen::VectorXd start(4);
        start << k.q.row(begin).transpose(), k.qd.row(begin).transpose();
        return start;
      },
      options.segment, options.simulator, who, it, simulated, result);
}

/// simulated.qdd from the model at θ in the simulated states, driven by `drive` at the samples.
SID_INLINE void fill_simulated_accelerations(const TwoLinkParameters<double>& theta,
                                             const MatrixX2<double>& drive, double gravity,
                                             Kinematics<double>& simulated) {
  for (Eigen::Index i = 0; i < simulated.size(); ++i)
    simulated.qdd.row(i) =
        two_link_forward_dynamics(theta, Vector2<double>(simulated.q.row(i).transpose()),
                                  Vector2<double>(simulated.qd.row(i).transpose()),
                                  Vector2<double>(drive.row(i).transpose()), gravity)
            .transpose();
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

}  // namespace detail

SID_INLINE InstrumentalVariableResult
refine_instrumental_variables(const Kinematics<double>& k, const LeastSquaresResult<double>& first,
                              const InstrumentalVariableOptions& options) {
  const char* who = "sid::refine_instrumental_variables";
  detail::check_iv_inputs(k, first, options, who);

  const StackedRegression<double> measured = stack_two_link_regression(k, options.gravity);
  const Eigen::VectorXd scale = measured.X.colwise().norm().cwiseMax(1e-300).transpose();
  const Eigen::MatrixXd x_scaled = measured.X * scale.cwiseInverse().asDiagonal();

  const MatrixX2<double> drive = detail::smoothed_torque(k);
  InstrumentalVariableResult result;
  result.fit = first;
  Kinematics<double> simulated = detail::instrument_kinematics(k, drive);
  for (int it = 1; it <= options.max_iterations; ++it) {
    const TwoLinkParameters<double> theta = result.fit.theta;
    if (!detail::simulate_states(k, drive, theta, options, who, it, simulated, result))
      return result;
    detail::fill_simulated_accelerations(theta, drive, options.gravity, simulated);
    const StackedRegression<double> instruments =
        stack_two_link_regression(simulated, options.gravity);
    Eigen::VectorXd next;
    if (!detail::solve_iv(instruments.X, x_scaled, measured.y, scale, who, it, next, result))
      return result;
    const double change =
        (next - result.fit.theta).cwiseQuotient(result.fit.theta).cwiseAbs().maxCoeff();
    detail::fill_iv_statistics(measured.X, measured.y, instruments.X, scale, next, result.fit);
    result.fit.message.clear();
    result.fit.ill_conditioned = false;
    result.iterations = it;
    if (change < options.tolerance) {
      result.converged = true;
      return result;
    }
  }
  result.message = std::string(who) + ": theta still changed by more than the tolerance after " +
                   std::to_string(options.max_iterations) + " iterations";
  return result;
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
