#include <sid/cubic_spline.hpp>

#include <gtest/gtest.h>

#include <cmath>

namespace {

constexpr double kTol = 1e-13;

// g(t) = 1 + 2 (t - 1) - (t - 1)^2 + 0.5 (t - 1)^3 on one piece [1, 3], written on two pieces.
sid::CubicSpline<double> two_piece_cubic() {
  auto g = [](double t, int order) {
    const double x = t - 1.0;
    switch (order) {
      case 0:
        return 1.0 + 2.0 * x - x * x + 0.5 * x * x * x;
      case 1:
        return 2.0 - 2.0 * x + 1.5 * x * x;
      case 2:
        return -2.0 + 3.0 * x;
      default:
        return 3.0;
    }
  };
  Eigen::VectorXd knots(3), a(2), b(2), c(2), d(2);
  knots << 1.0, 2.0, 3.0;
  for (int i = 0; i < 2; ++i) {
    a[i] = g(knots[i], 0);
    b[i] = g(knots[i], 1);
    c[i] = g(knots[i], 2) / 2.0;
    d[i] = g(knots[i], 3) / 6.0;
  }
  return sid::CubicSpline<double>(knots, a, b, c, d);
}

}  // namespace

TEST(CubicSpline, EvaluatesEveryDerivativeOfAGlobalCubic) {
  const auto s = two_piece_cubic();
  for (double t : {1.0, 1.3, 2.0, 2.7, 3.0}) {
    const double x = t - 1.0;
    EXPECT_NEAR(s.value(t), 1.0 + 2.0 * x - x * x + 0.5 * x * x * x, kTol) << t;
    EXPECT_NEAR(s.derivative(t, 1), 2.0 - 2.0 * x + 1.5 * x * x, kTol) << t;
    EXPECT_NEAR(s.derivative(t, 2), -2.0 + 3.0 * x, kTol) << t;
    EXPECT_NEAR(s.derivative(t, 3), 3.0, kTol) << t;
  }
}

TEST(CubicSpline, KnotFastPathAgreesWithGeneralEvaluation) {
  const auto s = two_piece_cubic();
  for (int order = 0; order <= 3; ++order) {
    const Eigen::VectorXd fast = s.derivatives_at_knots(order);
    for (Eigen::Index i = 0; i < s.size(); ++i)
      EXPECT_NEAR(fast[i], s.derivative(s.knots()[i], order), kTol)
          << "order " << order << " knot " << i;
  }
}

TEST(CubicSpline, ContinuesLinearlyOutsideTheKnots) {
  const auto s = two_piece_cubic();
  const double slope_left = s.derivative(1.0, 1), slope_right = s.derivative(3.0, 1);
  EXPECT_NEAR(s.value(0.0), s.value(1.0) - slope_left, kTol);
  EXPECT_NEAR(s.value(5.0), s.value(3.0) + 2.0 * slope_right, kTol);
  EXPECT_EQ(s.derivative(5.0, 1), slope_right);
  EXPECT_EQ(s.derivative(-1.0, 2), 0.0);
  EXPECT_EQ(s.derivative(-1.0, 3), 0.0);
}

TEST(CubicSpline, RejectsBadConstruction) {
  Eigen::VectorXd knots(3), c2(2), c1(1);
  knots << 0.0, 1.0, 1.0;
  c2.setZero();
  c1.setZero();
  EXPECT_THROW(sid::CubicSpline<double>(knots, c2, c2, c2, c2), std::invalid_argument);
  knots << 0.0, 1.0, 2.0;
  EXPECT_THROW(sid::CubicSpline<double>(knots, c1, c2, c2, c2), std::invalid_argument);
  EXPECT_THROW(two_piece_cubic().derivative(1.5, 4), std::invalid_argument);
}

template class sid::CubicSpline<float>;
template class sid::CubicSpline<double>;
