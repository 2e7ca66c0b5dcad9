// Tests of sid/model/urdf.hpp (and the XML reader under it): the TX40 of the n-joint reference
// set written as URDF must give Pinocchio's regressor and the reference's parameters; fixed
// joints fold in; every body a chain carries (branches, bodies past the tip, held joints) is
// lumped as Pinocchio lumps it (tests/data/urdf/), also in real descriptions (tests/data/urdf/
// real/); joint limits, dynamics and mimic are reported; the XML of real files is read; bad
// descriptions are refused with a message naming the problem.

#include <sid/model/urdf.hpp>

#include "chain_test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <limits>
#include <locale>
#include <map>
#include <ostream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Pinocchio lumps the same bodies by other arithmetic (SE3 actions on spatial inertias): the
// differences are round-off.
constexpr double kPinocchioParameterTol = 1e-12;  // entries of theta reach 11
constexpr double kPinocchioTorqueTol = 1e-12;     // [N m or N]; |tau| reaches 221 N
// The same chain written as DH rows and as URDF placements (an rpy round trip): round-off.
constexpr double kDhUrdfRegressorTol = 1e-12;  // entries of Y reach about 50
constexpr double kMimicMomentTol = 1e-15;      // [kg m]; first moments of about 0.01

std::string message_of(const std::string& urdf, const std::string& base = "base",
                       const std::string& tip = "tip",
                       const std::map<std::string, double>& held = {}) {
  try {
    (void)sid::chain_from_urdf(urdf, base, tip, held);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "no exception";
}

TEST(Urdf, Tx40GivesPinocchiosRegressorAndTheReferenceParameters) {
  const sid::UrdfChain arm =
      sid::chain_from_urdf(sid_test::read_text("ndof/tx40.urdf"), "base_link", "tool0");
  ASSERT_EQ(arm.chain.joints(), 6);
  EXPECT_EQ(arm.joint_names, (std::vector<std::string>{"j1", "j2", "j3", "j4", "j5", "j6"}));
  EXPECT_EQ(arm.link_names.back(), "link6");
  // The base's own mass is not the chain's and the flange has none; the camera fixed to link 3
  // off the path (0.3 kg at (0.05, 0, 0.1), 1e-4 kg m^2 about each axis) is link 3's, as in
  // Pinocchio.
  const sid_test::Table base = sid_test::read_table("ndof/base_tx40.csv");
  Eigen::VectorXd expected = base.col("theta").head(60);
  expected.segment<10>(20) += sid::standard_parameters(
      sid::LinkInertia<double>{0.3, {0.05, 0.0, 0.1}, 1e-4 * Eigen::Matrix3d::Identity()});
  EXPECT_LT((arm.theta.head(60) - expected).cwiseAbs().maxCoeff(), 1e-14);
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
  EXPECT_PRED2(contains, message_of(joint("type=\"floating\"")),
               "is floating; only revolute, continuous, prismatic and fixed");
  EXPECT_PRED2(contains, message_of(joint("type=\"planar\"")), "is planar");
  EXPECT_PRED2(contains, message_of(joint("")), "has no type");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\"", "<axis xyz=\"0 0 one\"/>")),
               "not three finite numbers");
  EXPECT_PRED2(contains, message_of(joint("type=\"fixed\"")), "no revolute");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\""), "base", "elbow"),
               "no joint leads to link 'elbow'");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\""), "shoulder", "tip"),
               "no link 'shoulder'");
  EXPECT_PRED2(contains, message_of(joint("type=\"revolute\"", "<axis xyz=\"0 0 0\"/>")),
               "zero axis");
  const std::string two_parents = head +
                                  R"(<joint name="a" type="revolute"><parent link="base"/>
    <child link="tip"/></joint><joint name="b" type="fixed"><parent link="base"/>
    <child link="tip"/></joint></robot>)";
  EXPECT_PRED2(contains, message_of(two_parents), "link 'tip' is the child of joints 'a' and 'b'");
  const std::string loop = head + R"(<joint name="a" type="revolute"><parent link="tip"/>
    <child link="x"/></joint><joint name="b" type="revolute"><parent link="x"/>
    <child link="tip"/></joint><link name="x"/></robot>)";
  EXPECT_PRED2(contains, message_of(loop), "the joints form a loop");
  const std::string no_mass = R"(<robot name="r"><link name="base"/>
    <link name="tip"><inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
    <joint name="j" type="revolute"><parent link="base"/><child link="tip"/></joint></robot>)";
  EXPECT_PRED2(contains, message_of(no_mass), "needs <mass> and <inertia>");
  // Every truncation of a real description is refused, none crashes.
  const std::string tx40 = sid_test::read_text("ndof/tx40.urdf");
  for (std::size_t length = 0; length + 10 < tx40.size(); length += 7)
    EXPECT_THROW((void)sid::chain_from_urdf(tx40.substr(0, length), "base_link", "tool0"),
                 std::invalid_argument)
        << length;
}

