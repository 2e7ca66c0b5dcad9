// Tests of the statistics behind sid::diagnose: chi-square tails, the Newey–West long-run
// variance and the noise-floor estimators, against closed forms and known values.

#include <sid/diagnosis/hac.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>
#include <sid/diagnosis/kinematic_floor.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/diagnosis/noise_floor.hpp>

#include "test_support.hpp"

namespace {

TEST(ChiSquare, TailMatchesClosedForms) {
  constexpr double kTol = 1e-12;
  for (double x : {0.0, 0.1, 1.0, 3.84, 6.63, 10.0, 30.0, 80.0}) {
    // df = 2: exp(−x/2); df = 1: erfc(sqrt(x/2)); df = 4: exp(−x/2)(1 + x/2).
    EXPECT_NEAR(sid::chi_square_tail(x, 2.0), std::exp(-x / 2), kTol) << x;
    EXPECT_NEAR(sid::chi_square_tail(x, 1.0), std::erfc(std::sqrt(x / 2)), kTol) << x;
    EXPECT_NEAR(sid::chi_square_tail(x, 4.0), std::exp(-x / 2) * (1 + x / 2), kTol) << x;
  }
}

TEST(ChiSquare, TailMatchesTabulatedCriticalValues) {
  // Critical values of standard tables (e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4).
  constexpr double kTol = 2e-4;
  EXPECT_NEAR(sid::chi_square_tail(3.841, 1.0), 0.05, kTol);
  EXPECT_NEAR(sid::chi_square_tail(6.635, 1.0), 0.01, kTol);
  EXPECT_NEAR(sid::chi_square_tail(9.210, 2.0), 0.01, kTol);
  EXPECT_NEAR(sid::chi_square_tail(11.345, 3.0), 0.01, kTol);
  EXPECT_NEAR(sid::chi_square_tail(18.307, 10.0), 0.05, kTol);
  EXPECT_NEAR(sid::chi_square_tail(124.342, 100.0), 0.05, kTol);
}

TEST(ChiSquare, CriticalValueInvertsTheTail) {
  for (double df : {1.0, 2.0, 3.0, 7.0, 200.0})
    for (double alpha : {0.5, 0.05, 1e-3, 1e-8}) {
      const double x = sid::chi_square_critical(alpha, df);
      EXPECT_NEAR(sid::chi_square_tail(x, df), alpha, 1e-9 * alpha + 1e-14) << df << " " << alpha;
    }
  EXPECT_NEAR(sid::chi_square_critical(0.05, 1.0), 3.841459, 1e-5);
}

TEST(ChiSquare, ThrowsOnBadArguments) {
  sid_test::expect_invalid_argument([] { (void)sid::chi_square_tail(-1.0, 1.0); },
                                    "sid::chi_square_tail", "x");
  sid_test::expect_invalid_argument([] { (void)sid::chi_square_tail(1.0, 0.0); },
                                    "sid::chi_square_tail", "df");
  sid_test::expect_invalid_argument([] { (void)sid::chi_square_critical(1.0, 1.0); },
                                    "sid::chi_square_critical", "alpha");
}

/// AR(1) x_t = φ x_{t−1} + u_t, u ~ N(0, s²), started from its stationary distribution.
Eigen::VectorXd ar1(Eigen::Index n, double phi, double s, std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, s);
  Eigen::VectorXd x(n);
  x[0] = normal(rng) / std::sqrt(1 - phi * phi);
  for (Eigen::Index t = 1; t < n; ++t) x[t] = phi * x[t - 1] + normal(rng);
  return x;
}

TEST(NeweyWest, VarianceOfTheMeanOfAnAr1SeriesMatchesItsLongRunVariance) {
  // The long-run variance of an AR(1) is s² / (1 − φ)², so var(mean) ≈ s² / (n (1 − φ)²). Averaged
  // over replications, the HAC estimate must find it (the OLS variance s²/(1−φ²)/n is 1/9 of it
  // for φ = 0.8). (Bartlett's kernel alone at Andrews' bandwidth comes out 11 % low for φ = 0.8:
  // hence the prewhitening.)
  constexpr Eigen::Index kN = 4000;
  constexpr int kRuns = 40;
  std::mt19937_64 rng(7);
  for (double phi : {0.0, 0.5, 0.8}) {
    const double s = 0.3;
    const double truth = s * s / ((1 - phi) * (1 - phi)) / kN;
    double mean_estimate = 0;
    for (int run = 0; run < kRuns; ++run) {
      const Eigen::VectorXd x = ar1(kN, phi, s, rng);
      // The mean as an OLS fit on a constant: scores x_t − x̄, bread 1/n.
      const Eigen::MatrixXd scores = (x.array() - x.mean()).matrix();
      mean_estimate += sid::hac_long_run_sum(scores)(0, 0) / (double(kN) * kN) / kRuns;
    }
    EXPECT_NEAR(mean_estimate / truth, 1.0, 0.1) << "phi " << phi;
  }
}

