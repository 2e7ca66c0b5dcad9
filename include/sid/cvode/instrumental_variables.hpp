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

#include <sid/arm.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/config.hpp>
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
#include <vector>

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

  /// The iterations ran (they may still have stopped before converging: see converged).
  bool ok() const noexcept { return !failed; }
};

namespace detail {

/// The measured torque smoothed by GCV, per joint: the drive of the instrument simulation.
template <int Joints>
JointSamples<double, Joints> smoothed_torque(const Kinematics<double, Joints>& k) {
  JointSamples<double, Joints> drive(k.size(), k.joints());
  const SmoothingSpline<double> smoother(k.t);
  for (Eigen::Index j = 0; j < k.joints(); ++j) {
    const VectorX<double> tau = k.tau.col(j);
    const SmoothingFit<double> fit =
        smoother.fit_cross_validated(tau, 1.0, SmoothingCriterion::Gcv);
    fit.spline.derivatives_at_knots(0, drive.col(j));
  }
  return drive;
}

/// Simulates rhs into simulated.q and qd at the times simulated.t, in segments of `segment`
/// seconds that share their boundary sample; segment a starting at sample b starts from
/// start_at(b). False, with the failure in result (`it` numbers the iteration), if a
/// simulation failed.
template <int Joints, typename Rhs, typename Start>
bool simulate_segments(const Rhs& rhs, const Start& start_at, double segment,
                       const SimulatorOptions& simulator, const char* who, int it,
                       Kinematics<double, Joints>& simulated, InstrumentalVariableResult& result) {
  const Eigen::Index count = simulated.size(), n = simulated.q.cols();
  for (Eigen::Index begin = 0; begin < count - 1;) {
    Eigen::Index end = begin + 1;
    while (end < count - 1 && simulated.t[end] < simulated.t[begin] + segment) ++end;
    const SimulationResult sim =
        simulate(rhs, start_at(begin), simulated.t.segment(begin, end - begin + 1), simulator);
    if (!sim.ok()) {
      result.failed = true;
      result.message = std::string(who) + ": the simulation of iteration " + std::to_string(it) +
                       " failed at t = " + std::to_string(simulated.t[begin]) + " s (" +
                       sim.flag_name + "): " + sim.message;
      return false;
    }
    simulated.q.middleRows(begin, end - begin + 1) = sim.states.leftCols(n);
    simulated.qd.middleRows(begin, end - begin + 1) = sim.states.rightCols(n);
    begin = end;
  }
  return true;
}

/// The IV statistics for a given θ (fills everything least_squares would); the rows are joint
/// by joint, `joints` blocks of equal length.
SID_INLINE void fill_iv_statistics(const Eigen::MatrixXd& x, const Eigen::VectorXd& y,
                                   const Eigen::MatrixXd& w, const Eigen::VectorXd& scale,
                                   const Eigen::VectorXd& theta, LeastSquaresResult<double>& fit,
                                   int joints = 2);

/// The IV estimate θ of (WᵀX) θ = Wᵀy, solved with both sides column-scaled by `scale`
/// (x_scaled = X diag(scale)⁻¹) into `next`. False, with the failure in result (`it` numbers
/// the iteration), if WᵀX is singular or θ not finite.
SID_INLINE bool solve_iv(const Eigen::MatrixXd& w, const Eigen::MatrixXd& x_scaled,
                         const Eigen::VectorXd& y, const Eigen::VectorXd& scale, const char* who,
                         int it, Eigen::VectorXd& next, InstrumentalVariableResult& result);

/// When the IV iteration has converged: the largest relative change of a parameter (the
/// paper's arm, whose parameters are all far from zero), or the largest change times its
/// column's norm over the largest such product (a chain's base parameters, some near zero).
enum class IvConvergence { Relative, ScaledColumns };

/// What each arm's options set for the one IV iteration (iterate_instrumental_variables).
struct IvSettings {
  int max_iterations = 10;
  double tolerance = 1e-4;
  IvConvergence convergence = IvConvergence::Relative;
  double segment = 0.5;
  SimulatorOptions simulator;
  Eigen::VectorXd prior;  ///< for Arm::simulatable()
  ChainConsistencyOptions consistency;
};

/// IDIM-IV on any arm, after the caller checked its inputs: the rows are
/// stacked_regression(arm, runs, samples); each iteration simulates Arm::simulatable() of the
/// current estimate through every run (driven by its measured torque smoothed by GCV,
/// restarting from its state every `segment` seconds), takes the same rows at the simulated
/// states as instruments and solves (WᵀX) θ = Wᵀy column-scaled. `who` prefixes the messages.
SID_INLINE InstrumentalVariableResult iterate_instrumental_variables(
    const Arm& arm, const std::vector<ChainKinematics<double>>& runs,
    const std::vector<std::vector<Eigen::Index>>& samples, const LeastSquaresResult<double>& first,
    const IvSettings& settings, const char* who);

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
SID_INLINE InstrumentalVariableResult
refine_instrumental_variables(const Kinematics<double>& k, const LeastSquaresResult<double>& first,
                              const InstrumentalVariableOptions& options = {});

/// @brief The IV step as the hook that the Monte Carlo study (sid/study/montecarlo.hpp, which
/// must stay free of SUNDIALS) calls for its `css_iv` method.
/// The hook throws std::runtime_error when the iteration stopped on a failure (a failed
/// simulation, singular instruments), so the study counts that run as failed instead of
/// silently reporting the first estimate.
SID_INLINE std::function<LeastSquaresResult<double>(const Kinematics<double>&,
                                                    const LeastSquaresResult<double>&)>
instrumental_variable_step(const InstrumentalVariableOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/instrumental_variables-inl.hpp>
#endif
