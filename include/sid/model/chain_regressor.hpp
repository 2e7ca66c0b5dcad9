#pragma once
/// @file
/// @brief The joint-torque regressor of a sid::SerialChain, tau = Y(q, qd, qdd) theta, by a
/// Newton-Euler recursion written in the parameters (no symbolic expansion), and its stacking
/// over samples.
///
/// theta holds, per link i = 1..n, the ten standard parameters in link frame i
/// [m, mx, my, mz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz] (first moments m c, inertia about the frame's
/// origin), then the viscous coefficients Fv_1..Fv_n and the Coulomb levels Fc_1..Fc_n:
/// tau_j += Fv_j qd_j + Fc_j sign(qd_j), with sign(0) = 0. This is Pinocchio's order
/// (`computeJointTorqueRegressor`) followed by the friction columns. A revolute joint's tau is
/// the torque about its axis [N m], a prismatic joint's the force along it [N].

#include <sid/model/regressor.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Standard inertial parameters of one link.
inline constexpr int kLinkParameters = 10;

/// @brief Length of theta for a chain of this many joints: ten per link, two friction values
///        per joint.
constexpr Eigen::Index chain_parameter_count(int joints) noexcept {
  return static_cast<Eigen::Index>(joints) * (kLinkParameters + 2);
}

/// @brief The names of theta's entries: m_1, mx_1, ..., Izz_n, Fv_1..Fv_n, Fc_1..Fc_n.
inline std::vector<std::string> chain_parameter_names(int joints) {
  static const char* const link[kLinkParameters] = {"m",   "mx",  "my",  "mz",  "Ixx",
                                                    "Ixy", "Iyy", "Ixz", "Iyz", "Izz"};
  std::vector<std::string> names;
  for (int i = 1; i <= joints; ++i)
    for (const char* name : link) names.push_back(std::string(name) + "_" + std::to_string(i));
  for (const char* friction : {"Fv_", "Fc_"})
    for (int i = 1; i <= joints; ++i) names.push_back(friction + std::to_string(i));
  return names;
}

/// @brief A chain regressor on the stack (at most kMaxChainJoints rows).
template <typename Scalar>
using ChainRegressor = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                     kMaxChainJoints, kMaxChainJoints*(kLinkParameters + 2)>;

