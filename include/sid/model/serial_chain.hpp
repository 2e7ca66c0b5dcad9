#pragma once
/// @file
/// @brief sid::SerialChain: the kinematics of a serial arm of revolute and prismatic joints, from
/// joint placements as URDF writes them or from a Denavit-Hartenberg table (revolute and
/// prismatic rows) in the standard or the modified (Khalil/Craig) convention.

#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

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

/// @brief How a joint moves its child link: turning about its axis or sliding along it.
enum class JointType {
  Revolute,   ///< Rot(axis, q + offset); q [rad], its generalized force a torque [N m]
  Prismatic,  ///< Trans(axis (q + offset)); q [m], its generalized force a force [N]
};

/// @brief One row of a DH table [m, rad]. A revolute row's joint angle is q + offset and its
/// slide d; a prismatic row's slide is q + d and its joint angle the constant offset.
template <typename Scalar>
struct DhJoint {
  Scalar a = Scalar(0);
  Scalar alpha = Scalar(0);
  Scalar d = Scalar(0);
  Scalar offset = Scalar(0);
  JointType type = JointType::Revolute;
};

/// @brief The pose of a child frame in its parent: x_parent = rotation x_child + translation.
template <typename Scalar>
struct FramePose {
  Matrix3<Scalar> rotation = Matrix3<Scalar>::Identity();
  Vector3<Scalar> translation = Vector3<Scalar>::Zero();
};

/// @brief A joint placed in its parent link's frame, the way URDF writes it and any DH row can
/// be written: T(parent, child)(q) = before * Rot(axis, q + offset) * after for a revolute
/// joint, before * Trans(axis (q + offset)) * after for a prismatic one.
template <typename Scalar>
struct JointPlacement {
  FramePose<Scalar> before;  ///< the joint frame in the parent's frame (URDF's <origin>)
  Vector3<Scalar> axis = Vector3<Scalar>::UnitZ();  ///< in the joint frame (URDF's <axis>)
  FramePose<Scalar> after;    ///< the child link's frame in the moved joint frame
  Scalar offset = Scalar(0);  ///< [rad] or [m]
  JointType type = JointType::Revolute;
};

/// @brief A DH row as a joint placement. A revolute row turns about z by q + offset; a
/// prismatic row (row.type) slides along z by q + d, turned about z by the constant offset:
/// T(i-1, i) = Rz(offset) Tz(q + d) Tx(a) Rx(alpha) (standard) or
/// Rx(alpha) Tx(a) Rz(offset) Tz(q + d) (modified).
template <typename Scalar>
JointPlacement<Scalar> dh_placement(DhConvention convention, const DhJoint<Scalar>& row) {
  using std::cos;
  using std::sin;
  const Scalar ca = cos(row.alpha), sa = sin(row.alpha);
  Matrix3<Scalar> rx;
  rx << Scalar(1), Scalar(0), Scalar(0), Scalar(0), ca, -sa, Scalar(0), sa, ca;
  JointPlacement<Scalar> joint;
  if (row.type == JointType::Prismatic) {
    const Scalar ct = cos(row.offset), st = sin(row.offset);
    Matrix3<Scalar> rz;
    rz << ct, -st, Scalar(0), st, ct, Scalar(0), Scalar(0), Scalar(0), Scalar(1);
    joint.type = JointType::Prismatic;
    joint.offset = row.d;
    if (convention == DhConvention::Standard) {
      joint.before.rotation = rz;  // Rz(offset) Tz(q + d) Tx(a) Rx(alpha)
      joint.after.rotation = rx;
      joint.after.translation << row.a, Scalar(0), Scalar(0);
    } else {
      joint.before.rotation = rx * rz;  // Rx(alpha) Tx(a) Rz(offset) Tz(q + d)
      joint.before.translation << row.a, Scalar(0), Scalar(0);
    }
    return joint;
  }
  joint.type = row.type;  // a type that is neither is refused by SerialChain
  joint.offset = row.offset;
  if (convention == DhConvention::Standard) {
    joint.after.rotation = rx;  // Rz(q) Tz(d) Tx(a) Rx(alpha)
    joint.after.translation << row.a, Scalar(0), row.d;
  } else {
    joint.before.rotation = rx;  // Rx(alpha) Tx(a) Rz(q) Tz(d)
    joint.before.translation << row.a, Scalar(0), Scalar(0);
    joint.after.translation << Scalar(0), Scalar(0), row.d;
  }
  return joint;
}

