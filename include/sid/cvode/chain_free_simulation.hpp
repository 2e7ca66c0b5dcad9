#pragma once
/// @file
/// @brief Free (open-loop) simulation of a chain model driven by the measured torque, compared
/// with the measured angles, through the O(n) forward dynamics: where a model that fits the
/// torques still drifts away from the motion, something physical is missing. The chain's
/// counterpart of sid/cvode/free_simulation.hpp.

#include <sid/cvode/simulator.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Settings of free_chain_simulation().
struct ChainFreeSimulationOptions {
  /// Length of a segment [s]: each restarts from the smoothed state, because open-loop
  /// trajectories of an arm diverge from each other however good the model is. > 0.
  double segment = 1.0;
  /// A state with |q| or |qd| above this is a blow-up: the segment stops there. > 0.
  double blow_up = 1e4;
  /// BDF: a fitted Coulomb term Fc tanh(qd / eps) adds a stiff damping Fc / eps near every
  /// velocity reversal. The reference is a smoothed angle, so 1e-8 is ample.
  SimulatorOptions simulator = [] {
    SimulatorOptions o;
    o.rtol = o.atol = 1e-8;
    o.method = IntegrationMethod::Bdf;
    return o;
  }();
};

/// @brief A chain's free simulation and its disagreement with the smoothed measured angles.
struct [[nodiscard]] ChainFreeSimulation {
  Eigen::MatrixXd q;          ///< simulated angles, one row per sample (NaN after a failure)
  Eigen::MatrixXd error;      ///< smoothed measured q - simulated q
  Eigen::VectorXd error_rms;  ///< per joint, over the samples simulated (NaN if none)
  Eigen::Index segments = 0, failed_segments = 0;
  std::string message;  ///< empty when every segment ran to its end

  bool ok() const noexcept { return failed_segments == 0; }
};

/// @brief Simulates model at theta (a real body: model.parameter_names() order, drive terms
/// included) from the smoothed state k.q, k.qd at the start of every segment, driven by k.tau
/// (linear between samples; pass the torque smoothed as the angles were).
/// @throws std::invalid_argument for sizes that disagree, fewer than 2 samples, times that do
///         not increase or bad options.
inline ChainFreeSimulation free_chain_simulation(const ChainModel& model,
                                                 const Eigen::VectorXd& theta,
                                                 const ChainKinematics<double>& k,
                                                 const ChainFreeSimulationOptions& options = {}) {
  const std::string who = "sid::free_chain_simulation: ";
  const int n = model.joints();
  const Eigen::Index m = k.t.size();
  if (theta.size() != model.parameters() || k.q.cols() != n || k.qd.cols() != n ||
      k.tau.cols() != n || k.q.rows() != m || k.qd.rows() != m || k.tau.rows() != m)
    throw std::invalid_argument(who + "theta or the kinematics do not match the model's " +
                                std::to_string(n) + " joints and " +
                                std::to_string(model.parameters()) + " parameters");
  if (m < 2) throw std::invalid_argument(who + "needs at least 2 samples");
  for (Eigen::Index i = 1; i < m; ++i)
    if (!(k.t[i] > k.t[i - 1]))
      throw std::invalid_argument(who + "times must increase (sample " + std::to_string(i) + ")");
  if (!(options.segment > 0.0) || !(options.blow_up > 0.0))
    throw std::invalid_argument(who + "segment and blow_up must be > 0");

  using Vector = ChainModel::Vector;
  ChainFreeSimulation out;
  out.q = Eigen::MatrixXd::Constant(m, n, std::numeric_limits<double>::quiet_NaN());
  Eigen::Index begin = 0;
  for (;;) {
    Eigen::Index end = std::min(begin + 2, m);  // exclusive; at least one interval
    while (end < m && k.t[end] - k.t[begin] <= options.segment) ++end;
    ++out.segments;
    const Eigen::VectorXd t = k.t.segment(begin, end - begin);
    Eigen::VectorXd x0(2 * n);
    x0 << k.q.row(begin).transpose(), k.qd.row(begin).transpose();
    Eigen::Index at = 0;  // the sample interval of the last call, searched forward
    const auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                         Eigen::Map<Eigen::VectorXd>& xdot) {
      if (x.cwiseAbs().maxCoeff() > options.blow_up)
        throw std::runtime_error("the state passed the blow-up bound");
      while (at + 1 < t.size() - 1 && time > t[at + 1]) ++at;
      while (at > 0 && time < t[at]) --at;
      const double s = std::clamp((time - t[at]) / (t[at + 1] - t[at]), 0.0, 1.0);
      const Vector tau =
          ((1.0 - s) * k.tau.row(begin + at) + s * k.tau.row(begin + at + 1)).transpose();
      const Vector q = x.head(n), qd = x.tail(n);
      xdot.head(n) = qd;
      xdot.tail(n) = model.forward_dynamics(theta, q, qd, tau);
    };
    const SimulationResult sim = simulate(rhs, x0, t, options.simulator);
    out.q.middleRows(begin, sim.completed) = sim.states.topLeftCorner(sim.completed, n);
    if (!sim.ok()) {
      ++out.failed_segments;
      out.message += (out.message.empty() ? "" : "; ") + std::string("segment at t = ") +
                     std::to_string(k.t[begin]) + " s stopped at " + std::to_string(sim.t_reached) +
                     " s (" + sim.message + ")";
    }
    if (end >= m) break;
    begin = end - 1;  // segments share their boundary sample: the next restarts there
  }
  out.error = k.q - out.q;
  out.error_rms = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::quiet_NaN());
  for (int j = 0; j < n; ++j) {
    double sum = 0.0;
    Eigen::Index count = 0;
    for (Eigen::Index i = 0; i < m; ++i)
      if (std::isfinite(out.error(i, j))) {
        sum += out.error(i, j) * out.error(i, j);
        ++count;
      }
    if (count > 0) out.error_rms[j] = std::sqrt(sum / static_cast<double>(count));
  }
  return out;
}

}  // namespace sid