namespace detail {

template <typename Scalar>
using ChainVectorRef = Eigen::Ref<const VectorX<NoDeduce<Scalar>>>;
template <typename Scalar>
using ChainSamplesRef =
    Eigen::Ref<const Eigen::Matrix<NoDeduce<Scalar>, Eigen::Dynamic, Eigen::Dynamic>>;
template <typename Scalar>
using ChainRegressorRef =
    Eigen::Ref<Eigen::Matrix<NoDeduce<Scalar>, Eigen::Dynamic, Eigen::Dynamic>>;

/// A link's wrench about its frame's origin is linear in its ten parameters: with angular
/// velocity w, angular acceleration w' and origin acceleration a (gravity included),
/// f = m a + w' x h + w x (w x h) and n = I w' + w x I w + h x a. Its power for a joint motion
/// (angular wu, linear vu at the origin), wu . n + vu . f, is therefore a row over the ten
/// parameters; written out, it costs a few cross products instead of a 6 x 10 matrix per link.
/// y^T I x for a symmetric I, as a row over [Ixx, Ixy, Iyy, Ixz, Iyz, Izz].
template <typename Scalar, typename Row>
void add_inertia_row(const Vector3<Scalar>& y, const Vector3<Scalar>& x, Row& row) {
  row[4] += y[0] * x[0];
  row[5] += y[0] * x[1] + y[1] * x[0];
  row[6] += y[1] * x[1];
  row[7] += y[0] * x[2] + y[2] * x[0];
  row[8] += y[1] * x[2] + y[2] * x[1];
  row[9] += y[2] * x[2];
}

/// The power row of a link's wrench for the joint motion (wu, vu), all in the link's frame.
template <typename Scalar>
Eigen::Matrix<Scalar, 1, kLinkParameters> link_power_row(const Vector3<Scalar>& w,
                                                         const Vector3<Scalar>& wd,
                                                         const Vector3<Scalar>& a,
                                                         const Vector3<Scalar>& wu,
                                                         const Vector3<Scalar>& vu) {
  Eigen::Matrix<Scalar, 1, kLinkParameters> row;
  row[0] = vu.dot(a);
  // h: wu . (h x a) + vu . (w' x h + w x (w x h))
  row.template segment<3>(1) = a.cross(wu) + vu.cross(wd) + w.cross(w.cross(vu));
  row.template tail<6>().setZero();
  // I: wu . (I w') + wu . (w x I w) = wu^T I w' + (wu x w)^T I w
  add_inertia_row(wu, wd, row);
  add_inertia_row(Vector3<Scalar>(wu.cross(w)), w, row);
  return row;
}

template <typename Scalar>
Scalar sign(const Scalar& x) {
  return Scalar((x > Scalar(0)) - (x < Scalar(0)));
}

/// Per-link motion of the forward recursion, in each link's own frame.
template <typename Scalar>
struct ChainMotion {
  std::array<FramePose<Scalar>, kMaxChainJoints> pose;
  /// Joint i's motion per unit rate in its link's frame: the angular velocity (the axis for a
  /// revolute joint, zero for a prismatic one) and the velocity it gives the frame's origin
  /// (point x axis for a revolute joint, the axis for a prismatic one).
  std::array<Vector3<Scalar>, kMaxChainJoints> u, ru;
  std::array<Vector3<Scalar>, kMaxChainJoints> w, wd, a;
};

template <typename Scalar, typename Joints>
void chain_motion(const SerialChain<Scalar>& chain, const Joints& q, const Joints& qd,
                  const Joints& qdd, ChainMotion<Scalar>& m) {
  // Spatial recursion: velocity (w, v) and spatial acceleration (wd, ad) of each frame's origin;
  // the base accelerates against gravity so that every link feels its weight.
  Vector3<Scalar> w = Vector3<Scalar>::Zero(), v = Vector3<Scalar>::Zero();
  Vector3<Scalar> wd = Vector3<Scalar>::Zero(), ad = -chain.gravity();
  for (int i = 0; i < chain.joints(); ++i) {
    const auto k = static_cast<std::size_t>(i);
    m.pose[k] = chain.link_pose(i, q[i]);
    const JointAxis<Scalar> axis = chain.joint_axis(i);
    if (chain.placements()[k].type == JointType::Prismatic) {
      m.u[k].setZero();
      m.ru[k] = axis.direction;
    } else {
      m.u[k] = axis.direction;
      m.ru[k] = axis.point.cross(axis.direction);
    }
    const Matrix3<Scalar>& rt = m.pose[k].rotation;
    const Vector3<Scalar>& p = m.pose[k].translation;
    const Vector3<Scalar>& u = m.u[k];
    const Vector3<Scalar>& ru = m.ru[k];
    const Vector3<Scalar> w_joint = u * qd[i], v_joint = ru * qd[i];
    const Vector3<Scalar> w_new = rt.transpose() * w + w_joint;
    const Vector3<Scalar> v_new = rt.transpose() * (v + w.cross(p)) + v_joint;
    const Vector3<Scalar> wd_new = rt.transpose() * wd + u * qdd[i] + w_new.cross(w_joint);
    const Vector3<Scalar> ad_new = rt.transpose() * (ad + wd.cross(p)) + ru * qdd[i] +
                                   w_new.cross(v_joint) + v_new.cross(w_joint);
    w = w_new;
    v = v_new;
    wd = wd_new;
    ad = ad_new;
    m.w[k] = w;
    m.wd[k] = wd;
    m.a[k] = ad + w.cross(v);  // the origin's classical acceleration
  }
}

/// The links' columns, the first kLinkParameters * joints() of out (the rest is not touched).
template <typename Scalar, typename Joints, typename Out>
void chain_link_columns_unchecked(const SerialChain<Scalar>& chain, const Joints& q,
                                  const Joints& qd, const Joints& qdd, Out&& out) {
  ChainMotion<Scalar> m;
  chain_motion(chain, q, qd, qdd, m);
  const int n = chain.joints();
  out.leftCols(kLinkParameters * n).setZero();
  for (int i = 0; i < n; ++i) {
    // Joint i carries the wrenches of links i..n-1; its torque (or force) is the power of their
    // wrench per unit joint rate. Rather than carry each link's ten wrench columns in to joint i,
    // carry joint i's motion (axis direction, and the velocity it gives each frame's origin) out to
    // each link: one 6-vector per link instead of a 6 x 10 block.
    Vector3<Scalar> w = m.u[static_cast<std::size_t>(i)];
    Vector3<Scalar> v = m.ru[static_cast<std::size_t>(i)];
    for (int j = i; j < n; ++j) {
      const auto k = static_cast<std::size_t>(j);
      if (j > i) {
        const Matrix3<Scalar>& r = m.pose[k].rotation;
        v = r.transpose() * (v + w.cross(m.pose[k].translation));
        w = r.transpose() * w;
      }
      out.block(i, kLinkParameters * j, 1, kLinkParameters) =
          link_power_row(m.w[k], m.wd[k], m.a[k], w, v);
    }
  }
}

/// Y_links(q, qd, qdd) theta_links, the links' part of the torques [N m or N], by the
/// Newton-Euler recursion with the parameters themselves: each link's wrench (as in
/// link_power_row) carried from the tip to the base. O(n) where the regressor has O(n^2) rows
/// of ten; equal to the regressor's product to rounding.
template <typename Scalar, typename Links, typename Joints, typename Tau>
void chain_link_torques_unchecked(const SerialChain<Scalar>& chain, const Links& theta,
                                  const Joints& q, const Joints& qd, const Joints& qdd, Tau& tau) {
  ChainMotion<Scalar> m;
  chain_motion(chain, q, qd, qdd, m);
  const int n = chain.joints();
  // The wrench of links i..n-1 about frame i's origin, in frame i.
  Vector3<Scalar> f = Vector3<Scalar>::Zero(), torque = Vector3<Scalar>::Zero();
  for (int i = n - 1; i >= 0; --i) {
    const auto k = static_cast<std::size_t>(i);
    const auto p = theta.template segment<kLinkParameters>(kLinkParameters * i);
    const Vector3<Scalar> h(p[1], p[2], p[3]);
    Matrix3<Scalar> inertia;
    inertia << p[4], p[5], p[7], p[5], p[6], p[8], p[7], p[8], p[9];
    const Vector3<Scalar>& w = m.w[k];
    const Vector3<Scalar>& wd = m.wd[k];
    const Vector3<Scalar>& a = m.a[k];
    if (i + 1 < n) {
      const Matrix3<Scalar>& r = m.pose[k + 1].rotation;
      const Vector3<Scalar> child = r * f;
      torque = r * torque + m.pose[k + 1].translation.cross(child);
      f = child;
    }
    f += p[0] * a + wd.cross(h) + w.cross(w.cross(h));
    torque += inertia * wd + w.cross(inertia * w) + h.cross(a);
    tau[i] = m.u[k].dot(torque) + m.ru[k].dot(f);
  }
}

template <typename Scalar, typename Joints, typename Out>
void chain_regressor_unchecked(const SerialChain<Scalar>& chain, const Joints& q, const Joints& qd,
                               const Joints& qdd, Out& out) {
  chain_link_columns_unchecked(chain, q, qd, qdd, out);
  const int n = chain.joints();
  out.rightCols(2 * n).setZero();
  for (int i = 0; i < n; ++i) {
    out(i, kLinkParameters * n + i) = qd[i];
    out(i, (kLinkParameters + 1) * n + i) = sign(qd[i]);
  }
}

template <typename Scalar>
void check_chain_joints(const char* who, const SerialChain<Scalar>& chain, const char* name,
                        Eigen::Index size) {
  if (size != chain.joints())
    throw std::invalid_argument(std::string(who) + ": " + name + " has " + std::to_string(size) +
                                " entries but the chain has " + std::to_string(chain.joints()) +
                                " joints");
}

template <typename Scalar>
void check_chain_theta(const char* who, const SerialChain<Scalar>& chain,
                       const ChainVectorRef<Scalar>& theta) {
  const Eigen::Index p = chain_parameter_count(chain.joints());
  if (theta.size() != p)
    throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                " entries, the chain has " + std::to_string(p) + " parameters");
}

