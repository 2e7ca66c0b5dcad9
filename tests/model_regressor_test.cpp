// Tests of include/sid/model/regressor.hpp: stacking the regressor over a trajectory (paper
// eq. 10) and recovering theta from the noise-free reference trajectory.

#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <random>
#include <stdexcept>
#include <string>

namespace {

constexpr double kExactRecoveryRelTol = 1e-9;  // theta from exact q, qd, qdd, tau
constexpr double kRoundoffTol = 1e-13;
constexpr double kDropBefore = 0.25;  // s, as every method of the paper

sid::Kinematics<double> random_kinematics(Eigen::Index n, unsigned seed) {
  std::srand(seed);
  sid::Kinematics<double> k;
  k.t = Eigen::VectorXd::LinSpaced(n, 0.0, 1.0);
  k.q = 3.0 * sid::MatrixX2<double>::Random(n, 2);
  k.qd = 3.0 * sid::MatrixX2<double>::Random(n, 2);
  k.qdd = 10.0 * sid::MatrixX2<double>::Random(n, 2);
  k.tau = sid::MatrixX2<double>::Random(n, 2);
  return k;
}

sid::Kinematics<double> reference_kinematics() {
  const auto table = sid_test::read_table("trajectory_noise_free.csv");
  const Eigen::VectorXd t = table.col("t");
  Eigen::Index first = 0;
  while (t[first] < kDropBefore) ++first;
  const Eigen::Index n = t.size() - first;
  sid::Kinematics<double> k;
  k.t = t.tail(n);
  k.q.resize(n, 2);
  k.qd.resize(n, 2);
  k.qdd.resize(n, 2);
  k.tau.resize(n, 2);
  k.q << table.col("q1").tail(n), table.col("q2").tail(n);
  k.qd << table.col("qd1").tail(n), table.col("qd2").tail(n);
  k.qdd << table.col("qdd1").tail(n), table.col("qdd2").tail(n);
  k.tau << table.col("tau1").tail(n), table.col("tau2").tail(n);
  return k;
}

TEST(StackRegressor, JointOneRowsFirstThenJointTwo) {
  const auto k = random_kinematics(37, 1);
  const Eigen::Index n = k.size();
  const auto model = sid::two_link_arm_model<double>();
  const auto fast = sid::stack_two_link_regression(k);
  const auto generic = sid::stack_regression(model, k);
  ASSERT_EQ(fast.X.rows(), 2 * n);
  ASSERT_EQ(fast.X.cols(), 7);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto z = sid::two_link_regressor<double>(k.q.row(i).transpose(), k.qd.row(i).transpose(),
                                                   k.qdd.row(i).transpose());
    EXPECT_LE((fast.X.row(i) - z.row(0)).cwiseAbs().maxCoeff(), kRoundoffTol) << "sample " << i;
    EXPECT_LE((fast.X.row(n + i) - z.row(1)).cwiseAbs().maxCoeff(), kRoundoffTol) << i;
    EXPECT_LE((generic.X.row(i) - z.row(0)).cwiseAbs().maxCoeff(), kRoundoffTol) << i;
    EXPECT_LE((generic.X.row(n + i) - z.row(1)).cwiseAbs().maxCoeff(), kRoundoffTol) << i;
    EXPECT_EQ(fast.y[i], k.tau(i, 0));
    EXPECT_EQ(fast.y[n + i], k.tau(i, 1));
    EXPECT_EQ(generic.y[i], k.tau(i, 0));
    EXPECT_EQ(generic.y[n + i], k.tau(i, 1));
  }
}

TEST(StackRegressor, RecoversExactThetaFromNoiseFreeTrajectory) {
  const auto k = reference_kinematics();
  ASSERT_EQ(k.size(), 3901);
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  const auto model = sid::two_link_arm_model<double>();
  for (const auto& r : {sid::stack_two_link_regression(k), sid::stack_regression(model, k)}) {
    const Eigen::VectorXd estimate = r.X.colPivHouseholderQr().solve(r.y);
    for (Eigen::Index j = 0; j < 7; ++j)
      EXPECT_NEAR(estimate[j], theta[j], kExactRecoveryRelTol * std::abs(theta[j]))
          << "theta" << j + 1;
  }
}

