// Tests of include/sid/model/dynamics.hpp: mass matrix, bias torque, forward dynamics and the
// regressor derived from an inverse-dynamics function, against the closed-form arm and Pinocchio.

#include <sid/model/dynamics.hpp>
#include <sid/model/model.hpp>
#include <sid/model/two_link_arm.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>

#include <random>

namespace {

constexpr double kPinocchioRelTol = 1e-12;  // relative, accelerations up to ~2e3 rad/s^2
constexpr double kRoundoffTol = 1e-13;
constexpr double kRelRoundoffTol = 1e-12;

using V2 = sid::Vector2<double>;

struct RandomState {
  V2 q, qd, qdd;
};

RandomState random_state(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), rate(-3.0, 3.0), acc(-10.0, 10.0);
  return {V2(angle(rng), angle(rng)), V2(rate(rng), rate(rng)), V2(acc(rng), acc(rng))};
}

/// The closed-form inverse dynamics at fixed theta, as dynamics.hpp takes it.
auto closed_form_id(const sid::TwoLinkParameters<double>& theta) {
  return [theta](const V2& q, const V2& qd, const V2& qdd) {
    return sid::two_link_inverse_dynamics(theta, q, qd, qdd);
  };
}

TEST(Dynamics, MassMatrixFromInverseDynamicsEqualsClosedForm) {
  std::mt19937_64 rng(1);
  const auto theta = sid::paper_arm_parameters<double>();
  const auto model = sid::two_link_arm_model<double>();
  for (int k = 0; k < 100; ++k) {
    const auto s = random_state(rng);
    const auto d = sid::two_link_mass_matrix(theta, s.q);
    EXPECT_LE((sid::mass_matrix_from_inverse_dynamics(closed_form_id(theta), s.q) - d).norm(),
              kRoundoffTol);
    const sid::Matrix2<double> d_model = model.mass_matrix(theta, s.q);
    EXPECT_LE((d_model - d).norm(), kRoundoffTol);
    EXPECT_LE(std::abs(d_model(0, 1) - d_model(1, 0)), kRoundoffTol);
    EXPECT_EQ(Eigen::LLT<Eigen::Matrix2d>(d_model).info(), Eigen::Success) << s.q.transpose();
  }
}

TEST(Dynamics, BiasTorqueIsInverseDynamicsAtZeroAcceleration) {
  std::mt19937_64 rng(2);
  const auto theta = sid::paper_arm_parameters<double>();
  const auto model = sid::two_link_arm_model<double>();
  for (int k = 0; k < 100; ++k) {
    const auto s = random_state(rng);
    const V2 h = sid::two_link_bias_torque(theta, s.q, s.qd);
    EXPECT_LE((model.bias_torque(theta, s.q, s.qd) - h).norm(), kRoundoffTol);
    EXPECT_LE((sid::bias_torque_from_inverse_dynamics(closed_form_id(theta), s.q, s.qd) - h).norm(),
              kRoundoffTol);
  }
}

TEST(Dynamics, GenericForwardDynamicsEqualsClosedForm) {
  std::mt19937_64 rng(3);
  const auto theta = sid::paper_arm_parameters<double>();
  const auto model = sid::two_link_arm_model<double>();
  for (int k = 0; k < 100; ++k) {
    const auto s = random_state(rng);
    const V2 tau = s.qdd / 5.0;  // [-2, 2] N m
    const V2 qdd = sid::two_link_forward_dynamics(theta, s.q, s.qd, tau);
    EXPECT_LE((model.forward_dynamics(theta, s.q, s.qd, tau) - qdd).norm(),
              kRelRoundoffTol * qdd.norm());
    EXPECT_LE(
        (sid::forward_dynamics_from_inverse_dynamics(closed_form_id(theta), s.q, s.qd, tau) - qdd)
            .norm(),
        kRelRoundoffTol * qdd.norm());
  }
}

TEST(Dynamics, GenericForwardDynamicsMatchesPinocchioAba) {
  const auto table = sid_test::read_table("forward_dynamics_cases.csv");
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const auto col = [&](const char* name) { return table.data(i, table.column(name)); };
    const V2 qdd = model.forward_dynamics(theta, V2(col("q1"), col("q2")),
                                          V2(col("qd1"), col("qd2")), V2(col("tau1"), col("tau2")));
    const V2 expected(col("qdd1"), col("qdd2"));
    EXPECT_LE((qdd - expected).norm(), kPinocchioRelTol * expected.norm()) << "case " << i;
  }
}

TEST(Dynamics, ForwardDynamicsInvertsInverseDynamics) {
  std::mt19937_64 rng(4);
  const auto theta = sid::paper_arm_parameters<double>();
  for (int k = 0; k < 100; ++k) {
    const auto s = random_state(rng);
    const V2 tau = sid::two_link_inverse_dynamics(theta, s.q, s.qd, s.qdd);
    EXPECT_LE((sid::two_link_forward_dynamics(theta, s.q, s.qd, tau) - s.qdd).norm(),
              kRelRoundoffTol * s.qdd.norm());
  }
}

TEST(Dynamics, RegressorByUnitParameterVectorsEqualsClosedForm) {
  std::mt19937_64 rng(5);
  const auto id_of_theta = [](const sid::ModelParameters<double>& t, const V2& q, const V2& qd,
                              const V2& qdd) {
    return sid::two_link_inverse_dynamics(sid::TwoLinkParameters<double>(t), q, qd, qdd);
  };
  for (int k = 0; k < 100; ++k) {
    const auto s = random_state(rng);
    Eigen::Matrix<double, 2, 7> z;
    sid::regressor_from_inverse_dynamics(id_of_theta, 7, s.q, s.qd, s.qdd, z);
    EXPECT_LE((z - sid::two_link_regressor(s.q, s.qd, s.qdd)).cwiseAbs().maxCoeff(), kRoundoffTol)
        << "q = " << s.q.transpose();
  }
}

TEST(Dynamics, Solve2x2MatchesLu) {
  sid::Matrix2<double> d;
  d << 0.05, 0.007, 0.007, 0.003;
  const V2 rhs(1.0, -2.0);
  const V2 x = sid::solve_2x2(d, rhs);
  EXPECT_LE((x - d.partialPivLu().solve(rhs)).norm(), kRelRoundoffTol * x.norm());
}

TEST(Dynamics, StateDerivativeOfModelEqualsClosedForm) {
  const auto model = sid::two_link_arm_model<double>();
  const auto theta = sid::paper_arm_parameters<double>();
  const sid::ArmState<double> x(0.5, -0.4, 1.2, -0.8);
  const V2 tau(6.0 * std::sin(1.0), 4.0 * std::cos(1.0));
  const auto expected = sid::two_link_state_derivative(theta, x, tau);
  EXPECT_LE((model.state_derivative(theta, x, tau) - expected).norm(),
            kRelRoundoffTol * expected.norm());
  const auto fd = [&](const V2& q, const V2& qd, const V2& u) {
    return sid::two_link_forward_dynamics(theta, q, qd, u);
  };
  EXPECT_LE((sid::state_derivative_from_forward_dynamics(fd, x, tau) - expected).norm(),
            kRoundoffTol);
}

}  // namespace
