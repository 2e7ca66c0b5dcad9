#pragma once
/// @file
/// @brief Forward dynamics of a serial chain in O(n): Featherstone's articulated-body algorithm,
/// in each link's own frame, from the links' ten standard parameters (the same parameters the
/// regressor is linear in), with rotor inertias (armature) on the joints.
///
/// The O(n^3) route (sid/model/chain_dynamics.hpp: n + 2 inverse dynamics and a Cholesky of
/// M(q)) gives the same accelerations; this one is what a simulator calls at every step.

#include <sid/model/chain_dynamics.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>

#include <Eigen/Core>

#include <array>
#include <limits>
#include <stdexcept>
#include <string>

namespace sid {

namespace detail {

template <typename Scalar>
using Vector6 = Eigen::Matrix<Scalar, 6, 1>;
template <typename Scalar>
using Matrix6 = Eigen::Matrix<Scalar, 6, 6>;

template <typename Scalar>
Matrix3<Scalar> cross_matrix(const Vector3<Scalar>& v) {
  Matrix3<Scalar> s;
  s << Scalar(0), -v[2], v[1], v[2], Scalar(0), -v[0], -v[1], v[0], Scalar(0);
  return s;
}

/// The spatial inertia (angular rows first) of ten parameters [m, m c, I about the origin]:
/// momentum = (I w + h x v, m v - h x w) for the motion (w, v) of the frame's origin.
template <typename Scalar, typename Phi>
Matrix6<Scalar> spatial_inertia(const Phi& phi) {
  Matrix6<Scalar> s;
  const Vector3<Scalar> h(phi[1], phi[2], phi[3]);
  s.template topLeftCorner<3, 3>() << phi[4], phi[5], phi[7], phi[5], phi[6], phi[8], phi[7],
      phi[8], phi[9];
  s.template topRightCorner<3, 3>() = cross_matrix(h);
  s.template bottomLeftCorner<3, 3>() = -cross_matrix(h);
  s.template bottomRightCorner<3, 3>() = phi[0] * Matrix3<Scalar>::Identity();
  return s;
}

/// v x m for motion vectors (angular part first).
template <typename Scalar>
Vector6<Scalar> cross_motion(const Vector6<Scalar>& v, const Vector6<Scalar>& m) {
  Vector6<Scalar> r;
  const Vector3<Scalar> w = v.template head<3>(), vl = v.template tail<3>();
  r.template head<3>() = w.cross(m.template head<3>());
  r.template tail<3>() = w.cross(m.template tail<3>()) + vl.cross(m.template head<3>());
  return r;
}

/// v x* f for a motion v and a force f (moment first).
template <typename Scalar>
Vector6<Scalar> cross_force(const Vector6<Scalar>& v, const Vector6<Scalar>& f) {
  Vector6<Scalar> r;
  const Vector3<Scalar> w = v.template head<3>(), vl = v.template tail<3>();
  r.template head<3>() = w.cross(f.template head<3>()) + vl.cross(f.template tail<3>());
  r.template tail<3>() = w.cross(f.template tail<3>());
  return r;
}

/// The motion transform from the parent's frame to the child's, for the child's pose in the
/// parent: (w, v) -> (R^T w, R^T (v + w x p)). Its transpose carries forces back.
template <typename Scalar>
Matrix6<Scalar> motion_transform(const FramePose<Scalar>& pose) {
  Matrix6<Scalar> x;
  const Matrix3<Scalar> rt = pose.rotation.transpose();
  x.template topLeftCorner<3, 3>() = rt;
  x.template topRightCorner<3, 3>().setZero();
  x.template bottomLeftCorner<3, 3>() = -rt * cross_matrix(pose.translation);
  x.template bottomRightCorner<3, 3>() = rt;
  return x;
}

/// The articulated-body algorithm. links: ten parameters per link; armature: one rotor inertia
/// per joint added to the joint's own inertia; with_motion false solves M(q) qdd = tau alone
/// (no velocities, no gravity). NaN where an articulated inertia is not positive.
template <typename Scalar, typename Links, typename Armature, typename Joints, typename Tau>
ChainVector<Scalar> articulated_body_unchecked(const SerialChain<Scalar>& chain, const Links& links,
                                               const Armature& armature, const Joints& q,
                                               const Joints& qd, const Tau& tau, bool with_motion) {
  const int n = chain.joints();
  std::array<Matrix6<Scalar>, kMaxChainJoints> x, inertia;
  std::array<Vector6<Scalar>, kMaxChainJoints> s, c, bias, u_col;
  std::array<Scalar, kMaxChainJoints> d, u;
  Vector6<Scalar> v = Vector6<Scalar>::Zero();
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    x[k] = motion_transform(chain.link_pose(i, q[i]));
    const JointAxis<Scalar> axis = chain.joint_axis(i);
    if (chain.placements()[k].type == JointType::Prismatic)
      s[k] << Vector3<Scalar>::Zero(), axis.direction;
    else
      s[k] << axis.direction, axis.point.cross(axis.direction);
    inertia[k] =
        spatial_inertia<Scalar>(links.template segment<kLinkParameters>(kLinkParameters * i));
    if (with_motion) {
      const Vector6<Scalar> joint_motion = s[k] * qd[i];
      v = x[k] * v + joint_motion;
      c[k] = cross_motion(v, joint_motion);
      bias[k] = cross_force(v, Vector6<Scalar>(inertia[k] * v));
    } else {
      c[k].setZero();
      bias[k].setZero();
    }
  }
  for (int i = n - 1; i >= 0; --i) {
    const auto k = static_cast<std::size_t>(i);
    u_col[k] = inertia[k] * s[k];
    d[k] = s[k].dot(u_col[k]) + armature[i];
    u[k] = tau[i] - s[k].dot(bias[k]);
    if (!(d[k] > Scalar(0)))
      return ChainVector<Scalar>::Constant(n, Scalar(std::numeric_limits<double>::quiet_NaN()));
    if (i > 0) {
      const Matrix6<Scalar> reduced = inertia[k] - u_col[k] * u_col[k].transpose() / d[k];
      const Vector6<Scalar> reduced_bias = bias[k] + reduced * c[k] + u_col[k] * (u[k] / d[k]);
      inertia[k - 1] += x[k].transpose() * reduced * x[k];
      bias[k - 1] += x[k].transpose() * reduced_bias;
    }
  }
  ChainVector<Scalar> qdd(n);
  Vector6<Scalar> a = Vector6<Scalar>::Zero();
  if (with_motion) a.template tail<3>() = -chain.gravity();  // the base accelerates up
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    a = x[k] * a + c[k];
    qdd[i] = (u[k] - u_col[k].dot(a)) / d[k];
    a += s[k] * qdd[i];
  }
  return qdd;
}

}  // namespace detail

