#pragma once
/// @file
/// @brief Where a force at a point of the last link goes: the point's linear Jacobian, and the
/// joint torques a force there applies (J^T f), the way the outside acts on an arm through its
/// tool.

#include <sid/model/chain_dynamics.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <stdexcept>
#include <string>

namespace sid {

template <typename Scalar>
using PointJacobian = Eigen::Matrix<Scalar, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kMaxChainJoints>;

/// @brief J(q) (3 x n) with v = J(q) qd the velocity, in the base frame, of the point `point`
/// fixed in the last link's frame [m].
/// @throws std::invalid_argument if q's size is not the chain's.
template <typename Scalar>
PointJacobian<Scalar> chain_point_jacobian(const SerialChain<Scalar>& chain,
                                           const Eigen::Ref<const Eigen::Matrix<Scalar, -1, 1>>& q,
                                           const Vector3<Scalar>& point) {
  const int n = chain.joints();
  if (q.size() != n)
    throw std::invalid_argument("sid::chain_point_jacobian: q has " + std::to_string(q.size()) +
                                " entries, the chain " + std::to_string(n) + " joints");
  FramePose<Scalar> base;
  std::array<FramePose<Scalar>, kMaxChainJoints> pose;
  for (int i = 0; i < n; ++i) {
    const FramePose<Scalar> local = chain.link_pose(i, q[i]);
    base.translation += base.rotation * local.translation;
    base.rotation = base.rotation * local.rotation;
    pose[static_cast<std::size_t>(i)] = base;
  }
  const Vector3<Scalar> tip = base.translation + base.rotation * point;
  PointJacobian<Scalar> j(3, n);
  for (int i = 0; i < n; ++i) {
    const FramePose<Scalar>& x = pose[static_cast<std::size_t>(i)];
    const JointAxis<Scalar> axis = chain.joint_axis(i);
    const Vector3<Scalar> direction = x.rotation * axis.direction;
    if (chain.joint_type(i) == JointType::Prismatic)
      j.col(i) = direction;
    else
      j.col(i) = direction.cross(tip - (x.translation + x.rotation * axis.point));
  }
  return j;
}

/// @brief The joint torques [N m, or N on a prismatic joint] a force `force` [N, base frame]
/// at `point` of the last link applies: J(q)^T force.
/// @throws std::invalid_argument as chain_point_jacobian.
template <typename Scalar>
ChainVector<Scalar> chain_point_force_torque(
    const SerialChain<Scalar>& chain, const Eigen::Ref<const Eigen::Matrix<Scalar, -1, 1>>& q,
    const Vector3<Scalar>& point, const Vector3<Scalar>& force) {
  return chain_point_jacobian(chain, q, point).transpose() * force;
}

}  // namespace sid
