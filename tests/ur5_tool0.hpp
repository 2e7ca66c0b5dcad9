#pragma once
// Test-only: the UR5's tool0 flange (tests/data/urdf/real/ur5_robot.urdf) written out by hand, so
// that the tools' own composition of the URDF's fixed joints is checked against it.

#include <sid/model/link_inertia.hpp>

#include <Eigen/Geometry>

namespace sid_test {

/// tool0's pose in wrist_3_link's frame: joint wrist_3_link-tool0_fixed_joint, xyz 0 0.0823 0,
/// rpy -1.57079632679 0 0.
inline sid::FramePose<double> tool0_in_wrist_3() {
  sid::FramePose<double> pose;
  pose.rotation = Eigen::AngleAxisd(-1.57079632679, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation = Eigen::Vector3d(0.0, 0.0823, 0.0);
  return pose;
}

/// A body given in tool0's frame, in wrist_3_link's (the last moving link's, where the chain
/// model carries it): by hand, not by the library's change of frame, which the tools use.
inline sid::LinkInertia<double> in_wrist_3(const sid::LinkInertia<double>& in_tool0) {
  const sid::FramePose<double> t = tool0_in_wrist_3();
  sid::LinkInertia<double> body;
  body.mass = in_tool0.mass;
  body.com = t.rotation * in_tool0.com + t.translation;
  body.inertia_com = t.rotation * in_tool0.inertia_com * t.rotation.transpose();
  return body;
}

}  // namespace sid_test