TEST(StackRegressor, WritesIntoCallerStorageAndSubBlocks) {
  const auto k = random_kinematics(20, 2);
  Eigen::MatrixXd x(40, 7);
  sid::stack_two_link_regressor<double>(k.q, k.qd, k.qdd, sid::kPaperGravity, x);
  // Part of a trajectory (a derivative method's kept window) without copying it first.
  Eigen::MatrixXd x_part(20, 7);
  sid::stack_two_link_regressor<double>(k.q.middleRows(5, 10), k.qd.middleRows(5, 10),
                                        k.qdd.middleRows(5, 10), sid::kPaperGravity, x_part);
  EXPECT_LE((x_part.topRows(10) - x.middleRows(5, 10)).cwiseAbs().maxCoeff(), kRoundoffTol);
  EXPECT_LE((x_part.bottomRows(10) - x.middleRows(25, 10)).cwiseAbs().maxCoeff(), kRoundoffTol);
  Eigen::VectorXd y(40);
  sid::stack_torque<double>(k.tau, y);
  EXPECT_EQ(y.head(20), k.tau.col(0));
  EXPECT_EQ(y.tail(20), k.tau.col(1));
}

TEST(StackRegressor, FastPathHandlesLargeAnglesAndFloat) {
  auto k = random_kinematics(300, 3);
  k.q(150, 0) = 5e7;  // outside the inline sincos range: that chunk falls back to std
  const auto model = sid::two_link_arm_model<double>();
  const auto fast = sid::stack_two_link_regression(k);
  const auto generic = sid::stack_regression(model, k);
  EXPECT_LE((fast.X - generic.X).cwiseAbs().maxCoeff(), kRoundoffTol);

  sid::Kinematics<float> kf{k.t.cast<float>(), k.q.cast<float>(), k.qd.cast<float>(),
                            k.qdd.cast<float>(), k.tau.cast<float>()};
  kf.q(150, 0) = 0.5f;
  const auto rf = sid::stack_two_link_regression(kf);
  const auto rg = sid::stack_regression(sid::two_link_arm_model<float>(), kf);
  EXPECT_EQ(rf.X, rg.X);
}

TEST(StackRegressor, ThrowsOnMismatchedSizes) {
  const auto k = random_kinematics(10, 4);
  const auto model = sid::two_link_arm_model<double>();
  Eigen::MatrixXd x(20, 7), x_bad(20, 6);
  const sid::MatrixX2<double> short_qd = k.qd.topRows(9);
  sid_test::expect_invalid_argument(
      [&] { sid::stack_two_link_regressor<double>(k.q, short_qd, k.qdd, 9.81, x); },
      "sid::stack_two_link_regressor", "q has 10 rows but qd has 9");
  sid_test::expect_invalid_argument(
      [&] { sid::stack_regressor<double>(model, k.q, k.qd, short_qd, x); }, "sid::stack_regressor",
      "qdd has 9");
  sid_test::expect_invalid_argument(
      [&] { sid::stack_regressor<double>(model, k.q, k.qd, k.qdd, x_bad); }, "sid::stack_regressor",
      "X is 20 x 6");
  sid_test::expect_invalid_argument(
      [&] { sid::stack_two_link_regressor<double>(k.q, k.qd, k.qdd, 9.81, x_bad); },
      "sid::stack_two_link_regressor", "X");
  Eigen::VectorXd y_bad(19);
  sid_test::expect_invalid_argument([&] { sid::stack_torque<double>(k.tau, y_bad); },
                                    "sid::stack_torque", "y has 19");
  auto k_bad = k;
  k_bad.tau.conservativeResize(8, 2);
  sid_test::expect_invalid_argument([&] { (void)sid::stack_two_link_regression(k_bad); },
                                    "sid::stack_two_link_regression", "tau has 8");
  sid_test::expect_invalid_argument([&] { (void)sid::stack_regression(model, k_bad); },
                                    "sid::stack_regression", "tau");
}

}  // namespace
