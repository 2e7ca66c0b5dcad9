#include <sid/smoothing_spline.hpp>

#include "test_support.hpp"

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <utility>

namespace {

// Tolerances required against the 60-digit references.
constexpr double kValueTol = 1e-12;       // g, relative to max|g|
constexpr double kDerivativeTol = 1e-11;  // g', g'', relative to their max
constexpr double kParameterTol = 1e-12;   // p, relative
constexpr double kIdentityTol = 1e-12;

using Vec = Eigen::VectorXd;
using Spline = sid::SmoothingSpline<double>;

double rel_max_error(const Vec& got, const Vec& want) {
  return (got - want).cwiseAbs().maxCoeff() / want.cwiseAbs().maxCoeff();
}

struct Case {
  Vec t, y, dy, g, dg, d2g;
  double S, p;
};

Case load(const std::string& file) {
  const auto table = sid_test::read_table(file);
  return {table.col("t"),
          table.col("y"),
          table.col("dy"),
          table.col("g"),
          table.col("dg"),
          table.col("d2g"),
          sid_test::comment_value(table, "S"),
          sid_test::comment_value(table, "p")};
}

// Noisy samples of a smooth signal on a jittered grid, the kind of data the smoother is for.
struct Noisy {
  Vec t, y;
};
Noisy noisy_signal(Eigen::Index n, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> jitter(0.5, 1.5);
  Noisy s{Vec(n), Vec(n)};
  double t = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    s.t[i] = t;
    s.y[i] = std::sin(2.0 * t) + 0.3 * std::cos(5.0 * t) + noise(rng);
    t += jitter(rng) * 10.0 / static_cast<double>(n);
  }
  return s;
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

class SmoothingSplineReference : public ::testing::TestWithParam<std::string> {};

TEST_P(SmoothingSplineReference, MatchesSixtyDigitReference) {
  const Case c = load(GetParam());
  const auto fit = Spline(c.t).fit_constrained(c.y, c.dy, c.S);
  EXPECT_LE(std::abs(fit.p - c.p) / c.p, kParameterTol) << "p=" << fit.p << " want " << c.p;
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(0), c.g), kValueTol);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(1), c.dg), kDerivativeTol);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(2), c.d2g), kDerivativeTol);
  EXPECT_NEAR(fit.F, c.S, kIdentityTol * c.S);
  EXPECT_DOUBLE_EQ(fit.lambda, 1.0 / fit.p);
}

TEST_P(SmoothingSplineReference, PenaltyFormAtReferencePMatchesToo) {
  const Case c = load(GetParam());
  const auto fit = Spline(c.t).fit_penalized(c.y, c.dy, c.p);
  EXPECT_EQ(fit.factorizations, 1);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(0), c.g), kValueTol);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(2), c.d2g), kDerivativeTol);
  EXPECT_NEAR(fit.F, c.S, 1e-10 * c.S);
}

INSTANTIATE_TEST_SUITE_P(ReferenceCases, SmoothingSplineReference,
                         ::testing::Values("uniform_n101.csv", "nonuniform_n64.csv",
                                           "short_n5.csv"));

TEST(SmoothingSpline, ZeroSInterpolates) {
  const Noisy s = noisy_signal(200, 0.1, 1);
  const auto fit = Spline(s.t).fit_constrained(s.y, 0.1, 0.0);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(0), s.y), kIdentityTol);
  EXPECT_EQ(fit.F, 0.0);
  EXPECT_TRUE(std::isinf(fit.p));
  EXPECT_EQ(fit.lambda, 0.0);
}

TEST(SmoothingSpline, ReproducesStraightLineForAnySOrP) {
  const Noisy s = noisy_signal(50, 0.1, 2);
  const Vec line = (2.0 - 3.0 * s.t.array()).matrix();
  const Spline spline(s.t);
  auto check = [&](const sid::SmoothingFit<double>& fit, const std::string& what) {
    EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(0), line), kIdentityTol) << what;
    EXPECT_LE((fit.spline.derivatives_at_knots(1).array() + 3.0).abs().maxCoeff(), 1e-10) << what;
    EXPECT_LE(fit.spline.derivatives_at_knots(2).cwiseAbs().maxCoeff(), 1e-9) << what;
  };
  for (double S : {0.0, 1.0, 50.0, 1e6})
    check(spline.fit_constrained(line, 0.1, S), "S=" + std::to_string(S));
  for (double p : {0.0, 1e-3, 1.0, 1e3, std::numeric_limits<double>::infinity()})
    check(spline.fit_penalized(line, 0.1, p), "p=" + std::to_string(p));
}

