#pragma once
/// @file
/// @brief Everything that follows from an inverse-dynamics function of a two-joint arm: mass
/// matrix, bias torque, forward dynamics, the state-space right-hand side, and the regressor.
///
/// For a model D(q) qdd + h(q, qd) = tau that is linear in qdd and in theta (paper eq. 38, 9):
///   column j of D(q) = ID(q, 0, e_j) - ID(q, 0, 0),   h(q, qd) = ID(q, qd, 0),
///   qdd = D(q)^-1 (tau - h(q, qd)),                   column j of Z = ID_{theta=e_j}(q, qd, qdd).
/// None of this needs symbolic algebra, so any model written as a sum of terms gets all of it.

#include <sid/model/terms.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

namespace sid {

template <typename Scalar>
using Matrix2 = Eigen::Matrix<Scalar, 2, 2>;

/// @brief State of a two-joint arm, x = (q1, q2, qd1, qd2) [rad, rad, rad/s, rad/s].
template <typename Scalar>
using ArmState = Eigen::Matrix<Scalar, 4, 1>;

/// @brief Solves D x = rhs for a 2 x 2 matrix by Cramer's rule (no pivoting needed: D is
/// symmetric positive definite for a physical arm).
/// @pre det(D) != 0; otherwise the result is inf/NaN.
template <typename Scalar>
Vector2<Scalar> solve_2x2(const Matrix2<Scalar>& d,
                          const Vector2<detail::NoDeduce<Scalar>>& rhs) noexcept {
  const Scalar inv_det = Scalar(1) / (d(0, 0) * d(1, 1) - d(0, 1) * d(1, 0));
  return Vector2<Scalar>((d(1, 1) * rhs[0] - d(0, 1) * rhs[1]) * inv_det,
                         (d(0, 0) * rhs[1] - d(1, 0) * rhs[0]) * inv_det);
}

/// @brief D(q) from an inverse-dynamics function: column j = ID(q, 0, e_j) - ID(q, 0, 0).
/// @param inverse_dynamics callable (q, qd, qdd) -> tau [N m], each a Vector2<Scalar>.
/// @param q joint angles [rad].
/// @return D(q) [kg m^2].
template <typename Scalar, typename InverseDynamics>
Matrix2<Scalar> mass_matrix_from_inverse_dynamics(const InverseDynamics& inverse_dynamics,
                                                  const Vector2<Scalar>& q) {
  const Vector2<Scalar> zero = Vector2<Scalar>::Zero();
  const Vector2<Scalar> h0 = inverse_dynamics(q, zero, zero);
  Matrix2<Scalar> d;
  d.col(0) = inverse_dynamics(q, zero, Vector2<Scalar>::UnitX()) - h0;
  d.col(1) = inverse_dynamics(q, zero, Vector2<Scalar>::UnitY()) - h0;
  return d;
}

/// @brief Bias torque h(q, qd) = ID(q, qd, 0): Coriolis, centrifugal, gravity, friction [N m].
template <typename Scalar, typename InverseDynamics>
Vector2<Scalar> bias_torque_from_inverse_dynamics(const InverseDynamics& inverse_dynamics,
                                                  const Vector2<Scalar>& q,
                                                  const Vector2<detail::NoDeduce<Scalar>>& qd) {
  return inverse_dynamics(q, qd, Vector2<Scalar>::Zero());
}

/// @brief Forward dynamics qdd = D(q)^-1 (tau - h(q, qd)) from an inverse-dynamics function.
/// @param q [rad], qd [rad/s], tau applied joint torques [N m].
/// @return qdd [rad/s^2].
template <typename Scalar, typename InverseDynamics>
Vector2<Scalar> forward_dynamics_from_inverse_dynamics(
    const InverseDynamics& inverse_dynamics, const Vector2<Scalar>& q,
    const Vector2<detail::NoDeduce<Scalar>>& qd, const Vector2<detail::NoDeduce<Scalar>>& tau) {
  const Matrix2<Scalar> d = mass_matrix_from_inverse_dynamics(inverse_dynamics, q);
  const Vector2<Scalar> h = bias_torque_from_inverse_dynamics(inverse_dynamics, q, qd);
  return solve_2x2<Scalar>(d, tau - h);
}

/// @brief Regressor by unit parameter vectors: column j of Z is ID evaluated at theta = e_j.
/// @param inverse_dynamics callable (const ModelParameters<Scalar>& theta, q, qd, qdd) -> tau.
/// @param num_parameters p, at most kMaxModelParameters.
/// @param[out] out 2 x p, already sized.
/// @pre inverse_dynamics is linear (homogeneous) in theta.
template <typename Scalar, typename InverseDynamics>
void regressor_from_inverse_dynamics(const InverseDynamics& inverse_dynamics,
                                     Eigen::Index num_parameters, const Vector2<Scalar>& q,
                                     const Vector2<detail::NoDeduce<Scalar>>& qd,
                                     const Vector2<detail::NoDeduce<Scalar>>& qdd,
                                     RegressorView<detail::NoDeduce<Scalar>> out) {
  ModelParameters<Scalar> unit = ModelParameters<Scalar>::Zero(num_parameters);
  for (Eigen::Index j = 0; j < num_parameters; ++j) {
    unit[j] = Scalar(1);
    out.col(j) = inverse_dynamics(static_cast<const ModelParameters<Scalar>&>(unit), q, qd, qdd);
    unit[j] = Scalar(0);
  }
}

/// @brief State-space right-hand side xdot = (qd, qdd) for x = (q, qd) under torque tau [N m].
/// @param forward_dynamics callable (q, qd, tau) -> qdd [rad/s^2].
template <typename Scalar, typename ForwardDynamics>
ArmState<Scalar> state_derivative_from_forward_dynamics(
    const ForwardDynamics& forward_dynamics, const ArmState<Scalar>& x,
    const Vector2<detail::NoDeduce<Scalar>>& tau) {
  const Vector2<Scalar> q = x.template head<2>();
  const Vector2<Scalar> qd = x.template tail<2>();
  ArmState<Scalar> xdot;
  xdot.template head<2>() = qd;
  xdot.template tail<2>() = forward_dynamics(q, qd, tau);
  return xdot;
}

}  // namespace sid
