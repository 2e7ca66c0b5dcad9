// Tests of include/sid/least_squares.hpp. References are computed here independently, from
// Eigen's JacobiSVD of the (scaled) regressor, never from the QR the library uses.

#include <sid/least_squares.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Noise-free recovery with column scales 1e-6..1e6: the scaled problem has cond ~ 10, so theta
// is exact to a few hundred eps.
constexpr double kRecoveryRelTol = 1e-12;
// Deterministic quantities (covariance, condition number, per-joint sigma) against an SVD: both
// are backward stable, differences are eps * cond(scaled X)^2-ish, far below this.
constexpr double kAlgebraRelTol = 1e-10;
// Monte Carlo checks accept deviations of this many standard deviations of the estimator.
constexpr double kSigmas = 5.0;
constexpr int kRuns = 2000;

const std::vector<std::string> kNames = {"theta1", "theta2", "theta3", "theta4",
                                         "theta5", "theta6", "theta7"};

// m x p standard-normal regressor with column j multiplied by scales(j).
Eigen::MatrixXd random_regressor(Eigen::Index m, const Eigen::VectorXd& scales,
                                 std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Eigen::MatrixXd x(m, scales.size());
  for (Eigen::Index j = 0; j < x.cols(); ++j)
    for (Eigen::Index i = 0; i < m; ++i) x(i, j) = normal(rng) * scales(j);
  return x;
}

Eigen::VectorXd wild_scales() {
  Eigen::VectorXd s(7);
  s << 1e-6, 1e4, 1e-2, 1.0, 1e6, 3e-4, 50.0;
  return s;
}

// References go through the SVD of X with unit-norm columns, X = Xs D: an SVD of the raw X,
// whose singular values span 1e-6..1e6 here, is itself only accurate to eps * 1e12.
Eigen::VectorXd column_norms(const Eigen::MatrixXd& x) { return x.colwise().norm().transpose(); }

// (X^T X)^-1 = D^-1 (Xs^T Xs)^-1 D^-1 with (Xs^T Xs)^-1 = V S^-2 V^T from Xs = U S V^T.
Eigen::MatrixXd inverse_gram(const Eigen::MatrixXd& x) {
  const Eigen::VectorXd inv_d = column_norms(x).cwiseInverse();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(x * inv_d.asDiagonal(),
                                              Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd inv_s2 = svd.singularValues().array().square().inverse();
  return inv_d.asDiagonal() * (svd.matrixV() * inv_s2.asDiagonal() * svd.matrixV().transpose()) *
         inv_d.asDiagonal();
}

Eigen::VectorXd svd_solve(const Eigen::MatrixXd& x, const Eigen::VectorXd& y) {
  const Eigen::VectorXd inv_d = column_norms(x).cwiseInverse();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(x * inv_d.asDiagonal(),
                                              Eigen::ComputeThinU | Eigen::ComputeThinV);
  return inv_d.asDiagonal() * svd.solve(y);
}

double max_rel_error(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected) {
  return (actual - expected).cwiseAbs().maxCoeff() / expected.cwiseAbs().maxCoeff();
}

}  // namespace

TEST(LeastSquares, RecoversThetaFromNoiseFreeDataWithWildColumnScales) {
  std::mt19937_64 rng(11);
  const Eigen::MatrixXd x = random_regressor(400, wild_scales(), rng);
  // Parameters in inverse proportion to their columns (as physical units make them), so every
  // column contributes O(1) to y and y's rounding does not drown any parameter.
  Eigen::VectorXd theta(7);
  theta << 0.034, 0.0031, -0.0045, 0.133, 0.017, 0.62, -0.61;
  theta = theta.cwiseQuotient(wild_scales());
  const auto fit = sid::least_squares(x, x * theta, 2);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_EQ(fit.rank, 7);
  EXPECT_FALSE(fit.ill_conditioned);
  EXPECT_TRUE(fit.message.empty());
  for (Eigen::Index j = 0; j < 7; ++j)
    EXPECT_NEAR(fit.theta(j), theta(j), kRecoveryRelTol * std::abs(theta(j))) << "theta" << j + 1;
  // Residual of exact data: rounding of y = X theta, relative to |y|.
  EXPECT_LT(fit.residual.norm(), kRecoveryRelTol * (x * theta).norm());
}

