#include "mjcf_writer.hpp"

#include <sid/detail/xml.hpp>

#include "csv.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

using sid::detail::XmlElement;

// A tree with every kind of joint, shape and mesh a description has: a box drawn on the base, a
// rotated inertial, a mimic, a body whose inertia no real body has, a fixed tool.
const char* const kUrdf = R"(<robot name="tree">
  <link name="world"><visual><geometry><box size="1 2 3"/></geometry></visual></link>
  <joint name="j1" type="revolute">
    <parent link="world"/><child link="a"/>
    <origin xyz="0.1 0 0.2" rpy="0 0 1.5707963267948966"/>
    <axis xyz="0 0 2"/><limit lower="-1" upper="2" effort="30" velocity="1"/>
    <dynamics damping="0.5" friction="0.2"/>
  </joint>
  <link name="a">
    <inertial>
      <origin xyz="0 0 0.1" rpy="1.5707963267948966 0 0"/><mass value="2"/>
      <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/>
    </inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.05" length="0.4"/></geometry></collision>
    <visual><geometry><mesh filename="package://pkg/meshes/a.stl" scale="0.001 0.001 0.001"/></geometry></visual>
    <visual><geometry><mesh filename="package://pkg/meshes/a.dae"/></geometry></visual>
    <visual><geometry><mesh filename="meshes/missing.stl"/></geometry></visual>
  </link>
  <joint name="slide" type="prismatic">
    <parent link="a"/><child link="b"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.1" effort="0" velocity="1"/>
  </joint>
  <link name="b">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="finger" type="prismatic">
    <parent link="b"/><child link="c"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.05" effort="5" velocity="1"/>
    <mimic joint="slide" multiplier="-1" offset="0.01"/>
  </joint>
  <link name="c">
    <inertial><mass value="0.1"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="spin" type="continuous">
    <parent link="a"/><child link="d"/><origin xyz="0 0 0.4"/><axis xyz="0 0 1"/>
  </joint>
  <link name="d">
    <inertial><mass value="0.5"/><inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.002"/></inertial>
    <collision><geometry><sphere radius="0.02"/></geometry></collision>
  </link>
  <joint name="tool" type="fixed"><parent link="d"/><child link="tool"/><origin xyz="0 0 0.1"/></joint>
  <link name="tool"/>
</robot>
)";

class MjcfWriter : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("sid_app_mjcf_writer_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_ / "pkg" / "meshes");
    fs::create_directories(root_ / "pkg" / "urdf");
    fs::create_directories(root_ / "out");
    std::ofstream(root_ / "pkg" / "meshes" / "a.stl") << "solid a\nendsolid a\n";
    std::ofstream(root_ / "pkg" / "meshes" / "a.dae") << "<COLLADA/>\n";
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }

  sid::app::MjcfJointDrives drives() const {
    sid::app::MjcfJointDrives d;
    d.joints = {"j1", "spin"};
    d.damping = Eigen::Vector2d(1.5, 0.0);
    d.friction = Eigen::Vector2d(0.25, 0.1);
    d.armature = Eigen::Vector2d(0.01, 0.02);
    d.stiffness = Eigen::Vector2d(0.0, -3.0);
    return d;
  }

  sid::app::Mjcf write(const std::string& base = "world") const {
    return sid::app::mjcf_from_urdf(kUrdf, base, Eigen::Vector3d(0.0, 0.0, -9.81), drives(),
                                    {"off_1"},
                                    {(root_ / "pkg" / "urdf").string(), (root_ / "out").string()});
  }

  fs::path root_;
};

XmlElement parsed(const std::string& text) {
  return sid::detail::XmlParser(text, "test").parse_document();
}

// The element of a kind named name anywhere below e.
const XmlElement* find(const XmlElement& e, const std::string& kind, const std::string& name) {
  for (const XmlElement& c : e.children) {
    const std::string* n = c.attribute("name");
    if (c.name == kind && n && *n == name) return &c;
    if (const XmlElement* below = find(c, kind, name)) return below;
  }
  return nullptr;
}

std::vector<double> numbers(const XmlElement& e, const std::string& key) {
  std::vector<double> out;
  const std::string* text = e.attribute(key);
  if (!text) return out;
  std::istringstream in(*text);
  double v = 0.0;
  while (in >> v) out.push_back(v);
  return out;
}

bool lists(const std::vector<std::string>& items, const std::string& part) {
  for (const std::string& item : items)
    if (item.find(part) != std::string::npos) return true;
  return false;
}

