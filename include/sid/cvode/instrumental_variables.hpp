#pragma once
/// @file
/// @brief The instrumental-variable step of inverse-dynamics identification (IDIM-IV, Janot,
/// Vandanjon & Gautier 2014): regressor rows built from a simulation of the current estimate serve
/// as instruments, so the noise that smoothing leaves in q̂̈ no longer biases θ̂.
///
/// Least squares on X(q̂, q̂̇, q̂̈) is an errors-in-variables problem: the noise left in the
/// estimated accelerations attenuates the inertial parameters (θ2 by about −3 % at σq² = 1e-4).
/// The instruments W = X(simulated states) are correlated with X but not with that noise, so
/// θ = (WᵀX)⁻¹ Wᵀ y is consistent. The simulation depends on θ, hence the iteration.
///
/// Two choices make the instruments independent of the torque noise as well:
/// - the simulation is driven by the measured torque smoothed by GCV (with the raw torque, the
///   simulated q̈ at sample i would contain the noise of yᵢ itself, and the open-loop states would
///   random-walk);
/// - the arm is a double pendulum whose open-loop trajectories diverge, so each segment of
///   `segment` seconds restarts from the smoothed state; a wrong θ then cannot drift away from
///   the measured motion.

#include <sid/cvode/simulator.hpp>
#include <sid/identify.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace sid {

struct InstrumentalVariableOptions {
  /// Most IV iterations; the result reports how many were needed.
  int max_iterations = 10;
  /// Stop when max |Δθₖ / θₖ| falls below this [-].
  double tolerance = 1e-4;
  double gravity = kPaperGravity;  ///< [m/s²]
  /// Each simulated segment starts from the smoothed state and lasts this long [s], > 0.
  double segment = 0.5;
  /// The instruments need far less accuracy than generating a data set does.
  SimulatorOptions simulator = [] {
    SimulatorOptions o;
    o.rtol = o.atol = 1e-7;
    return o;
  }();
};

/// @brief The IV estimate with the statistics of a least-squares result, and how it got there.
struct [[nodiscard]] InstrumentalVariableResult {
  /// θ and its statistics: covariance σ² (WᵀX)⁻¹ WᵀW (XᵀW)⁻¹ with σ² = RSS / (m − p) of the IV
  /// residual y − Xθ. On failure (see message) this is the first estimate, unchanged.
  LeastSquaresResult<double> fit;
  int iterations = 0;      ///< IV iterations done
  bool converged = false;  ///< the change of θ fell below the tolerance
  /// A simulation failed, W^T X was singular or θ became non-finite: fit is the last good one.
  bool failed = false;
  std::string message;  ///< why it stopped before converging, if it did
};

