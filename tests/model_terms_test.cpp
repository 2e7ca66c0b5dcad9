// Tests of include/sid/model/terms.hpp and include/sid/model/model.hpp: a model as a sum of
// terms, checked against Pinocchio's cases and the closed-form arm.

#include <sid/model/model.hpp>
#include <sid/model/terms.hpp>
#include <sid/model/two_link_arm.hpp>

#include "allocation_counter.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <cmath>
#include <cstdlib>
#include <new>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

template class sid::Model<float>;
template class sid::Model<double>;
template struct sid::Term<float>;
template struct sid::Term<double>;

namespace {

constexpr double kPinocchioAbsTol = 1e-12;  // N m and regressor entries
constexpr double kRoundoffTol = 1e-13;
constexpr double kFloatRelTol = 1e-4;

using V2 = sid::Vector2<double>;

V2 pair(const sid_test::Table& table, Eigen::Index row, const char* a, const char* b) {
  return {table.data(row, table.column(a)), table.data(row, table.column(b))};
}

/// Coulomb friction smoothed with tanh: the kind of nonlinear term with a hyper-parameter (eps)
/// that later effects add, written here without touching the library.
sid::Term<double> coulomb_term(double eps) {
  return {"coulomb_friction",
          {"fc1", "fc2"},
          [eps](const V2&, const V2& qd, const V2&, sid::RegressorView<double> out) {
            out << std::tanh(qd[0] / eps), 0.0, 0.0, std::tanh(qd[1] / eps);
          }};
}

TEST(Model, ArmModelHasPaperParametersInOrder) {
  const auto model = sid::two_link_arm_model<double>();
  EXPECT_EQ(model.num_parameters(), 7);
  EXPECT_EQ(model.parameter_names(),
            (std::vector<std::string>{"theta1", "theta2", "theta3", "theta4", "theta5", "theta6",
                                      "theta7"}));
  EXPECT_EQ(model.parameter_offset("rigid_body"), 0);
  EXPECT_EQ(model.parameter_offset("viscous_friction"), 5);
  EXPECT_TRUE(model.has_term("viscous_friction"));
  EXPECT_FALSE(model.has_term("coulomb_friction"));
}

TEST(Model, RegressorFromTermsMatchesPinocchio) {
  const auto table = sid_test::read_table("regressor_cases.csv");
  const auto model = sid::two_link_arm_model<double>();
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const auto z = model.regressor(pair(table, i, "q1", "q2"), pair(table, i, "qd1", "qd2"),
                                   pair(table, i, "qdd1", "qdd2"));
    ASSERT_EQ(z.cols(), 7);
    for (int r = 0; r < 2; ++r)
      for (int c = 0; c < 7; ++c) {
        const std::string name = "Z" + std::to_string(r + 1) + std::to_string(c + 1);
        EXPECT_NEAR(z(r, c), table.data(i, table.column(name)), kPinocchioAbsTol) << name;
      }
  }
}

TEST(Model, InverseDynamicsMatchesPinocchioRnea) {
  const auto table = sid_test::read_table("rnea_cases.csv");
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  for (Eigen::Index i = 0; i < table.data.rows(); ++i) {
    const V2 tau =
        model.inverse_dynamics(theta, pair(table, i, "q1", "q2"), pair(table, i, "qd1", "qd2"),
                               pair(table, i, "qdd1", "qdd2"));
    const V2 expected = pair(table, i, "tau1", "tau2");
    EXPECT_NEAR(tau[0], expected[0], kPinocchioAbsTol) << "case " << i;
    EXPECT_NEAR(tau[1], expected[1], kPinocchioAbsTol) << "case " << i;
  }
}

TEST(Model, TermFromTorqueReproducesClosedFormColumns) {
  // The rigid-body term rebuilt from its torque formula (the closed-form inverse dynamics with
  // friction switched off) by unit parameter vectors: no regressor written by hand.
  const double g = sid::kPaperGravity;
  const auto rigid = sid::term_from_torque<double>(
      "rigid_from_torque", {"t1", "t2", "t3", "t4", "t5"},
      [g](const sid::ModelParameters<double>& t, const V2& q, const V2& qd, const V2& qdd) {
        sid::TwoLinkParameters<double> theta;
        theta << t, 0.0, 0.0;
        return sid::two_link_inverse_dynamics(theta, q, qd, qdd, g);
      });
  sid::Model<double> model;
  model.add(rigid).add(sid::viscous_friction_term<double>());
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  for (int k = 0; k < 50; ++k) {
    const V2 q(u(rng), u(rng)), qd(u(rng), u(rng)), qdd(3 * u(rng), 3 * u(rng));
    const auto z = model.regressor(q, qd, qdd);
    EXPECT_LE((z - sid::two_link_regressor(q, qd, qdd)).cwiseAbs().maxCoeff(), kRoundoffTol);
  }
}

TEST(Model, AddedTermAddsItsTorqueOnly) {
  constexpr double kEps = 0.01;  // rad/s
  auto model = sid::two_link_arm_model<double>();
  model.add(coulomb_term(kEps));
  ASSERT_EQ(model.num_parameters(), 9);
  EXPECT_EQ(model.parameter_names()[7], "fc1");
  EXPECT_EQ(model.parameter_offset("coulomb_friction"), 7);
  Eigen::VectorXd theta(9);
  theta << sid::paper_arm_parameters<double>(), 0.05, 0.02;
  const V2 q(0.4, -0.2), qd(0.3, -0.005), qdd(1.0, 2.0), tau(0.3, -0.1);
  const V2 expected =
      sid::two_link_inverse_dynamics(sid::paper_arm_parameters<double>(), q, qd, qdd) +
      V2(0.05 * std::tanh(qd[0] / kEps), 0.02 * std::tanh(qd[1] / kEps));
  EXPECT_LE((model.inverse_dynamics(theta, q, qd, qdd) - expected).norm(), kRoundoffTol);
  // Coulomb friction changes the bias torque, not the mass matrix.
  EXPECT_LE((model.mass_matrix(theta, q) -
             sid::two_link_mass_matrix(sid::paper_arm_parameters<double>(), q))
                .norm(),
            kRoundoffTol);
  // Forward dynamics inverts the extended inverse dynamics.
  const V2 acc = model.forward_dynamics(theta, q, qd, tau);
  EXPECT_LE((model.inverse_dynamics(theta, q, qd, acc) - tau).norm(), kRoundoffTol);
}