/// @brief qdd = M(q)^-1 (tau - h(q, qd)) by the articulated-body algorithm, O(n), with theta in
/// the layout of chain_forward_dynamics (ten per link, then Fv_1..Fv_n, Fc_1..Fc_n; the friction
/// torques Fv qd + Fc sign(qd) oppose tau). Allocates nothing.
/// @param q [rad or m], qd [rad/s or m/s], tau applied joint torques [N m or N].
/// @throws std::invalid_argument if a size does not match the chain, or if an articulated
///         inertia is not positive (theta is not a physical arm at this q).
template <typename Scalar>
ChainVector<Scalar> chain_forward_dynamics_aba(const SerialChain<Scalar>& chain,
                                               const detail::ChainVectorRef<Scalar>& theta,
                                               const detail::ChainVectorRef<Scalar>& q,
                                               const detail::ChainVectorRef<Scalar>& qd,
                                               const detail::ChainVectorRef<Scalar>& tau) {
  const char* who = "sid::chain_forward_dynamics_aba";
  detail::check_forward_dynamics_arguments(who, chain, theta, q, qd, tau);
  if (!(theta.allFinite() && q.allFinite() && qd.allFinite() && tau.allFinite()))
    throw std::invalid_argument(std::string(who) +
                                ": theta, q, qd or tau holds a value that is "
                                "not finite");
  const int n = chain.joints();
  ChainVector<Scalar> applied(n);
  for (int j = 0; j < n; ++j)
    applied[j] = tau[j] - theta[kLinkParameters * n + j] * qd[j] -
                 theta[(kLinkParameters + 1) * n + j] * detail::sign(qd[j]);
  const ChainVector<Scalar> qdd = detail::articulated_body_unchecked(
      chain, theta, ChainVector<Scalar>::Zero(n), q, qd, applied, true);
  if (!qdd.allFinite())
    throw std::invalid_argument(std::string(who) +
                                ": an articulated inertia is not positive at this q (theta is "
                                "not a physical arm)");
  return qdd;
}

}  // namespace sid