TEST_F(MjcfWriter, PlacesEachBodyWhereTheUrdfJointPutsItsLink) {
  const XmlElement mjcf = parsed(write().text);
  ASSERT_EQ(mjcf.name, "mujoco");
  EXPECT_EQ(*mjcf.attribute("model"), "tree");
  EXPECT_EQ(numbers(*mjcf.child("option"), "gravity"), (std::vector<double>{0.0, 0.0, -9.81}));
  const XmlElement* a = find(mjcf, "body", "a");
  ASSERT_NE(a, nullptr);
  EXPECT_EQ(numbers(*a, "pos"), (std::vector<double>{0.1, 0.0, 0.2}));
  const std::vector<double> w = numbers(*a, "quat");
  ASSERT_EQ(w.size(), 4u);
  const Eigen::Matrix3d rotation = Eigen::Quaterniond(w[0], w[1], w[2], w[3]).toRotationMatrix();
  EXPECT_TRUE(rotation.isApprox(
      Eigen::AngleAxisd(1.5707963267948966, Eigen::Vector3d::UnitZ()).toRotationMatrix(), 1e-12))
      << rotation;
  // The inertia about the centre of mass, turned from the <inertial>'s axes into the link's:
  // a quarter turn about x swaps y and z.
  const XmlElement* inertial = a->child("inertial");
  ASSERT_NE(inertial, nullptr);
  EXPECT_EQ(numbers(*inertial, "mass"), std::vector<double>{2.0});
  EXPECT_EQ(numbers(*inertial, "pos"), (std::vector<double>{0.0, 0.0, 0.1}));
  const std::vector<double> full = numbers(*inertial, "fullinertia");
  const std::vector<double> expected{0.1, 0.3, 0.2, 0.0, 0.0, 0.0};
  ASSERT_EQ(full.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(full[i], expected[i], 1e-15) << i;
  // The tool is welded (no joint), where the fixed joint puts it.
  const XmlElement* tool = find(mjcf, "body", "tool");
  ASSERT_NE(tool, nullptr);
  EXPECT_EQ(tool->child("joint"), nullptr);
  EXPECT_EQ(numbers(*tool, "pos"), (std::vector<double>{0.0, 0.0, 0.1}));
  // The base link is the world body: its box is the world's.
  const XmlElement* world = mjcf.child("worldbody");
  ASSERT_NE(world, nullptr);
  ASSERT_NE(world->child("geom"), nullptr);
  EXPECT_EQ(numbers(*world->child("geom"), "size"), (std::vector<double>{0.5, 1.0, 1.5}));
}

TEST_F(MjcfWriter, GivesTheChainsJointsTheirDrivesAndTheOthersTheirUrdfDynamics) {
  const sid::app::Mjcf out = write();
  const XmlElement mjcf = parsed(out.text);
  const XmlElement* j1 = find(mjcf, "joint", "j1");
  ASSERT_NE(j1, nullptr);
  EXPECT_EQ(*j1->attribute("type"), "hinge");
  EXPECT_EQ(numbers(*j1, "axis"), (std::vector<double>{0.0, 0.0, 1.0}));
  EXPECT_EQ(numbers(*j1, "range"), (std::vector<double>{-1.0, 2.0}));
  EXPECT_EQ(numbers(*j1, "damping"), std::vector<double>{1.5});  // identified, not the URDF's
  EXPECT_EQ(numbers(*j1, "frictionloss"), std::vector<double>{0.25});
  EXPECT_EQ(numbers(*j1, "armature"), std::vector<double>{0.01});
  EXPECT_EQ(j1->attribute("stiffness"), nullptr);
  const XmlElement* spin = find(mjcf, "joint", "spin");
  ASSERT_NE(spin, nullptr);
  EXPECT_EQ(spin->attribute("range"), nullptr);  // continuous
  EXPECT_EQ(spin->attribute("stiffness"), nullptr);
  EXPECT_TRUE(lists(out.left_out, "joint 'spin' stiffness -3 (negative)"));
  const XmlElement* slide = find(mjcf, "joint", "slide");
  ASSERT_NE(slide, nullptr);
  EXPECT_EQ(*slide->attribute("type"), "slide");
  EXPECT_EQ(numbers(*slide, "range"), (std::vector<double>{0.0, 0.1}));
  EXPECT_EQ(slide->attribute("damping"), nullptr);
  // The mimic: finger = 0.01 - slide.
  const XmlElement* equality = mjcf.child("equality");
  ASSERT_NE(equality, nullptr);
  ASSERT_EQ(equality->children.size(), 1u);
  EXPECT_EQ(*equality->children[0].attribute("joint1"), "finger");
  EXPECT_EQ(*equality->children[0].attribute("joint2"), "slide");
  EXPECT_EQ(numbers(equality->children[0], "polycoef"),
            (std::vector<double>{0.01, -1.0, 0.0, 0.0, 0.0}));
  // A motor on each joint of the chain, limited to its effort.
  const XmlElement* actuator = mjcf.child("actuator");
  ASSERT_NE(actuator, nullptr);
  ASSERT_EQ(actuator->children.size(), 2u);
  EXPECT_EQ(*actuator->children[0].attribute("joint"), "j1");
  EXPECT_EQ(numbers(actuator->children[0], "ctrlrange"), (std::vector<double>{-30.0, 30.0}));
  EXPECT_EQ(actuator->children[1].attribute("ctrlrange"), nullptr);
}

TEST_F(MjcfWriter, WritesTheMeshesMujocoReadsAndListsTheRest) {
  const sid::app::Mjcf out = write();
  const XmlElement mjcf = parsed(out.text);
  const XmlElement* asset = mjcf.child("asset");
  ASSERT_NE(asset, nullptr);
  ASSERT_EQ(asset->children.size(), 1u);
  const XmlElement& mesh = asset->children[0];
  EXPECT_EQ(*mesh.attribute("file"), "../pkg/meshes/a.stl");  // from the MJCF's directory
  EXPECT_EQ(numbers(mesh, "scale"), (std::vector<double>{0.001, 0.001, 0.001}));
  const XmlElement* a = find(mjcf, "body", "a");
  ASSERT_NE(a, nullptr);
  int drawn = 0, colliding = 0;
  for (const XmlElement& g : a->children) {
    if (g.name != "geom") continue;
    if (g.attribute("contype")) {
      ++drawn;
      EXPECT_EQ(*g.attribute("type"), "mesh");
      EXPECT_EQ(*g.attribute("mesh"), *mesh.attribute("name"));
    } else {
      ++colliding;
      EXPECT_EQ(*g.attribute("type"), "cylinder");
      EXPECT_EQ(numbers(g, "size"), (std::vector<double>{0.05, 0.2}));
    }
  }
  EXPECT_EQ(drawn, 1);
  EXPECT_EQ(colliding, 1);
  EXPECT_TRUE(lists(out.left_out, "a.dae (MuJoCo reads STL, OBJ and MSH meshes)"));
  EXPECT_TRUE(lists(out.left_out, "meshes/missing.stl (not found)"));
  // Link c's principal moments (0.001, 0.001, 0.01) break the triangle inequality.
  EXPECT_TRUE(lists(out.left_out, "link 'c' inertia"));
  EXPECT_EQ(*mjcf.child("compiler")->attribute("balanceinertia"), "true");
  // The comment says what was not written and what was left out.
  EXPECT_NE(out.text.find("MJCF has no place for off_1"), std::string::npos);
  EXPECT_NE(out.text.find("missing.stl (not found)"), std::string::npos);
}

TEST_F(MjcfWriter, StartsAtTheBaseLinkAndRefusesJointsAboveIt) {
  sid::app::MjcfJointDrives d = drives();
  const sid::app::MjcfPaths paths{(root_ / "pkg" / "urdf").string(), (root_ / "out").string()};
  d.joints = {"spin"};
  d.damping.resize(1);
  d.friction.resize(1);
  d.armature.resize(1);
  d.stiffness.resize(1);
  d.damping << 0.3;
  d.friction << 0.0;
  d.armature << 0.0;
  d.stiffness << 0.0;
  const XmlElement mjcf =
      parsed(sid::app::mjcf_from_urdf(kUrdf, "a", Eigen::Vector3d(0, 0, -9.81), d, {}, paths).text);
  EXPECT_EQ(find(mjcf, "joint", "j1"), nullptr);
  EXPECT_EQ(find(mjcf, "body", "a"), nullptr);  // the world
  EXPECT_NE(find(mjcf, "joint", "spin"), nullptr);
  EXPECT_THROW(
      (void)sid::app::mjcf_from_urdf(kUrdf, "b", Eigen::Vector3d(0, 0, -9.81), d, {}, paths),
      sid::app::InputError);
  try {
    (void)sid::app::mjcf_from_urdf(kUrdf, "nowhere", Eigen::Vector3d(0, 0, -9.81), d, {}, paths);
    ADD_FAILURE() << "no error for a base that is not a link";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nowhere"), std::string::npos) << e.what();
  }
}

TEST_F(MjcfWriter, GivesAPointMassTheLeastInertiaMujocoTakes) {
  const std::string urdf = R"(<robot name="point">
  <link name="base"/>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="p"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <link name="p">
    <inertial><origin xyz="0.3 0 0"/><mass value="0.5"/><inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>
  </link>
</robot>
)";
  sid::app::MjcfJointDrives d;
  d.joints = {"j"};
  d.damping = d.friction = d.armature = d.stiffness = Eigen::VectorXd::Zero(1);
  const sid::app::Mjcf out =
      sid::app::mjcf_from_urdf(urdf, "base", Eigen::Vector3d(0, 0, -9.81), d, {}, {"", ""});
  const XmlElement mjcf = parsed(out.text);
  const XmlElement* p = find(mjcf, "body", "p");
  ASSERT_NE(p, nullptr);
  ASSERT_NE(p->child("inertial"), nullptr) << out.text;
  const std::vector<double> full = numbers(*p->child("inertial"), "fullinertia");
  ASSERT_EQ(full.size(), 6u) << out.text;
  for (int i = 0; i < 3; ++i) EXPECT_EQ(full[static_cast<std::size_t>(i)], 1e-12);
  EXPECT_TRUE(lists(out.left_out, "link 'p' inertia as given (a moment of 0 kg m^2: raised to"));
}

}  // namespace
