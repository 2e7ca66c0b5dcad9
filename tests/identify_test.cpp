#include <sid/identify.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

namespace {

constexpr double kCssNoiseFreeTol = 1e-4;  // relative, the bound required of CSS on exact q

sid::Trajectory<double> reference_trajectory() {
  const auto table = sid_test::read_table("trajectory_noise_free.csv");
  sid::Trajectory<double> data;
  data.t = table.col("t");
  data.q.resize(data.t.size(), 2);
  data.tau.resize(data.t.size(), 2);
  data.q << table.col("q1"), table.col("q2");
  data.tau << table.col("tau1"), table.col("tau2");
  return data;
}

/// The reference trajectory with white Gaussian noise of standard deviation sigma [rad] on q.
sid::Trajectory<double> reference_trajectory_with_angle_noise(unsigned seed, double sigma) {
  auto data = reference_trajectory();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  for (Eigen::Index i = 0; i < data.size(); ++i)
    data.q(i, 0) += noise(rng), data.q(i, 1) += noise(rng);
  return data;
}

double max_relative_error(const Eigen::VectorXd& estimate, const Eigen::VectorXd& truth) {
  return (estimate - truth).cwiseQuotient(truth).cwiseAbs().maxCoeff();
}

template <typename F>
void expect_invalid(F&& f, const std::string& fragment) {
  try {
    f();
    FAIL() << "expected std::invalid_argument mentioning '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Identify, CssOnNoiseFreeAnglesRecoversTheta) {
  sid::IdentifyOptions options;
  options.method = sid::DerivativeMethod::SmoothingSpline;
  options.sigma_q = sid::Vector2<double>::Constant(1e-9);  // a tiny delta-q: nearly interpolating
  options.skip_end = 0.05;  // the natural end condition g''(t_n) = 0 is wrong for this motion
  const auto result = sid::identify(reference_trajectory(), options);
  ASSERT_TRUE(result.fit.ok()) << result.fit.message;
  const Eigen::VectorXd truth = sid::paper_arm_parameters<double>();
  EXPECT_LT(max_relative_error(result.fit.theta, truth), kCssNoiseFreeTol)
      << result.fit.theta.transpose();
  EXPECT_EQ(result.samples_used(), 4001 - 100 - 20);  // 0.25 <= t <= 9.95
  EXPECT_TRUE(std::isfinite(result.smoothing_p[0]) && std::isfinite(result.smoothing_p[1]));
}

TEST(Identify, CssKinematicsMatchTheExactDerivatives) {
  const auto table = sid_test::read_table("trajectory_noise_free.csv");
  sid::IdentifyOptions options;
  options.sigma_q = sid::Vector2<double>::Constant(1e-9);
  const auto all = sid::estimate_kinematics(reference_trajectory(), options);
  // Away from the ends, cubic-spline derivatives of exact samples are O(Ts^2) accurate.
  const auto k = sid::window(all, 0.25, 9.9);
  const Eigen::Index offset = 100;
  for (int j = 0; j < 2; ++j) {
    const std::string joint = std::to_string(j + 1);
    const Eigen::VectorXd qd = table.col("qd" + joint).segment(offset, k.size());
    const Eigen::VectorXd qdd = table.col("qdd" + joint).segment(offset, k.size());
    EXPECT_LT((k.qd.col(j) - qd).cwiseAbs().maxCoeff(), 1e-8 * qd.cwiseAbs().maxCoeff()) << joint;
    EXPECT_LT((k.qdd.col(j) - qdd).cwiseAbs().maxCoeff(), 1e-4 * qdd.cwiseAbs().maxCoeff())
        << joint;
  }
  // ... while at the very end the natural condition g'' = 0 is visibly wrong.
  const Eigen::Index last = all.size() - 1;
  EXPECT_NEAR(all.qdd(last, 1), 0.0, 1e-9);
  EXPECT_GT(std::abs(table.col("qdd2")[last]), 1.0);
}

TEST(Identify, ForwardDifferencesAreExactOnLinesAndAligned) {
  sid::Trajectory<double> data;
  const Eigen::Index n = 50;
  data.t = Eigen::VectorXd::LinSpaced(n, 0.0, 0.49);
  data.q.resize(n, 2);
  data.q.col(0) = 1.0 + 2.0 * data.t.array();
  data.q.col(1) = -3.0 * data.t.array();
  data.tau = Eigen::MatrixX2d::Ones(n, 2);
  sid::IdentifyOptions options;
  options.method = sid::DerivativeMethod::ForwardDifference;
  const auto k = sid::estimate_kinematics(data, options);
  ASSERT_EQ(k.size(), n - 2);
  EXPECT_NEAR((k.qd.col(0).array() - 2.0).abs().maxCoeff(), 0.0, 1e-11);
  EXPECT_NEAR((k.qd.col(1).array() + 3.0).abs().maxCoeff(), 0.0, 1e-11);
  EXPECT_NEAR(k.qdd.cwiseAbs().maxCoeff(), 0.0, 1e-8);
  EXPECT_EQ(k.t[5], data.t[5]);  // sample i keeps its own time: forward differences lead by Ts/2
}

TEST(Identify, FilteredMethodOnNoiseFreeDataIsCloseAndSkipsStartUp) {
  sid::IdentifyOptions options;
  options.method = sid::DerivativeMethod::FilteredDifference;
  const auto result = sid::identify(reference_trajectory(), options);
  ASSERT_TRUE(result.fit.ok());
  EXPECT_GE(result.kinematics.t[0], 1.7475 - 1e-9);
  EXPECT_LT(result.kinematics.t[0], 1.7475 + 0.0025);
  // The 2 Hz acceleration filter still distorts: the paper's own filtered bias is a few %.
  EXPECT_LT(max_relative_error(result.fit.theta, sid::paper_arm_parameters<double>()), 0.15);
}

TEST(Identify, WindowKeepsTheSampleOnTheBoundary) {
  sid::Kinematics<double> k;
  k.t = Eigen::VectorXd::LinSpaced(201, 0.0, 0.5);  // 0.0025 steps; t[100] is 0.25 up to rounding
  k.q = k.qd = k.qdd = k.tau = Eigen::MatrixX2d::Zero(201, 2);
  EXPECT_EQ(sid::window(k, 0.25).size(), 101);
  EXPECT_EQ(sid::window(k, 0.0).size(), 201);
  EXPECT_EQ(sid::window(k, 1.0).size(), 0);
  EXPECT_EQ(sid::window(k, 0.25, 0.3).size(), 21);
}

TEST(Identify, RejectsBadInputWithReasons) {
  auto data = reference_trajectory();
  sid::IdentifyOptions options;
  options.method = sid::DerivativeMethod::ForwardDifference;
  auto jittered = data;
  jittered.t[7] += 1e-4;
  expect_invalid([&] { (void)sid::identify(jittered, options); }, "uniform sampling");
  options.skip = 100.0;
  expect_invalid([&] { (void)sid::identify(data, options); }, "samples are left");
  options = {};
  options.sigma_q[1] = 0.0;
  expect_invalid([&] { (void)sid::identify(data, options); }, "sigma_q of joint 2");
  auto broken = data;
  broken.q(3, 1) = std::nan("");
  expect_invalid([&] { (void)sid::identify(broken, sid::IdentifyOptions{}); }, "q at row 3");
  expect_invalid([] { (void)sid::parse_derivative_method("spline"); }, "unknown method 'spline'");
  EXPECT_EQ(sid::parse_derivative_method("filtered"), sid::DerivativeMethod::FilteredDifference);
}

TEST(Identify, GcvSmoothingFindsTheNoiseLevelByItself) {
  const auto data = reference_trajectory_with_angle_noise(5, 1e-3);
  sid::IdentifyOptions options;
  options.smoothing = sid::SmoothingMode::Gcv;
  options.sigma_q.setConstant(std::nan(""));  // not needed, and must not be used
  const auto result = sid::identify(data, options);
  ASSERT_TRUE(result.fit.ok()) << result.fit.message;
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(result.smoothing.sigma[j], 1e-3, 0.1e-3) << "joint " << j + 1;
    EXPECT_GT(result.smoothing.trace[j], 2.0);
    EXPECT_NEAR(result.smoothing.lambda[j] * result.smoothing.p[j], 1.0, 1e-12);
  }
  // Noise-free torques: the angle noise alone limits the estimate.
  EXPECT_LT(max_relative_error(result.fit.theta, sid::paper_arm_parameters<double>()), 0.05);
  EXPECT_THROW(sid::parse_smoothing_mode("spline"), std::invalid_argument);
  EXPECT_EQ(sid::parse_smoothing_mode("cv"), sid::SmoothingMode::Cv);
}

TEST(Identify, WeightedLeastSquaresDownWeightsTheNoisierJointAndHelps) {
  // Joint 2's torque sensor is 10x noisier than joint 1's. Plain least squares lets those rows
  // dominate; IDIM-WLS weights each joint by its estimated noise, which must shrink the spread
  // of the estimates over repeated experiments (same kinematics, exact derivatives).
  const auto table = sid_test::read_table("trajectory_noise_free.csv");
  sid::Kinematics<double> exact;
  exact.t = table.col("t");
  const Eigen::Index n = exact.t.size();
  exact.q.resize(n, 2), exact.qd.resize(n, 2), exact.qdd.resize(n, 2), exact.tau.resize(n, 2);
  exact.q << table.col("q1"), table.col("q2");
  exact.qd << table.col("qd1"), table.col("qd2");
  exact.qdd << table.col("qdd1"), table.col("qdd2");
  exact.tau << table.col("tau1"), table.col("tau2");
  const auto k = sid::window(exact, 0.25);
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  constexpr int kRuns = 40;
  Eigen::VectorXd sq_ols = Eigen::VectorXd::Zero(7), sq_wls = Eigen::VectorXd::Zero(7);
  std::mt19937_64 rng(17);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int run = 0; run < kRuns; ++run) {
    auto noisy = k;
    for (Eigen::Index i = 0; i < k.size(); ++i)
      noisy.tau(i, 0) += 0.01 * noise(rng), noisy.tau(i, 1) += 0.1 * noise(rng);
    const auto ols = sid::fit_two_link(noisy, sid::kPaperGravity);
    const auto wls = sid::fit_two_link_weighted(noisy, sid::kPaperGravity);
    ASSERT_TRUE(ols.ok() && wls.ok());
    sq_ols += (ols.theta - theta).cwiseAbs2();
    sq_wls += (wls.theta - theta).cwiseAbs2();
    if (run == 0) {
      EXPECT_NEAR(wls.sigma2, 1.0, 0.1);  // the weights whiten the residuals
      EXPECT_TRUE(wls.relative_std_dev.allFinite());
    }
  }
  // theta6 (joint 1 friction) lives on joint 1's rows: WLS must estimate it much better.
  EXPECT_LT(sq_wls[5], 0.5 * sq_ols[5]);
  EXPECT_LT(sq_wls.sum(), sq_ols.sum());
}

