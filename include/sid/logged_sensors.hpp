#pragma once
/// @file
/// @brief The sensors of a cheap arm between its motion and its log: encoders that round each
/// angle to their step, and a torque channel that lags the angles'.
///
/// The simulator (sid::simulate_robot) and the chain Monte Carlo study log the truth through
/// them, so that both describe the same arm. Hobby servos log 12-bit positions and their
/// currents over a separate path; a logged angle is then a staircase and the torque a few
/// milliseconds late, faults that Gaussian noise on the angles does not show.

#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief How the log differs from the truth beyond white noise.
struct LoggedSensors {
  /// The encoders' resolution in bits per turn of the shaft each sits on: one for every joint
  /// or one per joint (revolute joints only); empty: the angles are not quantised. The logged
  /// angle is the noisy one rounded to the encoder's step, 2π / (2^bits · ratio). 12 bits on the
  /// joint is 1.5e-3 rad, about a hobby servo's.
  std::vector<int> encoder_bits;
  /// Turns of each encoder's shaft per turn of its joint: the gear ratio of an encoder on the
  /// motor, one for every joint or one per joint; empty: 1 (on the joint).
  std::vector<double> encoder_ratio;
  /// [s] How far the torque channel lags the angles': the torque logged at t is the drives' at
  /// t − torque_delay (linear between samples, the first sample's before the start); negative:
  /// the angles lag.
  double torque_delay = 0.0;

  bool quantised() const noexcept { return !encoder_bits.empty(); }
};

namespace detail {

/// A per-joint setting given once for every joint or once per joint.
template <typename T>
T per_joint(const std::vector<T>& values, int joint, int joints, T otherwise,
            const std::string& what, const std::string& who) {
  if (values.empty()) return otherwise;
  if (values.size() != 1 && values.size() != static_cast<std::size_t>(joints))
    throw std::invalid_argument(who + ": " + what + " needs one value or one per joint (" +
                                std::to_string(joints) + "), not " + std::to_string(values.size()));
  return values[values.size() == 1 ? 0 : static_cast<std::size_t>(joint)];
}

}  // namespace detail

/// @brief Each joint's encoder step [rad] (0: not quantised).
/// @param who the caller, the prefix of the messages.
/// @throws std::invalid_argument when bits are not 1..52, a ratio not > 0, a list has neither
///         one value nor one per joint, an encoder sits on a prismatic joint, or the delay is
///         not finite.
inline Eigen::VectorXd encoder_steps(const LoggedSensors& sensors, const SerialChain<double>& chain,
                                     const std::string& who) {
  const auto fail = [&who](const std::string& what) {
    throw std::invalid_argument(who + ": " + what);
  };
  if (!std::isfinite(sensors.torque_delay)) fail("the torque delay must be finite [s]");
  for (const int bits : sensors.encoder_bits)
    if (bits < 1 || bits > 52) fail("encoder bits must be 1..52, not " + std::to_string(bits));
  for (const double ratio : sensors.encoder_ratio)
    if (!(std::isfinite(ratio) && ratio > 0.0)) fail("an encoder ratio must be > 0");
  if (!sensors.encoder_ratio.empty() && sensors.encoder_bits.empty())
    fail("an encoder ratio needs encoder bits");
  const int n = chain.joints();
  Eigen::VectorXd steps = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    const int bits = detail::per_joint(sensors.encoder_bits, j, n, 0, "encoder_bits", who);
    const double ratio = detail::per_joint(sensors.encoder_ratio, j, n, 1.0, "encoder_ratio", who);
    if (bits == 0) continue;
    if (chain.placements()[static_cast<std::size_t>(j)].type != JointType::Revolute)
      fail("encoder bits are per turn: joint " + std::to_string(j + 1) + " is prismatic");
    steps[j] = 2.0 * 3.14159265358979323846 / (std::ldexp(1.0, bits) * ratio);
  }
  return steps;
}

/// @brief Rounds each column of q to its encoder's step (encoder_steps; 0 leaves it).
inline void round_to_encoders(const Eigen::VectorXd& steps, Eigen::MatrixXd& q) {
  for (Eigen::Index j = 0; j < q.cols(); ++j)
    if (steps[j] > 0.0) q.col(j) = (q.col(j) / steps[j]).array().round().matrix() * steps[j];
}

/// @brief The channel x logged `delay` seconds behind: at t, x at t − delay, linear between
/// samples, the first sample's before the start and the last one's after the end.
inline Eigen::MatrixXd delayed_channel(const Eigen::VectorXd& t, const Eigen::MatrixXd& x,
                                       double delay) {
  if (delay == 0.0) return x;
  Eigen::MatrixXd out(x.rows(), x.cols());
  const Eigen::Index last = t.size() - 1;
  Eigen::Index k = 0;
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const double at = t[i] - delay;
    if (at <= t[0]) {
      out.row(i) = x.row(0);
      continue;
    }
    if (at >= t[last]) {
      out.row(i) = x.row(last);
      continue;
    }
    // Times increase, so the bracketing interval only moves forward (or back, for a lead).
    while (k + 1 < last && t[k + 1] <= at) ++k;
    while (k > 0 && t[k] > at) --k;
    const double w = (at - t[k]) / (t[k + 1] - t[k]);
    out.row(i) = (1.0 - w) * x.row(k) + w * x.row(k + 1);
  }
  return out;
}

}  // namespace sid