TEST(NeweyWest, SumAtLagZeroIsTheGramMatrixAndWeightsFollowBartlett) {
  Eigen::MatrixXd g(4, 2);
  g << 1, 2, -1, 0.5, 3, -2, 0.25, 1;
  EXPECT_TRUE(sid::newey_west_sum(g, 0).isApprox(g.transpose() * g));
  // Lag 1: weight 1/2 on Γ1 + Γ1ᵀ, Γ1 = Σ_t g_t g_{t−1}ᵀ.
  Eigen::MatrixXd gamma1 = Eigen::MatrixXd::Zero(2, 2);
  for (int t = 1; t < 4; ++t) gamma1 += g.row(t).transpose() * g.row(t - 1);
  EXPECT_TRUE(
      sid::newey_west_sum(g, 1).isApprox(g.transpose() * g + 0.5 * (gamma1 + gamma1.transpose())));
}

TEST(NeweyWest, QuadraticFormsAreThoseOfTheLongRunSum) {
  constexpr double kTol = 1e-10;
  std::mt19937_64 rng(3);
  Eigen::MatrixXd directions(3, 2);
  directions << 1.0, 0.2, -0.5, 1.0, 0.3, -2.0;
  // Prewhitened (600 rows) and, below 3 k + 8 rows, plain Newey-West; correlated columns.
  for (const Eigen::Index n : {600, 12}) {
    Eigen::MatrixXd scores(n, 3);
    scores.col(0) = ar1(n, 0.8, 1.0, rng);
    scores.col(1) = ar1(n, 0.3, 2.0, rng) + 0.5 * scores.col(0);
    scores.col(2) = ar1(n, -0.4, 0.5, rng);
    const Eigen::MatrixXd sum = sid::hac_long_run_sum(scores);
    const Eigen::VectorXd forms = sid::hac_long_run_quadratic(scores, directions);
    ASSERT_EQ(forms.size(), 2);
    for (Eigen::Index i = 0; i < 2; ++i) {
      const double expected = directions.col(i).dot(sum * directions.col(i));
      EXPECT_NEAR(forms[i], expected, kTol * std::abs(expected)) << "n " << n << ", form " << i;
    }
  }
  EXPECT_THROW((void)sid::hac_long_run_quadratic(Eigen::MatrixXd::Ones(20, 2), directions),
               std::invalid_argument);
}

// The sandwich of stacked runs: a sample's rows add into one score, runs add their long-run
// sums, and a regression with one row per sample and white errors gives about the ordinary
// covariance σ² (XᵀX)⁻¹.
TEST(HacSandwich, AddsASamplesRowsAndTheRunsLongRunSums) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Index n = 4000;
  Eigen::MatrixXd x(2 * n, 3);
  Eigen::VectorXd e(2 * n);
  for (Eigen::Index i = 0; i < 2 * n; ++i) {
    x.row(i) << 1.0, normal(rng), normal(rng);
    e[i] = 0.5 * normal(rng);
  }
  std::vector<Eigen::Index> at(static_cast<std::size_t>(n)), paired(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    at[static_cast<std::size_t>(i)] = i;
    paired[static_cast<std::size_t>(i)] = i / 2;  // two rows per sample, as two joints
  }
  const Eigen::MatrixXd bread = (x.transpose() * x).inverse();
  const Eigen::MatrixXd two_runs = sid::hac_sandwich(
      {{x.topRows(n), e.head(n), at, n}, {x.bottomRows(n), e.tail(n), at, n}}, bread);
  Eigen::MatrixXd scores_1 = x.topRows(n), scores_2 = x.bottomRows(n);
  scores_1.array().colwise() *= e.head(n).array();
  scores_2.array().colwise() *= e.tail(n).array();
  const Eigen::MatrixXd by_hand =
      bread * (sid::hac_long_run_sum(scores_1) + sid::hac_long_run_sum(scores_2)) * bread;
  EXPECT_LT((two_runs - by_hand).norm(), 1e-12 * by_hand.norm());
  const Eigen::MatrixXd ordinary = 0.25 * bread;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(two_runs(c, c) / ordinary(c, c), 1.0, 0.15) << c;

  Eigen::MatrixXd summed = Eigen::MatrixXd::Zero(n / 2, 3);
  for (Eigen::Index i = 0; i < n; ++i) summed.row(i / 2) += e[i] * x.row(i);
  const Eigen::MatrixXd one_run =
      sid::hac_sandwich({{x.topRows(n), e.head(n), paired, n / 2}}, bread);
  EXPECT_LT((one_run - bread * sid::hac_long_run_sum(summed) * bread).norm(),
            1e-12 * one_run.norm());

  EXPECT_THROW((void)sid::hac_sandwich({{x.topRows(n), e.head(n - 1), at, n}}, bread),
               std::invalid_argument);
  EXPECT_THROW((void)sid::hac_sandwich({{x.topRows(n), e.head(n), at, n - 1}}, bread),
               std::invalid_argument);
}