TEST(SmoothingSpline, LargeSGivesWeightedLeastSquaresLine) {
  const Noisy s = noisy_signal(80, 0.2, 3);
  Vec dy = Vec::LinSpaced(80, 0.1, 0.4);
  Eigen::MatrixXd a(80, 2);
  a.col(0).setOnes();
  a.col(1) = s.t;
  const Vec w = dy.cwiseInverse();
  const Eigen::Vector2d coef =
      (w.asDiagonal() * a).colPivHouseholderQr().solve(w.asDiagonal() * s.y);
  const Vec want = a * coef;
  const double f_line = ((want - s.y).cwiseQuotient(dy)).squaredNorm();
  const auto fit = Spline(s.t).fit_constrained(s.y, dy, f_line * (1.0 + 1e-9));
  EXPECT_EQ(fit.p, 0.0);
  EXPECT_LE(rel_max_error(fit.spline.derivatives_at_knots(0), want), kIdentityTol);
  EXPECT_NEAR(fit.F, f_line, kIdentityTol * f_line);
  // Just below the line's F, the constraint is active and F = S.
  const auto active = Spline(s.t).fit_constrained(s.y, dy, 0.99 * f_line);
  EXPECT_GT(active.p, 0.0);
  EXPECT_NEAR(active.F, 0.99 * f_line, kIdentityTol * f_line);
}

TEST(SmoothingSpline, TwoPointsGiveTheLineThroughThem) {
  Vec t(2), y(2);
  t << 1.0, 3.0;
  y << 2.0, 6.0;
  const auto fit = Spline(t).fit_constrained(y, 0.5, 2.0);
  EXPECT_NEAR(fit.spline.value(2.0), 4.0, kIdentityTol);
  EXPECT_NEAR(fit.spline.derivative(2.0, 1), 2.0, kIdentityTol);
}

TEST(SmoothingSpline, ConvergedFitSatisfiesConstraintAndIsC2Natural) {
  const Noisy s = noisy_signal(1000, 0.05, 4);
  const auto fit = Spline(s.t).fit_constrained(s.y, 0.05);  // S = n
  EXPECT_NEAR(fit.F, 1000.0, kIdentityTol * 1000.0);
  EXPECT_GT(fit.iterations, 0);
  const auto& sp = fit.spline;
  EXPECT_EQ(sp.derivative(s.t[0], 2), 0.0);
  EXPECT_NEAR(sp.derivative(s.t[999], 2), 0.0,
              1e-9 * sp.derivatives_at_knots(2).cwiseAbs().maxCoeff());
  for (Eigen::Index i = 1; i + 1 < sp.size();
       ++i) {  // left piece at its end == right piece at start
    const double h = s.t[i] - s.t[i - 1];
    const double left[3] = {
        sp.a()[i - 1] + h * (sp.b()[i - 1] + h * (sp.c()[i - 1] + h * sp.d()[i - 1])),
        sp.b()[i - 1] + h * (2 * sp.c()[i - 1] + 3 * h * sp.d()[i - 1]),
        2 * sp.c()[i - 1] + 6 * h * sp.d()[i - 1]};
    const double right[3] = {sp.a()[i], sp.b()[i], 2 * sp.c()[i]};
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(left[k], right[k], 1e-9 * (1.0 + std::abs(right[k]))) << i << " " << k;
  }
  for (int order = 0; order <= 2; ++order) {
    const Vec fast = sp.derivatives_at_knots(order);
    const Vec slow = sp.evaluate(s.t, order);
    EXPECT_LE((fast - slow).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + fast.cwiseAbs().maxCoeff()))
        << order;
  }
}

