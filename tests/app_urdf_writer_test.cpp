#include "urdf_writer.hpp"

#include <sid/model/link_inertia.hpp>
#include <sid/model/urdf.hpp>

#include "csv.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <string>
#include <vector>

namespace {

// One moving link 'a' with a hand fixed to it and a finger on a slide past the tip (held at 0).
const char* const kUrdf = R"(<robot name="arm">
  <link name="base"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="a"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <link name="a">
    <inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
  </link>
  <joint name="flange" type="fixed"><parent link="a"/><child link="hand"/><origin xyz="0 0 0.2"/></joint>
  <link name="hand">
    <inertial><mass value="2"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
  </link>
  <joint name="finger_joint" type="prismatic">
    <parent link="hand"/><child link="finger"/><origin xyz="0.05 0 0"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.04" effort="5" velocity="1"/>
  </joint>
  <link name="finger">
    <inertial><mass value="0.01"/><inertia ixx="1e-6" ixy="0" ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial>
  </link>
</robot>
)";

sid::LinkParameters<double> body(double mass, const Eigen::Vector3d& com,
                                 const Eigen::Vector3d& moments) {
  sid::LinkInertia<double> b;
  b.mass = mass;
  b.com = com;
  b.inertia_com = moments.asDiagonal();
  return sid::standard_parameters(b);
}

double least_pseudo_eigenvalue(const sid::LinkParameters<double>& phi) {
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(sid::pseudo_inertia(phi)).eigenvalues()[0];
}

sid::LinkParameters<double> read_back(const std::string& urdf) {
  return sid::chain_from_urdf(urdf, "base", "a").theta.head<10>();
}

TEST(UrdfWithLinkParameters, KeepsTheDescribedBodiesWhenTheLinksOwnPartIsReal) {
  // The description's own link, heavier by 0.5 kg at its origin.
  const sid::LinkParameters<double> described = read_back(kUrdf);
  const sid::LinkParameters<double> phi =
      described + body(0.5, Eigen::Vector3d::Zero(), Eigen::Vector3d::Constant(1e-3));
  const std::string out =
      sid::app::urdf_with_link_parameters(kUrdf, "base", "a", {"a"}, {phi}, "--write-urdf");
  EXPECT_TRUE(read_back(out).isApprox(phi, 1e-12));
  EXPECT_NE(out.find("<mass value=\"2\"/>"), std::string::npos);  // the hand's, untouched
  EXPECT_EQ(out.find("<!--"), std::string::npos);
}

TEST(UrdfWithLinkParameters, LetsTheLinkTakeTheBodiesFixedToItWhenItsOwnPartIsNoBody) {
  // 3 kg at the hand's place with little inertia: less the described hand (2 kg, 0.1 kg m^2 about
  // each axis) no body is left, but the link and hand together are one.
  const sid::LinkParameters<double> phi =
      body(3.0, Eigen::Vector3d(0.0, 0.0, 0.2), Eigen::Vector3d(0.02, 0.02, 0.01)) +
      body(0.01, Eigen::Vector3d(0.05, 0.0, 0.2), Eigen::Vector3d::Constant(1e-6));
  const std::string out =
      sid::app::urdf_with_link_parameters(kUrdf, "base", "a", {"a"}, {phi}, "--write-urdf");
  EXPECT_TRUE(read_back(out).isApprox(phi, 1e-12)) << read_back(out).transpose();
  EXPECT_NE(out.find("with the bodies of hand, fixed to it"), std::string::npos) << out;
  EXPECT_NE(out.find("its body is in the <inertial> of link 'a'"), std::string::npos) << out;
  EXPECT_EQ(out.find("nearest real body"), std::string::npos) << out;
}

TEST(UrdfWithLinkParameters, WritesTheNearestRealBodyWhenTheFitLiesOnTheEdge) {
  // A rod along z through the link's origin and the hand's place: no extent across it, so the
  // finger 5 cm off its axis does not fit inside, whatever holds the hand.
  const sid::LinkParameters<double> phi =
      body(3.0, Eigen::Vector3d(0.0, 0.0, 0.1), Eigen::Vector3d(0.05, 0.05, 0.0));
  ASSERT_NEAR(least_pseudo_eigenvalue(phi), 0.0, 1e-12);
  const std::string out =
      sid::app::urdf_with_link_parameters(kUrdf, "base", "a", {"a"}, {phi}, "--write-urdf");
  const sid::LinkParameters<double> back = read_back(out);
  EXPECT_GE(least_pseudo_eigenvalue(back - body(0.01, Eigen::Vector3d(0.05, 0.0, 0.2),
                                                Eigen::Vector3d::Constant(1e-6))),
            0.0);
  // Near what was identified: the finger's 0.01 kg at 5 cm, 2.5e-5 kg m^2, is what moves.
  EXPECT_LT((back - phi).cwiseAbs().maxCoeff(), 1e-4) << (back - phi).transpose();
  EXPECT_NE(out.find("the nearest real body to the identified one"), std::string::npos) << out;
}

TEST(UrdfWithLinkParameters, RefusesALinkLighterThanWhatItCarries) {
  // 5 g: lighter than the finger alone.
  const sid::LinkParameters<double> phi =
      body(0.005, Eigen::Vector3d(0.0, 0.0, 0.1), Eigen::Vector3d::Constant(1e-6));
  try {
    (void)sid::app::urdf_with_link_parameters(kUrdf, "base", "a", {"a"}, {phi}, "--write-mjcf");
    ADD_FAILURE() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--write-mjcf: link 'a' is lighter than the bodies"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
