// Tests of include/sid/model/two_link_arm.hpp (closed-form arm) and include/sid/detail/sincos.hpp.
// References: Pinocchio cases in tests/data (see tests/data/README.md) and hand derivations.

#include <sid/model/two_link_arm.hpp>

#include <sid/detail/sincos.hpp>
#include <sid/model/two_link_chain.hpp>

#include "allocation_counter.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>

// Every function template compiles for float and double.
template sid::TwoLinkRegressor<float> sid::two_link_regressor<float>(const sid::Vector2<float>&,
                                                                     const sid::Vector2<float>&,
                                                                     const sid::Vector2<float>&,
                                                                     float) noexcept;
template sid::Vector2<float> sid::two_link_inverse_dynamics<float>(
    const sid::TwoLinkParameters<float>&, const sid::Vector2<float>&, const sid::Vector2<float>&,
    const sid::Vector2<float>&, float) noexcept;
template sid::Vector2<float> sid::two_link_forward_dynamics<float>(
    const sid::TwoLinkParameters<float>&, const sid::Vector2<float>&, const sid::Vector2<float>&,
    const sid::Vector2<float>&, float) noexcept;
template sid::ArmState<float> sid::two_link_state_derivative<float>(
    const sid::TwoLinkParameters<float>&, const sid::ArmState<float>&, const sid::Vector2<float>&,
    float) noexcept;
template sid::Model<float> sid::two_link_arm_model<float>(float);
template sid::TwoLinkRegressor<double> sid::two_link_regressor<double>(const sid::Vector2<double>&,
                                                                       const sid::Vector2<double>&,
                                                                       const sid::Vector2<double>&,
                                                                       double) noexcept;
template sid::Vector2<double> sid::two_link_forward_dynamics<double>(
    const sid::TwoLinkParameters<double>&, const sid::Vector2<double>&, const sid::Vector2<double>&,
    const sid::Vector2<double>&, double) noexcept;
template sid::Model<double> sid::two_link_arm_model<double>(double);

namespace {

constexpr double kPinocchioAbsTol = 1e-12;  // N m, and regressor entries (README of the data)
constexpr double kPinocchioRelTol = 1e-12;  // relative, accelerations up to ~2e3 rad/s^2
constexpr double kRoundoffTol = 1e-13;
constexpr double kSinCosTol = 4.5e-16;  // about 2 ulp of 1
constexpr double kFloatRelTol = 1e-4;

sid::Vector2<double> pair(const sid_test::Table& table, Eigen::Index row, const char* a,
                          const char* b) {
  return {table.data(row, table.column(a)), table.data(row, table.column(b))};
}

TEST(TwoLinkArm, RegressorMatchesPinocchio) {
  const auto table = sid_test::read_table("regressor_cases.csv");
  ASSERT_EQ(table.data.rows(), 50);
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const auto z = sid::two_link_regressor(pair(table, i, "q1", "q2"), pair(table, i, "qd1", "qd2"),
                                           pair(table, i, "qdd1", "qdd2"));
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 7; ++c) {
        const std::string name = "Z" + std::to_string(r + 1) + std::to_string(c + 1);
        EXPECT_NEAR(z(r, c), table.data(i, table.column(name)), kPinocchioAbsTol)
            << name << " case " << i;
      }
  }
}

TEST(TwoLinkArm, InverseDynamicsMatchesPinocchioRnea) {
  const auto table = sid_test::read_table("rnea_cases.csv");
  const auto theta = sid::paper_arm_parameters<double>();
  ASSERT_EQ(table.data.rows(), 50);
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const auto q = pair(table, i, "q1", "q2"), qd = pair(table, i, "qd1", "qd2"),
               qdd = pair(table, i, "qdd1", "qdd2"), tau = pair(table, i, "tau1", "tau2");
    const auto tau_id = sid::two_link_inverse_dynamics(theta, q, qd, qdd);
    EXPECT_NEAR(tau_id[0], tau[0], kPinocchioAbsTol) << "case " << i;
    EXPECT_NEAR(tau_id[1], tau[1], kPinocchioAbsTol) << "case " << i;
    const sid::Vector2<double> tau_z = sid::two_link_regressor(q, qd, qdd) * theta;
    EXPECT_NEAR(tau_z[0], tau[0], kPinocchioAbsTol) << "case " << i;
    EXPECT_NEAR(tau_z[1], tau[1], kPinocchioAbsTol) << "case " << i;
  }
}