TEST(Urdf, RefusesElementsNestedDeeperThan256) {
  // Unbounded recursion would overflow the stack long before 200 000 levels.
  std::string deep = "<robot>";
  for (int i = 0; i < 200000; ++i) deep += "<a>";
  EXPECT_NE(message_of(deep).find("elements nested deeper than 256"), std::string::npos);
  const auto nested = [](int depth) {
    std::string text;
    for (int i = 0; i < depth; ++i) text += i == 0 ? "<robot>" : "<a>";
    for (int i = depth - 1; i >= 0; --i) text += i == 0 ? "</robot>" : "</a>";
    return text;
  };
  EXPECT_NE(message_of(nested(256)).find("there is no link 'base'"), std::string::npos);
  EXPECT_NE(message_of(nested(257)).find("elements nested deeper than 256"), std::string::npos);
}

TEST(Urdf, CarriesALongLineOfLinksWithoutRecursion) {
  // 10 000 links of 1 g in a line past the tip: a recursive walk would need a frame per link.
  constexpr int kLinks = 10000;
  std::string urdf = R"(<robot name="r"><link name="base"/><link name="l0"/>
    <joint name="j" type="revolute"><parent link="base"/><child link="l0"/></joint>)";
  for (int i = 1; i <= kLinks; ++i) {
    const std::string link = "l" + std::to_string(i), parent = "l" + std::to_string(i - 1);
    urdf += "<link name=\"" + link +
            "\"><inertial><mass value=\"0.001\"/><inertia ixx=\"0\" ixy=\"0\" ixz=\"0\" "
            "iyy=\"0\" iyz=\"0\" izz=\"0\"/></inertial></link><joint name=\"f" +
            link + "\" type=\"fixed\"><parent link=\"" + parent + "\"/><child link=\"" + link +
            "\"/><origin xyz=\"0 0 0.001\"/></joint>";
  }
  urdf += "</robot>";
  const sid::UrdfChain arm = sid::chain_from_urdf(urdf, "base", "l0");
  EXPECT_NEAR(arm.theta[0], 0.001 * kLinks, 1e-9);
}

TEST(Urdf, XmlParserOwnsItsText) {
  sid::detail::XmlParser parser(std::string("<robot><link name=\"a\"/></robot>"), "test");
  const sid::detail::XmlElement root = parser.parse_document();  // the temporary is gone
  ASSERT_EQ(root.children.size(), 1u);
  EXPECT_EQ(*root.children[0].attribute("name"), "a");
}

TEST(Urdf, ReadsTheXmlOfRealDescriptions) {
  const std::string plain = R"(<robot name="r"><link name="base"/>
    <joint name="j" type="revolute"><parent link="base"/><child link="tip"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/></joint>
    <link name="tip"><inertial><origin xyz="0.1 0 0"/><mass value="1.5"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.03"/></inertial></link></robot>)";
  // A UTF-8 byte order mark, a DOCTYPE whose internal subset holds '>' and ']', character
  // references, names beyond ASCII, namespaced elements, comments and CDATA inside elements.
  std::string decorated =
      "\xEF\xBB\xBF<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<!DOCTYPE robot [\n"
      "  <!ELEMENT robot ANY> <!-- ] > --> <!ENTITY e \"]>\">\n]>\n" +
      std::string(R"(<robot name='r&#x2014;&#233;' xmlns:xacro="http://ros.org/wiki/xacro">
    <link name="base"/><GAZEBO/><xacro:property name="p" value="1"/>
    <joint name="&#106;" type="revolute"><!-- <joint> --><parent link="base"/>
    <child link="t&#105;p"/><![CDATA[ <link name="x"> ]]>
    <origin xyz="0 0 +5e-1"/><axis xyz="0 0 1"/></joint><link name="t&#x69;p"><inertial>
    <origin xyz=".1 0 0"/><mass value="&#49;.5"/><inertia ixx="1E-2" ixy="0" ixz="0"
    iyy="0.02" iyz="0" izz="0.03"/></inertial></link></robot>)");
  decorated.replace(decorated.find("GAZEBO"), 6,
                    "gaz\xC3\xA9"
                    "bo");  // e acute in UTF-8
  const sid::UrdfChain reference = sid::chain_from_urdf(plain, "base", "tip");
  const sid::UrdfChain arm = sid::chain_from_urdf(decorated, "base", "tip");
  EXPECT_EQ(arm.joint_names, reference.joint_names);
  EXPECT_EQ(arm.theta, reference.theta);
  EXPECT_EQ(arm.chain.link_pose(0, 0.3).translation, reference.chain.link_pose(0, 0.3).translation);
  // One, two, three and four bytes of UTF-8.
  sid::detail::XmlParser parser("<a b='&#65;&#233;&#x2014;&#x1F916;'/>", "test");
  EXPECT_EQ(*parser.parse_document().attribute("b"), "A\xC3\xA9\xE2\x80\x94\xF0\x9F\xA4\x96");
  // What it cannot read is still refused by name.
  const auto with_mass = [&](const std::string& mass) {
    std::string text = plain;
    return text.replace(text.find("1.5"), 3, mass);
  };
  const auto contains = [](const std::string& message, const std::string& part) {
    return message.find(part) != std::string::npos;
  };
  EXPECT_PRED2(contains, message_of(with_mass("&m;")),
               "line 4: unknown entity &m; in an attribute value (entities a DTD declares");
  EXPECT_PRED2(contains, message_of(with_mass("&#0;")), "character reference &#0; is not a");
  EXPECT_PRED2(contains, message_of(with_mass("&#xD800;")), "&#xD800; is not a character");
  EXPECT_PRED2(contains, message_of(with_mass("&#x110000;")), "&#x110000; is not a character");
  EXPECT_PRED2(contains, message_of(with_mass("&#1a;")), "&#1a; is not a character");
  EXPECT_PRED2(contains, message_of(with_mass("1 & 2")), "'&' that starts no entity");
  EXPECT_PRED2(contains, message_of(with_mass("0x1.8p0")), "value=\"0x1.8p0\" is not a finite");
  EXPECT_PRED2(contains, message_of("<!DOCTYPE robot [ <!ENTITY e \"x\"> <robot/>"),
               "line 1: unterminated DOCTYPE");
  EXPECT_PRED2(contains, message_of("\xEF\xBB\xBF"), "no root element");
}

