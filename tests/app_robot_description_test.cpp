// Tests of src/robot_description (the files sid_identify --robot and --transmission read): a
// DH table with prismatic rows, a transmission file that is XML (the robot's URDF with its
// ros_control <transmission> elements) read by sid::transmission_from_urdf, YAML otherwise, and
// the pose of a link fixed to the chain's last moving link (a load's frame).

#include "robot_description.hpp"

#include "app.hpp"
#include "app_test_support.hpp"

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace {

class RobotDescriptionFiles : public sid_test::AppTest {
 protected:
  template <typename F>
  static std::string message_of(F f) {
    try {
      f();
    } catch (const sid::app::InputError& e) {
      return e.what();
    }
    return "no exception";
  }
};

TEST_F(RobotDescriptionFiles, DhRowsMayBePrismatic) {
  const std::string path = write("slide.dh",
                                 "convention standard\n"
                                 "# name a alpha d offset [type]\n"
                                 "turn 0 0 0.1 0\n"
                                 "lift 0.2 0 0.3 0.5 prismatic  # slides by q + 0.3 m\n"
                                 "roll 0 0 0 0 revolute\n");
  const sid::RobotDescription robot = sid::app::read_robot_description(path, "", "");
  ASSERT_EQ(robot.chain.joints(), 3);
  EXPECT_EQ(robot.chain.joint_type(0), sid::JointType::Revolute);
  EXPECT_EQ(robot.chain.joint_type(1), sid::JointType::Prismatic);
  EXPECT_EQ(robot.chain.joint_type(2), sid::JointType::Revolute);
  // Rz(0.5) Tz(q + 0.3) Tx(0.2): the slide adds q along z.
  EXPECT_NEAR(robot.chain.link_pose(1, 0.25).translation.z(), 0.55, 1e-15);

  const std::string bad = write("bad.dh", "convention modified\nlift 0 0 0 0 slider\n");
  const std::string message =
      message_of([&] { (void)sid::app::read_robot_description(bad, "", ""); });
  EXPECT_NE(message.find("line 2: joint 'lift': the type is 'revolute' or 'prismatic', not "
                         "'slider'"),
            std::string::npos)
      << message;
  const std::string extra = write("extra.dh", "convention modified\nlift 0 0 0 0 prismatic 3\n");
  EXPECT_NE(message_of([&] {
              (void)sid::app::read_robot_description(extra, "", "");
            }).find("line 2: unexpected '3'"),
            std::string::npos);
}

TEST_F(RobotDescriptionFiles, TransmissionFileMayBeTheUrdf) {
  const std::string urdf = R"(
<robot name="arm">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/></joint>
  <transmission name="t2"><type>transmission_interface/SimpleTransmission</type>
    <joint name="j2"><offset>0.05</offset></joint>
    <actuator name="m2"><mechanicalReduction>-40</mechanicalReduction></actuator>
  </transmission>
</robot>
)";
  const std::vector<std::string> joints = {"j1", "j2"};
  const sid::Transmission t = sid::app::read_transmission(write("arm.urdf", urdf), joints);
  EXPECT_EQ(t.ratio().diagonal(), Eigen::Vector2d(1.0, -40.0));
  EXPECT_EQ(t.zero(), Eigen::Vector2d(0.0, 0.05));
  // Any name: the text starts with '<'.
  EXPECT_EQ(sid::app::read_transmission(write("drives.txt", urdf), joints).ratio(), t.ratio());
  // A .urdf or .xml name is XML even when the text is not.
  const std::string broken = write("broken.XML", "gear_ratios: [1, 2]\n");
  const std::string message =
      message_of([&] { (void)sid::app::read_transmission(broken, joints); });
  EXPECT_NE(message.find("broken.XML: sid::transmission_from_urdf: line 1"), std::string::npos)
      << message;
  // YAML as before.
  EXPECT_EQ(sid::app::read_transmission(write("drives.yaml", "gear_ratios: [3, 4]\n"), joints)
                .ratio()
                .diagonal(),
            Eigen::Vector2d(3.0, 4.0));
  // The library's refusal, with the file's name in front.
  const std::string zero = write("zero.urdf",
                                 "<transmission name=\"t\"><type>"
                                 "transmission_interface/SimpleTransmission</type>"
                                 "<joint name=\"j1\"/><actuator name=\"m\">"
                                 "<mechanicalReduction>0</mechanicalReduction>"
                                 "</actuator></transmission>");
  EXPECT_NE(message_of([&] { (void)sid::app::read_transmission(zero, joints); })
                .find("zero.urdf: sid::transmission_from_urdf: transmission 't', actuator 'm': "
                      "<mechanicalReduction> is 0"),
            std::string::npos);
}

