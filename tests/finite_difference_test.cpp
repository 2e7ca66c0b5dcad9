// Tests of include/sid/finite_difference.hpp: exactness on polynomials as Taylor's theorem says,
// the sample bookkeeping, and bad input.

#include <sid/finite_difference.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>

namespace {

// Differences of O(1) samples divided by Ts = 0.01 (or its square): rounding of the samples,
// ~1e-16, is amplified by 1/Ts = 1e2 for x' and 4/Ts^2 = 4e4 for x''.
constexpr double kTs = 0.01;
constexpr double kFirstTol = 1e-11;
constexpr double kSecondTol = 1e-9;
constexpr Eigen::Index kSamples = 41;

Eigen::VectorXd times() { return Eigen::VectorXd::LinSpaced(kSamples, 0.0, kTs * (kSamples - 1)); }

// Columns: a quadratic and a cubic with their derivatives, evaluated at t.
Eigen::ArrayXd quadratic(const Eigen::ArrayXd& t) { return 0.3 - 1.2 * t + 2.5 * t.square(); }
Eigen::ArrayXd quadratic_d1(const Eigen::ArrayXd& t) { return -1.2 + 5.0 * t; }
constexpr double kQuadraticD2 = 5.0;
Eigen::ArrayXd cubic(const Eigen::ArrayXd& t) {
  return 1.0 + 0.5 * t - 3.0 * t.square() + 4.0 * t.cube();
}
Eigen::ArrayXd cubic_d1(const Eigen::ArrayXd& t) { return 0.5 - 6.0 * t + 12.0 * t.square(); }
Eigen::ArrayXd cubic_d2(const Eigen::ArrayXd& t) { return -6.0 + 24.0 * t; }
constexpr double kCubicD3 = 24.0;

}  // namespace

TEST(FiniteDifference, ForwardIsExactOnLines) {
  const Eigen::ArrayXd t = times();
  Eigen::MatrixXd x(kSamples, 2);
  x.col(0) = (2.0 - 3.0 * t).matrix();
  x.col(1) = (0.5 + 7.0 * t).matrix();
  const auto d = sid::forward_differences(x, kTs);
  ASSERT_EQ(d.first.rows(), kSamples - 1);
  ASSERT_EQ(d.first.cols(), 2);
  EXPECT_LT((d.first.col(0).array() + 3.0).abs().maxCoeff(), kFirstTol);
  EXPECT_LT((d.first.col(1).array() - 7.0).abs().maxCoeff(), kFirstTol);
  EXPECT_LT(d.second.cwiseAbs().maxCoeff(), kSecondTol);
}

TEST(FiniteDifference, ForwardFirstDifferenceHasTaylorErrorOnQuadratics) {
  // (x(t + h) - x(t)) / h = x'(t) + h x''/2 exactly for a quadratic: first order, not exact.
  const Eigen::ArrayXd t = times();
  const auto d = sid::forward_differences(quadratic(t).matrix(), kTs);
  const Eigen::ArrayXd expected = quadratic_d1(t.head(kSamples - 1)) + kTs * kQuadraticD2 / 2.0;
  EXPECT_LT((d.first.col(0).array() - expected).abs().maxCoeff(), kFirstTol);
}

TEST(FiniteDifference, ForwardSecondDifferenceIsCentredOneSampleLater) {
  // Eq. 48: the forward difference of forward differences at i is the centred second
  // difference at i + 1, exact for cubics there: x''(t_i + Ts).
  const Eigen::ArrayXd t = times();
  const auto d = sid::forward_differences(cubic(t).matrix(), kTs);
  ASSERT_EQ(d.second.rows(), kSamples - 2);
  EXPECT_EQ(d.second_begin, 0);
  const Eigen::ArrayXd expected = cubic_d2(t.head(kSamples - 2) + kTs);
  EXPECT_LT((d.second.col(0).array() - expected).abs().maxCoeff(), kSecondTol);
}

TEST(FiniteDifference, CentralIsExactOnQuadratics) {
  const Eigen::ArrayXd t = times();
  Eigen::MatrixXd x(kSamples, 2);
  x.col(0) = quadratic(t).matrix();
  x.col(1) = (-2.0 * quadratic(t)).matrix();
  const auto d = sid::central_differences(x, kTs);
  ASSERT_EQ(d.first.rows(), kSamples - 2);
  ASSERT_EQ(d.second.rows(), kSamples - 2);
  const Eigen::ArrayXd t_mid = t.segment(1, kSamples - 2);
  EXPECT_LT((d.first.col(0).array() - quadratic_d1(t_mid)).abs().maxCoeff(), kFirstTol);
  EXPECT_LT((d.first.col(1).array() + 2.0 * quadratic_d1(t_mid)).abs().maxCoeff(), kFirstTol);
  EXPECT_LT((d.second.col(0).array() - kQuadraticD2).abs().maxCoeff(), kSecondTol);
  EXPECT_LT((d.second.col(1).array() + 2.0 * kQuadraticD2).abs().maxCoeff(), kSecondTol);
}

