#pragma once
/// @file
/// @brief The paper's open-loop experiment (Dolinsky & Celikovsky, section 3.1; corrected in
/// docs/paper-reproduction.md): a two-joint arm driven by a known torque, simulated with CVODE and
/// sampled on a uniform grid. It produces the true trajectory that measurement noise is added to.

#include <sid/cvode/simulator.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <exception>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace sid {

/// @brief The paper's input torque: u1 = 6 sin t, u2 = 4 cos t [N m], t in [s].
struct PaperInput {
  Vector2<double> operator()(double t) const {
    return Vector2<double>(6.0 * std::sin(t), 4.0 * std::cos(t));
  }
};

/// @brief A second excitation with four frequencies instead of the paper's one, so that a
/// conclusion drawn from data (an effect named, a parameter estimated) can be checked on a
/// different trajectory: u1 = 5 sin 1.3t + 2 sin 3.1t, u2 = 3 cos 0.7t + 1.5 sin 2.3t [N m],
/// t in [s].
struct MultisineInput {
  Vector2<double> operator()(double t) const {
    return Vector2<double>(5.0 * std::sin(1.3 * t) + 2.0 * std::sin(3.1 * t),
                           3.0 * std::cos(0.7 * t) + 1.5 * std::sin(2.3 * t));
  }
};

/// @brief Settings of the experiment; the defaults are the paper's (x(0) = 0, T = 10 s,
/// Ts = 0.0025 s, so 4001 samples from t = 0 inclusive).
struct ArmExperiment {
  /// Length of the experiment T [s], > 0.
  double duration = 10.0;
  /// Sampling period Ts [s], > 0 and <= duration.
  double sample_time = 0.0025;
  /// Initial joint angles [rad].
  Vector2<double> q0 = Vector2<double>::Zero();
  /// Initial joint velocities [rad/s].
  Vector2<double> qd0 = Vector2<double>::Zero();
  SimulatorOptions simulator = SimulatorOptions();
};

/// @brief The sampling grid t_k = k Ts, k = 0..round(T / Ts).
/// Computed as k * Ts (not by accumulating Ts) so t_k equals numpy.arange(n) * Ts exactly, as in
/// tests/data/trajectory_noise_free.csv.
/// @param[in] duration T [s], finite and > 0.
/// @param[in] sample_time Ts [s], finite, > 0 and <= duration.
/// @throws std::invalid_argument naming the bad argument.
inline Eigen::VectorXd sample_grid(double duration, double sample_time) {
  using std::isfinite;
  if (!(duration > 0.0) || !isfinite(duration))
    throw std::invalid_argument("sid::sample_grid: duration must be finite and > 0");
  if (!(sample_time > 0.0) || !isfinite(sample_time) || sample_time > duration)
    throw std::invalid_argument(
        "sid::sample_grid: sample_time must be finite, > 0 and <= duration");
  const double intervals = std::round(duration / sample_time);
  if (intervals > 1e9)
    throw std::invalid_argument("sid::sample_grid: duration / sample_time exceeds 1e9 samples");
  const auto n = static_cast<Eigen::Index>(intervals) + 1;
  Eigen::VectorXd t(n);
  for (Eigen::Index k = 0; k < n; ++k) t[k] = static_cast<double>(k) * sample_time;
  return t;
}

/// @brief The true (noise-free) trajectory of an experiment and how the simulation went.
/// Class invariant: truth holds the samples the simulator reached (all of the grid on success);
/// truth.qdd is the model's acceleration at each sample (not a differentiated signal) and
/// truth.tau the input at each sample.
struct [[nodiscard]] ExperimentResult {
  Kinematics<double> truth;
  SimulationStatus status = SimulationStatus::Success;
  /// CVODE's flag name of the last call, e.g. "CV_SUCCESS" or "CV_TOO_MUCH_WORK".
  std::string flag_name;
  /// Empty on success; otherwise what went wrong (CVODE's message or the exception text).
  std::string message;
  SimulationStatistics statistics;

  bool ok() const { return status == SimulationStatus::Success; }
  /// The measured-data view {t, q, tau} of the truth, as the identification pipeline takes it.
  Trajectory<double> trajectory() const { return Trajectory<double>{truth.t, truth.q, truth.tau}; }
};

