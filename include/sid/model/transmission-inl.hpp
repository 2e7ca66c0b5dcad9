#pragma once
// Definitions of sid/model/transmission.hpp (see sid/config.hpp).

#include <sid/model/transmission.hpp>

namespace sid {

SID_INLINE Transmission::Transmission(const Eigen::MatrixXd& ratio, const Eigen::VectorXd& zero)
    : ratio_(ratio), zero_(zero) {
  const std::string who = "sid::Transmission: ";
  if (ratio.rows() == 0 || ratio.rows() != ratio.cols())
    throw std::invalid_argument(who + "the ratio matrix must be square and not empty, got " +
                                std::to_string(ratio.rows()) + " x " +
                                std::to_string(ratio.cols()));
  if (!ratio.allFinite() || !zero.allFinite())
    throw std::invalid_argument(who + "a ratio or zero offset is not finite");
  if (zero.size() != ratio.rows())
    throw std::invalid_argument(who + "the zero offsets have " + std::to_string(zero.size()) +
                                " entries for " + std::to_string(ratio.rows()) + " joints");
  for (Eigen::Index i = 0; i < ratio.rows(); ++i)
    if (ratio(i, i) == 0.0)
      throw std::invalid_argument(who + "motor " + std::to_string(i + 1) +
                                  " has no ratio to its own joint");
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(ratio);
  if (!lu.isInvertible()) throw std::invalid_argument(who + "the ratio matrix is singular");
  inverse_ = lu.inverse();
}

SID_INLINE ChainTrajectory<double> Transmission::joint_side(
    const ChainTrajectory<double>& motor) const {
  motor.validate("sid::Transmission::joint_side");
  if (motor.joints() != joints())
    throw std::invalid_argument("sid::Transmission::joint_side: the log has " +
                                std::to_string(motor.joints()) + " joints, the transmission " +
                                std::to_string(joints()));
  ChainTrajectory<double> out;
  out.t = motor.t;
  out.q = motor.q * inverse_.transpose();
  out.q.rowwise() += zero_.transpose();
  out.tau = motor.tau * ratio_;
  return out;
}

}  // namespace sid