TEST(LeastSquares, ReportsLinearlyDependentColumnsByName) {
  std::mt19937_64 rng(12);
  Eigen::MatrixXd x = random_regressor(100, Eigen::VectorXd::Ones(7), rng);
  x.col(4) = 2.5 * x.col(2);  // theta5's column is a multiple of theta3's
  const Eigen::VectorXd y = x * Eigen::VectorXd::LinSpaced(7, 1.0, 7.0);
  sid::LeastSquaresOptions options;
  options.column_names = kNames;
  const auto fit = sid::least_squares(x, y, 2, options);
  EXPECT_EQ(fit.status, sid::LeastSquaresStatus::RankDeficient);
  EXPECT_EQ(fit.rank, 6);
  EXPECT_EQ(fit.dependent_columns, (std::vector<Eigen::Index>{2, 4}));
  EXPECT_NE(fit.message.find("columns theta3, theta5 are linearly dependent"), std::string::npos)
      << fit.message;
  EXPECT_TRUE(std::isnan(fit.covariance(0, 0)));
  // The data are consistent, so the minimum-norm solution still fits them.
  EXPECT_LT(fit.residual.norm(), kRecoveryRelTol * y.norm());
}

TEST(LeastSquares, ReportsAllColumnsOfACombinationAndZeroColumns) {
  std::mt19937_64 rng(13);
  Eigen::MatrixXd x = random_regressor(60, Eigen::VectorXd::Ones(7), rng);
  x.col(6) = 1e3 * x.col(0) - 0.2 * x.col(3);  // scale-free: the scaling must not hide it
  sid::LeastSquaresOptions options;
  options.column_names = kNames;
  const auto combo = sid::least_squares(x, x.col(1), 1, options);
  EXPECT_EQ(combo.status, sid::LeastSquaresStatus::RankDeficient);
  EXPECT_EQ(combo.dependent_columns, (std::vector<Eigen::Index>{0, 3, 6}));
  EXPECT_NE(combo.message.find("columns theta1, theta4, theta7 are linearly dependent"),
            std::string::npos)
      << combo.message;

  x = random_regressor(60, Eigen::VectorXd::Ones(7), rng);
  x.col(1).setZero();
  const auto zero = sid::least_squares(x, x.col(0), 1);  // no names: 0-based indices
  EXPECT_EQ(zero.status, sid::LeastSquaresStatus::RankDeficient);
  EXPECT_EQ(zero.dependent_columns, (std::vector<Eigen::Index>{1}));
  EXPECT_NE(zero.message.find("column 1 is zero"), std::string::npos) << zero.message;
}

TEST(LeastSquares, CovarianceEqualsSigma2TimesInverseGram) {
  std::mt19937_64 rng(14);
  const Eigen::MatrixXd x = random_regressor(300, wild_scales(), rng);
  std::normal_distribution<double> normal;
  Eigen::VectorXd y(300);
  for (auto& v : y) v = normal(rng);
  const auto fit = sid::least_squares(x, y, 3);
  ASSERT_TRUE(fit.ok());
  const Eigen::VectorXd theta = svd_solve(x, y);
  const double sigma2 = (y - x * theta).squaredNorm() / (300 - 7);
  EXPECT_NEAR(fit.sigma2, sigma2, kAlgebraRelTol * sigma2);
  // Compare D cov D (D = column scales) so that all entries are O(1).
  const Eigen::VectorXd s = column_norms(x);
  const Eigen::MatrixXd expected = s.asDiagonal() * (sigma2 * inverse_gram(x)) * s.asDiagonal();
  const Eigen::MatrixXd actual = s.asDiagonal() * fit.covariance * s.asDiagonal();
  EXPECT_LT(max_rel_error(actual, expected), kAlgebraRelTol);
  for (Eigen::Index j = 0; j < 7; ++j) {
    EXPECT_NEAR(fit.std_dev(j), std::sqrt(fit.covariance(j, j)), kAlgebraRelTol * fit.std_dev(j));
    EXPECT_NEAR(fit.relative_std_dev(j), 100.0 * fit.std_dev(j) / std::abs(fit.theta(j)),
                kAlgebraRelTol * fit.relative_std_dev(j));
  }
}

