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
/// with tau + tau_ext = M qdd + c + g + f (ArmDynamics). The integral of tau - beta is taken by
/// the trapezoid rule (the rectangle rule's error, dt/2 times the rate of change of tau - beta,
/// is tenths of a newton metre at 1 kHz on a moving arm); r's own term by the rectangle rule,
/// which makes each step the discrete lag r_k = (1 - K dt) r_(k-1) + K dt tau_ext.
///
/// Each update is noexcept and allocates nothing: a 1 kHz loop can run it. Holds a reference to
/// the ArmDynamics, which must outlive it.
class MomentumObserver {
 public:
  using Vector = ArmDynamics::Vector;

  /// @param gains K_j [1/s] per joint, > 0: the bandwidth of each joint's estimate (higher
  ///        follows faster, passes more noise; with a sample time dt, K dt must stay below 1).
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
    integral_.setZero(arm_.joints());
  }

  /// @brief Takes the sample (q, qd, tau) dt [s] after the previous one (the first sample only
  /// starts the observer) and returns the estimate of the external torque tau_ext [N m].
  /// tau: the drive torques, as the identification's logs give them.
  const Vector& update(const Eigen::Ref<const Eigen::VectorXd>& q,
                       const Eigen::Ref<const Eigen::VectorXd>& qd,
                       const Eigen::Ref<const Eigen::VectorXd>& tau, double dt) noexcept {
    arm_.momentum(q, qd, p_, beta_);
    if (!started_) {
      start_ = p_;
      previous_ = tau - beta_;
      started_ = true;
      return external_;
    }
    const Vector balance = tau - beta_;
    integral_ += (0.5 * (balance + previous_) + external_) * dt;
    previous_ = balance;
    external_ = gains_.cwiseProduct(p_ - start_ - integral_);
    return external_;
  }

  const Vector& external_torque() const noexcept { return external_; }
  const Vector& gains() const noexcept { return gains_; }

 private:
  const ArmDynamics& arm_;
  Vector gains_, p_, beta_, start_, external_, integral_, previous_;
  bool started_ = false;
};

}  // namespace sid
