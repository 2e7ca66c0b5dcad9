#pragma once
/// @file
/// @brief The paper's two-link planar arm (eq. 38-40, corrected as docs/paper-reproduction.md
/// lists): its parameters, its terms for sid::Model, and closed-form fixed-size fast paths for
/// control loops.
///
/// Conventions: q1 from the downward vertical (gravity pulls toward q = 0), q2 relative to link 1,
/// counter-clockwise positive. D(q) qdd + C(q, qd) qd + G(q) + diag(theta6, theta7) qd = tau with
///   D = [[t1 + t2 + 2 t3 cos q2, t2 + t3 cos q2], [t2 + t3 cos q2, t2]],
///   C qd = [-t3 sin q2 (2 qd1 qd2 + qd2^2), t3 sin q2 qd1^2],
///   G = [t4 g sin q1 + t5 g sin(q1 + q2), t5 g sin(q1 + q2)].

#include <sid/detail/sincos.hpp>
#include <sid/model/dynamics.hpp>
#include <sid/model/model.hpp>
#include <sid/model/terms.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>

namespace sid {

/// theta = (theta1..theta7): [kg m^2, kg m^2, kg m^2, kg m, kg m, N m s/rad, N m s/rad].
template <typename Scalar>
using TwoLinkParameters = Eigen::Matrix<Scalar, 7, 1>;

/// tau = Z theta with Z of size 2 x 7 (row = joint).
template <typename Scalar>
using TwoLinkRegressor = Eigen::Matrix<Scalar, 2, 7>;

/// Gravity of the paper's experiment [m/s^2].
inline constexpr double kPaperGravity = 9.81;

/// @brief Physical parameters of the arm (links along their axes, centres of mass on them).
template <typename Scalar>
struct TwoLinkPhysical {
  Scalar l1;   ///< length of link 1 [m]
  Scalar lc1;  ///< joint 1 to centre of mass of link 1 [m]
  Scalar lc2;  ///< joint 2 to centre of mass of link 2 [m]
  Scalar m1;   ///< mass of link 1 [kg]
  Scalar m2;   ///< mass of link 2 [kg]
  Scalar I1;   ///< inertia of link 1 about its centre of mass, normal to the plane [kg m^2]
  Scalar I2;   ///< inertia of link 2 about its centre of mass [kg m^2]
  Scalar mu1;  ///< viscous friction of joint 1 [N m s/rad]
  Scalar mu2;  ///< viscous friction of joint 2 [N m s/rad]
};

/// @brief The paper's arm with the corrections listed in docs/paper-reproduction.md (lc1 = 0.0398
/// m, lc2 = 0.0392 m, not the printed 0.00398/0.00392; mu1 = mu2 = 0.6189 from the tables).
template <typename Scalar = double>
TwoLinkPhysical<Scalar> paper_arm_physical() noexcept {
  return {Scalar(0.2675), Scalar(0.0398), Scalar(0.0392), Scalar(0.4347), Scalar(0.4322),
          Scalar(0.0024), Scalar(0.0024), Scalar(0.6189), Scalar(0.6189)};
}

/// @brief The paper's true parameters, exactly as two_link_parameters(paper_arm_physical())
/// (the paper's printed row rounds theta2 and theta5 wrongly).
template <typename Scalar = double>
TwoLinkParameters<Scalar> paper_arm_parameters() noexcept {
  TwoLinkParameters<Scalar> theta;
  theta << Scalar(0.034015193438), Scalar(0.003064135808), Scalar(0.0045320492), Scalar(0.13291456),
      Scalar(0.01694224), Scalar(0.6189), Scalar(0.6189);
  return theta;
}

/// @brief Base parameters from physical ones (paper eq. 40): t1 = m1 lc1^2 + I1 + m2 l1^2,
/// t2 = m2 lc2^2 + I2, t3 = m2 l1 lc2, t4 = m1 lc1 + m2 l1, t5 = m2 lc2, t6 = mu1, t7 = mu2.
template <typename Scalar>
TwoLinkParameters<Scalar> two_link_parameters(const TwoLinkPhysical<Scalar>& p) noexcept {
  TwoLinkParameters<Scalar> theta;
  theta << p.m1 * p.lc1 * p.lc1 + p.I1 + p.m2 * p.l1 * p.l1, p.m2 * p.lc2 * p.lc2 + p.I2,
      p.m2 * p.l1 * p.lc2, p.m1 * p.lc1 + p.m2 * p.l1, p.m2 * p.lc2, p.mu1, p.mu2;
  return theta;
}

/// @brief True if the mass matrix D(theta, q) is positive definite at every q: theta2 > 0 and
/// det D = theta1 theta2 - theta3^2 cos^2 q2 > 0 for every q2, i.e. theta1 theta2 > theta3^2.
template <typename Scalar>
bool two_link_mass_matrix_positive_definite(const TwoLinkParameters<Scalar>& theta) noexcept {
  return theta[1] > Scalar(0) && theta[0] * theta[1] > theta[2] * theta[2];
}

namespace detail {

/// Writes the five rigid-body columns (theta1..theta5) of the closed-form regressor into
/// out(0..1, 0..4). sin(q1 + q2) comes from the addition formula so that only two
/// sincos evaluations are needed.
template <typename Scalar, typename Out>
void two_link_rigid_body_columns(const Vector2<Scalar>& q, const Vector2<Scalar>& qd,
                                 const Vector2<Scalar>& qdd, Scalar g, Out& out) noexcept {
  const auto [s1, c1] = detail::sincos(q[0]);
  const auto [s2, c2] = detail::sincos(q[1]);
  const Scalar gs12 = g * (s1 * c2 + c1 * s2);
  out(0, 0) = qdd[0];
  out(1, 0) = Scalar(0);
  out(0, 1) = qdd[0] + qdd[1];
  out(1, 1) = qdd[0] + qdd[1];
  out(0, 2) = c2 * (Scalar(2) * qdd[0] + qdd[1]) - s2 * (Scalar(2) * qd[0] + qd[1]) * qd[1];
  out(1, 2) = c2 * qdd[0] + s2 * qd[0] * qd[0];
  out(0, 3) = g * s1;
  out(1, 3) = Scalar(0);
  out(0, 4) = gs12;
  out(1, 4) = gs12;
}

template <typename Scalar, typename Out>
void two_link_viscous_columns(const Vector2<Scalar>& qd, Out& out) noexcept {
  out(0, 0) = qd[0];
  out(1, 0) = Scalar(0);
  out(0, 1) = Scalar(0);
  out(1, 1) = qd[1];
}

}  // namespace detail

/// @brief Closed-form regressor Z(q, qd, qdd), tau = Z theta (the corrected model; checked against
/// Pinocchio). Fast path: fixed size, no allocation.
/// @param q [rad], qd [rad/s], qdd [rad/s^2], g gravity [m/s^2].
template <typename Scalar>
TwoLinkRegressor<Scalar> two_link_regressor(const Vector2<Scalar>& q,
                                            const Vector2<detail::NoDeduce<Scalar>>& qd,
                                            const Vector2<detail::NoDeduce<Scalar>>& qdd,
                                            detail::NoDeduce<Scalar> g = kPaperGravity) noexcept {
  TwoLinkRegressor<Scalar> z;
  detail::two_link_rigid_body_columns(q, qd, qdd, g, z);
  auto friction = z.template rightCols<2>();
  detail::two_link_viscous_columns(qd, friction);
  return z;
}

/// @brief D(q) [kg m^2] in closed form (paper eq. 39).
template <typename Scalar>
Matrix2<Scalar> two_link_mass_matrix(const TwoLinkParameters<Scalar>& theta,
                                     const Vector2<detail::NoDeduce<Scalar>>& q) noexcept {
  const Scalar t3c2 = theta[2] * detail::sincos(q[1]).cos;
  Matrix2<Scalar> d;
  d << theta[0] + theta[1] + Scalar(2) * t3c2, theta[1] + t3c2, theta[1] + t3c2, theta[1];
  return d;
}

/// @brief h(q, qd) = C(q, qd) qd + G(q) + friction [N m] in closed form.
template <typename Scalar>
Vector2<Scalar> two_link_bias_torque(const TwoLinkParameters<Scalar>& theta,
                                     const Vector2<detail::NoDeduce<Scalar>>& q,
                                     const Vector2<detail::NoDeduce<Scalar>>& qd,
                                     detail::NoDeduce<Scalar> g = kPaperGravity) noexcept {
  const auto [s1, c1] = detail::sincos(q[0]);
  const auto [s2, c2] = detail::sincos(q[1]);
  const Scalar t5gs12 = theta[4] * g * (s1 * c2 + c1 * s2);
  const Scalar t3s2 = theta[2] * s2;
  return Vector2<Scalar>(
      -t3s2 * (Scalar(2) * qd[0] + qd[1]) * qd[1] + theta[3] * g * s1 + t5gs12 + theta[5] * qd[0],
      t3s2 * qd[0] * qd[0] + t5gs12 + theta[6] * qd[1]);
}

/// @brief Inverse dynamics tau = D(q) qdd + h(q, qd) [N m] in closed form (computed from D, C, G
/// directly, not through Z, so the two are independent checks of each other).
template <typename Scalar>
Vector2<Scalar> two_link_inverse_dynamics(const TwoLinkParameters<Scalar>& theta,
                                          const Vector2<detail::NoDeduce<Scalar>>& q,
                                          const Vector2<detail::NoDeduce<Scalar>>& qd,
                                          const Vector2<detail::NoDeduce<Scalar>>& qdd,
                                          detail::NoDeduce<Scalar> g = kPaperGravity) noexcept {
  const auto [s1, c1] = detail::sincos(q[0]);
  const auto [s2, c2] = detail::sincos(q[1]);
  const Scalar t5gs12 = theta[4] * g * (s1 * c2 + c1 * s2);
  const Scalar t3c2 = theta[2] * c2, t3s2 = theta[2] * s2;
  const Scalar d11 = theta[0] + theta[1] + Scalar(2) * t3c2, d12 = theta[1] + t3c2;
  return Vector2<Scalar>(
      d11 * qdd[0] + d12 * qdd[1] - t3s2 * (Scalar(2) * qd[0] + qd[1]) * qd[1] + theta[3] * g * s1 +
          t5gs12 + theta[5] * qd[0],
      d12 * qdd[0] + theta[1] * qdd[1] + t3s2 * qd[0] * qd[0] + t5gs12 + theta[6] * qd[1]);
}

/// @brief Forward dynamics qdd = D(q)^-1 (tau - h(q, qd)) [rad/s^2] for applied torques tau [N m].
/// @pre theta physical (D positive definite); otherwise the result may be inf/NaN.
template <typename Scalar>
Vector2<Scalar> two_link_forward_dynamics(const TwoLinkParameters<Scalar>& theta,
                                          const Vector2<detail::NoDeduce<Scalar>>& q,
                                          const Vector2<detail::NoDeduce<Scalar>>& qd,
                                          const Vector2<detail::NoDeduce<Scalar>>& tau,
                                          detail::NoDeduce<Scalar> g = kPaperGravity) noexcept {
  return solve_2x2<Scalar>(two_link_mass_matrix(theta, q),
                           tau - two_link_bias_torque(theta, q, qd, g));
}

/// @brief State-space right-hand side xdot = (qd, qdd) for x = (q1, q2, qd1, qd2) under applied
/// torques tau [N m]; what the simulator integrates.
template <typename Scalar>
ArmState<Scalar> two_link_state_derivative(const TwoLinkParameters<Scalar>& theta,
                                           const ArmState<detail::NoDeduce<Scalar>>& x,
                                           const Vector2<detail::NoDeduce<Scalar>>& tau,
                                           detail::NoDeduce<Scalar> g = kPaperGravity) noexcept {
  const Vector2<Scalar> q = x.template head<2>();
  const Vector2<Scalar> qd = x.template tail<2>();
  ArmState<Scalar> xdot;
  xdot.template head<2>() = qd;
  xdot.template tail<2>() = two_link_forward_dynamics(theta, q, qd, tau, g);
  return xdot;
}

/// @brief The rigid-body term of the arm, parameters "theta1".."theta5" (paper eq. 40).
/// @param g gravity [m/s^2], a fixed hyper-parameter of the term.
template <typename Scalar>
Term<Scalar> two_link_rigid_body_term(Scalar g = Scalar(kPaperGravity)) {
  return {
      "rigid_body",
      {"theta1", "theta2", "theta3", "theta4", "theta5"},
      [g](const Vector2<Scalar>& q, const Vector2<Scalar>& qd, const Vector2<Scalar>& qdd,
          RegressorView<Scalar> out) { detail::two_link_rigid_body_columns(q, qd, qdd, g, out); }};
}

/// @brief Viscous joint friction tau_j = mu_j qd_j, parameters "theta6", "theta7" [N m s/rad].
template <typename Scalar>
Term<Scalar> viscous_friction_term() {
  return {"viscous_friction",
          {"theta6", "theta7"},
          [](const Vector2<Scalar>&, const Vector2<Scalar>& qd, const Vector2<Scalar>&,
             RegressorView<Scalar> out) { detail::two_link_viscous_columns(qd, out); }};
}

/// @brief The paper's 7-parameter model: rigid body (theta1..5) + viscous friction (theta6, 7).
template <typename Scalar>
Model<Scalar> two_link_arm_model(Scalar g = Scalar(kPaperGravity)) {
  Model<Scalar> model;
  model.add(two_link_rigid_body_term<Scalar>(g));
  model.add(viscous_friction_term<Scalar>());
  return model;
}

}  // namespace sid
