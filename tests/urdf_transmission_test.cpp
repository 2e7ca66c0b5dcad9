// Tests of sid/model/urdf_transmission.hpp: ros_control's (ROS 1) and ros2_control's (ROS 2)
// <transmission> elements give the sid::Transmission whose joint side is what those packages
// compute from the actuator side (their equations written out here), joints without one keep
// ratio 1, transmissions of joints off the chain are skipped, and bad elements are refused with
// a message naming them.

#include <sid/model/urdf_transmission.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

constexpr double kTol = 1e-12;  // joint values [rad], torques [N m] of order 100

/// A three-joint arm (j1, j2, j3) with a finger joint past the tip, and the given elements.
std::string robot(const std::string& transmissions) {
  return R"(<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/><link name="finger"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/></joint>
  <joint name="finger_joint" type="prismatic"><parent link="l3"/><child link="finger"/></joint>
)" + transmissions +
         "</robot>\n";
}

/// A ROS 1 SimpleTransmission.
std::string ros1_simple(const std::string& joint, const std::string& reduction,
                        const std::string& offset = "") {
  return "<transmission name=\"t_" + joint +
         "\"><type>transmission_interface/SimpleTransmission</type>"
         "<joint name=\"" +
         joint +
         "\"><hardwareInterface>hardware_interface/EffortJointInterface</hardwareInterface>" +
         (offset.empty() ? "" : "<offset>" + offset + "</offset>") + "</joint><actuator name=\"m_" +
         joint + "\">" +
         (reduction.empty() ? "" : "<mechanicalReduction>" + reduction + "</mechanicalReduction>") +
         "</actuator></transmission>\n";
}

const std::vector<std::string> kChain = {"j1", "j2", "j3"};