TEST(TwoLinkArm, ForwardDynamicsMatchesPinocchioAba) {
  const auto table = sid_test::read_table("forward_dynamics_cases.csv");
  const auto theta = sid::paper_arm_parameters<double>();
  ASSERT_EQ(table.data.rows(), 50);
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const auto qdd = sid::two_link_forward_dynamics(theta, pair(table, i, "q1", "q2"),
                                                    pair(table, i, "qd1", "qd2"),
                                                    pair(table, i, "tau1", "tau2"));
    const auto expected = pair(table, i, "qdd1", "qdd2");
    EXPECT_LE((qdd - expected).norm(), kPinocchioRelTol * expected.norm()) << "case " << i;
  }
}

TEST(TwoLinkArm, GravityTorqueAtRestMatchesHandDerivation) {
  // Arm horizontal (q1 = pi/2) and straight: tau1 = g (theta4 + theta5), tau2 = g theta5.
  const auto theta = sid::paper_arm_parameters<double>();
  const double g = sid::kPaperGravity;
  const auto tau =
      sid::two_link_inverse_dynamics(theta, sid::Vector2<double>(M_PI / 2, 0.0),
                                     sid::Vector2<double>::Zero(), sid::Vector2<double>::Zero());
  EXPECT_NEAR(tau[0], g * (theta[3] + theta[4]), kRoundoffTol);
  EXPECT_NEAR(tau[1], g * theta[4], kRoundoffTol);
  // Hanging straight down: no torque at all.
  const auto tau0 =
      sid::two_link_inverse_dynamics(theta, sid::Vector2<double>::Zero(),
                                     sid::Vector2<double>::Zero(), sid::Vector2<double>::Zero());
  EXPECT_EQ(tau0.norm(), 0.0);
}

// The closed-form test against the smallest eigenvalue of D on a fine q2 grid, for random
// parameters around the paper's (about half of them not physical).
TEST(TwoLinkArm, MassMatrixPositiveDefinitenessMatchesItsEigenvaluesOnAGrid) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> scale(-0.5, 2.0);
  int physical = 0;
  for (int trial = 0; trial < 200; ++trial) {
    sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
    for (int k = 0; k < 3; ++k) theta[k] *= scale(rng);
    double min_eigenvalue = std::numeric_limits<double>::infinity();
    for (int i = 0; i <= 720; ++i) {
      const sid::Vector2<double> q(0.3, -M_PI + i * M_PI / 360.0);
      const Eigen::Matrix2d d = sid::two_link_mass_matrix(theta, q);
      min_eigenvalue =
          std::min(min_eigenvalue,
                   Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(d).eigenvalues().minCoeff());
    }
    const bool closed_form = sid::two_link_mass_matrix_positive_definite(theta);
    physical += closed_form ? 1 : 0;
    EXPECT_EQ(closed_form, min_eigenvalue > 0.0) << theta.transpose();
  }
  EXPECT_GT(physical, 20);
  EXPECT_LT(physical, 180);
}

TEST(TwoLinkArm, PhysicalParametersGiveCorrectedTheta) {
  const auto physical = sid::paper_arm_physical<double>();
  const auto theta = sid::two_link_parameters(physical);
  EXPECT_LE((theta - sid::paper_arm_parameters<double>()).norm(), kRoundoffTol * theta.norm());
  // Physically theta3 = l1 theta5 (the corrected paper), a check the 7-parameter model leaves free.
  EXPECT_NEAR(theta[2], physical.l1 * theta[4], kRoundoffTol);
}

TEST(TwoLinkArm, MassMatrixIsSymmetricPositiveDefinite) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-10.0, 10.0);
  const auto theta = sid::paper_arm_parameters<double>();
  for (int k = 0; k < 200; ++k) {
    const sid::Vector2<double> q(angle(rng), angle(rng));
    const auto d = sid::two_link_mass_matrix(theta, q);
    EXPECT_EQ(d(0, 1), d(1, 0));
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(d);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0) << "q = " << q.transpose();
  }
}