template <typename Scalar>
void check_chain_state(const char* who, const SerialChain<Scalar>& chain,
                       const ChainVectorRef<Scalar>& q, const ChainVectorRef<Scalar>& qd,
                       const ChainVectorRef<Scalar>& qdd) {
  check_chain_joints(who, chain, "q", q.size());
  check_chain_joints(who, chain, "qd", qd.size());
  check_chain_joints(who, chain, "qdd", qdd.size());
}

}  // namespace detail

/// @brief Y(q, qd, qdd) written into out (joints() x chain_parameter_count(joints())).
/// @param q [rad or m], qd [rad/s or m/s], qdd [rad/s^2 or m/s^2], each of joints() entries.
/// Allocates nothing.
/// @throws std::invalid_argument if a size does not match the chain.
template <typename Scalar>
void chain_regressor(const SerialChain<Scalar>& chain, const detail::ChainVectorRef<Scalar>& q,
                     const detail::ChainVectorRef<Scalar>& qd,
                     const detail::ChainVectorRef<Scalar>& qdd,
                     detail::ChainRegressorRef<Scalar> out) {
  const char* who = "sid::chain_regressor";
  detail::check_chain_state(who, chain, q, qd, qdd);
  detail::check_chain_joints(who, chain, "out (rows)", out.rows());
  if (out.cols() != chain_parameter_count(chain.joints()))
    throw std::invalid_argument(
        std::string(who) + ": out has " + std::to_string(out.cols()) + " columns, the chain has " +
        std::to_string(chain_parameter_count(chain.joints())) + " parameters");
  detail::chain_regressor_unchecked(chain, q, qd, qdd, out);
}