TEST(NeweyWest, WaldStatisticIsTheQuadraticForm) {
  Eigen::Vector2d gamma(1.0, -2.0);
  Eigen::Matrix2d v;
  v << 2.0, 0.5, 0.5, 1.0;
  EXPECT_NEAR(sid::wald_statistic(gamma, v), gamma.dot(v.inverse() * gamma), 1e-12);
}

TEST(NoiseFloor, FindsWhiteNoiseOnASmoothSignal) {
  // A test τ: a few N m of sinusoids at 400 Hz, σ = 0.1 N m.
  constexpr Eigen::Index kN = 4001;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(kN, 0.0, 10.0);
  std::mt19937_64 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (double sigma : {0.1, 0.01}) {
    Eigen::VectorXd y(kN);
    for (Eigen::Index i = 0; i < kN; ++i)
      y[i] = 5 * std::sin(1.3 * t[i]) + 2 * std::sin(3.1 * t[i]) + sigma * normal(rng);
    EXPECT_NEAR(sid::noise_sigma_gcv(t, y) / sigma, 1.0, 0.1) << sigma;
    EXPECT_NEAR(sid::noise_sigma_second_differences(y) / sigma, 1.0, 0.1) << sigma;
  }
}

TEST(NoiseFloor, ThrowsOnTooFewSamples) {
  sid_test::expect_invalid_argument(
      [] { (void)sid::noise_sigma_second_differences(Eigen::VectorXd::Zero(2)); },
      "sid::noise_sigma_second_differences", "samples");
}

// The kinematic floor of a model whose inverse dynamics is tau1 = qdd1 (theta1 = 1) is the RMS
// of the smoothed noise's second derivative, and of tau1 = qd1 (theta6 = 1) of its first: both
// known exactly from the smoother's derivative rows, sigma^2 sum_k (d^m A_ik / dt^m)^2, which
// smoothing each unit vector gives.
TEST(KinematicFloor, MatchesTheSmoothersDerivativeVarianceForAPureInertiaAndADamper) {
  const Eigen::Index n = 161;
  sid::Kinematics<double> k;
  k.t = Eigen::VectorXd::LinSpaced(n, 0.0, 0.4);  // 2.5 ms steps
  k.q = k.qd = k.qdd = k.tau = sid::MatrixX2<double>::Zero(n, 2);
  const double sigma = 1e-3, p = 6e4;  // the order of the GCV choice at sigma_q^2 = 1e-6
  const sid::SmoothingSpline<double> spline(k.t);
  Eigen::VectorXd var1 = Eigen::VectorXd::Zero(n), var2 = Eigen::VectorXd::Zero(n);
  for (Eigen::Index c = 0; c < n; ++c) {
    const auto fit = spline.fit_penalized(Eigen::VectorXd::Unit(n, c), 1.0, p);
    var1 += sigma * sigma * fit.spline.derivatives_at_knots(1).cwiseAbs2();
    var2 += sigma * sigma * fit.spline.derivatives_at_knots(2).cwiseAbs2();
  }
  const Eigen::Index first = 20, count = n - 40;  // judged rows away from the ends
  const double exact_qdd = std::sqrt(var2.segment(first, count).mean());
  const double exact_qd = std::sqrt(var1.segment(first, count).mean());
  const sid::Model<double> model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd weight = Eigen::VectorXd::Ones(2 * count);
  constexpr int kRuns = 400;  // Monte Carlo error of the RMS about 1/sqrt(2 x 400 x ~10) < 2 %
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(7);
  theta[0] = 1.0;
  const sid::Vector2<double> inertia = sid::kinematic_noise_rms(
      model, theta, k, {sigma, sigma}, {p, p}, first, count, weight, kRuns, 7u);
  EXPECT_NEAR(inertia[0], exact_qdd, 0.05 * exact_qdd);
  EXPECT_EQ(inertia[1], 0.0);
  theta.setZero();
  theta[5] = 1.0;
  const sid::Vector2<double> damper = sid::kinematic_noise_rms(
      model, theta, k, {sigma, sigma}, {p, p}, first, count, weight, kRuns, 7u);
  EXPECT_NEAR(damper[0], exact_qd, 0.05 * exact_qd);
  // Left-out rows do not count: with joint 1's rows all out its floor is 0.
  Eigen::VectorXd none = weight;
  none.head(count).setZero();
  EXPECT_EQ(sid::kinematic_noise_rms(model, theta, k, {sigma, sigma}, {p, p}, first, count, none, 2,
                                     7u)[0],
            0.0);
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::kinematic_noise_rms(model, theta, k, {sigma, sigma}, {p, p}, first, n, weight, 2,
                                       7u);
      },
      "sid::kinematic_noise_rms", "rows");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::kinematic_noise_rms(model, theta, k, {0.0, sigma}, {p, p}, first, count, weight,
                                       2, 7u);
      },
      "sid::kinematic_noise_rms", "sigma_q");
}

}  // namespace
