#pragma once
/// @file
/// @brief Everything that follows from an inverse-dynamics function of an arm: mass
/// matrix, bias torque, forward dynamics, the state-space right-hand side, and the regressor.
///
/// For a model D(q) qdd + h(q, qd) = tau that is linear in qdd and in theta (paper eq. 38, 9):
///   column j of D(q) = ID(q, 0, e_j) - ID(q, 0, 0),   h(q, qd) = ID(q, qd, 0),
///   qdd = D(q)^-1 (tau - h(q, qd)),                   column j of Z = ID_{theta=e_j}(q, qd, qdd).
/// None of this needs symbolic algebra, so any model written as a sum of terms gets all of it.

#include <sid/model/terms.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <limits>

namespace sid {

template <typename Scalar>
using Matrix2 = Eigen::Matrix<Scalar, 2, 2>;

/// @brief A joints x joints matrix on the stack (Matrix2 for the paper's arm).
template <typename Scalar, int Joints = 2>
using JointMatrix = Eigen::Matrix<Scalar, Joints, Joints, Eigen::ColMajor,
                                  detail::max_joints(Joints), detail::max_joints(Joints)>;

/// @brief State x = (q, qd) of an arm [rad, rad/s], on the stack: (q1, q2, qd1, qd2) for the
/// paper's arm.
template <typename Scalar, int Joints = 2>
using JointState = Eigen::Matrix<Scalar, Joints == Eigen::Dynamic ? Eigen::Dynamic : 2 * Joints, 1,
                                 Eigen::ColMajor, 2 * detail::max_joints(Joints), 1>;

/// @brief State of a two-joint arm, x = (q1, q2, qd1, qd2) [rad, rad, rad/s, rad/s].
template <typename Scalar>
using ArmState = JointState<Scalar, 2>;

namespace detail {
/// A parameter that takes its type from the other arguments, so that it may be an expression.
template <typename Scalar, int Joints>
using JointVectorArgument = NoDeduce<JointVector<Scalar, Joints>>;
}  // namespace detail

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
/// @param inverse_dynamics callable (q, qd, qdd) -> tau [N m], each a JointVector.
/// @param q joint angles [rad].
/// @return D(q) [kg m^2].
template <typename Scalar, int Joints, typename InverseDynamics>
JointMatrix<Scalar, Joints> mass_matrix_from_inverse_dynamics(
    const InverseDynamics& inverse_dynamics, const JointVector<Scalar, Joints>& q) {
  const auto n = q.size();
  const JointVector<Scalar, Joints> zero = JointVector<Scalar, Joints>::Zero(n);
  const JointVector<Scalar, Joints> h0 = inverse_dynamics(q, zero, zero);
  JointMatrix<Scalar, Joints> d(n, n);
  for (Eigen::Index j = 0; j < n; ++j)
    d.col(j) = inverse_dynamics(q, zero, JointVector<Scalar, Joints>::Unit(n, j)) - h0;
  return d;
}

/// @brief Bias torque h(q, qd) = ID(q, qd, 0): Coriolis, centrifugal, gravity, friction [N m].
template <typename Scalar, int Joints, typename InverseDynamics>
JointVector<Scalar, Joints> bias_torque_from_inverse_dynamics(
    const InverseDynamics& inverse_dynamics, const JointVector<Scalar, Joints>& q,
    const detail::JointVectorArgument<Scalar, Joints>& qd) {
  return inverse_dynamics(q, qd, JointVector<Scalar, Joints>::Zero(q.size()));
}

/// @brief Forward dynamics qdd = D(q)^-1 (tau - h(q, qd)) from an inverse-dynamics function;
/// NaN where D(q) is not positive definite (beyond two joints; two joints: inf/NaN where it is
/// singular).
/// @param q [rad], qd [rad/s], tau applied joint torques [N m].
/// @return qdd [rad/s^2].
template <typename Scalar, int Joints, typename InverseDynamics>
JointVector<Scalar, Joints> forward_dynamics_from_inverse_dynamics(
    const InverseDynamics& inverse_dynamics, const JointVector<Scalar, Joints>& q,
    const detail::JointVectorArgument<Scalar, Joints>& qd,
    const detail::JointVectorArgument<Scalar, Joints>& tau) {
  const JointMatrix<Scalar, Joints> d = mass_matrix_from_inverse_dynamics(inverse_dynamics, q);
  const JointVector<Scalar, Joints> h = bias_torque_from_inverse_dynamics(inverse_dynamics, q, qd);
  if constexpr (Joints == 2) {
    return solve_2x2<Scalar>(d, tau - h);
  } else {
    const Eigen::LLT<JointMatrix<Scalar, Joints>> llt(d);
    if (llt.info() != Eigen::Success)
      return JointVector<Scalar, Joints>::Constant(
          q.size(), Scalar(std::numeric_limits<double>::quiet_NaN()));
    return llt.solve(tau - h);
  }
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
/// @tparam Joints not deducible from the state's type: give it beyond two joints.
template <typename Scalar, int Joints = 2, typename ForwardDynamics>
JointState<Scalar, Joints> state_derivative_from_forward_dynamics(
    const ForwardDynamics& forward_dynamics, const JointState<Scalar, Joints>& x,
    const detail::JointVectorArgument<Scalar, Joints>& tau) {
  const Eigen::Index n = x.size() / 2;
  const JointVector<Scalar, Joints> q = x.head(n);
  const JointVector<Scalar, Joints> qd = x.tail(n);
  JointState<Scalar, Joints> xdot(2 * n);
  xdot.head(n) = qd;
  xdot.tail(n) = forward_dynamics(q, qd, tau);
  return xdot;
}

}  // namespace sid