// The scaled GCV fit is the penalty-form fit at scale x the chosen lambda (checked against an
// independent fit_penalized call), while sigma_hat stays the estimate at the chosen lambda.
TEST(Identify, CrossValidationLambdaScaleSmoothsLessAtTheScaledLambda) {
  const auto data = reference_trajectory_with_angle_noise(6, 1e-2);
  sid::IdentifyOptions options;
  options.smoothing = sid::SmoothingMode::Gcv;
  sid::SmoothingReport chosen, scaled;
  (void)sid::estimate_kinematics(data, options, &chosen);
  options.cross_validation_lambda_scale = 0.25;
  const auto k = sid::estimate_kinematics(data, options, &scaled);
  Eigen::Index first = 0;
  while (data.t[first] < data.t[0] + options.cross_validation_skip - 1e-9) ++first;
  const Eigen::Index used = data.size() - first;
  const sid::SmoothingSpline<double> spline(data.t.tail(used));
  for (int j = 0; j < 2; ++j) {
    EXPECT_NEAR(scaled.lambda[j] / chosen.lambda[j], 0.25, 1e-12) << "joint " << j + 1;
    EXPECT_EQ(scaled.sigma[j], chosen.sigma[j]) << "joint " << j + 1;
    EXPECT_GT(scaled.trace[j], chosen.trace[j]) << "joint " << j + 1;  // less smoothing
    const Eigen::VectorXd qj = data.q.col(j).tail(used);
    const auto fit = spline.fit_penalized(qj, 1.0, 1.0 / (0.25 * chosen.lambda[j]));
    Eigen::VectorXd qdd(used);
    fit.spline.derivatives_at_knots(2, qdd);
    EXPECT_LT((k.qdd.col(j) - qdd).cwiseAbs().maxCoeff(), 1e-9 * qdd.cwiseAbs().maxCoeff())
        << "joint " << j + 1;
  }
  options.cross_validation_lambda_scale = 0.0;
  expect_invalid([&] { (void)sid::estimate_kinematics(data, options); },
                 "cross_validation_lambda_scale");
}
