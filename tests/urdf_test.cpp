// Tests of sid/model/urdf.hpp (and the XML reader under it): the TX40 of the n-joint reference
// set written as URDF must give Pinocchio's regressor and the reference's parameters; fixed
// joints fold in; bad descriptions are refused with a message naming the problem.

#include <sid/model/urdf.hpp>

#include "chain_test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace {

std::string read_text(const std::string& name) {
  std::ifstream in(sid_test::data_path(name));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string message_of(const std::string& urdf, const std::string& base = "base",
                       const std::string& tip = "tip") {
  try {
    (void)sid::chain_from_urdf(urdf, base, tip);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

TEST(Urdf, Tx40GivesPinocchiosRegressorAndTheReferenceParameters) {
  const sid::UrdfChain arm =
      sid::chain_from_urdf(read_text("ndof/tx40.urdf"), "base_link", "tool0");
  ASSERT_EQ(arm.chain.joints(), 6);
  EXPECT_EQ(arm.joint_names, (std::vector<std::string>{"j1", "j2", "j3", "j4", "j5", "j6"}));
  EXPECT_EQ(arm.link_names.back(), "link6");
  // The base's own mass and the camera off the path are not the chain's; the flange has none.
  const sid_test::Table base = sid_test::read_table("ndof/base_tx40.csv");
  EXPECT_LT((arm.theta - base.col("theta")).head(60).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_TRUE(arm.theta.tail(12).isZero());

  sid_test::expect_reference_regressor(arm.chain, "tx40");
}

TEST(Urdf, FixedJointsFoldIntoTheMovingLinkBeforeThem) {
  // A 2 kg body with principal inertias (0.02, 0.03, 0.04) at its frame's (0.1, 0, 0), fixed
  // 0.5 m along x and turned 90 degrees about z: in link 1 it sits at (0.5, 0.1, 0) with
  // principal inertias (0.03, 0.02, 0.04) along x, y, z.
  const std::string urdf = R"(<robot name="folded">
    <link name="base"/>
    <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
      <origin xyz="0 0 0.3" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>
    <link name="upper"><inertial><origin xyz="0.1 0 0"/><mass value="1"/>
      <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>
    <joint name="weld" type="fixed"><parent link="upper"/><child link="tip"/>
      <origin xyz="0.5 0 0" rpy="0 0 1.5707963267948966"/></joint>
    <link name="tip"><inertial><origin xyz="0.1 0 0"/><mass value="2"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  </robot>)";
  const sid::UrdfChain arm = sid::chain_from_urdf(urdf, "base", "tip");
  ASSERT_EQ(arm.chain.joints(), 1);
  const sid::LinkInertia<double> upper{1.0, {0.1, 0.0, 0.0}, 0.01 * Eigen::Matrix3d::Identity()};
  const sid::LinkInertia<double> tip{
      2.0, {0.5, 0.1, 0.0}, Eigen::Vector3d(0.03, 0.02, 0.04).asDiagonal().toDenseMatrix()};
  const sid::LinkParameters<double> expected =
      sid::standard_parameters(upper) + sid::standard_parameters(tip);
  EXPECT_LT((arm.theta.head(10) - expected).cwiseAbs().maxCoeff(), 1e-15);
  // URDF's default axis is x.
  const std::string default_axis = R"(<robot name="r"><link name="base"/><link name="tip"/>
    <joint name="j" type="continuous"><parent link="base"/><child link="tip"/></joint></robot>)";
  EXPECT_EQ(sid::chain_from_urdf(default_axis, "base", "tip").chain.joint_axis(0).direction,
            Eigen::Vector3d::UnitX());
  // rpy is roll about x, then pitch about y, then yaw about z, all about the parent's axes.
  const std::string turned = R"(<robot name="r"><link name="base"/><link name="tip"/>
    <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
    <origin xyz="1 2 3" rpy="0.3 -0.5 1.2"/><axis xyz="0 0 1"/></joint></robot>)";
  const sid::FramePose<double> pose =
      sid::chain_from_urdf(turned, "base", "tip").chain.link_pose(0, 0.0);
  const Eigen::Matrix3d rpy = (Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
  EXPECT_LT((pose.rotation - rpy).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_EQ(pose.translation, Eigen::Vector3d(1.0, 2.0, 3.0));
}

TEST(Urdf, RefusesWhatItCannotReadWithTheReason) {
  const std::string head = R"(<robot name="r"><link name="base"/><link name="tip"/>)";
  const auto joint = [&](const std::string& attributes, const std::string& inside = "") {
    return head + "<joint name=\"j\" " + attributes +
           "><parent link=\"base\"/><child link=\"tip\"/>" + inside + "</joint></robot>";
  };
  const auto contains = [](const std::string& message, const std::string& part) {
    return message.find(part) != std::string::npos;
  };
  EXPECT_PRED2(contains, message_of(head), "line 1: element <robot> is not closed");
  EXPECT_PRED2(contains, message_of("<robot><link name=\"base\"></robot>"),
               "</robot> closes <link>");
  EXPECT_PRED2(contains, message_of("<robot name=\"a\" name=\"b\"/>"), "given twice");
  EXPECT_PRED2(contains, message_of("<model/>"), "not <robot>");
  EXPECT_PRED2(contains, message_of(joint("type=\"prismatic\"")), "only revolute");
  EXPECT_PRED2(contains, message_of(joint("")), "has no type");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\"", "<axis xyz=\"0 0 one\"/>")),
               "not three finite numbers");
  EXPECT_PRED2(contains, message_of(joint("type=\"fixed\"")), "no revolute joint");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\""), "base", "elbow"),
               "no joint leads to link 'elbow'");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\""), "shoulder", "tip"),
               "no link 'shoulder'");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\"", "<axis xyz=\"0 0 0\"/>")),
               "zero axis");
  const std::string no_mass = R"(<robot name="r"><link name="base"/>
    <link name="tip"><inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    <joint name="j" type="revolute"><parent link="base"/><child link="tip"/></joint></robot>)";
  EXPECT_PRED2(contains, message_of(no_mass), "needs <mass> and <inertia>");
  // Every truncation of a real description is refused, none crashes.
  const std::string tx40 = read_text("ndof/tx40.urdf");
  for (std::size_t length = 0; length + 10 < tx40.size(); length += 7)
    EXPECT_THROW((void)sid::chain_from_urdf(tx40.substr(0, length), "base_link", "tool0"),
                 std::invalid_argument)
        << length;
}

}  // namespace
