// Tests of sid::add_measurement_noise (include/sid/measurement_noise.hpp).

#include <sid/measurement_noise.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

namespace {

// n draws of N(0, s^2): the sample mean has standard error s / sqrt(n) and the sample variance
// s^2 sqrt(2 / (n - 1)). Five standard errors: a false alarm about once in 3.5 million runs (and
// the seeds are fixed, so a pass is a pass for good).
constexpr double kStandardErrors = 5.0;
constexpr Eigen::Index kSamples = 200000;

sid::Trajectory<double> smooth_truth(Eigen::Index n) {
  sid::Trajectory<double> truth;
  truth.t = Eigen::VectorXd::LinSpaced(n, 0.0, 0.0025 * static_cast<double>(n - 1));
  truth.q.resize(n, 2);
  truth.tau.resize(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    truth.q(i, 0) = std::sin(truth.t[i]);
    truth.q(i, 1) = 0.5 * std::cos(2.0 * truth.t[i]);
    truth.tau(i, 0) = 6.0 * std::sin(truth.t[i]);
    truth.tau(i, 1) = 4.0 * std::cos(truth.t[i]);
  }
  return truth;
}

TEST(MeasurementNoise, SameSeedGivesSameNoise) {
  const auto truth = smooth_truth(1000);
  const sid::MeasurementNoise<double> noise{1e-6, 1e-2};
  std::mt19937_64 a(42), b(42), c(43);
  const auto first = sid::add_measurement_noise(truth, noise, a);
  const auto second = sid::add_measurement_noise(truth, noise, b);
  const auto other = sid::add_measurement_noise(truth, noise, c);
  EXPECT_EQ(first.q, second.q);
  EXPECT_EQ(first.tau, second.tau);
  EXPECT_NE(first.q, other.q);
  EXPECT_NE(first.tau, other.tau);
  EXPECT_EQ(first.t, truth.t);  // time is not measured with noise
  // The generator advanced: a second call with it gives new noise.
  const auto third = sid::add_measurement_noise(truth, noise, a);
  EXPECT_NE(third.q, first.q);
}

TEST(MeasurementNoise, SampleMeanAndVarianceMatchTheVariances) {
  const auto truth = smooth_truth(kSamples);
  const double q_variance = 1e-4;
  const double tau_variance = 1e-2;
  std::mt19937_64 rng(2024);
  const auto measured = sid::add_measurement_noise(
      truth, sid::MeasurementNoise<double>{q_variance, tau_variance}, rng);
  const double n = static_cast<double>(kSamples);
  auto check = [&](const Eigen::VectorXd& error, double variance, const char* what) {
    const double mean = error.mean();
    const double sample_variance = (error.array() - mean).square().sum() / (n - 1.0);
    EXPECT_LT(std::abs(mean), kStandardErrors * std::sqrt(variance / n)) << what;
    EXPECT_LT(std::abs(sample_variance - variance),
              kStandardErrors * variance * std::sqrt(2.0 / (n - 1.0)))
        << what << ": sample variance " << sample_variance;
  };
  for (int j = 0; j < 2; ++j) {
    check(measured.q.col(j) - truth.q.col(j), q_variance, j == 0 ? "q1" : "q2");
    check(measured.tau.col(j) - truth.tau.col(j), tau_variance, j == 0 ? "tau1" : "tau2");
  }
  // Independent channels: the correlation of the q1 and q2 noise is within 5 / sqrt(n) of 0.
  const Eigen::VectorXd e1 = measured.q.col(0) - truth.q.col(0);
  const Eigen::VectorXd e2 = measured.q.col(1) - truth.q.col(1);
  const double correlation =
      (e1.array() - e1.mean()).matrix().dot((e2.array() - e2.mean()).matrix()) /
      std::sqrt((e1.array() - e1.mean()).square().sum() * (e2.array() - e2.mean()).square().sum());
  EXPECT_LT(std::abs(correlation), kStandardErrors / std::sqrt(n));
}

TEST(MeasurementNoise, ZeroVarianceReturnsExactValues) {
  const auto truth = smooth_truth(500);
  std::mt19937_64 rng(1);
  const auto exact =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{0.0, 0.0}, rng);
  EXPECT_EQ(exact.q, truth.q);
  EXPECT_EQ(exact.tau, truth.tau);
  // Zero variance on one channel only: that channel stays exact, the other is noisy.
  std::mt19937_64 rng_q(5);
  const auto q_only =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{1e-6, 0.0}, rng_q);
  EXPECT_NE(q_only.q, truth.q);
  EXPECT_EQ(q_only.tau, truth.tau);
}