TEST(FiniteDifference, CentralSecondDifferenceIsExactOnCubics) {
  const Eigen::ArrayXd t = times();
  const auto d = sid::central_differences(cubic(t).matrix(), kTs);
  const Eigen::ArrayXd t_mid = t.segment(1, kSamples - 2);
  EXPECT_LT((d.second.col(0).array() - cubic_d2(t_mid)).abs().maxCoeff(), kSecondTol);
}

TEST(FiniteDifference, CentralFirstDifferenceHasTaylorErrorOnCubics) {
  // (x(t + h) - x(t - h)) / 2h = x'(t) + h^2 x'''/6 exactly for a cubic: second order.
  const Eigen::ArrayXd t = times();
  const auto d = sid::central_differences(cubic(t).matrix(), kTs);
  const Eigen::ArrayXd t_mid = t.segment(1, kSamples - 2);
  const Eigen::ArrayXd expected = cubic_d1(t_mid) + kTs * kTs * kCubicD3 / 6.0;
  EXPECT_LT((d.first.col(0).array() - expected).abs().maxCoeff(), kFirstTol);
}

TEST(FiniteDifference, ReportsWhichSamplesEachSchemeCovers) {
  const Eigen::MatrixXd x = Eigen::MatrixXd::Random(10, 3);
  const auto fwd = sid::forward_differences(x, kTs);
  EXPECT_EQ(fwd.first_begin, 0);
  EXPECT_EQ(fwd.first.rows(), 9);
  EXPECT_EQ(fwd.second.rows(), 8);
  EXPECT_EQ(fwd.begin(), 0);
  EXPECT_EQ(fwd.end(), 8);
  EXPECT_EQ(fwd.first_common().rows(), 8);
  EXPECT_EQ(fwd.second_common().rows(), 8);
  EXPECT_EQ(fwd.first_common().cols(), 3);

  const auto cen = sid::central_differences(x, kTs);
  EXPECT_EQ(cen.first_begin, 1);
  EXPECT_EQ(cen.second_begin, 1);
  EXPECT_EQ(cen.begin(), 1);
  EXPECT_EQ(cen.end(), 9);
  // Row r of the result belongs to sample first_begin + r: check one by hand.
  EXPECT_DOUBLE_EQ(cen.first(3, 2), (x(5, 2) - x(3, 2)) / (2.0 * kTs));
  EXPECT_DOUBLE_EQ(fwd.first(3, 2), (x(4, 2) - x(3, 2)) / kTs);
}

TEST(FiniteDifference, AcceptsFixedTwoColumnSignals) {
  Eigen::Matrix<double, Eigen::Dynamic, 2> q(5, 2);
  q << 0, 0, 1, 2, 2, 4, 3, 6, 4, 8;
  const auto d = sid::forward_differences(q, 1.0);
  EXPECT_EQ(d.first(0, 1), 2.0);
  EXPECT_EQ(d.second(0, 0), 0.0);
}

TEST(FiniteDifference, WorksInFloat) {
  const Eigen::VectorXf x = Eigen::VectorXf::LinSpaced(5, 0.0f, 4.0f);
  const sid::FiniteDifferences<float> d = sid::central_differences(x, 0.5f);
  EXPECT_FLOAT_EQ(d.first(0, 0), 2.0f);
}

TEST(FiniteDifference, ThrowsOnBadInput) {
  const Eigen::MatrixXd two_samples = Eigen::MatrixXd::Zero(2, 2);
  const Eigen::MatrixXd ok = Eigen::MatrixXd::Zero(3, 2);
  EXPECT_THROW((void)sid::forward_differences(two_samples, kTs), std::invalid_argument);
  EXPECT_THROW((void)sid::central_differences(two_samples, kTs), std::invalid_argument);
  EXPECT_THROW((void)sid::forward_differences(ok, 0.0), std::invalid_argument);
  EXPECT_THROW((void)sid::central_differences(ok, -kTs), std::invalid_argument);
  EXPECT_THROW((void)sid::forward_differences(ok, std::numeric_limits<double>::quiet_NaN()),
               std::invalid_argument);
  Eigen::MatrixXd with_nan = ok;
  with_nan(1, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW((void)sid::central_differences(with_nan, kTs), std::invalid_argument);
  try {
    (void)sid::forward_differences(ok, -1.0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "sid::forward_differences: ts must be positive and finite, got -1");
  }
}