TEST(LeastSquares, CovarianceMatchesMonteCarloSpreadOfEstimates) {
  // theta_hat ~ N(theta, Sigma) with Sigma = sigma^2 (X^T X)^-1. The sample covariance S of N
  // estimates is Wishart: Var(S_ij) = (Sigma_ii Sigma_jj + Sigma_ij^2) / (N - 1), so each entry
  // must lie within kSigmas of those standard deviations. The reported covariance uses the
  // estimate s^2 with (m - p) s^2 / sigma^2 ~ chi^2(m - p): its mean over N fits has relative
  // standard deviation sqrt(2 / (m - p) / N).
  constexpr Eigen::Index kRows = 120;
  constexpr double kSigma = 0.3;
  std::mt19937_64 rng(15);
  Eigen::VectorXd scales(3);
  scales << 1e-3, 1.0, 1e3;
  Eigen::MatrixXd x = random_regressor(kRows, scales, rng);
  x.col(1) += 0.5e3 * x.col(0);  // correlated columns: non-trivial off-diagonal covariance
  const Eigen::Vector3d theta(2.0, -1.0, 0.5e-3);
  const Eigen::MatrixXd sigma_ref = kSigma * kSigma * inverse_gram(x);

  std::normal_distribution<double> noise(0.0, kSigma);
  Eigen::MatrixXd estimates(kRuns, 3);
  Eigen::MatrixXd mean_reported = Eigen::MatrixXd::Zero(3, 3);
  for (int run = 0; run < kRuns; ++run) {
    Eigen::VectorXd y = x * theta;
    for (auto& v : y) v += noise(rng);
    const auto fit = sid::least_squares(x, y);
    ASSERT_TRUE(fit.ok());
    estimates.row(run) = fit.theta.transpose();
    mean_reported += fit.covariance / kRuns;
  }
  const Eigen::MatrixXd centered = estimates.rowwise() - estimates.colwise().mean();
  const Eigen::MatrixXd sample_cov = centered.transpose() * centered / (kRuns - 1);
  for (Eigen::Index i = 0; i < 3; ++i)
    for (Eigen::Index j = 0; j < 3; ++j) {
      const double sd = std::sqrt(
          (sigma_ref(i, i) * sigma_ref(j, j) + sigma_ref(i, j) * sigma_ref(i, j)) / (kRuns - 1));
      EXPECT_NEAR(sample_cov(i, j), sigma_ref(i, j), kSigmas * sd) << i << "," << j;
    }
  const double rel_sd = std::sqrt(2.0 / (kRows - 3) / kRuns);
  for (Eigen::Index i = 0; i < 3; ++i)
    for (Eigen::Index j = 0; j < 3; ++j)
      EXPECT_NEAR(mean_reported(i, j), sigma_ref(i, j),
                  kSigmas * rel_sd * std::abs(sigma_ref(i, j)))
          << i << "," << j;
}

TEST(LeastSquares, PerJointStatisticsUseTheirRowBlocks) {
  constexpr Eigen::Index kPerJoint = 150;
  std::mt19937_64 rng(16);
  const Eigen::MatrixXd x = random_regressor(2 * kPerJoint, wild_scales(), rng);
  std::normal_distribution<double> normal;
  // theta ~ 1 / scale keeps y = O(1): a residual is only as accurate as eps |y|.
  Eigen::VectorXd y = x * wild_scales().cwiseInverse();
  for (Eigen::Index i = 0; i < 2 * kPerJoint; ++i)
    y(i) += (i < kPerJoint ? 0.01 : 0.5) * normal(rng);
  const auto fit = sid::least_squares(x, y, 2);
  ASSERT_TRUE(fit.ok());
  const Eigen::VectorXd r = y - x * svd_solve(x, y);
  const double dof_j = kPerJoint - 7.0 * kPerJoint / (2.0 * kPerJoint);
  for (Eigen::Index j = 0; j < 2; ++j) {
    const double rss_j = r.segment(j * kPerJoint, kPerJoint).squaredNorm();
    EXPECT_NEAR(fit.sigma2_per_joint(j), rss_j / dof_j, kAlgebraRelTol * rss_j / dof_j) << j;
    EXPECT_NEAR(fit.residual_rms(j), std::sqrt(rss_j / kPerJoint),
                kAlgebraRelTol * std::sqrt(rss_j / kPerJoint));
  }
  // The pooled estimate is the dof-weighted mean of the per-joint ones.
  EXPECT_NEAR(fit.sigma2, (fit.sigma2_per_joint.sum() * dof_j) / (2 * kPerJoint - 7),
              kAlgebraRelTol * fit.sigma2);
}