TEST(SmoothingSpline, ResultDoesNotDependOnTimeUnits) {
  const Noisy s = noisy_signal(400, 0.05, 5);
  const auto base = Spline(s.t).fit_constrained(s.y, 0.05);
  for (double scale : {1e-6, 1e6}) {
    const auto scaled = Spline(s.t * scale).fit_constrained(s.y, 0.05);
    EXPECT_LE(
        rel_max_error(scaled.spline.derivatives_at_knots(0), base.spline.derivatives_at_knots(0)),
        1e-9)
        << scale;
    EXPECT_LE(rel_max_error(scaled.spline.derivatives_at_knots(1) * scale,
                            base.spline.derivatives_at_knots(1)),
              1e-8)
        << scale;
  }
}

TEST(SmoothingSpline, ConvergesOnLargeInput) {
  const Noisy s = noisy_signal(200000, 0.01, 6);
  const auto fit = Spline(s.t).fit_constrained(s.y, 0.01);
  // At this n each (Qu)ᵢ is a second difference of a smooth u and F carries rounding noise of
  // about 1e-9 relative; the search stops at that floor instead of chasing it.
  constexpr double kLargeNFloor = 1e-8;
  EXPECT_NEAR(fit.F, 200000.0, kLargeNFloor * 200000.0);
  EXPECT_LE(fit.factorizations, 16);
  // The smooth signal is recovered far better than the noise level.
  const Vec truth = (2.0 * s.t.array()).sin() + 0.3 * (5.0 * s.t.array()).cos();
  EXPECT_LT((fit.spline.derivatives_at_knots(0) - truth).cwiseAbs().maxCoeff(), 0.01);
}

TEST(SmoothingSpline, SeveralSignalsShareOneGrid) {
  const Noisy s = noisy_signal(300, 0.05, 7);
  const Spline spline(s.t);
  const Vec y2 = 3.0 * s.y;
  const auto a = spline.fit_constrained(s.y, 0.05);
  // y and dy scaled by 3: the roughness term grows 9-fold, the data term is unchanged.
  const auto b = spline.fit_constrained(y2, 0.15);
  EXPECT_NEAR(b.p, 9.0 * a.p, 1e-10 * b.p);
  EXPECT_LE(rel_max_error(b.spline.derivatives_at_knots(0), 3.0 * a.spline.derivatives_at_knots(0)),
            1e-10);
}

TEST(SmoothingSpline, FloatInstantiationSmooths) {
  Eigen::VectorXf t = Eigen::VectorXf::LinSpaced(50, 0.0f, 1.0f);
  Eigen::VectorXf y = (3.0f * t.array()).sin().matrix();
  const auto fit = sid::SmoothingSpline<float>(t).fit_constrained(y, 0.01f, 0.0f);
  EXPECT_LE((fit.spline.derivatives_at_knots(0) - y).cwiseAbs().maxCoeff(), 1e-5f);
}

TEST(SmoothingSpline, RejectsBadInputWithNamedArgument) {
  Vec t = Vec::LinSpaced(5, 0.0, 1.0), y = Vec::Ones(5);
  expect_invalid([] { Spline(Vec::Zero(1)); }, "at least 2");
  Vec dup = t;
  dup[3] = dup[2];
  expect_invalid([&] { Spline{dup}; }, "strictly increasing (t[3] <= t[2])");
  Vec dec = t;
  dec[1] = -1.0;
  expect_invalid([&] { Spline{dec}; }, "strictly increasing");
  Vec nan_t = t;
  nan_t[2] = std::nan("");
  expect_invalid([&] { Spline{nan_t}; }, "t[2] is not finite");
  const Spline s(t);
  expect_invalid([&] { (void)s.fit_constrained(Vec::Ones(4), 0.1, 5.0); },
                 "y has 4 samples but t has 5");
  Vec nan_y = y;
  nan_y[4] = std::numeric_limits<double>::infinity();
  expect_invalid([&] { (void)s.fit_constrained(nan_y, 0.1, 5.0); }, "y[4] is not finite");
  expect_invalid([&] { (void)s.fit_constrained(y, 0.0, 5.0); }, "dy must be finite and > 0");
  Vec dy = Vec::Constant(5, 0.1);
  dy[1] = -0.1;
  expect_invalid([&] { (void)s.fit_constrained(y, dy, 5.0); }, "dy[1] must be finite and > 0");
  expect_invalid([&] { (void)s.fit_constrained(y, Vec::Constant(3, 0.1), 5.0); },
                 "dy has 3 entries");
  expect_invalid([&] { (void)s.fit_constrained(y, 0.1, -1.0); }, "S must be finite and >= 0");
  expect_invalid([&] { (void)s.fit_penalized(y, 0.1, -1.0); }, "p must be >= 0");
}