// A German-style locale: decimal comma, dots between groups of three digits.
struct CommaDecimal : std::numpunct<char> {
  char do_decimal_point() const override { return ','; }
  char do_thousands_sep() const override { return '.'; }
  std::string do_grouping() const override { return "\3"; }
};

class GlobalLocale {
 public:
  explicit GlobalLocale(const std::locale& locale) : previous_(std::locale::global(locale)) {}
  ~GlobalLocale() { std::locale::global(previous_); }
  GlobalLocale(const GlobalLocale&) = delete;
  GlobalLocale& operator=(const GlobalLocale&) = delete;

 private:
  std::locale previous_;
};

TEST(Urdf, ReadsNumbersTheSameUnderAGermanLocale) {
  const std::string urdf = sid_test::read_text("urdf/arm_hand.urdf");
  const sid::UrdfChain classic = sid::chain_from_urdf(urdf, "base_link", "tool0");
  {
    const GlobalLocale german(std::locale(std::locale::classic(), new CommaDecimal));
    std::istringstream check("0.5");
    double half = 0.0;
    check >> half;
    ASSERT_NE(half, 0.5) << "the locale does not change how streams read numbers";
    const sid::UrdfChain arm = sid::chain_from_urdf(urdf, "base_link", "tool0");
    EXPECT_EQ(arm.theta, classic.theta);
    EXPECT_EQ(arm.chain.link_pose(1, 0.3).translation, classic.chain.link_pose(1, 0.3).translation);
    EXPECT_EQ(arm.joints[0].limit.lower, -2.9);
  }
}

TEST(Urdf, ReportsLimitsDynamicsAndMimicOfEachJoint) {
  const sid::UrdfChain arm =
      sid::chain_from_urdf(sid_test::read_text("urdf/arm_hand.urdf"), "base_link", "tool0");
  ASSERT_EQ(arm.joints.size(), 5u);
  const sid::UrdfJoint& j1 = arm.joints[0];
  EXPECT_EQ(j1.type, "revolute");
  EXPECT_EQ(j1.limit.lower, -2.9);
  EXPECT_EQ(j1.limit.upper, 2.9);
  EXPECT_EQ(j1.limit.velocity, 2.5);
  EXPECT_EQ(j1.limit.effort, 150.0);
  EXPECT_EQ(j1.damping, 0.5);
  EXPECT_EQ(j1.friction, 1.2);
  EXPECT_FALSE(j1.mimic.has_value());
  EXPECT_EQ(arm.joints[1].damping, 0.4);
  EXPECT_EQ(arm.joints[1].friction, 0.0);  // absent
  EXPECT_EQ(arm.joints[3].damping, 0.0);   // no <dynamics>
  const sid::UrdfJoint& j5 = arm.joints[4];
  EXPECT_EQ(j5.type, "continuous");
  EXPECT_TRUE(std::isnan(j5.limit.lower));
  EXPECT_TRUE(std::isnan(j5.limit.upper));
  EXPECT_EQ(j5.limit.velocity, 6.0);
  EXPECT_EQ(j5.limit.effort, 10.0);
  EXPECT_EQ(j5.friction, 0.3);
  const std::string mimic = R"(<robot name="r"><link name="base"/><link name="mid"/>
    <link name="tip"/><joint name="a" type="continuous"><parent link="base"/><child link="mid"/>
    </joint><joint name="b" type="revolute"><parent link="mid"/><child link="tip"/>
    <mimic joint="a" multiplier="-2" offset="0.1"/></joint>
    <joint name="c" type="revolute"><parent link="mid"/><child link="side"/>
    <mimic joint="b"/></joint><link name="side"/></robot>)";
  const sid::UrdfChain mimicking = sid::chain_from_urdf(mimic, "base", "tip");
  ASSERT_EQ(mimicking.joints.size(), 2u);
  EXPECT_TRUE(std::isnan(mimicking.joints[0].limit.effort));
  ASSERT_TRUE(mimicking.joints[1].mimic.has_value());
  EXPECT_EQ(mimicking.joints[1].mimic->joint, "a");
  EXPECT_EQ(mimicking.joints[1].mimic->multiplier, -2.0);
  EXPECT_EQ(mimicking.joints[1].mimic->offset, 0.1);
  EXPECT_EQ(mimicking.held_joints, (std::map<std::string, double>{{"c", 0.0}}));
}

