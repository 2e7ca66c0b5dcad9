#pragma once
/// @file
/// @brief sid::SerialChain: the kinematics of a serial arm of revolute joints, from a
/// Denavit-Hartenberg table in the standard or the modified (Khalil/Craig) convention.

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief The joint count a chain may have; the per-sample recursions keep their link states
/// on the stack up to this size, so they run without heap memory in a control loop.
inline constexpr int kMaxChainJoints = 12;

template <typename Scalar>
using Vector3 = Eigen::Matrix<Scalar, 3, 1>;
template <typename Scalar>
using Matrix3 = Eigen::Matrix<Scalar, 3, 3>;

/// @brief Which Denavit-Hartenberg convention a table is written in.
enum class DhConvention {
  /// T(i-1, i) = Rz(q_i + offset_i) Tz(d_i) Tx(a_i) Rx(alpha_i): frame i sits at the far end of
  /// link i and joint i turns about z(i-1) (Corke's `rne`, most textbooks).
  Standard,
  /// T(i-1, i) = Rx(alpha_i) Tx(a_i) Rz(q_i + offset_i) Tz(d_i): frame i sits on joint i and
  /// joint i turns about z(i). Craig's a(i-1) and alpha(i-1) are written on row i, as Khalil
  /// writes d_i and alpha_i.
  Modified,
};

/// @brief One row of a DH table [m, rad]; the joint angle is q + offset.
template <typename Scalar>
struct DhJoint {
  Scalar a = Scalar(0);
  Scalar alpha = Scalar(0);
  Scalar d = Scalar(0);
  Scalar offset = Scalar(0);
};

/// @brief The pose of a child frame in its parent: x_parent = rotation x_child + translation.
template <typename Scalar>
struct FramePose {
  Matrix3<Scalar> rotation;
  Vector3<Scalar> translation;
};

/// @brief A revolute joint's axis in the frame of the link it moves: the unit direction and a
/// point on the axis. Both are constant in that frame for either DH convention.
template <typename Scalar>
struct JointAxis {
  Vector3<Scalar> direction;
  Vector3<Scalar> point;
};

/// @brief A chain of revolute joints from a base frame to the last link's frame.
///
/// Class invariant: 1 <= joints() <= kMaxChainJoints and every table entry and the gravity are
/// finite.
template <typename Scalar>
class SerialChain {
 public:
  /// @param gravity the gravitational acceleration in the base frame [m/s^2]; the default is
  ///        9.81 along -z.
  /// @throws std::invalid_argument if the table is empty, longer than kMaxChainJoints, or holds a
  ///         value that is not finite.
  SerialChain(DhConvention convention, std::vector<DhJoint<Scalar>> table,
              const Vector3<Scalar>& gravity = Vector3<Scalar>(Scalar(0), Scalar(0), Scalar(-9.81)))
      : convention_(convention), table_(std::move(table)), gravity_(gravity) {
    const char* who = "sid::SerialChain";
    if (table_.empty()) throw std::invalid_argument(std::string(who) + ": the DH table is empty");
    if (static_cast<int>(table_.size()) > kMaxChainJoints)
      throw std::invalid_argument(std::string(who) + ": the DH table has " +
                                  std::to_string(table_.size()) + " rows, at most " +
                                  std::to_string(kMaxChainJoints) + " are supported");
    for (std::size_t i = 0; i < table_.size(); ++i) {
      const auto& j = table_[i];
      if (!(finite(j.a) && finite(j.alpha) && finite(j.d) && finite(j.offset)))
        throw std::invalid_argument(std::string(who) + ": row " + std::to_string(i + 1) +
                                    " of the DH table is not finite");
    }
    if (!(finite(gravity_[0]) && finite(gravity_[1]) && finite(gravity_[2])))
      throw std::invalid_argument(std::string(who) + ": the gravity vector is not finite");
  }

  int joints() const noexcept { return static_cast<int>(table_.size()); }
  DhConvention convention() const noexcept { return convention_; }
  const std::vector<DhJoint<Scalar>>& table() const noexcept { return table_; }
  const Vector3<Scalar>& gravity() const noexcept { return gravity_; }

  /// @brief The pose of link frame i (0-based joint index) in frame i-1 (the base for i = 0) at
  ///        joint angle q [rad].
  /// @throws std::invalid_argument if i is not a joint index.
  FramePose<Scalar> link_pose(int i, Scalar q) const {
    const DhJoint<Scalar>& j = row(i, "sid::SerialChain::link_pose");
    using std::cos;
    using std::sin;
    const Scalar theta = q + j.offset;
    const Scalar ct = cos(theta), st = sin(theta), ca = cos(j.alpha), sa = sin(j.alpha);
    FramePose<Scalar> pose;
    if (convention_ == DhConvention::Standard) {
      // Rz(theta) Rx(alpha)
      pose.rotation << ct, -st * ca, st * sa, st, ct * ca, -ct * sa, Scalar(0), sa, ca;
      pose.translation << j.a * ct, j.a * st, j.d;
    } else {
      // Rx(alpha) Rz(theta)
      pose.rotation << ct, -st, Scalar(0), ca * st, ca * ct, -sa, sa * st, sa * ct, ca;
      pose.translation << j.a, -sa * j.d, ca * j.d;
    }
    return pose;
  }

  /// @brief Joint i's axis in link frame i.
  /// @throws std::invalid_argument if i is not a joint index.
  JointAxis<Scalar> joint_axis(int i) const {
    const DhJoint<Scalar>& j = row(i, "sid::SerialChain::joint_axis");
    if (convention_ == DhConvention::Modified)
      return {Vector3<Scalar>::UnitZ(), Vector3<Scalar>::Zero()};
    // z(i-1) seen from frame i: Rx(alpha)^T e_z, through the origin of frame i-1.
    using std::cos;
    using std::sin;
    const Scalar ca = cos(j.alpha), sa = sin(j.alpha);
    return {Vector3<Scalar>(Scalar(0), sa, ca), -Vector3<Scalar>(j.a, sa * j.d, ca * j.d)};
  }

  /// @brief The pose of every link frame in the base frame at joint angles q [rad].
  /// @throws std::invalid_argument if q.size() != joints().
  std::vector<FramePose<Scalar>> forward_kinematics(
      const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& q) const {
    if (q.size() != joints())
      throw std::invalid_argument("sid::SerialChain::forward_kinematics: q has " +
                                  std::to_string(q.size()) + " entries but the chain has " +
                                  std::to_string(joints()) + " joints");
    std::vector<FramePose<Scalar>> poses;
    FramePose<Scalar> base{Matrix3<Scalar>::Identity(), Vector3<Scalar>::Zero()};
    for (int i = 0; i < joints(); ++i) {
      const FramePose<Scalar> local = link_pose(i, q[i]);
      base.translation += base.rotation * local.translation;
      base.rotation = base.rotation * local.rotation;
      poses.push_back(base);
    }
    return poses;
  }

 private:
  const DhJoint<Scalar>& row(int i, const char* who) const {
    if (i < 0 || i >= joints())
      throw std::invalid_argument(std::string(who) + ": joint index " + std::to_string(i) +
                                  " is outside 0.." + std::to_string(joints() - 1));
    return table_[static_cast<std::size_t>(i)];
  }

  static bool finite(const Scalar& x) {
    using std::isfinite;
    return isfinite(x);
  }

  DhConvention convention_;
  std::vector<DhJoint<Scalar>> table_;
  Vector3<Scalar> gravity_;
};

}  // namespace sid
