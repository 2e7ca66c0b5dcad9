// sid::excite_robot: the model with the candidates, the random start and its design judged alike,
// and the refusals of what no motion separates.
#include <sid/excite_robot.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/SVD>

#include <algorithm>
#include <stdexcept>
#include <string>
#include <vector>

#include "small_arm.hpp"

namespace {

sid::DescriptionDynamics description_of(const sid_test::SmallArm& arm) {
  sid::DescriptionDynamics d;
  d.link_parameters = arm.theta.head(arm.model.rigid_body_parameters());
  return d;
}

sid::RobotExcitationOptions quick_options() {
  sid::RobotExcitationOptions o;
  o.design = sid_test::small_options();
  o.design.max_evaluations = 40;
  o.seed = 3;
  return o;
}

sid::ExcitationCandidate drive_candidate(const char* id, sid::DriveTermKind kind, int joint) {
  sid::ExcitationCandidate c;
  c.id = id;
  c.term.kind = kind;
  c.term.index = joint;
  return c;
}

sid::ExcitationCandidate angle_offset_candidate(const char* id, int joint) {
  sid::ExcitationCandidate c;
  c.id = id;
  c.angle_offset = true;
  c.term.index = joint;
  return c;
}

// 1 - R^2 of column c of w on its other columns, each scaled to unit norm, by an SVD
// least-squares fit (the workflow uses a pivoted QR).
double share_by_svd(const Eigen::MatrixXd& w, Eigen::Index c) {
  const Eigen::MatrixXd scaled = w * w.colwise().norm().cwiseInverse().asDiagonal();
  Eigen::MatrixXd others(w.rows(), w.cols() - 1);
  others << scaled.leftCols(c), scaled.rightCols(w.cols() - c - 1);
  const Eigen::VectorXd z = scaled.col(c);
  const Eigen::VectorXd fit =
      others * others.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(z);
  return (z - fit).squaredNorm() / z.squaredNorm();
}

}  // namespace

TEST(ExciteRobot, JudgesTheRandomStartAndItsDesignAlike) {
  const sid_test::SmallArm arm = sid_test::small_arm();
  const sid::RobotExcitationOptions options = quick_options();
  const sid::RobotExcitation e =
      sid::excite_robot(arm.model, description_of(arm), arm.q0, arm.limits, options);
  EXPECT_EQ(e.model.parameters(), arm.model.parameters());
  EXPECT_TRUE(e.theta.head(30).isApprox(arm.theta.head(30)));
  EXPECT_EQ(e.columns, arm.columns);
  ASSERT_TRUE(e.design.has_value());
  ASSERT_TRUE(e.designed.has_value());
  EXPECT_LE(e.design->objective, e.design->start_objective);
  EXPECT_EQ(&e.chosen(), &*e.designed);
  const Eigen::VectorXd grid =
      sid::excitation_grid(options.design.base_frequency, options.design.samples);
  for (const sid::ExcitationAssessment* a : {&e.random, &*e.designed}) {
    const Eigen::MatrixXd w =
        sid::excitation_regressor(arm.model, arm.columns, a->trajectory, grid);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(w * w.colwise().norm().cwiseInverse().asDiagonal());
    const Eigen::VectorXd s = svd.singularValues();
    EXPECT_NEAR(a->condition_number, s[0] / s[s.size() - 1], 1e-9 * a->condition_number);
    for (const Eigen::VectorXd* use : {&a->use.q, &a->use.qd, &a->use.qdd, &a->use.tau})
      EXPECT_LE(use->maxCoeff(), 1.0 + 1e-9);
    EXPECT_EQ(a->separate_shares.size(), 0);
  }
  // The same seed, the same start and design.
  const sid::RobotExcitation again =
      sid::excite_robot(arm.model, description_of(arm), arm.q0, arm.limits, options);
  EXPECT_EQ(again.designed->trajectory.a, e.designed->trajectory.a);
  EXPECT_EQ(again.designed->trajectory.b, e.designed->trajectory.b);
}

TEST(ExciteRobot, ACandidateJoinsTheModelAndItsShareIsReported) {
  const sid_test::SmallArm arm = sid_test::small_arm();
  sid::RobotExcitationOptions options = quick_options();
  options.random_only = true;
  options.separate = {drive_candidate("spring_j2", sid::DriveTermKind::Spring, 1),
                      angle_offset_candidate("angle_offset_q2", 1)};
  const sid::RobotExcitation e =
      sid::excite_robot(arm.model, description_of(arm), arm.q0, arm.limits, options);
  EXPECT_FALSE(e.design.has_value());
  EXPECT_EQ(&e.chosen(), &e.random);
  ASSERT_EQ(e.model.parameters(), arm.model.parameters() + 1);
  EXPECT_EQ(e.model.terms().back().kind, sid::DriveTermKind::Spring);
  EXPECT_EQ(e.theta[e.model.parameters() - 1], 0.0);  // the description has no spring
  EXPECT_EQ(e.angle_offsets, std::vector<int>{1});
  const Eigen::Index spring = e.model.parameters() - 1;
  const auto at = std::find(e.columns.begin(), e.columns.end(), spring);
  ASSERT_NE(at, e.columns.end());
  // The shares against an independent fit of the same columns.
  const Eigen::VectorXd grid =
      sid::excitation_grid(options.design.base_frequency, options.design.samples);
  const Eigen::MatrixXd w = sid::excitation_regressor(e.model, e.columns, e.random.trajectory, grid,
                                                      e.theta, e.angle_offsets);
  ASSERT_EQ(e.random.separate_shares.size(), 2);
  EXPECT_NEAR(e.random.separate_shares[0], share_by_svd(w, at - e.columns.begin()), 1e-8);
  EXPECT_NEAR(e.random.separate_shares[1], share_by_svd(w, w.cols() - 1), 1e-8);
  EXPECT_GT(e.random.separate_shares.minCoeff(), 0.0);
  EXPECT_NEAR(e.separable_share, 1.0 - sid::ChainDiagnoseOptions().separability_r2, 0.0);
}

TEST(ExciteRobot, RefusesWhatNoMotionSeparatesAndADescriptionWithoutLinks) {
  const sid_test::SmallArm arm = sid_test::small_arm();
  const auto refused = [&](const sid::ExcitationCandidate& c, const std::string& words) {
    sid::RobotExcitationOptions options = quick_options();
    options.random_only = true;
    options.separate = {c};
    try {
      sid::excite_robot(arm.model, description_of(arm), arm.q0, arm.limits, options);
      ADD_FAILURE() << c.id << " was not refused";
    } catch (const sid::InseparableCandidate& e) {
      EXPECT_EQ(std::string(e.what()).rfind(c.id, 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  // A rotor about the vertical first axis is that link's inertia; turning everything beyond a
  // vertical axis about it changes no torque.
  refused(drive_candidate("armature_j1", sid::DriveTermKind::Armature, 0),
          "no excitation separates it");
  refused(angle_offset_candidate("angle_offset_q1", 0), "absorb this encoder offset");
  EXPECT_THROW(
      sid::excite_robot(arm.model, sid::DescriptionDynamics{}, arm.q0, arm.limits, quick_options()),
      std::invalid_argument);
}