// A chain of a fixture in tests/data/urdf/, with the joints off it held as in the reference.
struct PinocchioCase {
  std::string name;  // of its reference files
  std::string urdf, base, tip;
  std::map<std::string, double> held;
};

std::ostream& operator<<(std::ostream& os, const PinocchioCase& c) { return os << c.name; }

const PinocchioCase kArmTool0{"arm_tool0", "arm_hand.urdf", "base_link", "tool0", {}};
const PinocchioCase kArmTool0Held{
    "arm_tool0_held",
    "arm_hand.urdf",
    "base_link",
    "tool0",
    {{"sensor_tilt", 0.7}, {"finger_left", 0.03}, {"finger_right", 0.01}}};
const PinocchioCase kArmLink2Held{"arm_link2_held",
                                  "arm_hand.urdf",
                                  "base_link",
                                  "link2",
                                  {{"sensor_tilt", -0.4},
                                   {"j3", 0.9},
                                   {"j4", -0.8},
                                   {"j5", 2.3},
                                   {"finger_left", 0.02},
                                   {"finger_right", 0.02}}};

class CarriedBodies : public ::testing::TestWithParam<PinocchioCase> {};

TEST_P(CarriedBodies, GiveThePinocchioReducedModelsParametersAndTorques) {
  const PinocchioCase& c = GetParam();
  const sid::UrdfChain arm =
      sid::chain_from_urdf(sid_test::read_text("urdf/" + c.urdf), c.base, c.tip, c.held);
  const int n = arm.chain.joints();
  const Eigen::VectorXd theta = sid_test::read_table("urdf/" + c.name + "_theta.csv").col("theta");
  ASSERT_EQ(theta.size(), sid::kLinkParameters * n);
  EXPECT_LT((arm.theta.head(theta.size()) - theta).cwiseAbs().maxCoeff(), kPinocchioParameterTol);
  const sid_test::Table rnea = sid_test::read_table("urdf/" + c.name + "_rnea.csv");
  ASSERT_EQ(rnea.data.cols(), 4 * n);
  for (Eigen::Index row = 0; row < rnea.data.rows(); ++row) {
    const auto part = [&](int k) { return Eigen::VectorXd(rnea.data.row(row).segment(k * n, n)); };
    const Eigen::VectorXd tau =
        sid::chain_inverse_dynamics(arm.chain, arm.theta, part(0), part(1), part(2));
    EXPECT_LT((tau - part(3)).cwiseAbs().maxCoeff(), kPinocchioTorqueTol) << "state " << row;
  }
}

// A mobile manipulator's prismatic torso lift and telescoping forearm (unaligned axis), with its
// head and gripper fingers held.
const PinocchioCase kMobileGripper{
    "mobile_gripper", "mobile_manipulator.urdf", "base_footprint", "gripper_link", {}};
const PinocchioCase kMobileGripperHeld{"mobile_gripper_held",
                                       "mobile_manipulator.urdf",
                                       "base_footprint",
                                       "gripper_link",
                                       {{"head_pan", 0.5},
                                        {"head_tilt", -0.3},
                                        {"l_gripper_finger", 0.04},
                                        {"r_gripper_finger", 0.01}}};

INSTANTIATE_TEST_SUITE_P(Urdf, CarriedBodies,
                         ::testing::Values(kArmTool0, kArmTool0Held, kArmLink2Held, kMobileGripper,
                                           kMobileGripperHeld),
                         [](const auto& info) { return info.param.name; });

