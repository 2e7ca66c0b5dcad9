// Tests of src/robot_description (the files sid_identify --robot and --transmission read): a
// DH table with prismatic rows, and a transmission file that is XML (the robot's URDF with its
// ros_control <transmission> elements) read by sid::transmission_from_urdf, YAML otherwise.

#include "robot_description.hpp"

#include "app.hpp"
#include "app_test_support.hpp"

#include <gtest/gtest.h>

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
  const sid::app::RobotDescription robot = sid::app::read_robot_description(path, "", "");
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

}  // namespace