/// @brief tau = Y(q, qd, qdd) theta [N m or N]; allocates nothing but the result.
/// @throws std::invalid_argument if a size does not match the chain.
template <typename Scalar>
VectorX<Scalar> chain_inverse_dynamics(const SerialChain<Scalar>& chain,
                                       const detail::ChainVectorRef<Scalar>& theta,
                                       const detail::ChainVectorRef<Scalar>& q,
                                       const detail::ChainVectorRef<Scalar>& qd,
                                       const detail::ChainVectorRef<Scalar>& qdd) {
  const char* who = "sid::chain_inverse_dynamics";
  detail::check_chain_theta(who, chain, theta);
  detail::check_chain_state(who, chain, q, qd, qdd);
  ChainRegressor<Scalar> y(chain.joints(), theta.size());
  detail::chain_regressor_unchecked(chain, q, qd, qdd, y);
  return y * theta;
}

/// @brief The regression over N samples: row j N + k of X and y is joint j at sample k.
/// @param q, qd, qdd, tau N x joints() samples [rad, rad/s, rad/s^2, N m; m, m/s, m/s^2, N for
///        prismatic joints].
/// @throws std::invalid_argument if the sizes disagree, there are no samples, or a value is not
///         finite.
template <typename Scalar>
StackedRegression<Scalar> stack_chain_regression(const SerialChain<Scalar>& chain,
                                                 const detail::ChainSamplesRef<Scalar>& q,
                                                 const detail::ChainSamplesRef<Scalar>& qd,
                                                 const detail::ChainSamplesRef<Scalar>& qdd,
                                                 const detail::ChainSamplesRef<Scalar>& tau) {
  const char* who = "sid::stack_chain_regression";
  const Eigen::Index samples = q.rows(), n = chain.joints();
  if (samples == 0) throw std::invalid_argument(std::string(who) + ": there are no samples");
  const auto check = [&](const char* name, const auto& m) {
    if (m.rows() != samples || m.cols() != n)
      throw std::invalid_argument(std::string(who) + ": " + name + " is " +
                                  std::to_string(m.rows()) + " x " + std::to_string(m.cols()) +
                                  ", expected " + std::to_string(samples) + " x " +
                                  std::to_string(n) + " (samples x joints)");
    if (!m.allFinite())
      throw std::invalid_argument(std::string(who) + ": " + name +
                                  " holds a value that is not finite");
  };
  check("q", q);
  check("qd", qd);
  check("qdd", qdd);
  check("tau", tau);
  StackedRegression<Scalar> r;
  r.X.resize(n * samples, chain_parameter_count(static_cast<int>(n)));
  r.y.resize(n * samples);
  ChainRegressor<Scalar> y(n, r.X.cols());
  for (Eigen::Index k = 0; k < samples; ++k) {
    detail::chain_regressor_unchecked(chain, q.row(k), qd.row(k), qdd.row(k), y);
    for (Eigen::Index j = 0; j < n; ++j) {
      r.X.row(j * samples + k) = y.row(j);
      r.y[j * samples + k] = tau(k, j);
    }
  }
  return r;
}

}  // namespace sid