// Real descriptions, copied unchanged from example-robot-data 6.0.0 into tests/data/urdf/real/
// (origin and licences in tests/data/README.md; references by gen_real_reference.py). Each base
// is its URDF's root, so Pinocchio's gravity is sid's default. They carry what hand-written
// fixtures lack: <transmission>s whose <joint> children name joints again, <gazebo> blocks with
// namespaced elements, comments everywhere, mimic joints, numbers such as "2.1E-06".
const PinocchioCase kRealRobots[] = {
    // 7 axes; the hand and its two prismatic fingers past the tip
    {"panda_link8_held",
     "panda.urdf",
     "panda_link0",
     "panda_link8",
     {{"panda_finger_joint1", 0.035}, {"panda_finger_joint2", 0.01}}},
    // a fixed world joint before the first axis
    {"ur5_tool0", "ur5_robot.urdf", "world", "tool0", {}},
    // prismatic torso lift, continuous rolls; the torso carries the head, a tilting laser and
    // the whole left arm, all held. The gripper's four <mimic> joints of r_gripper_l_finger_joint
    // are given at 0, where Pinocchio (which ignores <mimic>) held them for the reference;
    // otherwise they would follow it.
    {"pr2_right_held",
     "pr2.urdf",
     "base_footprint",
     "r_gripper_tool_frame",
     {{"head_pan_joint", 0.4},
      {"head_tilt_joint", -0.3},
      {"laser_tilt_mount_joint", 0.2},
      {"l_shoulder_pan_joint", 0.6},
      {"l_shoulder_lift_joint", 0.3},
      {"l_upper_arm_roll_joint", -0.5},
      {"l_elbow_flex_joint", -1.2},
      {"l_forearm_roll_joint", 0.8},
      {"l_wrist_flex_joint", -0.4},
      {"l_wrist_roll_joint", 1.5},
      {"r_gripper_l_finger_joint", 0.3},
      {"r_gripper_r_finger_joint", 0.3},
      {"r_gripper_l_parallel_root_joint", 0.0},
      {"r_gripper_r_parallel_root_joint", 0.0},
      {"r_gripper_l_finger_tip_joint", 0.0},
      {"r_gripper_r_finger_tip_joint", 0.0}}},
    // a middle link as the tip: the forearm, wrist and gripper past it held
    {"pr2_elbow_held",
     "pr2.urdf",
     "base_footprint",
     "r_elbow_flex_link",
     {{"r_forearm_roll_joint", 1.1},
      {"r_wrist_flex_joint", -0.6},
      {"r_wrist_roll_joint", 2.0},
      {"l_elbow_flex_joint", -0.7}}},
    // dual-arm: the left arm with its prismatic fingers held
    {"baxter_left_held",
     "baxter.urdf",
     "base",
     "left_gripper",
     {{"l_gripper_l_finger_joint", 0.01}, {"l_gripper_r_finger_joint", -0.01}}},
    // humanoid: waist and left arm from the pelvis; the torso carries the head and right arm
    {"g1_left_hand_held",
     "g1_29dof_rev_1_0.urdf",
     "pelvis",
     "left_rubber_hand",
     {{"right_shoulder_pitch_joint", 0.4},
      {"right_shoulder_roll_joint", -0.3},
      {"right_elbow_joint", 1.0},
      {"right_wrist_yaw_joint", 0.5}}},
    // three continuous joints, fingers fixed past the tip
    {"kinova_end_effector", "kinova.urdf", "base", "j2s6s200_end_effector", {}},
};

// Round-off only (the largest differences are ~1e-16 of max |theta| and max |tau|).
constexpr double kRealParameterTol = 1e-12;  // relative to max |theta| (up to 81, the PR2's)
constexpr double kRealTorqueTol = 1e-10;     // relative to max |tau| (up to 1450 N, the PR2's)

class RealRobots : public ::testing::TestWithParam<PinocchioCase> {};

TEST_P(RealRobots, GiveThePinocchioReducedModelsParametersAndTorques) {
  const PinocchioCase& c = GetParam();
  const sid::UrdfChain arm =
      sid::chain_from_urdf(sid_test::read_text("urdf/real/" + c.urdf), c.base, c.tip, c.held);
  const int n = arm.chain.joints();
  const sid_test::Table theta_table = sid_test::read_table("urdf/real/" + c.name + "_theta.csv");
  ASSERT_FALSE(theta_table.comments.empty());  // "... joints j1 j2 ...; held ..."
  const std::string& comment = theta_table.comments[0];
  const std::size_t from = comment.find(", joints ") + 9;
  std::string names;
  for (const std::string& joint : arm.joint_names) names += (names.empty() ? "" : " ") + joint;
  EXPECT_EQ(comment.substr(from, comment.find(';', from) - from), names);
  const Eigen::VectorXd theta = theta_table.col("theta");
  ASSERT_EQ(theta.size(), sid::kLinkParameters * n);
  EXPECT_LT((arm.theta.head(theta.size()) - theta).cwiseAbs().maxCoeff(),
            kRealParameterTol * theta.cwiseAbs().maxCoeff());
  EXPECT_TRUE(arm.theta.tail(2 * n).isZero());
  const sid_test::Table rnea = sid_test::read_table("urdf/real/" + c.name + "_rnea.csv");
  ASSERT_EQ(rnea.data.cols(), 4 * n);
  ASSERT_EQ(rnea.data.rows(), 20);
  const double tau_scale = rnea.data.rightCols(n).cwiseAbs().maxCoeff();
  for (Eigen::Index row = 0; row < rnea.data.rows(); ++row) {
    const auto part = [&](int k) { return Eigen::VectorXd(rnea.data.row(row).segment(k * n, n)); };
    const Eigen::VectorXd tau =
        sid::chain_inverse_dynamics(arm.chain, arm.theta, part(0), part(1), part(2));
    EXPECT_LT((tau - part(3)).cwiseAbs().maxCoeff(), kRealTorqueTol * tau_scale) << "state " << row;
  }
}

