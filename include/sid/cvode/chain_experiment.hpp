#pragma once
/// @file
/// @brief An identification experiment on any serial chain, simulated with CVODE: the arm
/// (a ChainModel at given parameters, drive terms included) tracks a Fourier excitation under
/// computed torque with a PD correction, or is driven open loop by a given torque, and q, qd, qdd
/// and the applied torque are sampled. The true trajectory that measurement noise is added to.

#include <sid/cvode/experiment.hpp>
#include <sid/cvode/simulator.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <functional>
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
  /// The torque the outside applies at the joints at time t and angles q (e.g. a push at the
  /// tool, chain_point_force_torque), which the drives do not give and the log's torque does not
  /// hold; empty: none.
  std::function<ChainModel::Vector(double t, const ChainModel::Vector& q)> external_torque;
};

/// @brief The true trajectory of a chain experiment and how the simulation went.
struct [[nodiscard]] ChainExperimentResult {
  ChainKinematics<double> truth;  ///< the samples reached; tau is the applied torque
  /// The outside's torque at each sample (ChainExperiment::external_torque); empty without it.
  Eigen::MatrixXd external;
  SimulationStatus status = SimulationStatus::Success;
  std::string flag_name;
  std::string message;
  SimulationStatistics statistics;

  bool ok() const { return status == SimulationStatus::Success; }
  /// The measured-data view {t, q, tau}, as identify_chain takes it.
  ChainTrajectory<double> trajectory() const { return {truth.t, truth.q, truth.tau}; }
};

namespace detail {

/// The true samples of a chain simulation on the grid t: the states CVODE reached, the torque
/// applied(k, q, qd) at sample k and the model's accelerations under it.
template <typename Applied>
ChainExperimentResult chain_experiment_result(const ChainModel& model, const Eigen::VectorXd& theta,
                                              const Eigen::VectorXd& t, const SimulationResult& sim,
                                              const Applied& applied) {
  using Vector = ChainModel::Vector;
  const int n = model.joints();
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
    const Vector tau = applied(k, q, qd);
    truth.tau.row(k) = tau.transpose();
    truth.qdd.row(k) = model.forward_dynamics(theta, q, qd, tau).transpose();
  }
  return result;
}

}  // namespace detail

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
  const auto& external = experiment.external_torque;
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    const Vector q = x.head(n), qd = x.tail(n);
    xdot.head(n) = qd;
    Vector tau = applied(time, q, qd);
    if (external) tau += external(time, q);
    xdot.tail(n) = model.forward_dynamics(theta, q, qd, tau);
  };
  const SimulationResult sim = simulate(rhs, x0, t, experiment.simulator);

  ChainExperimentResult result = detail::chain_experiment_result(
      model, theta, t, sim,
      [&](Eigen::Index k, const Vector& q, const Vector& qd) { return applied(t[k], q, qd); });
  if (!external) return result;
  ChainKinematics<double>& truth = result.truth;
  result.external.resize(truth.size(), n);
  for (Eigen::Index k = 0; k < truth.size(); ++k) {
    const Vector q = truth.q.row(k).transpose(), qd = truth.qd.row(k).transpose();
    const Vector outside = external(t[k], q);
    result.external.row(k) = outside.transpose();
    const Vector tau = truth.tau.row(k).transpose() + outside;
    truth.qdd.row(k) = model.forward_dynamics(theta, q, qd, tau).transpose();
  }
  return result;
}

/// @brief Simulates model at parameters theta open loop from the state x0 = (q, qd), driven by
/// the torque `tau` given at the times t (one row per time; linear between them), and samples it
/// at t. The arm goes wherever the torque takes it: nothing holds it within its limits.
/// @param blow_up a state entry above this in magnitude stops the run as failed (an arm that
///        falls or spins away), > 0.
/// @throws std::invalid_argument for sizes that disagree, fewer than 2 times, times that do not
///         increase, or values that are not finite.
inline ChainExperimentResult simulate_chain_torque(
    const ChainModel& model, const Eigen::VectorXd& theta, const Eigen::VectorXd& t,
    const Eigen::MatrixXd& tau, const Eigen::VectorXd& x0,
    const SimulatorOptions& simulator = {1e-9, 1e-9}, double blow_up = 1e4) {
  const std::string who = "sid::simulate_chain_torque: ";
  const int n = model.joints();
  if (theta.size() != model.parameters() || tau.cols() != n || x0.size() != 2 * n ||
      tau.rows() != t.size())
    throw std::invalid_argument(who + "the model has " + std::to_string(n) + " joints and " +
                                std::to_string(model.parameters()) + " parameters; theta has " +
                                std::to_string(theta.size()) + " entries, tau " +
                                std::to_string(tau.rows()) + " x " + std::to_string(tau.cols()) +
                                " for " + std::to_string(t.size()) + " times, x0 " +
                                std::to_string(x0.size()) + " entries");
  if (t.size() < 2) throw std::invalid_argument(who + "needs at least 2 times");
  if (!theta.allFinite() || !tau.allFinite() || !x0.allFinite() || !t.allFinite())
    throw std::invalid_argument(who + "theta, t, tau and x0 must be finite");
  for (Eigen::Index i = 1; i < t.size(); ++i)
    if (!(t[i] > t[i - 1]))
      throw std::invalid_argument(who + "times must increase (time " + std::to_string(i) + ")");
  if (!(blow_up > 0.0)) throw std::invalid_argument(who + "blow_up must be > 0");

  using Vector = ChainModel::Vector;
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    if (x.cwiseAbs().maxCoeff() > blow_up)
      throw std::runtime_error("the state passed the blow-up bound " + std::to_string(blow_up));
    const Vector q = x.head(n), qd = x.tail(n);
    xdot.head(n) = qd;
    xdot.tail(n) = model.forward_dynamics(theta, q, qd, detail::drive_at(t, tau, time));
  };
  const SimulationResult sim = simulate(rhs, x0, t, simulator);

  return detail::chain_experiment_result(
      model, theta, t, sim,
      [&](Eigen::Index k, const Vector&, const Vector&) { return Vector(tau.row(k).transpose()); });
}

}  // namespace sid
