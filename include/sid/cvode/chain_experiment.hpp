#pragma once
/// @file
/// @brief An identification experiment on any serial chain, simulated with CVODE: the arm
/// (a ChainModel at given parameters, drive terms included) tracks a Fourier excitation under
/// computed torque with a PD correction, and q, qd, qdd and the applied torque are sampled on a
/// uniform grid. The true trajectory that measurement noise is added to.

#include <sid/cvode/experiment.hpp>
#include <sid/cvode/simulator.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

/// @brief Settings of a chain experiment.
struct ChainExperiment {
  double duration = 10.0;      ///< T [s], > 0
  double sample_time = 0.001;  ///< Ts [s], > 0 and <= duration
  /// The PD correction's natural frequency [rad/s] and damping ratio, per joint scaled by the
  /// diagonal of M(q0): tau = ID(desired) + M_jj (w^2 e_j + 2 zeta w e'_j).
  double tracking_frequency = 10.0;
  double tracking_damping = 1.0;
  SimulatorOptions simulator = SimulatorOptions{1e-9, 1e-9};
};

/// @brief The true trajectory of a chain experiment and how the simulation went.
struct [[nodiscard]] ChainExperimentResult {
  ChainKinematics<double> truth;  ///< the samples reached; tau is the applied torque
  SimulationStatus status = SimulationStatus::Success;
  std::string flag_name;
  std::string message;
  SimulationStatistics statistics;

  bool ok() const { return status == SimulationStatus::Success; }
  /// The measured-data view {t, q, tau}, as identify_chain takes it.
  ChainTrajectory<double> trajectory() const { return {truth.t, truth.q, truth.tau}; }
};

/// @brief Simulates model at parameters theta (model.parameter_names() order) tracking desired
/// from its own initial state, through the model's O(n) forward dynamics.
/// @throws std::invalid_argument for sizes that disagree, a bad grid, bad gains or an invalid
///         trajectory.
inline ChainExperimentResult simulate_chain_experiment(const ChainModel& model,
                                                       const Eigen::VectorXd& theta,
                                                       const FourierTrajectory& desired,
                                                       const ChainExperiment& experiment = {}) {
  const char* who = "sid::simulate_chain_experiment";
  desired.validate(who);
  const int n = model.joints();
  if (desired.joints() != n || theta.size() != model.parameters())
    throw std::invalid_argument(std::string(who) + ": the model has " + std::to_string(n) +
                                " joints and " + std::to_string(model.parameters()) +
                                " parameters; the trajectory " + std::to_string(desired.joints()) +
                                " joints, theta " + std::to_string(theta.size()) + " entries");
  if (!theta.allFinite())
    throw std::invalid_argument(std::string(who) + ": theta holds a value that is not finite");
  if (!(experiment.tracking_frequency >= 0.0) || !(experiment.tracking_damping >= 0.0) ||
      !std::isfinite(experiment.tracking_frequency) || !std::isfinite(experiment.tracking_damping))
    throw std::invalid_argument(std::string(who) +
                                ": tracking_frequency and tracking_damping must be finite, >= 0");
  const Eigen::VectorXd t = sample_grid(experiment.duration, experiment.sample_time);

  using Vector = ChainModel::Vector;
  Vector q_d(n), qd_d(n), qdd_d(n);
  desired.evaluate(0.0, q_d, qd_d, qdd_d);
  const Vector inertia = model.model().mass_matrix(theta, q_d).diagonal();
  const double w = experiment.tracking_frequency;
  const Vector kp = inertia * (w * w), kd = inertia * (2.0 * experiment.tracking_damping * w);
  Eigen::VectorXd x0(2 * n);
  x0 << q_d, qd_d;

  // The applied torque at time t in state (q, qd): computed torque plus the PD correction.
  const auto applied = [&](double time, const Vector& q, const Vector& qd) {
    Vector qr(n), qdr(n), qddr(n);
    desired.evaluate(time, qr, qdr, qddr);
    Vector tau = model.model().inverse_dynamics(theta, qr, qdr, qddr);
    tau += kp.cwiseProduct(qr - q) + kd.cwiseProduct(qdr - qd);
    return tau;
  };
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    const Vector q = x.head(n), qd = x.tail(n);
    xdot.head(n) = qd;
    xdot.tail(n) = model.forward_dynamics(theta, q, qd, applied(time, q, qd));
  };
  const SimulationResult sim = simulate(rhs, x0, t, experiment.simulator);

  ChainExperimentResult result;
  result.status = sim.status;
  result.flag_name = sim.flag_name;
  result.message = sim.message;
  result.statistics = sim.statistics;
  const Eigen::Index samples = sim.completed;
  ChainKinematics<double>& truth = result.truth;
  truth.t = t.head(samples);
  truth.q = sim.states.topLeftCorner(samples, n);
  truth.qd = sim.states.block(0, n, samples, n);
  truth.qdd.resize(samples, n);
  truth.tau.resize(samples, n);
  for (Eigen::Index k = 0; k < samples; ++k) {
    const Vector q = truth.q.row(k).transpose(), qd = truth.qd.row(k).transpose();
    const Vector tau = applied(t[k], q, qd);
    truth.tau.row(k) = tau.transpose();
    truth.qdd.row(k) = model.forward_dynamics(theta, q, qd, tau).transpose();
  }
  return result;
}

}  // namespace sid