INSTANTIATE_TEST_SUITE_P(Urdf, RealRobots, ::testing::ValuesIn(kRealRobots),
                         [](const auto& info) { return info.param.name; });

TEST(Urdf, ReadsPrismaticJoints) {
  const sid::UrdfChain robot = sid::chain_from_urdf(
      sid_test::read_text("urdf/mobile_manipulator.urdf"), "base_footprint", "gripper_link");
  EXPECT_EQ(robot.joint_names,
            (std::vector<std::string>{"torso_lift", "shoulder_pan", "shoulder_lift", "arm_extend",
                                      "wrist_flex", "wrist_roll"}));
  ASSERT_EQ(robot.chain.joints(), 6);
  EXPECT_EQ(robot.chain.joint_type(0), sid::JointType::Prismatic);
  EXPECT_EQ(robot.chain.joint_type(1), sid::JointType::Revolute);
  EXPECT_EQ(robot.chain.joint_type(3), sid::JointType::Prismatic);
  EXPECT_EQ(robot.joints[0].type, "prismatic");
  EXPECT_EQ(robot.joints[0].limit.upper, 0.4);
  EXPECT_EQ(robot.joints[0].damping, 80.0);
  EXPECT_EQ(robot.joints[0].friction, 25.0);
  // The lift raises the torso along the base's z; the telescope slides along its unit axis.
  const sid::FramePose<double> lifted = robot.chain.link_pose(0, 0.25);
  EXPECT_LT((lifted.translation - Eigen::Vector3d(-0.08, 0.0, 0.1 + 0.35 + 0.25)).norm(), 1e-15);
  EXPECT_EQ(lifted.rotation, Eigen::Matrix3d::Identity());
  const Eigen::Vector3d slide =
      robot.chain.link_pose(3, 0.2).translation - robot.chain.link_pose(3, 0.0).translation;
  const Eigen::Vector3d along = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()) *
                                Eigen::Vector3d(1.0, 0.0, 0.2).normalized();
  EXPECT_LT((slide - 0.2 * along).norm(), 1e-15);
}