/// @brief Simulates the arm D(q) qdd + C(q, qd) qd + G(q) = u(t) through its forward dynamics and
/// samples q, qd, qdd and tau = u(t) on the experiment's grid.
///
/// The state is x = (q1, q2, qd1, qd2).
/// Example (with the model header of the project):
/// @code
///   const auto theta = ...;  // the paper's parameters
///   auto fd = [&](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
///                 const sid::Vector2<double>& tau) {
///     return sid::two_link_forward_dynamics(theta, q, qd, tau, 9.81);
///   };
///   const sid::ExperimentResult run = sid::simulate_arm_experiment(fd);
///   if (!run.ok()) { /* run.flag_name, run.message */ }
/// @endcode
/// @tparam ForwardDynamics callable as `qdd = fd(q, qd, tau)` with q [rad], qd [rad/s],
///   tau [N m] given as `const sid::Vector2<double>&`, returning something convertible to
///   sid::Vector2<double> [rad/s^2]. It may throw (reported as SimulationStatus::RhsFailure).
/// @tparam Input callable as `tau = u(t)`, t [s], returning sid::Vector2<double> [N m].
/// @param[in] fd forward dynamics.
/// @param[in] u input torque (default: the paper's).
/// @param[in] experiment grid, initial state and simulator settings (default: the paper's).
/// @throws std::invalid_argument for a bad grid, initial state or simulator option.
template <typename ForwardDynamics, typename Input = PaperInput>
ExperimentResult simulate_arm_experiment(const ForwardDynamics& fd, const Input& u = Input(),
                                         const ArmExperiment& experiment = ArmExperiment()) {
  const Eigen::VectorXd t = sample_grid(experiment.duration, experiment.sample_time);
  if (!experiment.q0.allFinite())
    throw std::invalid_argument("sid::simulate_arm_experiment: experiment.q0 must be finite");
  if (!experiment.qd0.allFinite())
    throw std::invalid_argument("sid::simulate_arm_experiment: experiment.qd0 must be finite");
  Eigen::VectorXd x0(4);
  x0 << experiment.q0, experiment.qd0;

  auto accelerations = [&](double time, const Vector2<double>& q, const Vector2<double>& qd) {
    const Vector2<double> tau = u(time);
    return Vector2<double>(fd(q, qd, tau));
  };
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    const Vector2<double> q = x.head<2>();
    const Vector2<double> qd = x.tail<2>();
    xdot.head<2>() = qd;
    xdot.tail<2>() = accelerations(time, q, qd);
  };
  const SimulationResult sim = simulate(rhs, x0, t, experiment.simulator);

  ExperimentResult result;
  result.status = sim.status;
  result.flag_name = sim.flag_name;
  result.message = sim.message;
  result.statistics = sim.statistics;

  const Eigen::Index n = sim.completed;
  Kinematics<double>& truth = result.truth;
  truth.t = t.head(n);
  truth.q = sim.states.topLeftCorner(n, 2);
  truth.qd = sim.states.block(0, 2, n, 2);
  truth.qdd.resize(n, 2);
  truth.tau.resize(n, 2);
  Eigen::Index k = 0;
  try {
    for (; k < n; ++k) {
      const Vector2<double> q = truth.q.row(k).transpose();
      const Vector2<double> qd = truth.qd.row(k).transpose();
      const Vector2<double> tau = u(t[k]);
      truth.tau.row(k) = tau.transpose();
      truth.qdd.row(k) = Vector2<double>(fd(q, qd, tau)).transpose();
    }
  } catch (const std::exception& e) {
    // The same contract as during the simulation: a throwing model is a status, not an escape.
    result.status = SimulationStatus::RhsFailure;
    result.message =
        std::string("forward dynamics threw at t = ") + std::to_string(t[k]) + ": " + e.what();
    truth.t.conservativeResize(k);
    truth.q.conservativeResize(k, 2);
    truth.qd.conservativeResize(k, 2);
    truth.qdd.conservativeResize(k, 2);
    truth.tau.conservativeResize(k, 2);
  }
  return result;
}

}  // namespace sid
