#include <sid/banded.hpp>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include <random>

namespace {

constexpr double kSolveTol = 1e-12;

// A random SPD matrix with `bw` sub-diagonals: diagonally dominant by construction.
Eigen::MatrixXd random_banded_spd(Eigen::Index n, int bw, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index k = 1; k <= bw && i + k < n; ++k) a(i + k, i) = a(i, i + k) = u(rng);
  for (Eigen::Index i = 0; i < n; ++i) a(i, i) = 2.0 * bw + 1.0 + u(rng);
  return a;
}

template <int Bw>
void check_against_dense(Eigen::Index n) {
  std::mt19937_64 rng(42 + n);
  const Eigen::MatrixXd a = random_banded_spd(n, Bw, rng);
  sid::BandedLDLT<double, Bw> ldlt(n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (int k = 0; k <= Bw && j + k < n; ++k) ldlt.band()(k, j) = a(j + k, j);
  ASSERT_TRUE(ldlt.factorize());
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(n, -1.0, 2.0);
  const Eigen::VectorXd x = ldlt.solve(b);
  const Eigen::VectorXd x_dense = a.ldlt().solve(b);
  EXPECT_LE((x - x_dense).norm(), kSolveTol * x_dense.norm()) << "n=" << n << " bw=" << Bw;
  EXPECT_LE((a * x - b).norm(), kSolveTol * b.norm());
}

}  // namespace

TEST(BandedLDLT, SolvesLikeDenseLDLTForEveryBandwidth) {
  for (Eigen::Index n : {1, 2, 3, 5, 17, 100}) {
    check_against_dense<1>(n);
    check_against_dense<2>(n);
    check_against_dense<3>(n);
  }
}

TEST(BandedLDLT, FactorReproducesMatrix) {
  std::mt19937_64 rng(7);
  const Eigen::Index n = 12;
  const Eigen::MatrixXd a = random_banded_spd(n, 2, rng);
  sid::BandedLDLT<double, 2> ldlt(n);
  for (Eigen::Index j = 0; j < n; ++j)
    for (int k = 0; k <= 2 && j + k < n; ++k) ldlt.band()(k, j) = a(j + k, j);
  ASSERT_TRUE(ldlt.factorize());
  Eigen::MatrixXd l = Eigen::MatrixXd::Identity(n, n);
  Eigen::VectorXd d(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    d[j] = ldlt.band()(0, j);
    for (int k = 1; k <= 2 && j + k < n; ++k) l(j + k, j) = ldlt.band()(k, j);
  }
  EXPECT_LE((l * d.asDiagonal() * l.transpose() - a).norm(), kSolveTol * a.norm());
}

TEST(BandedLDLT, ReportsIndefiniteMatrix) {
  sid::BandedLDLT<double, 1> ldlt(3);
  ldlt.band() << 1.0, 1.0, 1.0,  // diagonal
      2.0, 0.0, 0.0;             // sub-diagonal: det of the leading 2x2 = 1 - 4 < 0
  EXPECT_FALSE(ldlt.factorize());
  EXPECT_THROW(ldlt.solve(Eigen::VectorXd::Ones(3)), std::logic_error);
}

TEST(BandedLDLT, RejectsWrongRightHandSideSize) {
  sid::BandedLDLT<double, 2> ldlt(4);
  ldlt.band().row(0).setConstant(4.0);
  ASSERT_TRUE(ldlt.factorize());
  try {
    (void)ldlt.solve(Eigen::VectorXd::Ones(3));
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("3 rows"), std::string::npos) << e.what();
  }
}

template class sid::BandedLDLT<float, 2>;
template class sid::BandedLDLT<double, 3>;
