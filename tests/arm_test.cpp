#include <sid/arm.hpp>

#include "small_arm.hpp"
#include "test_support.hpp"

#include <sid/model/two_link_arm.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <random>
#include <vector>

namespace {

// An arm, the body it simulates at the truth, and the truth's estimated parameters.
struct ArmCase {
  sid::Arm arm;
  Eigen::VectorXd body;
  Eigen::VectorXd estimated;
};

ArmCase paper_case() {
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  return {sid::paper_arm(), theta, theta};
}

ArmCase chain_case() {
  const sid_test::SmallArm small = sid_test::small_arm();
  const sid::BaseParameters<double> base = sid::chain_base_parameters(small.model);
  return {sid::chain_arm(small.model, base), small.theta, base.beta(small.theta)};
}

// Random states and torques, with the accelerations the arm's forward dynamics gives them.
sid::ChainKinematics<double> forward_samples(const sid::Arm& arm, const Eigen::VectorXd& body,
                                             int count, unsigned seed) {
  const int n = arm.joints();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  sid::ChainKinematics<double> k;
  k.t = Eigen::VectorXd::LinSpaced(count, 0.0, 0.01 * (count - 1));
  k.q.resize(count, n);
  k.qd.resize(count, n);
  k.qdd.resize(count, n);
  k.tau.resize(count, n);
  for (int i = 0; i < count; ++i) {
    sid::Arm::Vector q(n), qd(n), tau(n);
    for (int j = 0; j < n; ++j) {
      q[j] = 1.5 * u(rng);
      qd[j] = u(rng);
      tau[j] = 5.0 * u(rng);
    }
    k.q.row(i) = q.transpose();
    k.qd.row(i) = qd.transpose();
    k.tau.row(i) = tau.transpose();
    k.qdd.row(i) = arm.forward_dynamics(body, q, qd, tau).transpose();
  }
  return k;
}

class ArmKinds : public ::testing::TestWithParam<bool> {
 protected:
  ArmCase make() const { return GetParam() ? chain_case() : paper_case(); }
};

TEST_P(ArmKinds, RegressionRowsGiveTheTorqueTheForwardDynamicsWasDrivenBy) {
  // The regressor and the forward dynamics are written apart (closed form or Newton-Euler rows;
  // the 2x2 solve or the articulated-body algorithm): Y(q, qd, qdd(tau)) beta = tau.
  const ArmCase c = make();
  const sid::ChainKinematics<double> k = forward_samples(c.arm, c.body, 12, 3);
  const std::vector<Eigen::Index> all = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11};
  const sid::ChainRegression r = c.arm.regression(k, all);
  ASSERT_EQ(r.x.rows(), 12 * c.arm.joints());
  ASSERT_EQ(r.x.cols(), c.arm.parameters());
  for (int j = 0; j < c.arm.joints(); ++j)
    EXPECT_TRUE(r.y.segment(12 * j, 12).isApprox(k.tau.col(j), 1e-15)) << "joint " << j;
  EXPECT_LT((r.x * c.estimated - r.y).norm(), 1e-9 * r.y.norm());
}

TEST_P(ArmKinds, RegressionAtSomeSamplesIsThoseRowsOfAll) {
  const ArmCase c = make();
  const sid::ChainKinematics<double> k = forward_samples(c.arm, c.body, 6, 5);
  const sid::ChainRegression all = c.arm.regression(k, {0, 1, 2, 3, 4, 5});
  const sid::ChainRegression some = c.arm.regression(k, {1, 4});
  ASSERT_EQ(some.x.rows(), 2 * c.arm.joints());
  for (int j = 0; j < c.arm.joints(); ++j) {
    EXPECT_TRUE(some.x.row(2 * j).isApprox(all.x.row(6 * j + 1), 1e-15));
    EXPECT_TRUE(some.x.row(2 * j + 1).isApprox(all.x.row(6 * j + 4), 1e-15));
    EXPECT_EQ(some.y[2 * j + 1], all.y[6 * j + 4]);
  }
}

TEST_P(ArmKinds, StackedRunsKeepEachJointsRowsTogether) {
  const ArmCase c = make();
  const sid::ChainKinematics<double> a = forward_samples(c.arm, c.body, 4, 7),
                                     b = forward_samples(c.arm, c.body, 3, 8);
  const sid::ChainRegression ra = c.arm.regression(a, {0, 1, 2, 3}),
                             rb = c.arm.regression(b, {0, 2});
  const sid::ChainRegression both = sid::stacked_regression(c.arm, {a, b}, {{0, 1, 2, 3}, {0, 2}});
  ASSERT_EQ(both.x.rows(), 6 * c.arm.joints());
  for (int j = 0; j < c.arm.joints(); ++j) {
    EXPECT_EQ(both.x.middleRows(6 * j, 4), ra.x.middleRows(4 * j, 4)) << "joint " << j;
    EXPECT_EQ(both.x.middleRows(6 * j + 4, 2), rb.x.middleRows(2 * j, 2)) << "joint " << j;
    EXPECT_EQ(both.y.segment(6 * j + 4, 2), rb.y.segment(2 * j, 2));
  }
  EXPECT_THROW((void)sid::stacked_regression(c.arm, {a, b}, {{0}}), std::invalid_argument);
}

TEST_P(ArmKinds, ACopyGivesTheSameRows) {
  const ArmCase c = make();
  const sid::Arm copy = c.arm;
  const sid::ChainKinematics<double> k = forward_samples(copy, c.body, 3, 9);
  EXPECT_EQ(copy.regression(k, {0, 1, 2}).x, c.arm.regression(k, {0, 1, 2}).x);
}

INSTANTIATE_TEST_SUITE_P(PaperAndChain, ArmKinds, ::testing::Values(false, true),
                         [](const ::testing::TestParamInfo<bool>& info) {
                           return info.param ? "Chain" : "Paper";
                         });

TEST(PaperArm, SimulatesTheEstimateItselfUnderItsGravity) {
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  sid::LeastSquaresResult<double> estimate;
  estimate.theta = theta;
  EXPECT_EQ(sid::paper_arm().simulatable(estimate, 0.0), theta);
  // Without gravity an arm at rest under no torque stays at rest.
  const sid::Arm::Vector q = Eigen::Vector2d(0.3, -0.4), zero = Eigen::Vector2d::Zero();
  EXPECT_EQ(sid::paper_arm(0.0).forward_dynamics(theta, q, zero, zero), zero);
  EXPECT_GT(sid::paper_arm().forward_dynamics(theta, q, zero, zero).norm(), 1.0);
}

TEST(ArmRefusals, NameTheProblem) {
  const sid_test::SmallArm small = sid_test::small_arm();
  sid::BaseParameters<double> base = sid::chain_base_parameters(small.model);
  base.dependent.pop_back();
  sid_test::expect_invalid_argument([&] { (void)sid::chain_arm(small.model, base); },
                                    "sid::chain_arm", "not the model's");
  const sid::Arm chain = chain_case().arm;
  const sid::ChainKinematics<double> three = forward_samples(chain, small.theta, 3, 1);
  sid_test::expect_invalid_argument([&] { (void)sid::paper_arm().regression(three, {0}); },
                                    "sid::Arm::regression", "2 joints");
}

}  // namespace