TEST(Model, RegressorTimesThetaIsInverseDynamics) {
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  const V2 q(2.0, -0.7), qd(-1.0, 0.4), qdd(5.0, -3.0);
  const auto z = model.regressor(q, qd, qdd);
  const V2 tau = z * theta;
  EXPECT_LE((model.inverse_dynamics(theta, q, qd, qdd) - tau).norm(), kRoundoffTol);
}

TEST(Model, RegressorWritesIntoCallerStorage) {
  const auto model = sid::two_link_arm_model<double>();
  Eigen::Matrix<double, 2, 7> z;
  const V2 q(0.1, 0.2), qd(0.3, 0.4), qdd(0.5, 0.6);
  model.regressor(q, qd, qdd, z);
  EXPECT_EQ(z, sid::two_link_regressor(q, qd, qdd));
}

TEST(Model, EvaluationDoesNotAllocate) {
  const auto model = sid::two_link_arm_model<double>();
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters<double>();
  const V2 q(0.3, -1.1), qd(0.7, 2.0), qdd(-4.0, 9.0);
  const int before = sid_test::g_allocations;
  double sink = 0.0;
  for (int k = 0; k < 10; ++k) {
    sink += model.regressor(q, qd, qdd).sum();
    sink += model.inverse_dynamics(theta, q, qd, qdd).sum();
    sink += model.forward_dynamics(theta, q, qd, qdd).sum();
    sink += model.state_derivative(theta, sid::ArmState<double>::Zero(), qdd).sum();
  }
  EXPECT_EQ(sid_test::g_allocations, before);
  EXPECT_TRUE(std::isfinite(sink));
}

TEST(Model, FloatModelAgreesWithDouble) {
  const auto model_f = sid::two_link_arm_model<float>();
  const auto model_d = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  const Eigen::VectorXf theta_f = theta.cast<float>();
  const V2 q(0.3, -1.1), qd(0.7, 2.0), qdd(-4.0, 9.0);
  const V2 tau = model_d.inverse_dynamics(theta, q, qd, qdd);
  const sid::Vector2<float> tau_f =
      model_f.inverse_dynamics(theta_f, q.cast<float>(), qd.cast<float>(), qdd.cast<float>());
  EXPECT_LE((tau_f.cast<double>() - tau).norm(), kFloatRelTol * tau.norm());
}

TEST(Model, ThrowsOnWrongThetaLength) {
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = Eigen::VectorXd::Ones(6);
  const V2 z = V2::Zero();
  sid_test::expect_invalid_argument([&] { (void)model.inverse_dynamics(theta, z, z, z); },
                                    "sid::Model::inverse_dynamics", "theta has 6");
  sid_test::expect_invalid_argument([&] { (void)model.mass_matrix(theta, z); },
                                    "sid::Model::mass_matrix", "theta");
  sid_test::expect_invalid_argument([&] { (void)model.bias_torque(theta, z, z); },
                                    "sid::Model::bias_torque", "theta");
  sid_test::expect_invalid_argument([&] { (void)model.forward_dynamics(theta, z, z, z); },
                                    "sid::Model::forward_dynamics", "theta");
  sid_test::expect_invalid_argument(
      [&] { (void)model.state_derivative(theta, sid::ArmState<double>::Zero(), z); },
      "sid::Model::state_derivative", "theta");
}

TEST(Model, ThrowsOnWrongRegressorStorage) {
  const auto model = sid::two_link_arm_model<double>();
  Eigen::Matrix<double, 2, 6> z;
  const V2 v = V2::Zero();
  sid_test::expect_invalid_argument([&] { model.regressor(v, v, v, z); }, "sid::Model::regressor",
                                    "out is 2 x 6");
}

TEST(Model, RejectsInvalidTerms) {
  auto model = sid::two_link_arm_model<double>();
  sid_test::expect_invalid_argument([&] { model.add(sid::viscous_friction_term<double>()); },
                                    "sid::Model::add", "viscous_friction");
  auto nameless = coulomb_term(0.1);
  nameless.name.clear();
  sid_test::expect_invalid_argument([&] { model.add(nameless); }, "sid::Model::add", "name");
  auto no_columns = coulomb_term(0.1);
  no_columns.columns = nullptr;
  sid_test::expect_invalid_argument([&] { model.add(no_columns); }, "sid::Model::add",
                                    "column function");
  auto no_parameters = coulomb_term(0.1);
  no_parameters.parameter_names.clear();
  sid_test::expect_invalid_argument([&] { model.add(no_parameters); }, "sid::Model::add",
                                    "no parameters");
  auto huge = coulomb_term(0.1);
  huge.parameter_names.assign(sid::kMaxModelParameters, "p");
  sid_test::expect_invalid_argument([&] { model.add(huge); }, "sid::Model::add", "at most");
  EXPECT_EQ(model.num_parameters(), 7);  // failed adds leave the model unchanged
  sid_test::expect_invalid_argument([&] { (void)model.parameter_offset("spring"); },
                                    "sid::Model::parameter_offset", "spring");
}

}  // namespace
