// Tests of sid::quantisation_step: a signal of encoder counts or of a fixed number of logged
// decimals is on a grid of its step; a continuous signal with white noise is not.

#include <sid/quantisation.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace {

Eigen::VectorXd swing(Eigen::Index n) {
  Eigen::VectorXd x(n);
  for (Eigen::Index i = 0; i < n; ++i)
    x[i] = 0.8 * std::sin(0.003 * static_cast<double>(i)) + 0.3 * std::sin(0.011 * i + 1.0);
  return x;
}

TEST(QuantisationStep, FindsTheStepOfEncoderCountsAndOfLoggedDecimals) {
  const Eigen::VectorXd x = swing(5000);
  const double counts = 2.0 * 3.14159265358979323846 / 4096.0;  // a 12-bit encoder
  const Eigen::VectorXd encoder = (x / counts).array().round() * counts;
  EXPECT_NEAR(sid::quantisation_step(encoder), counts, 1e-12);
  // Logged to five decimals, as a CSV writer with a fixed format does.
  const Eigen::VectorXd decimals = (x * 1e5).array().round() / 1e5;
  EXPECT_NEAR(sid::quantisation_step(decimals), 1e-5, 1e-12);
  // A sample in a hundred off the grid (a glitch, a resampled value) leaves it a grid.
  Eigen::VectorXd glitched = encoder;
  for (Eigen::Index i = 7; i < glitched.size(); i += 100) glitched[i] += 0.37 * counts;
  EXPECT_NEAR(sid::quantisation_step(glitched), counts, 1e-12);
}

TEST(QuantisationStep, SaysNoGridForNoiseOrTooFewSteps) {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1e-4);
  Eigen::VectorXd noisy = swing(5000);
  for (Eigen::Index i = 0; i < noisy.size(); ++i) noisy[i] += normal(rng);
  EXPECT_EQ(sid::quantisation_step(noisy), 0.0);
  // A smooth signal without noise is not on a grid either.
  EXPECT_EQ(sid::quantisation_step(swing(5000)), 0.0);
  // A joint held still: no step at all.
  EXPECT_EQ(sid::quantisation_step(Eigen::VectorXd::Constant(1000, 0.25)), 0.0);
  const Eigen::VectorXd few = (swing(15) * 1e3).array().round() / 1e3;
  EXPECT_EQ(sid::quantisation_step(few), 0.0);
  Eigen::VectorXd with_nan = (swing(200) * 1e3).array().round() / 1e3;
  with_nan[10] = std::nan("");
  EXPECT_NEAR(sid::quantisation_step(with_nan), 1e-3, 1e-12) << "the NaN's differences skipped";
}

}  // namespace