TEST_F(RobotDescriptionFiles, FixedLinkPoseComposesTheFixedJointsBelowTheLastMovingLink) {
  // l1 moves; a flange and a tool are fixed below it, a finger on a joint of its own beside them.
  const std::string urdf = R"(
<robot name="arm">
  <link name="base"/><link name="l1"/><link name="flange"/><link name="tool"/>
  <link name="finger"/><link name="pad"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <origin xyz="0 0 0.3"/></joint>
  <joint name="f1" type="fixed"><parent link="l1"/><child link="flange"/>
    <origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/></joint>
  <joint name="f2" type="fixed"><parent link="flange"/><child link="tool"/>
    <origin xyz="0.05 0 0" rpy="1.5707963267948966 0 0"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="finger"/><axis xyz="1 0 0"/>
  </joint>
  <joint name="f3" type="fixed"><parent link="finger"/><child link="pad"/></joint>
</robot>
)";
  constexpr double kTolerance = 1e-15;
  const std::string path = write("arm.urdf", urdf);
  const sid::RobotDescription robot = sid::app::read_robot_description(path, "base", "tool");
  ASSERT_EQ(robot.link_names.back(), "l1");
  const sid::FramePose<double> l1 = sid::app::fixed_link_pose(robot, "l1", "--payload-frame");
  EXPECT_EQ(l1.rotation, Eigen::Matrix3d::Identity());
  EXPECT_EQ(l1.translation, Eigen::Vector3d::Zero());
  // tool in l1: Rz(pi/2) Rx(pi/2), at (0, 0, 0.1) + Rz(pi/2) (0.05, 0, 0) = (0, 0.05, 0.1).
  const sid::FramePose<double> tool = sid::app::fixed_link_pose(robot, "tool", "--payload-frame");
  const Eigen::Matrix3d turn = (Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  EXPECT_TRUE(tool.rotation.isApprox(turn, kTolerance)) << tool.rotation;
  EXPECT_LT((tool.translation - Eigen::Vector3d(0.0, 0.05, 0.1)).norm(), kTolerance)
      << tool.translation.transpose();
  const auto refusal = [&](const std::string& link) {
    return message_of([&] { (void)sid::app::fixed_link_pose(robot, link, "--payload-frame"); });
  };
  EXPECT_NE(refusal("pad").find("--payload-frame: link 'pad' is not rigidly attached to l1: "
                                "joint 'j2' between them is revolute; the frame must be fixed "
                                "to l1, the chain's last moving link (e.g. tool or l1 itself)"),
            std::string::npos)
      << refusal("pad");
  EXPECT_NE(refusal("base").find("--payload-frame: link 'base' is not below l1"), std::string::npos)
      << refusal("base");
  EXPECT_NE(refusal("hand").find("--payload-frame: the URDF has no link 'hand'"), std::string::npos)
      << refusal("hand");

  // The frame's name: the tip link unless another is given; a DH table names none.
  EXPECT_EQ(sid::app::payload_frame_name(robot, "", "--payload-frame"), "tool");
  EXPECT_EQ(sid::app::payload_frame_name(robot, "flange", "--payload-frame"), "flange");
  const sid::RobotDescription dh = sid::app::read_robot_description(
      write("arm.dh", "convention standard\nj1 0 0 0.3 0\n"), "", "");
  EXPECT_EQ(sid::app::payload_frame_name(dh, "", "--payload-frame"), "");
  EXPECT_NE(message_of([&] {
              (void)sid::app::payload_frame_name(dh, "tool", "--payload-frame");
            }).find("--payload-frame needs a URDF as --robot"),
            std::string::npos);
  EXPECT_NE(message_of([&] {
              (void)sid::app::fixed_link_pose(dh, "tool", "--payload-frame");
            }).find("--payload-frame needs a URDF as --robot"),
            std::string::npos);
}

}  // namespace