namespace detail {

/// The measured torque smoothed by GCV, per joint: the drive of the instrument simulation.
inline MatrixX2<double> smoothed_torque(const Kinematics<double>& k) {
  MatrixX2<double> drive(k.size(), 2);
  const SmoothingSpline<double> smoother(k.t);
  for (int j = 0; j < 2; ++j) {
    const VectorX<double> tau = k.tau.col(j);
    const SmoothingFit<double> fit = smoother.fit_cross_validated(tau, 1.0, SmoothingCriterion::Gcv);
    fit.spline.derivatives_at_knots(0, drive.col(j));
  }
  return drive;
}

/// The IV statistics for a given θ (fills everything least_squares would).
inline void fill_iv_statistics(const Eigen::MatrixXd& x, const Eigen::VectorXd& y, const Eigen::MatrixXd& w,
                               const Eigen::VectorXd& scale, const Eigen::VectorXd& theta,
                               LeastSquaresResult<double>& fit) {
  const Eigen::Index m = x.rows(), p = x.cols(), per_joint = m / 2;
  fit.status = LeastSquaresStatus::Success;
  fit.theta = theta;
  fit.residual = y - x * theta;
  fit.residual_rms.resize(2);
  fit.sigma2_per_joint.resize(2);
  const double dof_share = static_cast<double>(m - p) / 2.0;
  for (int j = 0; j < 2; ++j) {
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
  fit.covariance = scale.cwiseInverse().asDiagonal() * cov_scaled * scale.cwiseInverse().asDiagonal();
  fit.std_dev = fit.covariance.diagonal().cwiseSqrt();
  fit.relative_std_dev = 100.0 * fit.std_dev.cwiseQuotient(theta.cwiseAbs());
  const Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::NoQRPreconditioner> svd(wtx);  // square
  const auto& s = svd.singularValues();
  fit.condition_number = s[s.size() - 1] > 0.0 ? s[0] / s[s.size() - 1] : std::numeric_limits<double>::infinity();
  fit.rank = lu.rank();
  fit.column_scale = scale;
  fit.dependent_columns.clear();
}

}  // namespace detail

/// @brief Refines a first estimate on the kinematics k (the windowed samples an estimator kept,
/// with the measured τ) by IDIM-IV.
///
/// Each iteration simulates the arm with the current θ (segment by segment, see the file
/// comment), builds W from the simulated q, q̇ and q̈, and solves (WᵀX) θ = Wᵀy with both sides
/// column-scaled. A failed simulation or a singular WᵀX stops the iteration and keeps the last
/// good θ, with a message; reaching max_iterations is reported as not converged.
/// @param k at least 8 samples, t strictly increasing.
/// @param first the least-squares fit on k to start from (its θ must have 7 entries).
/// @throws std::invalid_argument on inconsistent sizes, a first fit that is not a success, or
/// bad options.
inline InstrumentalVariableResult refine_instrumental_variables(const Kinematics<double>& k,
                                                                const LeastSquaresResult<double>& first,
                                                                const InstrumentalVariableOptions& options = {}) {
  const char* who = "sid::refine_instrumental_variables";
  const Eigen::Index n = k.size();
  if (first.theta.size() != 7 || !first.ok())
    throw std::invalid_argument(std::string(who) + ": the first fit must be a successful 7-parameter fit");
  if (n < 8 || k.q.rows() != n || k.qd.rows() != n || k.qdd.rows() != n || k.tau.rows() != n)
    throw std::invalid_argument(std::string(who) + ": kinematics need at least 8 samples with equal lengths");
  if (options.max_iterations < 1) throw std::invalid_argument(std::string(who) + ": max_iterations must be >= 1");
  if (!(options.segment > 0.0)) throw std::invalid_argument(std::string(who) + ": segment must be > 0");
  if (!(options.tolerance > 0.0)) throw std::invalid_argument(std::string(who) + ": tolerance must be > 0");

  const StackedRegression<double> measured = stack_two_link_regression(k, options.gravity);
  const Eigen::VectorXd scale = measured.X.colwise().norm().cwiseMax(1e-300).transpose();
  const Eigen::MatrixXd x_scaled = measured.X * scale.cwiseInverse().asDiagonal();

  const MatrixX2<double> drive = detail::smoothed_torque(k);
  auto torque = [&](double time) {  // linear between samples, held beyond the ends
    if (time <= k.t[0]) return Vector2<double>(drive.row(0).transpose());
    if (time >= k.t[n - 1]) return Vector2<double>(drive.row(n - 1).transpose());
    const Eigen::Index i = std::upper_bound(k.t.data(), k.t.data() + n, time) - k.t.data() - 1;
    const double a = (time - k.t[i]) / (k.t[i + 1] - k.t[i]);
    return Vector2<double>((1.0 - a) * drive.row(i).transpose() + a * drive.row(i + 1).transpose());
  };

  InstrumentalVariableResult result;
  result.fit = first;
  Kinematics<double> simulated;
  simulated.t = k.t;
  simulated.q.resize(n, 2);
  simulated.qd.resize(n, 2);
  simulated.qdd.resize(n, 2);
  simulated.tau = drive;
  for (int it = 1; it <= options.max_iterations; ++it) {
    const TwoLinkParameters<double> theta = result.fit.theta;
    auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x, Eigen::Map<Eigen::VectorXd>& xdot) {
      const Vector2<double> q = x.head<2>(), qd = x.tail<2>();
      xdot.head<2>() = qd;
      xdot.tail<2>() = two_link_forward_dynamics(theta, q, qd, torque(time), options.gravity);
    };
    // Segments [begin, end] share their boundary sample; each starts from the smoothed state.
    for (Eigen::Index begin = 0; begin < n - 1;) {
      Eigen::Index end = begin + 1;
      while (end < n - 1 && k.t[end] < k.t[begin] + options.segment) ++end;
      Eigen::VectorXd start(4);
      start << k.q.row(begin).transpose(), k.qd.row(begin).transpose();
      const SimulationResult sim = simulate(rhs, start, k.t.segment(begin, end - begin + 1), options.simulator);
      if (!sim.ok()) {
        result.failed = true;
        result.message = std::string(who) + ": the simulation of iteration " + std::to_string(it) + " failed at t = " +
                         std::to_string(k.t[begin]) + " s (" + sim.flag_name + "): " + sim.message;
        return result;
      }
      simulated.q.middleRows(begin, end - begin + 1) = sim.states.leftCols(2);
      simulated.qd.middleRows(begin, end - begin + 1) = sim.states.rightCols(2);
      begin = end;
    }
    for (Eigen::Index i = 0; i < n; ++i)
      simulated.qdd.row(i) = two_link_forward_dynamics(theta, Vector2<double>(simulated.q.row(i).transpose()),
                                                       Vector2<double>(simulated.qd.row(i).transpose()),
                                                       Vector2<double>(drive.row(i).transpose()), options.gravity)
                                 .transpose();
    const StackedRegression<double> instruments = stack_two_link_regression(simulated, options.gravity);
    const Eigen::MatrixXd w_scaled = instruments.X * scale.cwiseInverse().asDiagonal();
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(w_scaled.transpose() * x_scaled);
    if (qr.rank() < 7) {
      result.failed = true;
        result.message = std::string(who) + ": the instruments of iteration " + std::to_string(it) +
                       " are not correlated with every regressor column (W^T X is singular)";
      return result;
    }
    const Eigen::VectorXd next = qr.solve(w_scaled.transpose() * measured.y).cwiseQuotient(scale);
    if (!next.allFinite()) {
      result.failed = true;
        result.message = std::string(who) + ": iteration " + std::to_string(it) + " gave a non-finite estimate";
      return result;
    }
    const double change = (next - result.fit.theta).cwiseQuotient(result.fit.theta).cwiseAbs().maxCoeff();
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

/// @brief The IV step as the hook that the Monte Carlo study (sid/study/montecarlo.hpp, which
/// must stay free of SUNDIALS) calls for its `css_iv` method.
/// The hook throws std::runtime_error when the iteration stopped on a failure (a failed
/// simulation, singular instruments), so the study counts that run as failed instead of
/// silently reporting the first estimate.
inline std::function<LeastSquaresResult<double>(const Kinematics<double>&, const LeastSquaresResult<double>&)>
instrumental_variable_step(const InstrumentalVariableOptions& options = {}) {
  return [options](const Kinematics<double>& k, const LeastSquaresResult<double>& first) {
    InstrumentalVariableResult iv = refine_instrumental_variables(k, first, options);
    if (iv.failed) throw std::runtime_error(iv.message);
    return std::move(iv.fit);
  };
}

}  // namespace sid