/// @brief A joint's axis in the frame of the link it moves: the unit direction and a point on
/// the axis (the joint frame's origin). Both are constant in that frame.
template <typename Scalar>
struct JointAxis {
  Vector3<Scalar> direction;
  Vector3<Scalar> point;
};

/// @brief A chain of revolute and prismatic joints from a base frame to the last link's frame.
///
/// Class invariant: 1 <= joints() <= kMaxChainJoints, every placement and the gravity are
/// finite, and every axis has unit length.
template <typename Scalar>
class SerialChain {
 public:
  /// @param gravity the gravitational acceleration in the base frame [m/s^2]; the default is
  ///        9.81 along -z.
  /// @throws std::invalid_argument if there are no joints or more than kMaxChainJoints, a value
  ///         is not finite, an axis is zero (axes are normalised) or a type is not a JointType.
  explicit SerialChain(std::vector<JointPlacement<Scalar>> joints,
                       const Vector3<Scalar>& gravity = default_gravity())
      : joints_(std::move(joints)), gravity_(gravity) {
    validate("sid::SerialChain");
  }

  /// @brief The chain of a DH table, one row per joint {a, alpha, d, offset[, type]} [m, rad]
  /// (see dh_placement).
  /// @throws std::invalid_argument as the other constructor.
  SerialChain(DhConvention convention, const std::vector<DhJoint<Scalar>>& table,
              const Vector3<Scalar>& gravity = default_gravity())
      : gravity_(gravity) {
    for (const auto& row : table) joints_.push_back(dh_placement(convention, row));
    validate("sid::SerialChain (DH table)");
  }

  int joints() const noexcept { return static_cast<int>(joints_.size()); }
  const std::vector<JointPlacement<Scalar>>& placements() const noexcept { return joints_; }
  const Vector3<Scalar>& gravity() const noexcept { return gravity_; }

  /// @brief Joint i's type.
  /// @throws std::invalid_argument if i is not a joint index.
  JointType joint_type(int i) const { return joint(i, "sid::SerialChain::joint_type").type; }

  /// @brief The pose of link frame i (0-based joint index) in frame i-1 (the base for i = 0) at
  ///        joint value q [rad or m].
  /// @throws std::invalid_argument if i is not a joint index.
  FramePose<Scalar> link_pose(int i, Scalar q) const {
    const JointPlacement<Scalar>& j = joint(i, "sid::SerialChain::link_pose");
    FramePose<Scalar> pose;
    if (j.type == JointType::Prismatic) {
      pose.rotation = j.before.rotation * j.after.rotation;
      pose.translation = j.before.translation +
                         j.before.rotation * (j.axis * (q + j.offset) + j.after.translation);
      return pose;
    }
    using std::cos;
    using std::sin;
    const Scalar c = cos(q + j.offset), s = sin(q + j.offset);
    const Shape& shape = shapes_[static_cast<std::size_t>(i)];
    Matrix3<Scalar> turned;
    if (shape.axis_index >= 0) {
      // Turning about a coordinate axis e_k (every DH joint, most URDF joints) moves two columns
      // of the placement: 12 products instead of Rodrigues' matrix and a 3 x 3 product.
      const int k = shape.axis_index, a = (k + 1) % 3, b = (k + 2) % 3;
      const Scalar sk = shape.axis_sign * s;
      const Matrix3<Scalar>& r = j.before.rotation;
      turned.col(a) = c * r.col(a) + sk * r.col(b);
      turned.col(b) = c * r.col(b) - sk * r.col(a);
      turned.col(k) = r.col(k);
    } else {
      const Vector3<Scalar>& u = j.axis;
      Matrix3<Scalar> turn = (Scalar(1) - c) * u * u.transpose();  // Rodrigues
      turn.diagonal().array() += c;
      turn(0, 1) -= s * u[2];
      turn(1, 0) += s * u[2];
      turn(0, 2) += s * u[1];
      turn(2, 0) -= s * u[1];
      turn(1, 2) -= s * u[0];
      turn(2, 1) += s * u[0];
      turned = j.before.rotation * turn;
    }
    if (shape.link_on_joint) {  // a URDF link's frame is its joint's frame
      pose.rotation = turned;
      pose.translation = j.before.translation;
    } else {
      pose.rotation = turned * j.after.rotation;
      pose.translation = j.before.translation + turned * j.after.translation;
    }
    return pose;
  }

