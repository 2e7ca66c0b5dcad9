#pragma once
/// @file
/// @brief sid::Transmission: how a chain's drives turn its joints, so that a log recorded on the
/// motor side goes in as it was recorded.
///
/// Motor angles are a linear map of the joint angles, q_motor = G q (G: the gear ratios on the
/// diagonal, a coupling off it, e.g. a wrist whose last motor turns with the joint before it).
/// The drives' power is the joints' power, tau_motor . qd_motor = tau . qd, so the joint torques
/// are tau = G^T tau_motor. This is FIGAROH's convention (its Rq is G, its Rt is G^T).

#include <sid/config.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>
#include <Eigen/LU>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Class invariant: ratio is square, finite and invertible; zero has one entry per joint.
class Transmission {
 public:
  /// @brief Direct drive: motor and joint are the same.
  explicit Transmission(int joints)
      : Transmission(Eigen::MatrixXd::Identity(joints, joints), Eigen::VectorXd::Zero(joints)) {}

  /// @param ratio G, with q_motor = G q; row i is motor i.
  /// @param zero added to the joint angles after the gear: q = G^-1 q_motor + zero [rad], the
  ///        encoder's zero in the model's convention.
  /// @throws std::invalid_argument if G is not square, not finite or singular, or zero's size
  ///         does not match.
  SID_INLINE Transmission(const Eigen::MatrixXd& ratio, const Eigen::VectorXd& zero);

  int joints() const noexcept { return static_cast<int>(ratio_.rows()); }
  const Eigen::MatrixXd& ratio() const noexcept { return ratio_; }
  const Eigen::VectorXd& zero() const noexcept { return zero_; }

  /// @brief The motors that turn more than their own joint (a row of G with an entry off the
  /// diagonal): their inertia and friction act on a combination of joint rates.
  std::vector<int> coupled_motors() const {
    std::vector<int> coupled;
    for (Eigen::Index i = 0; i < ratio_.rows(); ++i)
      for (Eigen::Index j = 0; j < ratio_.cols(); ++j)
        if (i != j && ratio_(i, j) != 0.0) {
          coupled.push_back(static_cast<int>(i));
          break;
        }
    return coupled;
  }

  /// @brief Motor i's rate per joint rate, divided by its own ratio: the joint-side combination
  /// the motor's friction and inertia act on (e.g. qd5 + qd6 for the TX40's sixth motor).
  Eigen::RowVectorXd motor_direction(int motor) const {
    return ratio_.row(motor) / ratio_(motor, motor);
  }

  /// @brief The log on the joint side: q = G^-1 q_motor + zero, tau = G^T tau_motor.
  /// @throws std::invalid_argument if the log is invalid or has another number of joints.
  SID_INLINE ChainTrajectory<double> joint_side(const ChainTrajectory<double>& motor) const;

 private:
  Eigen::MatrixXd ratio_;
  Eigen::VectorXd zero_;
  Eigen::MatrixXd inverse_;
};

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/model/transmission-inl.hpp>
#endif