std::string message_of(const std::string& text, const std::vector<std::string>& chain = kChain) {
  try {
    (void)sid::transmission_from_urdf(text, chain);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

/// A motor-side log of `motors` columns at a few random samples.
sid::ChainTrajectory<double> motor_log(int motors, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  sid::ChainTrajectory<double> log;
  log.t = Eigen::VectorXd::LinSpaced(5, 0.0, 0.4);
  log.q = Eigen::MatrixXd::NullaryExpr(5, motors, [&] { return 40.0 * u(rng); });
  log.tau = Eigen::MatrixXd::NullaryExpr(5, motors, [&] { return u(rng); });
  return log;
}

TEST(UrdfTransmission, Ros1SimpleTransmissionIsRosControlsMapping) {
  // j1: reduction 50, offset 0.1; j3: -30 (a flipped direction); j2: none, so ratio 1; the
  // finger's transmission drives a joint off the chain and is skipped.
  const sid::Transmission t = sid::transmission_from_urdf(
      robot(ros1_simple("j1", "50", "0.1") + ros1_simple("j3", " -30 ") +
            ros1_simple("finger_joint", "7")),
      kChain);
  Eigen::Matrix3d g = Eigen::Matrix3d::Zero();
  g.diagonal() << 50.0, 1.0, -30.0;
  EXPECT_EQ(t.ratio(), g);
  EXPECT_EQ(t.zero(), Eigen::Vector3d(0.1, 0.0, 0.0));

  // ros_control: x_j = x_a / n + x_off, tau_j = n tau_a.
  const sid::ChainTrajectory<double> motor = motor_log(3, 1);
  const sid::ChainTrajectory<double> joint = t.joint_side(motor);
  const Eigen::Vector3d n(50.0, 1.0, -30.0), off(0.1, 0.0, 0.0);
  for (Eigen::Index k = 0; k < motor.t.size(); ++k)
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(joint.q(k, j), motor.q(k, j) / n[j] + off[j], kTol);
      EXPECT_NEAR(joint.tau(k, j), n[j] * motor.tau(k, j), kTol);
    }
}

TEST(UrdfTransmission, Ros2TransmissionsInsideRos2ControlAreRead) {
  // ros2_control reads the joint's <mechanical_reduction> and <offset>; the actuator's may
  // repeat it. A joint without <mechanical_reduction> has 1, as there.
  const std::string text = robot(R"(
  <ros2_control name="arm" type="system">
    <hardware><plugin>mock_components/GenericSystem</plugin></hardware>
    <joint name="j1"><command_interface name="effort"/></joint>
    <transmission name="t1">
      <plugin>transmission_interface/SimpleTransmission</plugin>
      <actuator name="m1" role="actuator1"><mechanical_reduction>100</mechanical_reduction></actuator>
      <joint name="j2" role="joint1">
        <mechanical_reduction>100</mechanical_reduction>
        <offset>-0.5</offset>
      </joint>
    </transmission>
    <transmission name="t2">
      <plugin> transmission_interface/SimpleTransmission </plugin>
      <actuator name="m2"/>
      <joint name="j3"><offset>0.25</offset></joint>
    </transmission>
  </ros2_control>
)");
  const sid::Transmission t = sid::transmission_from_urdf(text, kChain);
  EXPECT_EQ(t.ratio().diagonal(), Eigen::Vector3d(1.0, 100.0, 1.0));
  EXPECT_TRUE(t.coupled_motors().empty());
  EXPECT_EQ(t.zero(), Eigen::Vector3d(0.0, -0.5, 0.25));
}

TEST(UrdfTransmission, DifferentialTransmissionIsRosControlsMapping) {
  // A wrist: actuators 1 and 2 (reductions 20, -15) drive joints j2 and j3 (joint reductions
  // 1.5, 0.8, offsets 0.2, -0.1). ROS 1 sorts by <role>, written here in reverse order.
  const std::string ros1 = robot(R"(
  <transmission name="wrist">
    <type>transmission_interface/DifferentialTransmission</type>
    <actuator name="m_b"><role>actuator2</role><mechanicalReduction>-15</mechanicalReduction></actuator>
    <actuator name="m_a"><role>actuator1</role><mechanicalReduction>20</mechanicalReduction></actuator>
    <joint name="j3"><role>joint2</role><mechanicalReduction>0.8</mechanicalReduction>
      <offset>-0.1</offset></joint>
    <joint name="j2"><role>joint1</role><mechanicalReduction>1.5</mechanicalReduction>
      <offset>0.2</offset></joint>
  </transmission>
)");
  // ROS 2 takes the elements in the order written.
  const std::string ros2 = robot(R"(
  <ros2_control name="arm" type="system"><transmission name="wrist">
    <plugin>transmission_interface/DifferentialTransmission</plugin>
    <actuator name="m_a" role="actuator1"><mechanical_reduction>20</mechanical_reduction></actuator>
    <actuator name="m_b" role="actuator2"><mechanical_reduction>-15</mechanical_reduction></actuator>
    <joint name="j2" role="joint1"><mechanical_reduction>1.5</mechanical_reduction>
      <offset>0.2</offset></joint>
    <joint name="j3"><mechanical_reduction>0.8</mechanical_reduction><offset>-0.1</offset></joint>
  </transmission></ros2_control>
)");
  const double na1 = 20.0, na2 = -15.0, nj1 = 1.5, nj2 = 0.8, x1 = 0.2, x2 = -0.1;
  for (const std::string& text : {ros1, ros2}) {
    const sid::Transmission t = sid::transmission_from_urdf(text, kChain);
    EXPECT_EQ(t.coupled_motors(), (std::vector<int>{1, 2}));
    const sid::ChainTrajectory<double> motor = motor_log(3, 2);
    const sid::ChainTrajectory<double> joint = t.joint_side(motor);
    for (Eigen::Index k = 0; k < motor.t.size(); ++k) {
      // Motor 2 (actuator1) is joint 2's, motor 3 (actuator2) joint 3's.
      const double a1 = motor.q(k, 1), a2 = motor.q(k, 2);
      const double f1 = motor.tau(k, 1), f2 = motor.tau(k, 2);
      EXPECT_NEAR(joint.q(k, 1), (a1 / na1 + a2 / na2) / (2.0 * nj1) + x1, kTol);
      EXPECT_NEAR(joint.q(k, 2), (a1 / na1 - a2 / na2) / (2.0 * nj2) + x2, kTol);
      EXPECT_NEAR(joint.tau(k, 1), nj1 * (na1 * f1 + na2 * f2), kTol);
      EXPECT_NEAR(joint.tau(k, 2), nj2 * (na1 * f1 - na2 * f2), kTol);
      EXPECT_EQ(joint.q(k, 0), motor.q(k, 0));  // j1 has no transmission
      EXPECT_EQ(joint.tau(k, 0), motor.tau(k, 0));
    }
  }
}

TEST(UrdfTransmission, ReadsALoneTransmissionAndTextAsXmlWritesIt) {
  // A file of one element; the reduction through a character reference and in CDATA, a comment
  // inside the text.
  const sid::Transmission t = sid::transmission_from_urdf(
      "\xEF\xBB\xBF<transmission name=\"t\"><type>transmission_interface/Simple<!-- -->"
      "Transmission</type><joint name=\"j2\"><offset>&#45;0.5</offset></joint>"
      "<actuator name=\"m\"><mechanicalReduction><![CDATA[12.5]]></mechanicalReduction>"
      "</actuator></transmission>",
      kChain);
  EXPECT_EQ(t.ratio().diagonal(), Eigen::Vector3d(1.0, 12.5, 1.0));
  EXPECT_EQ(t.zero(), Eigen::Vector3d(0.0, -0.5, 0.0));
}

TEST(UrdfTransmission, RefusesWhatItCannotReadNamingTheElement) {
  const auto expect = [](const std::string& text, const std::string& part) {
    const std::string message = message_of(text);
    EXPECT_NE(message.find("sid::transmission_from_urdf"), std::string::npos) << message;
    EXPECT_NE(message.find(part), std::string::npos) << "expected '" << part << "' in: " << message;
  };
  expect(robot(""), "no <transmission> element");
  expect(robot(ros1_simple("finger_joint", "7")), "no <transmission> drives a joint of the chain");
  expect(robot(ros1_simple("wrist_9", "7")),
         "transmission 't_wrist_9', joint 'wrist_9': not a joint of the chain (j1, j2, j3)");
  expect(robot(ros1_simple("j1", "0")),
         "transmission 't_j1', actuator 'm_j1': <mechanicalReduction> is 0");
  expect(robot(ros1_simple("j1", "")),
         "transmission 't_j1', actuator 'm_j1' has no "
         "<mechanicalReduction>");
  expect(robot(ros1_simple("j1", "fifty")),
         "<mechanicalReduction>fifty</mechanicalReduction> "
         "is not a finite number");
  expect(robot(ros1_simple("j1", "50", "0.1rad")), "<offset>0.1rad</offset> is not a finite");
  expect(robot(ros1_simple("j1", "50") + ros1_simple("j1", "40")),
         "joint 'j1' is driven by transmission 't_j1' and by transmission 't_j1'");
  expect(robot("<transmission name=\"f\"><type>transmission_interface/FourBarLinkageTransmission"
               "</type><joint name=\"j1\"/><actuator name=\"m\"/></transmission>"),
         "transmission 'f' is of type 'transmission_interface/FourBarLinkageTransmission'");
  expect(robot("<transmission name=\"u\"><joint name=\"j1\"/><actuator name=\"m\"/>"
               "</transmission>"),
         "transmission 'u' has no <type> (ROS 1) or <plugin> (ROS 2)");
  expect(robot("<transmission><type>transmission_interface/SimpleTransmission</type>"
               "<joint name=\"j1\"/><joint name=\"j2\"/><actuator name=\"m\"/></transmission>"),
         "transmission #1 has 2 joints and 1 actuators; a SimpleTransmission has 1 of each");
  expect(robot("<transmission name=\"x\"><plugin>transmission_interface/SimpleTransmission"
               "</plugin><joint name=\"j1\"><mechanicalReduction>5</mechanicalReduction></joint>"
               "<actuator name=\"m\"/></transmission>"),
         "transmission 'x', joint 'j1': <mechanicalReduction> is ROS 1's");
  expect(robot("<transmission name=\"x\"><plugin>transmission_interface/SimpleTransmission"
               "</plugin><joint name=\"j1\"><mechanical_reduction>5</mechanical_reduction>"
               "</joint><actuator name=\"m\"><mechanical_reduction>6</mechanical_reduction>"
               "</actuator></transmission>"),
         "transmission 'x', actuator 'm': <mechanical_reduction> 6.000000 differs from the "
         "joint's");
  expect(robot("<transmission name=\"x\"><type>transmission_interface/SimpleTransmission"
               "</type><joint name=\"j1\"><mechanicalReduction>5</mechanicalReduction></joint>"
               "<actuator name=\"m\"><mechanicalReduction>6</mechanicalReduction></actuator>"
               "</transmission>"),
         "ros_control's SimpleTransmission reads the reduction from the actuator's");
  const std::string differential =
      "<transmission name=\"d\"><type>transmission_interface/DifferentialTransmission</type>"
      "<actuator name=\"a\"><role>actuator1</role><mechanicalReduction>2</mechanicalReduction>"
      "</actuator><actuator name=\"b\"><role>ROLE</role><mechanicalReduction>2"
      "</mechanicalReduction></actuator><joint name=\"j1\"><role>joint1</role></joint>"
      "<joint name=\"JOINT\"><role>joint2</role></joint></transmission>";
  const auto with = [&](const std::string& role, const std::string& joint) {
    std::string text = differential;
    text.replace(text.find("ROLE"), 4, role);
    text.replace(text.find("JOINT"), 5, joint);
    return robot(text);
  };
  expect(with("actuator2", "finger_joint"),
         "transmission 'd' couples a joint of the chain with "
         "one off it");
  expect(with("actuator1", "j2"), "transmission 'd': both actuators have the role 'actuator1'");
  expect(with("motor", "j2"),
         "transmission 'd', actuator 'b': <role> is 'motor', expected "
         "'actuator1' or 'actuator2'");
  expect(with("actuator2", "j1"), "transmission 'd' names joint 'j1' twice");
  expect(robot("<ros2_control name=\"r\"><transmission name=\"d\"><plugin>transmission_interface/"
               "DifferentialTransmission</plugin><actuator name=\"a\" role=\"actuator2\"/>"
               "<actuator name=\"b\" role=\"actuator1\"/><joint name=\"j1\"/><joint name=\"j2\"/>"
               "</transmission></ros2_control>"),
         "ros2_control takes them in the order written");
  expect("<robot><transmission", "line 1");
}

}  // namespace