TEST(LeastSquares, PerJointSigma2HasItsExactExpectation) {
  // With noise covariance D = diag(sigma_j^2 per block) the residual r = (I - H) e has
  // covariance C = (I - H) D (I - H); RSS_j = r^T P_j r (P_j selects block j) has mean tr(P_j C)
  // and variance 2 tr((P_j C)^2). The estimator's mean over N fits must lie within kSigmas
  // standard deviations (sqrt(var / N) / dof_j) of tr(P_j C) / dof_j.
  constexpr Eigen::Index kPerJoint = 40;
  constexpr Eigen::Index kRows = 2 * kPerJoint;
  const Eigen::Vector2d sigma(0.05, 0.2);
  std::mt19937_64 rng(17);
  const Eigen::MatrixXd x = random_regressor(kRows, Eigen::Vector4d(1.0, 2.0, 1e-2, 1e2), rng);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(x, Eigen::ComputeThinU);
  const Eigen::MatrixXd i_minus_h =
      Eigen::MatrixXd::Identity(kRows, kRows) - svd.matrixU() * svd.matrixU().transpose();
  Eigen::VectorXd d(kRows);
  d << Eigen::VectorXd::Constant(kPerJoint, sigma(0) * sigma(0)),
      Eigen::VectorXd::Constant(kPerJoint, sigma(1) * sigma(1));
  const Eigen::MatrixXd c = i_minus_h * d.asDiagonal() * i_minus_h;
  const double dof_j = kPerJoint - 4.0 / 2.0;

  std::normal_distribution<double> normal;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int run = 0; run < kRuns; ++run) {
    Eigen::VectorXd y = x * Eigen::Vector4d(1.0, -2.0, 3.0, 0.1);
    for (Eigen::Index i = 0; i < kRows; ++i) y(i) += sigma(i / kPerJoint) * normal(rng);
    const auto fit = sid::least_squares(x, y, 2);
    ASSERT_TRUE(fit.ok());
    mean += fit.sigma2_per_joint / kRuns;
  }
  for (Eigen::Index j = 0; j < 2; ++j) {
    const Eigen::MatrixXd block = c.block(j * kPerJoint, j * kPerJoint, kPerJoint, kPerJoint);
    const double expected = block.trace() / dof_j;
    // tr((P_j C)^2) = sum over block rows of (C_jj C_jj) entries: ||C_jj||_F^2 (C symmetric).
    const double sd = std::sqrt(2.0 * block.squaredNorm() / kRuns) / dof_j;
    EXPECT_NEAR(mean(j), expected, kSigmas * sd) << "joint " << j;
  }
}

TEST(LeastSquares, ConditionNumberMatchesJacobiSvdOfScaledRegressor) {
  std::mt19937_64 rng(18);
  Eigen::MatrixXd x = random_regressor(200, wild_scales(), rng);
  x.col(3) = x.col(6) / 50.0 + 1e-3 * x.col(3);  // nearly collinear pair: cond ~ 1e3
  const auto fit = sid::least_squares(x, x.col(2), 2);
  ASSERT_TRUE(fit.ok());
  const Eigen::MatrixXd scaled = x * column_norms(x).cwiseInverse().asDiagonal();
  const Eigen::VectorXd sv = Eigen::JacobiSVD<Eigen::MatrixXd>(scaled).singularValues();
  const double cond = sv(0) / sv(sv.size() - 1);
  EXPECT_NEAR(fit.condition_number, cond, kAlgebraRelTol * cond);
  EXPECT_GT(fit.condition_number, 10.0);
}

TEST(LeastSquares, WarnsWhenBadlyConditionedAndTheThresholdIsAnOption) {
  std::mt19937_64 rng(19);
  Eigen::MatrixXd x = random_regressor(200, Eigen::VectorXd::Ones(3), rng);
  x.col(2) = x.col(0) + 1e-9 * x.col(1).reverse();  // cond ~ 1e9, still full rank
  sid::LeastSquaresOptions options;
  options.column_names = {"a", "b", "c"};
  const auto fit = sid::least_squares(x, x.col(1), 1, options);
  EXPECT_TRUE(fit.ok());
  EXPECT_EQ(fit.rank, 3);
  EXPECT_TRUE(fit.ill_conditioned);
  EXPECT_GT(fit.condition_number, 1e8);
  EXPECT_NE(fit.message.find("condition number"), std::string::npos) << fit.message;

  options.condition_warning = 1e12;
  const auto relaxed = sid::least_squares(x, x.col(1), 1, options);
  EXPECT_TRUE(relaxed.ok());
  EXPECT_FALSE(relaxed.ill_conditioned);
  EXPECT_TRUE(relaxed.message.empty());
}

