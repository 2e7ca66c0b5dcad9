// Tests of sid/close_abscissae.hpp: merging samples at (nearly) one abscissa, and smoothing
// scattered data whose gaps come within rounding of each other.

#include <sid/close_abscissae.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace {

using Eigen::VectorXd;

TEST(MergeCloseAbscissae, MergesTiesAndCloseSamplesIntoTheirWeightedMeans) {
  const VectorXd t = (VectorXd(6) << 0.0, 1.0, 1.0, 2.0, 2.0 + 1e-9, 3.0).finished();
  const VectorXd y = (VectorXd(6) << 1.0, 2.0, 4.0, 3.0, 6.0, 5.0).finished();
  const VectorXd dy = (VectorXd(6) << 1.0, 1.0, 1.0, 1.0, 0.5, 1.0).finished();
  const auto ties = sid::merge_close_abscissae<double>(t, y, dy, 0.0);
  ASSERT_EQ(ties.t.size(), 5);
  EXPECT_DOUBLE_EQ(ties.y[1], 3.0);
  EXPECT_DOUBLE_EQ(ties.dy[1], 1.0 / std::sqrt(2.0));
  const auto close = sid::merge_close_abscissae<double>(t, y, dy, 1e-6);
  ASSERT_EQ(close.t.size(), 4);
  // Weights 1 and 4: the mean leans to the more precise sample.
  EXPECT_DOUBLE_EQ(close.y[2], (3.0 + 4.0 * 6.0) / 5.0);
  EXPECT_NEAR(close.t[2], 2.0 + 0.8e-9, 1e-15);
  EXPECT_DOUBLE_EQ(close.dy[2], 1.0 / std::sqrt(5.0));
  EXPECT_DOUBLE_EQ(close.t[3], 3.0);
}

TEST(MergeCloseAbscissae, RefusesBadInput) {
  const VectorXd t = (VectorXd(3) << 0.0, 2.0, 1.0).finished();
  const VectorXd ones = VectorXd::Ones(3);
  EXPECT_THROW(sid::merge_close_abscissae<double>(t, ones, ones, 0.0), std::invalid_argument);
  const VectorXd sorted = (VectorXd(3) << 0.0, 1.0, 2.0).finished();
  EXPECT_THROW(sid::merge_close_abscissae<double>(sorted, ones, -ones, 0.0), std::invalid_argument);
  EXPECT_THROW(sid::merge_close_abscissae<double>(sorted, ones, ones, -1.0), std::invalid_argument);
  EXPECT_THROW(sid::merge_close_abscissae<double>(sorted, VectorXd::Ones(2), ones, 0.0),
               std::invalid_argument);
  const VectorXd nan = (VectorXd(3) << 0.0, std::nan(""), 2.0).finished();
  EXPECT_THROW(sid::merge_close_abscissae<double>(sorted, nan, ones, 0.0), std::invalid_argument);
}

const auto penalized = [](double lambda) {
  return [lambda](const sid::SmoothingSpline<double>& s, const VectorXd& y, const VectorXd& dy) {
    return s.fit_penalized(y, dy, 1.0 / lambda);
  };
};

TEST(FitMergingCloseAbscissae, LeavesWellSpacedDataAsTheyAre) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  VectorXd t(2000), y(2000);
  for (Eigen::Index i = 0; i < t.size(); ++i) t[i] = static_cast<double>(i) / 1999.0;
  for (Eigen::Index i = 0; i < t.size(); ++i) y[i] = std::sin(6.0 * t[i]) + 0.1 * (u(rng) - 0.5);
  const VectorXd dy = VectorXd::Ones(t.size());
  const auto fit = sid::fit_merging_close_abscissae<double>(t, y, dy, penalized(1e-6));
  EXPECT_EQ(fit.merge_tolerance, 0.0);
  EXPECT_EQ(fit.knots, t.size());
  const auto direct = sid::SmoothingSpline<double>(t).fit_penalized(y, dy, 1e6);
  EXPECT_EQ(fit.fit.spline.evaluate(t, 2), direct.spline.evaluate(t, 2));
}

// A million sorted uniform-random points: gaps down to about 1e-12 of the range, where the
// banded system at λ = 1e-6 is not numerically positive definite (on the machines we ran it
// on; the fit must work either way). The merged fit follows the curve within the noise and
// reproduces a line exactly, with any samples merged.
TEST(FitMergingCloseAbscissae, SmoothsAMillionScatteredPoints) {
  const Eigen::Index n = 1000000;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.1);
  std::vector<double> sorted(static_cast<std::size_t>(n));
  for (double& x : sorted) x = u(rng);
  std::sort(sorted.begin(), sorted.end());
  const VectorXd t = Eigen::Map<const VectorXd>(sorted.data(), n);
  VectorXd y(n), line(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    y[i] = std::sin(6.0 * t[i]) + noise(rng);
    line[i] = 2.0 - 0.5 * t[i];
  }
  const VectorXd dy = VectorXd::Ones(n);
  const auto fit = sid::fit_merging_close_abscissae<double>(t, y, dy, penalized(1e-6));
  EXPECT_LE(fit.merge_tolerance, 1e-6);
  EXPECT_GT(fit.knots, n / 2);
  const VectorXd g = fit.fit.spline.evaluate(t, 0);
  double worst = 0.0;
  for (Eigen::Index i = 0; i < n; ++i)
    worst = std::max(worst, std::abs(g[i] - std::sin(6.0 * t[i])));
  EXPECT_LT(worst, 0.03);  // the noise is 0.1; the fit averages about 800 samples
  const auto straight = sid::fit_merging_close_abscissae<double>(t, line, dy, penalized(1e-6));
  EXPECT_LT((straight.fit.spline.evaluate(t, 0) - line).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((straight.fit.spline.evaluate(t, 1).array() + 0.5).abs().maxCoeff(), 1e-6);
}

}  // namespace