  /// @brief Joint i's axis in link frame i.
  /// @throws std::invalid_argument if i is not a joint index.
  JointAxis<Scalar> joint_axis(int i) const {
    (void)joint(i, "sid::SerialChain::joint_axis");
    return axes_[static_cast<std::size_t>(i)];
  }

  /// @brief The pose of every link frame in the base frame at joint values q [rad or m].
  /// @throws std::invalid_argument if q.size() != joints().
  std::vector<FramePose<Scalar>> forward_kinematics(
      const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& q) const {
    if (q.size() != joints())
      throw std::invalid_argument("sid::SerialChain::forward_kinematics: q has " +
                                  std::to_string(q.size()) + " entries but the chain has " +
                                  std::to_string(joints()) + " joints");
    std::vector<FramePose<Scalar>> poses;
    FramePose<Scalar> base;
    for (int i = 0; i < joints(); ++i) {
      const FramePose<Scalar> local = link_pose(i, q[i]);
      base.translation += base.rotation * local.translation;
      base.rotation = base.rotation * local.rotation;
      poses.push_back(base);
    }
    return poses;
  }

 private:
  static Vector3<Scalar> default_gravity() {
    return Vector3<Scalar>(Scalar(0), Scalar(0), Scalar(-9.81));
  }

  void validate(const char* who) {
    if (joints_.empty())
      throw std::invalid_argument(std::string(who) + ": the chain has no joints");
    if (joints() > kMaxChainJoints)
      throw std::invalid_argument(std::string(who) + ": the chain has " + std::to_string(joints()) +
                                  " joints, at most " + std::to_string(kMaxChainJoints) +
                                  " are supported");
    for (std::size_t i = 0; i < joints_.size(); ++i) {
      auto& j = joints_[i];
      const std::string joint_name = std::string(who) + ": joint " + std::to_string(i + 1);
      if (!(j.before.rotation.allFinite() && j.before.translation.allFinite() &&
            j.axis.allFinite() && j.after.rotation.allFinite() && j.after.translation.allFinite() &&
            finite(j.offset)))
        throw std::invalid_argument(joint_name + " has a value that is not finite");
      const Scalar length = j.axis.norm();
      if (!(length > Scalar(0))) throw std::invalid_argument(joint_name + " has a zero axis");
      if (j.type != JointType::Revolute && j.type != JointType::Prismatic)
        throw std::invalid_argument(joint_name + " has an unknown type");
      j.axis /= length;
      // The axis passes through the joint frame's origin; seen from the child link's frame.
      const Matrix3<Scalar> back = j.after.rotation.transpose();
      axes_.push_back({back * j.axis, -(back * j.after.translation)});
      Shape shape;
      for (int k = 0; k < 3; ++k)
        if (j.axis[(k + 1) % 3] == Scalar(0) && j.axis[(k + 2) % 3] == Scalar(0)) {
          shape.axis_index = k;
          shape.axis_sign = j.axis[k] > Scalar(0) ? Scalar(1) : Scalar(-1);
        }
      shape.link_on_joint = j.after.rotation == Matrix3<Scalar>::Identity() &&
                            j.after.translation == Vector3<Scalar>::Zero();
      shapes_.push_back(shape);
    }
    if (!gravity_.allFinite())
      throw std::invalid_argument(std::string(who) + ": the gravity vector is not finite");
  }

  const JointPlacement<Scalar>& joint(int i, const char* who) const {
    if (i < 0 || i >= joints())
      throw std::invalid_argument(std::string(who) + ": joint index " + std::to_string(i) +
                                  " is outside 0.." + std::to_string(joints() - 1));
    return joints_[static_cast<std::size_t>(i)];
  }

  static bool finite(const Scalar& x) {
    using std::isfinite;
    return isfinite(x);
  }

  /// What link_pose may skip for a joint: turning about a coordinate axis (axis_index 0, 1, 2
  /// for x, y, z, -1 for any other), and an identity `after`.
  struct Shape {
    int axis_index = -1;
    Scalar axis_sign = Scalar(1);
    bool link_on_joint = false;
  };

  std::vector<JointPlacement<Scalar>> joints_;
  std::vector<JointAxis<Scalar>> axes_;
  std::vector<Shape> shapes_;
  Vector3<Scalar> gravity_;
};

}  // namespace sid