TEST(LeastSquares, WeightedFitIsTheFitOfWhitenedRows) {
  std::mt19937_64 rng(20);
  const Eigen::MatrixXd x = random_regressor(100, wild_scales(), rng);
  std::normal_distribution<double> normal;
  Eigen::VectorXd y(100), w(100);
  for (Eigen::Index i = 0; i < 100; ++i) {
    y(i) = normal(rng);
    w(i) = i < 50 ? 4.0 : 0.25;
  }
  const auto weighted = sid::weighted_least_squares(x, y, w, 2);
  ASSERT_TRUE(weighted.ok());
  const Eigen::VectorXd root = w.cwiseSqrt();
  const Eigen::MatrixXd xw = root.asDiagonal() * x;
  const Eigen::VectorXd yw = root.cwiseProduct(y);
  const Eigen::VectorXd theta = svd_solve(xw, yw);
  EXPECT_LT(max_rel_error(x * weighted.theta, x * theta), kAlgebraRelTol);
  const double sigma2 = (yw - xw * theta).squaredNorm() / (100 - 7);
  EXPECT_NEAR(weighted.sigma2, sigma2, kAlgebraRelTol * sigma2);
  const Eigen::VectorXd s = column_norms(x);
  EXPECT_LT(max_rel_error(s.asDiagonal() * weighted.covariance * s.asDiagonal(),
                          s.asDiagonal() * (sigma2 * inverse_gram(xw)) * s.asDiagonal()),
            kAlgebraRelTol);
  // residual stays in the units of y
  EXPECT_LT((weighted.residual - (y - x * weighted.theta)).cwiseAbs().maxCoeff(),
            kAlgebraRelTol * y.norm());
}

TEST(LeastSquares, WorksInFloat) {
  constexpr float kFloatTol = 1e-4f;
  Eigen::MatrixXf x(6, 2);
  x << 1, 0, 1, 1, 1, 2, 1, 3, 1, 4, 1, 5;
  const Eigen::VectorXf y = x * Eigen::Vector2f(0.5f, -2.0f);
  const auto fit = sid::least_squares(x, y, 2);
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit.theta(0), 0.5f, kFloatTol);
  EXPECT_NEAR(fit.theta(1), -2.0f, kFloatTol);
}

TEST(LeastSquares, ThrowsOnBadInput) {
  const Eigen::MatrixXd x = Eigen::MatrixXd::Random(10, 3);
  const Eigen::VectorXd y = Eigen::VectorXd::Random(10);
  EXPECT_THROW((void)sid::least_squares(Eigen::MatrixXd::Random(3, 3), Eigen::VectorXd::Random(3)),
               std::invalid_argument);
  EXPECT_THROW((void)sid::least_squares(x, Eigen::VectorXd::Random(9)), std::invalid_argument);
  EXPECT_THROW((void)sid::least_squares(x, y, 3), std::invalid_argument);
  EXPECT_THROW((void)sid::least_squares(x, y, 0), std::invalid_argument);
  sid::LeastSquaresOptions options;
  options.column_names = {"a", "b"};
  EXPECT_THROW((void)sid::least_squares(x, y, 1, options), std::invalid_argument);
  Eigen::MatrixXd x_nan = x;
  x_nan(4, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)sid::least_squares(x_nan, y), std::invalid_argument);
  Eigen::VectorXd y_inf = y;
  y_inf(0) = std::numeric_limits<double>::infinity();
  EXPECT_THROW((void)sid::least_squares(x, y_inf), std::invalid_argument);
  EXPECT_THROW((void)sid::weighted_least_squares(x, y, Eigen::VectorXd::Ones(9)),
               std::invalid_argument);
  EXPECT_THROW((void)sid::weighted_least_squares(x, y, Eigen::VectorXd::Zero(10)),
               std::invalid_argument);
  try {
    (void)sid::least_squares(x, y, 3);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("sid::least_squares: joints", 0), 0u) << e.what();
  }
}