TEST(SmoothingSplineGcv, ScoreAndTraceMatchSciPyAtEveryLambda) {
  const Case c = load("uniform_n101.csv");
  const auto ref = sid_test::read_table("gcv_reference.csv");
  const Spline spline(c.t);
  const double n = static_cast<double>(c.t.size());
  const Vec ones = Vec::Ones(c.t.size());
  constexpr double kGcvTol = 1e-8;  // SciPy's hat matrix comes from n separate fits
  for (Eigen::Index k = 0; k < ref.data.rows(); ++k) {
    const double lam = ref.col("lam")[k], p = 1.0 / lam;
    const auto fit = spline.fit_penalized(c.y, 1.0, p);
    const double trace = spline.hat_diagonal(ones, p).sum();
    const double gcv = n * fit.F / ((n - trace) * (n - trace));
    EXPECT_NEAR(trace, ref.col("trace")[k], kGcvTol * n) << "lam=" << lam;
    EXPECT_NEAR(gcv, ref.col("gcv")[k], kGcvTol * ref.col("gcv")[k]) << "lam=" << lam;
  }
}

TEST(SmoothingSplineGcv, ChosenLambdaIsTheFineLogGridMinimum) {
  const Case c = load("uniform_n101.csv");
  const auto ref = sid_test::read_table("gcv_reference.csv");
  const Vec lam = ref.col("lam");
  for (const auto& [criterion, column] : {std::pair{sid::SmoothingCriterion::Gcv, "gcv"},
                                          std::pair{sid::SmoothingCriterion::Cv, "cv"}}) {
    const Vec score = ref.col(column);
    Eigen::Index best;
    const double best_score = score.minCoeff(&best);
    ASSERT_TRUE(best > 0 && best + 1 < lam.size()) << "the reference grid must contain the minimum";
    const auto fit = Spline(c.t).fit_cross_validated(c.y, 1.0, criterion);
    EXPECT_GE(fit.lambda, lam[best - 1]) << column;
    EXPECT_LE(fit.lambda, lam[best + 1]) << column;
    EXPECT_LE(fit.criterion, best_score * (1.0 + 1e-9)) << column;  // at least as good as the grid
    EXPECT_NEAR(fit.F, (fit.spline.derivatives_at_knots(0) - c.y).squaredNorm(), 1e-12);
  }
}

TEST(SmoothingSplineGcv, LeveragesMatchTheDenseHatMatrix) {
  const Noisy s = noisy_signal(40, 0.1, 11);
  const Vec dy = Vec::LinSpaced(40, 0.05, 0.2);
  const Spline spline(s.t);
  for (double p : {1e-2, 1.0, 1e3}) {
    const Vec leverages = spline.hat_diagonal(dy, p);
    for (Eigen::Index i = 0; i < 40; ++i) {  // column i of the hat matrix = fit of the unit vector
      const Vec unit = Vec::Unit(40, i);
      const double a_ii = spline.fit_penalized(unit, dy, p).spline.derivatives_at_knots(0)[i];
      EXPECT_NEAR(leverages[i], a_ii, 1e-10) << "p=" << p << " i=" << i;
    }
  }
}

TEST(SmoothingSplineGcv, EstimatesTheNoiseLevelWithoutBeingTold) {
  constexpr double kSigma = 0.05;
  const Noisy s = noisy_signal(20000, kSigma, 12);
  const auto fit = Spline(s.t).fit_cross_validated(s.y);
  EXPECT_NEAR(fit.sigma, kSigma, 0.1 * kSigma);
  EXPECT_GT(fit.trace, 2.0);
  EXPECT_LT(fit.trace, 200.0);
  const Vec truth = (2.0 * s.t.array()).sin() + 0.3 * (5.0 * s.t.array()).cos();
  // The fit is far closer to the truth than the data are (RMS error << sigma).
  const double rms =
      std::sqrt((fit.spline.derivatives_at_knots(0) - truth).squaredNorm() / 20000.0);
  EXPECT_LT(rms, 0.1 * kSigma);
}

template class sid::SmoothingSpline<float>;
template class sid::SmoothingSpline<double>;