TEST(TwoLinkArm, MassMatrixTimesAccelerationIsInertialTorque) {
  // D qdd = ID(q, qd, qdd) - ID(q, qd, 0) for the closed forms of D and ID.
  const auto theta = sid::paper_arm_parameters<double>();
  const sid::Vector2<double> q(0.3, -1.1), qd(0.7, 2.0), qdd(-4.0, 9.0);
  const sid::Vector2<double> inertial =
      sid::two_link_inverse_dynamics(theta, q, qd, qdd) - sid::two_link_bias_torque(theta, q, qd);
  EXPECT_LE((sid::two_link_mass_matrix(theta, q) * qdd - inertial).norm(), kRoundoffTol);
}

TEST(TwoLinkArm, StateDerivativeStacksVelocityAndAcceleration) {
  const auto theta = sid::paper_arm_parameters<double>();
  const sid::ArmState<double> x(0.1, 0.2, -0.3, 0.4);
  const sid::Vector2<double> tau(1.0, -0.5);
  const auto xdot = sid::two_link_state_derivative(theta, x, tau);
  EXPECT_EQ(xdot.head<2>(), x.tail<2>());
  EXPECT_EQ(xdot.tail<2>(), sid::two_link_forward_dynamics(theta, sid::Vector2<double>(x.head<2>()),
                                                           sid::Vector2<double>(x.tail<2>()), tau));
}

TEST(TwoLinkArm, FloatAgreesWithDouble) {
  const auto theta = sid::paper_arm_parameters<double>();
  const sid::Vector2<double> q(0.3, -1.1), qd(0.7, 2.0), tau(1.0, 0.5);
  const auto qdd = sid::two_link_forward_dynamics(theta, q, qd, tau);
  const auto qdd_f = sid::two_link_forward_dynamics<float>(
      theta.cast<float>(), q.cast<float>(), qd.cast<float>(), tau.cast<float>(), 9.81f);
  EXPECT_LE((qdd_f.cast<double>() - qdd).norm(), kFloatRelTol * qdd.norm());
}

TEST(TwoLinkArm, FastPathsAreNoexceptAndDoNotAllocate) {
  const auto theta = sid::paper_arm_parameters<double>();
  const sid::Vector2<double> q(0.3, -1.1), qd(0.7, 2.0), qdd(-4.0, 9.0);
  static_assert(noexcept(sid::two_link_regressor(q, qd, qdd)));
  static_assert(noexcept(sid::two_link_inverse_dynamics(theta, q, qd, qdd)));
  static_assert(noexcept(sid::two_link_forward_dynamics(theta, q, qd, qdd)));
  static_assert(noexcept(sid::two_link_mass_matrix(theta, q)));
  const int before = sid_test::g_allocations;
  double sink = 0.0;
  for (int k = 0; k < 10; ++k) {
    sink += sid::two_link_regressor(q, qd, qdd).sum();
    sink += sid::two_link_inverse_dynamics(theta, q, qd, qdd).sum();
    sink += sid::two_link_forward_dynamics(theta, q, qd, qdd).sum();
    sink += sid::two_link_state_derivative(theta, sid::ArmState<double>::Zero(), qdd).sum();
  }
  EXPECT_EQ(sid_test::g_allocations, before);
  EXPECT_TRUE(std::isfinite(sink));
  // The counter works: an allocation is seen.
  auto* probe = new Eigen::VectorXd(3);
  EXPECT_GT(sid_test::g_allocations, before);
  delete probe;
}

TEST(SinCos, MatchesStdWithinTwoUlp) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> wide(-1e3, 1e3), narrow(-4.0, 4.0);
  constexpr int kCount = 4096;
  Eigen::ArrayXd x(kCount), s(kCount), c(kCount);
  for (int i = 0; i < kCount; ++i) x[i] = (i % 2) ? wide(rng) : narrow(rng);
  x[0] = 0.0;
  x[1] = -0.0;
  x[2] = M_PI / 4;
  x[3] = -M_PI / 2;
  x[4] = 3 * M_PI;
  x[5] = 9.9e5;
  sid::detail::sincos_batch(x.data(), s.data(), c.data(), kCount);
  for (int i = 0; i < kCount; ++i) {
    const auto one = sid::detail::sincos(x[i]);
    EXPECT_NEAR(one.sin, std::sin(x[i]), kSinCosTol) << "x = " << x[i];
    EXPECT_NEAR(one.cos, std::cos(x[i]), kSinCosTol) << "x = " << x[i];
    EXPECT_EQ(s[i], one.sin) << "x = " << x[i];
    EXPECT_EQ(c[i], one.cos) << "x = " << x[i];
  }
}

