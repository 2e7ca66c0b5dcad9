#pragma once
/// @file
/// @brief A chain's mass matrix, bias torque and forward dynamics, from its regressor: the one
/// model description that identification fits also moves the arm.

#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

template <typename Scalar>
using ChainMatrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                  kMaxChainJoints, kMaxChainJoints>;
template <typename Scalar>
using ChainVector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxChainJoints, 1>;

namespace detail {

/// h(q, qd) = ID(q, qd, 0): gravity, Coriolis and centrifugal torques and friction.
template <typename Scalar>
ChainVector<Scalar> bias_unchecked(const SerialChain<Scalar>& chain,
                                   const ChainVectorRef<Scalar>& theta,
                                   const ChainVectorRef<Scalar>& q,
                                   const ChainVectorRef<Scalar>& qd) {
  const int n = chain.joints();
  ChainRegressor<Scalar> y(n, theta.size());
  const ChainVector<Scalar> zero = ChainVector<Scalar>::Zero(n);
  chain_regressor_unchecked(chain, q, qd, ChainVectorRef<Scalar>(zero), y);
  return y * theta;
}

/// M(q): column j is ID(q, 0, e_j) - ID(q, 0, 0) (friction vanishes at rest, sign(0) = 0).
template <typename Scalar>
ChainMatrix<Scalar> mass_unchecked(const SerialChain<Scalar>& chain,
                                   const ChainVectorRef<Scalar>& theta,
                                   const ChainVectorRef<Scalar>& q) {
  const int n = chain.joints();
  const ChainVector<Scalar> zero = ChainVector<Scalar>::Zero(n);
  const ChainVectorRef<Scalar> at_rest_rate(zero);
  const ChainVector<Scalar> at_rest = bias_unchecked(chain, theta, q, at_rest_rate);
  ChainMatrix<Scalar> m(n, n);
  ChainRegressor<Scalar> y(n, theta.size());
  ChainVector<Scalar> unit = zero;
  const ChainVectorRef<Scalar> unit_acceleration(unit);
  for (int j = 0; j < n; ++j) {
    unit[j] = Scalar(1);
    chain_regressor_unchecked(chain, q, at_rest_rate, unit_acceleration, y);
    m.col(j) = y * theta - at_rest;
    unit[j] = Scalar(0);
  }
  return m;
}

/// The sizes a forward-dynamics call needs, checked the same way by both routes.
template <typename Scalar>
void check_forward_dynamics_arguments(const char* who, const SerialChain<Scalar>& chain,
                                      const ChainVectorRef<Scalar>& theta,
                                      const ChainVectorRef<Scalar>& q,
                                      const ChainVectorRef<Scalar>& qd,
                                      const ChainVectorRef<Scalar>& tau) {
  check_chain_theta(who, chain, theta);
  check_chain_joints(who, chain, "q", q.size());
  check_chain_joints(who, chain, "qd", qd.size());
  check_chain_joints(who, chain, "tau", tau.size());
}

}  // namespace detail

/// @brief The joint-space mass matrix M(q) [kg m^2] (n x n, symmetric).
/// @throws std::invalid_argument if a size does not match the chain.
template <typename Scalar>
ChainMatrix<Scalar> chain_mass_matrix(const SerialChain<Scalar>& chain,
                                      const detail::ChainVectorRef<Scalar>& theta,
                                      const detail::ChainVectorRef<Scalar>& q) {
  const char* who = "sid::chain_mass_matrix";
  detail::check_chain_theta(who, chain, theta);
  detail::check_chain_joints(who, chain, "q", q.size());
  return detail::mass_unchecked(chain, theta, q);
}

/// @brief h(q, qd) [N m]: the torque that holds the arm at zero acceleration (gravity,
/// Coriolis, centrifugal and friction), so that tau = M(q) qdd + h(q, qd).
/// @throws std::invalid_argument if a size does not match the chain.
template <typename Scalar>
ChainVector<Scalar> chain_bias_torque(const SerialChain<Scalar>& chain,
                                      const detail::ChainVectorRef<Scalar>& theta,
                                      const detail::ChainVectorRef<Scalar>& q,
                                      const detail::ChainVectorRef<Scalar>& qd) {
  const char* who = "sid::chain_bias_torque";
  detail::check_chain_theta(who, chain, theta);
  detail::check_chain_joints(who, chain, "q", q.size());
  detail::check_chain_joints(who, chain, "qd", qd.size());
  return detail::bias_unchecked(chain, theta, q, qd);
}

/// @brief qdd = M(q)^-1 (tau - h(q, qd)) [rad/s^2] under applied joint torques tau [N m].
/// Allocates nothing; n + 2 regressor evaluations and a Cholesky factorization.
/// @throws std::invalid_argument if a size does not match the chain, or if M(q) is not
///         positive definite (theta is not a physical arm at this q).
template <typename Scalar>
ChainVector<Scalar> chain_forward_dynamics(const SerialChain<Scalar>& chain,
                                           const detail::ChainVectorRef<Scalar>& theta,
                                           const detail::ChainVectorRef<Scalar>& q,
                                           const detail::ChainVectorRef<Scalar>& qd,
                                           const detail::ChainVectorRef<Scalar>& tau) {
  const char* who = "sid::chain_forward_dynamics";
  detail::check_forward_dynamics_arguments(who, chain, theta, q, qd, tau);
  const Eigen::LLT<ChainMatrix<Scalar>> llt(detail::mass_unchecked(chain, theta, q));
  if (llt.info() != Eigen::Success)
    throw std::invalid_argument(std::string(who) +
                                ": the mass matrix is not positive definite at this q (theta is "
                                "not a physical arm)");
  return llt.solve(tau - detail::bias_unchecked(chain, theta, q, qd));
}

}  // namespace sid
