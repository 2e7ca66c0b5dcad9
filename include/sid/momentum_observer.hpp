#pragma once
/// @file
/// @brief sid::MomentumObserver: the external joint torque an identified arm feels, from its
/// angles, rates and drive torques alone (De Luca's generalized-momentum observer): no
/// acceleration, so no twice-differentiated encoder noise.

#include <sid/arm_dynamics.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

/// @brief r(t) = K (p(t) - p(0) - integral of (tau + r - beta) dt), p = M(q) qd: each r_j
/// follows the external torque through a first-order lag of rate K_j, dr/dt = K (tau_ext - r),
/// with tau + tau_ext = M qdd + c + g + f (ArmDynamics).
///
/// Each step is that lag solved exactly over the step for the torque the step's momentum change
/// shows, r_k = a r_(k-1) + (1 - a) ((p_k - p_(k-1)) / dt - (b_k + b_(k-1)) / 2) with
/// a = exp(-K dt) and b = tau - beta: stable at any sample time (a log's gaps, a loop's late
/// tick), where the textbook's Euler step diverges once K dt > 2. The trapezoid on b: the
/// rectangle rule's error, dt/2 times the rate of change of tau - beta, is tenths of a newton
/// metre at 1 kHz on a moving arm.
///
/// Each update is noexcept and allocates nothing: a 1 kHz loop can run it. Holds a reference to
/// the ArmDynamics, which must outlive it.
class MomentumObserver {
 public:
  using Vector = ArmDynamics::Vector;

  /// @param gains K_j [1/s] per joint, > 0: the bandwidth of each joint's estimate (higher
  ///        follows faster and passes more of the rates' noise).
  /// @throws std::invalid_argument if gains' size is not the arm's or a gain is not > 0.
  MomentumObserver(const ArmDynamics& arm, const Eigen::Ref<const Eigen::VectorXd>& gains)
      : arm_(arm), gains_(gains), p_(arm.joints()), beta_(arm.joints()) {
    if (gains.size() != arm.joints())
      throw std::invalid_argument("sid::MomentumObserver: " + std::to_string(gains.size()) +
                                  " gains for " + std::to_string(arm.joints()) + " joints");
    for (Eigen::Index j = 0; j < gains.size(); ++j)
      if (!(gains[j] > 0.0) || !std::isfinite(gains[j]))
        throw std::invalid_argument("sid::MomentumObserver: gain " + std::to_string(j + 1) +
                                    " must be finite and > 0");
    reset();
  }

  /// @brief Forgets the past: the next update starts the estimate at zero there.
  void reset() noexcept {
    started_ = false;
    external_.setZero(arm_.joints());
    step_ = 0.0;
  }

  /// @brief Takes the sample (q, qd, tau) dt [s] after the previous one (the first sample only
  /// starts the observer; a dt that is not > 0 takes the sample as the new start of the step)
  /// and returns the estimate of the external torque tau_ext [N m].
  /// tau: the drive torques, as the identification's logs give them.
  const Vector& update(const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& qd,
                       const Eigen::Ref<const Eigen::VectorXd>& tau, double dt) noexcept {
    arm_.momentum(q, qd, p_, beta_);
    const Vector balance = tau - beta_;
    if (started_ && dt > 0.0) {
      if (dt != step_) {  // a loop's fixed tick computes the decay once
        step_ = dt;
        decay_ = (-gains_ * dt).array().exp();
        follow_ = Vector::Ones(arm_.joints()) - decay_;
      }
      const Vector shown = (p_ - previous_p_) / dt - 0.5 * (balance + previous_balance_);
      external_ = decay_.cwiseProduct(external_) + follow_.cwiseProduct(shown);
    }
    started_ = true;
    previous_p_ = p_;
    previous_balance_ = balance;
    return external_;
  }

  const Vector& external_torque() const noexcept { return external_; }
  const Vector& gains() const noexcept { return gains_; }

 private:
  const ArmDynamics& arm_;
  Vector gains_, p_, beta_, external_, previous_p_, previous_balance_, decay_, follow_;
  double step_ = 0.0;
  bool started_ = false;
};

}  // namespace sid