TEST(Urdf, HeldMimicJointsFollowAGivenMaster) {
  // A hand past the tip: finger_right mimics finger_left (-1, +5 mm), the right pad mimics
  // finger_right (x2), the thumb mimics the chain's own joint.
  const std::string urdf = R"(<robot name="gripper">
    <link name="base"/><link name="hand"><inertial><mass value="0.5"/>
      <inertia ixx="1e-3" ixy="0" ixz="0" iyy="1e-3" iyz="0" izz="1e-3"/></inertial></link>
    <joint name="wrist" type="revolute"><parent link="base"/><child link="hand"/>
      <axis xyz="0 0 1"/></joint>
    <link name="left"><inertial><origin xyz="0 0 0.05"/><mass value="0.2"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link>
    <link name="right"><inertial><origin xyz="0 0 0.05"/><mass value="0.3"/>
      <inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial></link>
    <link name="pad"><inertial><origin xyz="0 0 0.02"/><mass value="0.1"/>
      <inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/></inertial></link>
    <link name="thumb"><inertial><origin xyz="0.03 0 0"/><mass value="0.1"/>
      <inertia ixx="1e-5" ixy="0" ixz="0" iyy="1e-5" iyz="0" izz="1e-5"/></inertial></link>
    <joint name="finger_left" type="prismatic"><parent link="hand"/><child link="left"/>
      <origin xyz="0 0.02 0.1"/><axis xyz="0 1 0"/></joint>
    <joint name="finger_right" type="prismatic"><parent link="hand"/><child link="right"/>
      <origin xyz="0 -0.02 0.1"/><axis xyz="0 1 0"/>
      <mimic joint="finger_left" multiplier="-1" offset="0.005"/></joint>
    <joint name="right_pad" type="revolute"><parent link="right"/><child link="pad"/>
      <origin xyz="0 0 0.1"/><axis xyz="1 0 0"/><mimic joint="finger_right" multiplier="2"/>
    </joint>
    <joint name="thumb_joint" type="revolute"><parent link="hand"/><child link="thumb"/>
      <axis xyz="0 1 0"/><mimic joint="wrist" multiplier="3" offset="0.2"/></joint>
  </robot>)";
  using Held = std::map<std::string, double>;
  // Nothing given: every held joint at 0, mimic or not (Pinocchio's reduced model at 0).
  const sid::UrdfChain at_zero = sid::chain_from_urdf(urdf, "base", "hand");
  EXPECT_EQ(
      at_zero.held_joints,
      (Held{
          {"finger_left", 0.0}, {"finger_right", 0.0}, {"right_pad", 0.0}, {"thumb_joint", 0.0}}));
  // The master given: the right finger at -0.03 + 0.005, its pad at twice that; the thumb,
  // whose master is on the chain, stays at 0.
  const sid::UrdfChain opened = sid::chain_from_urdf(urdf, "base", "hand", {{"finger_left", 0.03}});
  EXPECT_EQ(opened.held_joints.size(), 4u);
  EXPECT_EQ(opened.held_joints.at("finger_left"), 0.03);
  EXPECT_DOUBLE_EQ(opened.held_joints.at("finger_right"), -0.025);
  EXPECT_DOUBLE_EQ(opened.held_joints.at("right_pad"), -0.05);
  EXPECT_EQ(opened.held_joints.at("thumb_joint"), 0.0);
  // The bodies sit where those values put them: the same as giving every value by hand.
  EXPECT_EQ(opened.theta, sid::chain_from_urdf(urdf, "base", "hand", opened.held_joints).theta);
  // The link's first moment along y [kg m]: the left finger (0.2 kg) at 0.02 + q_l, the right
  // one (0.3 kg) at -0.02 + q_r, the pad (0.1 kg) 0.02 m along the right finger's z turned
  // about x by q_p, at -0.02 + q_r - 0.02 sin(q_p); the hand and the thumb add nothing.
  EXPECT_NEAR(
      opened.theta[2],
      0.2 * (0.02 + 0.03) + 0.3 * (-0.02 - 0.025) + 0.1 * (-0.02 - 0.025 - 0.02 * std::sin(-0.05)),
      kMimicMomentTol);
  EXPECT_NEAR(at_zero.theta[2], 0.2 * 0.02 + 0.3 * -0.02 + 0.1 * -0.02, kMimicMomentTol);
  // A value given for the mimic joint itself wins; its own mimic follows it.
  const sid::UrdfChain given =
      sid::chain_from_urdf(urdf, "base", "hand", {{"finger_left", 0.03}, {"finger_right", 0.01}});
  EXPECT_EQ(given.held_joints.at("finger_right"), 0.01);
  EXPECT_DOUBLE_EQ(given.held_joints.at("right_pad"), 0.02);
}