TEST(SinCos, FallsBackToStdOutsideFastRange) {
  for (const double x : {3e7, -1e12}) {
    EXPECT_EQ(sid::detail::sincos(x).sin, std::sin(x));
    EXPECT_EQ(sid::detail::sincos(x).cos, std::cos(x));
  }
  EXPECT_TRUE(std::isnan(sid::detail::sincos(std::numeric_limits<double>::quiet_NaN()).sin));
  EXPECT_TRUE(std::isnan(sid::detail::sincos(std::numeric_limits<double>::infinity()).cos));
  EXPECT_EQ(sid::detail::sincos(0.5f).sin, std::sin(0.5f));
}

}  // namespace

// The paper's model is the two-joint chain's, read through a one-way map of its link parameters.
TEST(TwoLinkChain, PaperRegressorTimesMappedParametersIsTheChainsTorque) {
  const double l1 = sid::paper_arm_physical().l1;
  const sid::SerialChain<double> chain = sid::two_link_chain(l1);
  std::mt19937 g(29);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::MatrixXd y(2, sid::chain_parameter_count(2));
  for (int trial = 0; trial < 20; ++trial) {
    // Any link parameters with no first moment across the link and no Coulomb friction; the
    // parameters off the plane (Ixx, Ixy, ...) move nothing here and are drawn too.
    Eigen::VectorXd phi =
        Eigen::VectorXd::NullaryExpr(sid::chain_parameter_count(2), [&] { return u(g); });
    phi[2] = phi[12] = 0.0;  // my_1, my_2
    phi.tail(2).setZero();   // Fc_1, Fc_2
    const sid::TwoLinkParameters<double> theta =
        sid::two_link_parameters_from_links<double>(phi, l1);
    const sid::Vector2<double> q(3 * u(g), 3 * u(g)), qd(2 * u(g), 2 * u(g)),
        qdd(5 * u(g), 5 * u(g));
    sid::chain_regressor(chain, Eigen::VectorXd(q), Eigen::VectorXd(qd), Eigen::VectorXd(qdd), y);
    const sid::Vector2<double> paper =
        sid::two_link_regressor(q, qd, qdd, sid::kPaperGravity) * theta;
    EXPECT_LT((paper - y * phi).cwiseAbs().maxCoeff(), 1e-13) << "trial " << trial;
  }
  // The paper's physical arm, as links, gives the paper's θ.
  const sid::TwoLinkPhysical<double> p = sid::paper_arm_physical();
  Eigen::VectorXd phi = Eigen::VectorXd::Zero(sid::chain_parameter_count(2));
  phi[0] = p.m1;
  phi[1] = p.m1 * p.lc1;
  phi[9] = p.I1 + p.m1 * p.lc1 * p.lc1;
  phi[10] = p.m2;
  phi[11] = p.m2 * p.lc2;
  phi[19] = p.I2 + p.m2 * p.lc2 * p.lc2;
  phi[20] = p.mu1;
  phi[21] = p.mu2;
  EXPECT_LT((sid::two_link_parameters_from_links<double>(phi, p.l1) - sid::two_link_parameters(p))
                .cwiseAbs()
                .maxCoeff(),
            1e-15);
  // my_2 moves the chain but no column of the paper's model: the map is one way.
  phi.setZero();
  phi[12] = 1.0;
  const sid::Vector2<double> q(0.3, 0.7), zero(0.0, 0.0);
  sid::chain_regressor(chain, Eigen::VectorXd(q), Eigen::VectorXd(zero), Eigen::VectorXd(zero), y);
  EXPECT_GT((y * phi).cwiseAbs().maxCoeff(), 1.0);
  EXPECT_EQ(sid::two_link_parameters_from_links<double>(phi, l1),
            sid::TwoLinkParameters<double>::Zero());
}