TEST(MeasurementNoise, QNoiseOfASeedDoesNotDependOnTauVariance) {
  const auto truth = smooth_truth(300);
  std::mt19937_64 a(9), b(9);
  const auto with_tau =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{1e-6, 1e-2}, a);
  const auto without_tau =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{1e-6, 0.0}, b);
  EXPECT_EQ(with_tau.q, without_tau.q);
}

TEST(MeasurementNoise, NoiseScalesWithStandardDeviation) {
  // Same seed, variance x100: the noise is exactly 10 times larger (value + sigma z).
  const auto truth = smooth_truth(100);
  std::mt19937_64 a(3), b(3);
  const auto small =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{1e-8, 1e-4}, a);
  const auto large =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<double>{1e-6, 1e-2}, b);
  constexpr double kRoundingTol = 1e-12;
  EXPECT_TRUE((large.q - truth.q).isApprox(10.0 * (small.q - truth.q), kRoundingTol));
  EXPECT_TRUE((large.tau - truth.tau).isApprox(10.0 * (small.tau - truth.tau), kRoundingTol));
}

TEST(MeasurementNoise, WorksForFloat) {
  sid::Trajectory<float> truth;
  truth.t = Eigen::VectorXf::LinSpaced(10, 0.0f, 1.0f);
  truth.q = sid::MatrixX2<float>::Ones(10, 2);
  truth.tau = sid::MatrixX2<float>::Zero(10, 2);
  std::mt19937 rng(1);
  const auto measured =
      sid::add_measurement_noise(truth, sid::MeasurementNoise<float>{1e-2f, 0.0f}, rng);
  EXPECT_NE(measured.q, truth.q);
  EXPECT_EQ(measured.tau, truth.tau);
}

TEST(MeasurementNoise, AcceptsKinematics) {
  const auto trajectory = smooth_truth(50);
  sid::Kinematics<double> truth;
  truth.t = trajectory.t;
  truth.q = trajectory.q;
  truth.qd = sid::MatrixX2<double>::Zero(50, 2);
  truth.qdd = sid::MatrixX2<double>::Zero(50, 2);
  truth.tau = trajectory.tau;
  std::mt19937_64 a(11), b(11);
  const sid::MeasurementNoise<double> noise{1e-6, 1e-2};
  const auto from_kinematics = sid::add_measurement_noise(truth, noise, a);
  const auto from_trajectory = sid::add_measurement_noise(trajectory, noise, b);
  EXPECT_EQ(from_kinematics.q, from_trajectory.q);
  EXPECT_EQ(from_kinematics.tau, from_trajectory.tau);
}

void expect_invalid_argument_naming(const sid::Trajectory<double>& truth,
                                    const sid::MeasurementNoise<double>& noise,
                                    const std::string& what) {
  std::mt19937_64 rng(0);
  try {
    static_cast<void>(sid::add_measurement_noise(truth, noise, rng));
    ADD_FAILURE() << "no exception; expected one naming " << what;
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("sid::add_measurement_noise", 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

TEST(MeasurementNoise, ThrowsOnBadVarianceOrTruth) {
  const auto truth = smooth_truth(10);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  expect_invalid_argument_naming(truth, {-1e-6, 1e-2}, "q_variance");
  expect_invalid_argument_naming(truth, {nan, 1e-2}, "q_variance");
  expect_invalid_argument_naming(truth, {inf, 1e-2}, "q_variance");
  expect_invalid_argument_naming(truth, {1e-6, -1.0}, "tau_variance");
  expect_invalid_argument_naming(truth, {1e-6, nan}, "tau_variance");
  auto bad = truth;
  bad.q(3, 1) = nan;
  expect_invalid_argument_naming(bad, {1e-6, 1e-2}, "q at row 3");
  bad = truth;
  bad.tau.conservativeResize(9, 2);
  expect_invalid_argument_naming(bad, {1e-6, 1e-2}, "same number of rows");
}

}  // namespace