TEST(Urdf, PrismaticDhRowsGiveTheRegressorOfTheirUrdf) {
  // Modified DH rows {a, alpha, d, offset, type}; each is the URDF joint with
  // <origin> = Rx(alpha) Tx(a) Rz(offset) Tz(d) and axis z, whose link frame is the DH frame.
  using Row = sid::DhJoint<double>;
  const auto prismatic = sid::JointType::Prismatic;
  const std::vector<Row> table = {{0.0, 0.0, 0.3, 0.4, prismatic},
                                  {0.1, -1.2, 0.05, 0.7, sid::JointType::Revolute},
                                  {0.25, 0.9, -0.1, -0.6, prismatic},
                                  {0.0, 1.5707963267948966, 0.2, 0.0, sid::JointType::Revolute},
                                  {0.05, -0.4, 0.0, 2.0, prismatic}};
  const sid::SerialChain<double> dh(sid::DhConvention::Modified, table);
  std::ostringstream urdf;
  urdf.imbue(std::locale::classic());
  urdf.precision(17);
  urdf << "<robot name=\"dh\"><link name=\"l0\"/>";
  for (std::size_t i = 0; i < table.size(); ++i) {
    const Row& r = table[i];
    const Eigen::Matrix3d rot = (Eigen::AngleAxisd(r.alpha, Eigen::Vector3d::UnitX()) *
                                 Eigen::AngleAxisd(r.offset, Eigen::Vector3d::UnitZ()))
                                    .toRotationMatrix();
    const Eigen::Vector3d xyz = Eigen::Vector3d(r.a, 0.0, 0.0) + rot * Eigen::Vector3d(0, 0, r.d);
    // URDF's R = Rz(yaw) Ry(pitch) Rx(roll).
    const double roll = std::atan2(rot(2, 1), rot(2, 2)), pitch = -std::asin(rot(2, 0)),
                 yaw = std::atan2(rot(1, 0), rot(0, 0));
    urdf << "<link name=\"l" << i + 1 << "\"/><joint name=\"j" << i + 1 << "\" type=\""
         << (r.type == prismatic ? "prismatic" : "revolute") << "\"><parent link=\"l" << i
         << "\"/><child link=\"l" << i + 1 << "\"/><origin xyz=\"" << xyz.transpose() << "\" rpy=\""
         << roll << " " << pitch << " " << yaw << "\"/><axis xyz=\"0 0 1\"/>"
         << "</joint>";
  }
  urdf << "</robot>";
  const sid::UrdfChain from_urdf = sid::chain_from_urdf(urdf.str(), "l0", "l5");
  ASSERT_EQ(from_urdf.chain.joints(), 5);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(dh.joint_type(i), from_urdf.chain.joint_type(i));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  const int p = sid::chain_parameter_count(5);
  Eigen::MatrixXd y_dh(5, p), y_urdf(5, p);
  for (int k = 0; k < 20; ++k) {
    const Eigen::VectorXd q = Eigen::VectorXd::NullaryExpr(5, [&] { return u(rng); });
    const Eigen::VectorXd qd = Eigen::VectorXd::NullaryExpr(5, [&] { return u(rng); });
    const Eigen::VectorXd qdd = Eigen::VectorXd::NullaryExpr(5, [&] { return u(rng); });
    sid::chain_regressor(dh, q, qd, qdd, y_dh);
    sid::chain_regressor(from_urdf.chain, q, qd, qdd, y_urdf);
    EXPECT_LT((y_dh - y_urdf).cwiseAbs().maxCoeff(), kDhUrdfRegressorTol) << "q " << q.transpose();
  }
}

TEST(Urdf, CarriesTheBodiesOffAndPastTheChainOnlyOnce) {
  const std::string urdf = sid_test::read_text("urdf/arm_hand.urdf");
  const sid::UrdfChain arm = sid::chain_from_urdf(urdf, "base_link", "tool0", kArmTool0Held.held);
  EXPECT_EQ(arm.joint_names, (std::vector<std::string>{"j1", "j2", "j3", "j4", "j5"}));
  EXPECT_EQ(arm.held_joints, kArmTool0Held.held);
  // The pedestal (3 kg) and the base (5 kg) are the base's: the moving links carry the rest.
  double total = 0.0;
  for (const char* link :
       {"link1", "link2", "camera_bracket", "camera", "sensor", "link3", "cover", "link4", "link5",
        "hand", "finger_left_link", "left_tip", "finger_right_link"}) {
    const std::string tag = std::string("<link name=\"") + link + "\">";
    const auto at = urdf.find("<mass value=\"", urdf.find(tag));
    total += std::stod(urdf.substr(at + 13));
  }
  double carried = 0.0;
  for (int i = 0; i < 5; ++i) carried += arm.theta[10 * i];
  EXPECT_NEAR(carried, total, 1e-14);
  // Held at 0 where the map does not say; a shorter chain holds the arm's own joints past it.
  EXPECT_EQ(sid::chain_from_urdf(urdf, "base_link", "tool0").held_joints,
            (std::map<std::string, double>{
                {"finger_left", 0.0}, {"finger_right", 0.0}, {"sensor_tilt", 0.0}}));
  EXPECT_EQ(sid::chain_from_urdf(urdf, "base_link", "link2", kArmLink2Held.held).held_joints,
            kArmLink2Held.held);
  // A chain that starts past the first joint: link1 and what hangs before j2 are the base's.
  const sid::UrdfChain upper = sid::chain_from_urdf(urdf, "link1", "tool0", kArmTool0Held.held);
  EXPECT_EQ(upper.joint_names.front(), "j2");
  EXPECT_LT((upper.theta.head(40) - arm.theta.segment(10, 40)).cwiseAbs().maxCoeff(), 1e-15);
  // The held map may not name what cannot be held.
  const auto contains = [](const std::string& message, const std::string& part) {
    return message.find(part) != std::string::npos;
  };
  EXPECT_PRED2(contains, message_of(urdf, "base_link", "tool0", {{"j3", 0.1}}),
               "held names joint 'j3', which is a joint of the chain");
  EXPECT_PRED2(contains, message_of(urdf, "base_link", "tool0", {{"camera_mount", 0.1}}),
               "which is fixed");
  EXPECT_PRED2(contains, message_of(urdf, "base_link", "tool0", {{"finger", 0.1}}),
               "held names joint 'finger', which there is not");
  EXPECT_PRED2(contains,
               message_of(urdf, "base_link", "tool0",
                          {{"finger_left", std::numeric_limits<double>::infinity()}}),
               "not finite");
}

}  // namespace
