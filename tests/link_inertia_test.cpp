// Tests of sid/model/link_inertia.hpp's change of frame: a body given in a child frame expressed
// in its parent, as parameters and as mass, centre of mass and inertia, against the same body
// built from point masses moved one by one.

#include <sid/model/link_inertia.hpp>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace {

constexpr double kTolerance = 1e-12;  // relative, one change of frame in double
constexpr float kFloatTolerance = 1e-5f;

struct PointMass {
  double mass;
  Eigen::Vector3d at;
};

/// The ten standard parameters of point masses, summed from their definition.
sid::LinkParameters<double> parameters_of(const std::vector<PointMass>& points) {
  double m = 0.0;
  Eigen::Vector3d h = Eigen::Vector3d::Zero();
  Eigen::Matrix3d i = Eigen::Matrix3d::Zero();
  for (const PointMass& p : points) {
    m += p.mass;
    h += p.mass * p.at;
    i += p.mass * (p.at.squaredNorm() * Eigen::Matrix3d::Identity() - p.at * p.at.transpose());
  }
  sid::LinkParameters<double> phi;
  phi << m, h, i(0, 0), i(0, 1), i(1, 1), i(0, 2), i(1, 2), i(2, 2);
  return phi;
}

/// A tool flange's pose in its link: turned about every axis and off the origin.
sid::FramePose<double> flange() {
  sid::FramePose<double> pose;
  pose.rotation = (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) *
                   Eigen::AngleAxisd(-1.1, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation = Eigen::Vector3d(0.05, 0.0823, -0.02);
  return pose;
}

std::vector<PointMass> random_body(unsigned seed) {
  std::mt19937 g(seed);
  std::uniform_real_distribution<double> mass(0.1, 1.0), at(-0.2, 0.2);
  std::vector<PointMass> points;
  for (int k = 0; k < 7; ++k) points.push_back({mass(g), Eigen::Vector3d(at(g), at(g), at(g))});
  return points;
}

TEST(ExpressedInParent, MatchesThePointMassesMovedOneByOne) {
  const sid::FramePose<double> pose = flange();
  for (unsigned seed = 1; seed <= 5; ++seed) {
    const std::vector<PointMass> child = random_body(seed);
    std::vector<PointMass> parent;
    for (const PointMass& p : child)
      parent.push_back({p.mass, pose.rotation * p.at + pose.translation});
    const sid::LinkParameters<double> truth = parameters_of(parent);
    const sid::LinkParameters<double> phi = parameters_of(child);
    const sid::LinkParameters<double> linear = sid::expressed_in_parent(phi, pose);
    const sid::LinkParameters<double> body =
        sid::standard_parameters(sid::expressed_in_parent(sid::link_inertia(phi), pose));
    EXPECT_TRUE(linear.isApprox(truth, kTolerance)) << linear.transpose() << "\n"
                                                    << truth.transpose();
    EXPECT_TRUE(body.isApprox(truth, kTolerance)) << body.transpose() << "\n" << truth.transpose();
  }
}

TEST(ExpressedInParent, TheInversePoseTakesTheBodyBack) {
  const sid::FramePose<double> pose = flange();
  const sid::FramePose<double> back = sid::inverse_pose(pose);
  const sid::LinkParameters<double> phi = parameters_of(random_body(9));
  EXPECT_TRUE(sid::expressed_in_parent(sid::expressed_in_parent(phi, pose), back)
                  .isApprox(phi, kTolerance));
  const sid::LinkInertia<double> body = sid::link_inertia(phi);
  const sid::LinkInertia<double> there_and_back =
      sid::expressed_in_parent(sid::expressed_in_parent(body, back), pose);
  EXPECT_TRUE(there_and_back.com.isApprox(body.com, kTolerance));
  EXPECT_TRUE(there_and_back.inertia_com.isApprox(body.inertia_com, kTolerance));
  // The pose and its inverse compose to the identity.
  EXPECT_TRUE((back.rotation * pose.rotation).isApprox(Eigen::Matrix3d::Identity(), kTolerance));
  EXPECT_LT((back.rotation * pose.translation + back.translation).norm(), kTolerance);
}

TEST(ExpressedInParent, IsLinearSoItMovesMasslessAndImpossibleParametersToo) {
  // Estimates and a covariance's columns are no bodies; the map must hold for them as well.
  const sid::FramePose<double> pose = flange();
  const sid::LinkParameters<double> a = parameters_of(random_body(3));
  sid::LinkParameters<double> b = parameters_of(random_body(4));
  b[0] = 0.0;  // first moments and inertia without mass
  b[9] = -b[9];
  const double x = 0.3, y = -2.0;
  EXPECT_TRUE(
      sid::expressed_in_parent(sid::LinkParameters<double>(x * a + y * b), pose)
          .isApprox(x * sid::expressed_in_parent(a, pose) + y * sid::expressed_in_parent(b, pose),
                    kTolerance));
  // A massless first moment h seen from an origin moved by p: the inertia gains 2 (h·p) 1 - p hᵀ
  // - h pᵀ, the first moment is unchanged.
  sid::LinkParameters<double> moment = sid::LinkParameters<double>::Zero();
  moment.segment<3>(1) = Eigen::Vector3d(0.2, -0.1, 0.3);
  sid::FramePose<double> shift;
  shift.translation = Eigen::Vector3d(0.0, 0.0, 0.5);
  const sid::LinkParameters<double> moved = sid::expressed_in_parent(moment, shift);
  EXPECT_EQ(moved[0], 0.0);
  EXPECT_TRUE(moved.segment<3>(1).isApprox(moment.segment<3>(1), kTolerance));
  // 2 (h·p) = 0.3; ixx = iyy = 0.3, izz = 0.3 - 2 * 0.15 = 0, ixz = -0.1, iyz = 0.05.
  sid::LinkParameters<double> expected;
  expected << 0.0, 0.2, -0.1, 0.3, 0.3, 0.0, 0.3, -0.1, 0.05, 0.0;
  EXPECT_TRUE((moved - expected).cwiseAbs().maxCoeff() < kTolerance) << moved.transpose();
}

TEST(ExpressedInParent, CompilesAndHoldsForFloat) {
  const sid::FramePose<double> pose = flange();
  sid::FramePose<float> pose_f;
  pose_f.rotation = pose.rotation.cast<float>();
  pose_f.translation = pose.translation.cast<float>();
  const sid::LinkParameters<double> phi = parameters_of(random_body(5));
  const sid::LinkParameters<float> moved =
      sid::expressed_in_parent(sid::LinkParameters<float>(phi.cast<float>()), pose_f);
  EXPECT_TRUE(moved.isApprox(sid::expressed_in_parent(phi, pose).cast<float>(), kFloatTolerance));
  const sid::LinkInertia<float> body = sid::expressed_in_parent(
      sid::link_inertia(sid::LinkParameters<float>(phi.cast<float>())), sid::inverse_pose(pose_f));
  EXPECT_GT(body.mass, 0.0f);
}

}  // namespace
