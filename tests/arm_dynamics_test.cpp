// Tests of sid/arm_dynamics.hpp and sid/momentum_observer.hpp: the recursive Newton-Euler
// inverse dynamics against Pinocchio's RNEA (tests/data/ndof/) and against the identification's
// regressor with every drive term and a coupled motor; the mass matrix, Coriolis and gravity
// split against the regressor's own; the momentum's balance against a finite difference; the
// observer against a known external torque; no heap allocation after construction.

#include <sid/arm_dynamics.hpp>
#include <sid/momentum_observer.hpp>

#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>

#include "allocation_counter.hpp"
#include "chain_test_support.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <stdexcept>
#include <vector>

namespace {

constexpr double kPi = 3.14159265358979323846;

// Gautier and Khalil's TX40 table (Khalil's modified DH), as the Pinocchio references use it.
sid::SerialChain<double> tx40_chain() {
  return sid::SerialChain<double>(sid::DhConvention::Modified, {{0.0, 0.0, 0.0, 0.0},
                                                                {0.0, -kPi / 2, 0.0, 0.0},
                                                                {0.225, 0.0, 0.035, 0.0},
                                                                {0.0, kPi / 2, 0.225, 0.0},
                                                                {0.0, -kPi / 2, 0.0, 0.0},
                                                                {0.0, kPi / 2, 0.0, 0.0}});
}

// The reference's parameters: ten per link, then Fv_1..Fv_6, Fc_1..Fc_6.
Eigen::VectorXd tx40_reference_theta() {
  return sid_test::read_table("ndof/base_tx40.csv").col("theta");
}

// The TX40 with every kind of drive term on every joint and the wrist's coupled motor 6 (it
// turns with joint 5, as on the real arm), with values that exercise each.
struct DrivenArm {
  sid::ChainModel model;
  Eigen::VectorXd theta;

  static sid::Transmission transmission() {
    Eigen::MatrixXd g = Eigen::MatrixXd::Identity(6, 6);
    g(5, 4) = 1.0;
    return sid::Transmission(g, Eigen::VectorXd::Zero(6));
  }

  DrivenArm()
      : model(
            tx40_chain(), {},
            [] {
              const std::vector<sid::DriveTermKind> kinds = {
                  sid::DriveTermKind::Viscous,          sid::DriveTermKind::Coulomb,
                  sid::DriveTermKind::CoulombAsymmetry, sid::DriveTermKind::Offset,
                  sid::DriveTermKind::Armature,         sid::DriveTermKind::Spring,
                  sid::DriveTermKind::Stribeck};
              return sid::drive_terms(kinds, transmission());
            }(),
            transmission(), 0.02),
        theta(model.parameters()) {
    const Eigen::VectorXd reference = tx40_reference_theta();
    theta.head(60) = reference.head(60);
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> level(0.05, 1.0);
    for (Eigen::Index c = 60; c < theta.size(); ++c) theta[c] = level(rng);
  }
};

Eigen::VectorXd random_vector(std::mt19937_64& rng, double range) {
  std::uniform_real_distribution<double> u(-range, range);
  Eigen::VectorXd v(6);
  for (auto& x : v) x = u(rng);
  return v;
}

// Every joint swings: q_j = amplitude sin(w_j t + phase j), w_j = rate + rate_step j.
struct Swing {
  double amplitude, rate, rate_step, phase;
  void at(double t, Eigen::VectorXd& q, Eigen::VectorXd& qd, Eigen::VectorXd& qdd) const {
    q.resize(6), qd.resize(6), qdd.resize(6);
    for (int j = 0; j < 6; ++j) {
      const double w = rate + rate_step * j, angle = w * t + phase * j;
      q[j] = amplitude * std::sin(angle);
      qd[j] = amplitude * w * std::cos(angle);
      qdd[j] = -amplitude * w * w * std::sin(angle);
    }
  }
};

TEST(ArmDynamics, InverseDynamicsIsPinocchiosRneaWithFriction) {
  const sid::Transmission direct(6);
  const sid::ChainModel model(
      tx40_chain(), {},
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb}, direct), direct,
      0.0);
  const Eigen::VectorXd reference = tx40_reference_theta();
  Eigen::VectorXd theta(model.parameters());
  theta.head(60) = reference.head(60);
  for (int j = 0; j < 6; ++j) {  // the model's order: fv_j, fc_j per joint
    theta[60 + 2 * j] = reference[60 + j];
    theta[61 + 2 * j] = reference[66 + j];
  }
  const sid::ArmDynamics arm(model, theta);
  const sid_test::Table table = sid_test::read_table("ndof/rnea_tx40.csv");
  ASSERT_GT(table.data.rows(), 10);
  Eigen::VectorXd tau(6);
  for (Eigen::Index row = 0; row < table.data.rows(); ++row) {
    arm.inverse_dynamics(sid_test::joints_of(table, row, "q"),
                         sid_test::joints_of(table, row, "qd"),
                         sid_test::joints_of(table, row, "qdd"), tau);
    // Both evaluate the same recursion in double: round-off, ~1e-13 of torques up to 77 N m.
    EXPECT_LT((tau - sid_test::joints_of(table, row, "tau")).cwiseAbs().maxCoeff(), 1e-9)
        << "sample " << row;
  }
}

TEST(ArmDynamics, EveryDriveTermAndCoupledMotorAsTheRegressorPredicts) {
  const DrivenArm a;
  const sid::ArmDynamics arm(a.model, a.theta);
  std::mt19937_64 rng(11);
  Eigen::MatrixXd y(6, a.model.parameters());
  Eigen::VectorXd tau(6), g(6), c(6), d(6), p(6), beta(6);
  Eigen::MatrixXd m(6, 6);
  for (int sample = 0; sample < 30; ++sample) {
    const Eigen::VectorXd q = random_vector(rng, kPi), qd = random_vector(rng, 2.0),
                          qdd = random_vector(rng, 5.0);
    a.model.regressor(q, qd, qdd, y);
    const Eigen::VectorXd expected = y * a.theta;
    arm.inverse_dynamics(q, qd, qdd, tau);
    const double scale = 1.0 + expected.cwiseAbs().maxCoeff();
    EXPECT_LT((tau - expected).cwiseAbs().maxCoeff(), 1e-12 * scale) << "sample " << sample;

    // The split: M qdd + c + g + d, each against the regressor's own pieces.
    arm.mass_matrix(q, m);
    arm.coriolis(q, qd, c);
    arm.gravity(q, g);
    arm.friction(q, qd, d);
    EXPECT_LT((m * qdd + c + g + d - expected).cwiseAbs().maxCoeff(), 1e-12 * scale);
    EXPECT_LT((m - m.transpose()).cwiseAbs().maxCoeff(), 1e-14 * m.cwiseAbs().maxCoeff());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(m).eigenvalues().minCoeff(), 0.0);
    const Eigen::VectorXd zero = Eigen::VectorXd::Zero(6);
    a.model.regressor(q, zero, zero, y);
    EXPECT_LT((g - y * a.theta).cwiseAbs().maxCoeff(), 1e-12 * scale) << "gravity";
    for (int j = 0; j < 6; ++j) {  // M's column j: ID(q, 0, e_j) - ID(q, 0, 0)
      Eigen::VectorXd unit = zero;
      unit[j] = 1.0;
      a.model.regressor(q, zero, unit, y);
      EXPECT_LT((m.col(j) - (y * a.theta - g)).cwiseAbs().maxCoeff(), 1e-12 * scale);
    }
    arm.momentum(q, qd, p, beta);
    EXPECT_LT((p - m * qd).cwiseAbs().maxCoeff(), 1e-12 * (1.0 + p.cwiseAbs().maxCoeff()));
  }
}

TEST(ArmDynamics, MomentumBalanceMatchesAFiniteDifferenceAlongAMotion) {
  // dp/dt = tau - beta with tau the drives' torque and no external one: the derivative of
  // p(q(t), qd(t)) by a central difference (error ~h^2) against beta from one pass.
  const DrivenArm a;
  const sid::ArmDynamics arm(a.model, a.theta);
  Eigen::VectorXd p_plus(6), p_minus(6), beta(6), p(6), tau(6);
  const Swing motion{0.9, 1.3, 0.4, 0.5};
  const double h = 1e-5;
  for (double t : {0.1, 0.7, 1.9, 3.3}) {
    Eigen::VectorXd q, qd, qdd;
    motion.at(t + h, q, qd, qdd);
    arm.momentum(q, qd, p_plus, beta);
    motion.at(t - h, q, qd, qdd);
    arm.momentum(q, qd, p_minus, beta);
    motion.at(t, q, qd, qdd);
    arm.momentum(q, qd, p, beta);
    arm.inverse_dynamics(q, qd, qdd, tau);
    const Eigen::VectorXd rate = (p_plus - p_minus) / (2.0 * h);
    EXPECT_LT((rate - (tau - beta)).cwiseAbs().maxCoeff(), 1e-5 * (1.0 + tau.cwiseAbs().maxCoeff()))
        << "t = " << t;
  }
}

TEST(ArmDynamics, AllocatesNothingAfterConstruction) {
  const DrivenArm a;
  const sid::ArmDynamics arm(a.model, a.theta);
  const Eigen::VectorXd gains = Eigen::VectorXd::Constant(6, 50.0);
  sid::MomentumObserver observer(arm, gains);
  sid::ArmDynamics::Vector q = sid::ArmDynamics::Vector::Constant(6, 0.3), qd = q, qdd = q, tau(6),
                           p(6);
  sid::ArmDynamics::Matrix m(6, 6);
  const int before = sid_test::g_allocations;
  for (int k = 0; k < 10; ++k) {
    arm.inverse_dynamics(q, qd, qdd, tau);
    arm.gravity(q, tau);
    arm.coriolis(q, qd, tau);
    arm.friction(q, qd, tau);
    arm.mass_matrix(q, m);
    arm.momentum(q, qd, p, tau);
    observer.update(q, qd, tau, 1e-3);
  }
  EXPECT_EQ(sid_test::g_allocations - before, 0);
  EXPECT_TRUE(tau.allFinite() && m.allFinite());
}

TEST(ArmDynamics, RefusesParametersThatAreNoArm) {
  const DrivenArm a;
  Eigen::VectorXd theta = a.theta;
  EXPECT_THROW(sid::ArmDynamics(a.model, theta.head(10)), std::invalid_argument);
  theta[20] = -1.0;  // link 3's mass
  try {
    sid::ArmDynamics arm(a.model, theta);
    FAIL() << "a negative mass was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("link 3"), std::string::npos) << e.what();
  }
  theta = a.theta;
  theta[60 + 4] = -0.1;  // joint 1's rotor inertia (its fifth drive term)
  EXPECT_THROW(sid::ArmDynamics(a.model, theta), std::invalid_argument);
}

TEST(MomentumObserver, FollowsAnExternalTorqueWithItsFirstOrderLag) {
  // The arm moves while an external torque steps on at t = 1 s and off at 2 s: the drives give
  // tau = ID - tau_ext. The estimate must rise as 1 - exp(-K t) and fall back to zero.
  const DrivenArm a;
  const sid::ArmDynamics arm(a.model, a.theta);
  const double gain = 100.0, dt = 1e-3;
  sid::MomentumObserver observer(arm, Eigen::VectorXd::Constant(6, gain));
  const Swing motion{0.7, 1.1, 0.3, 1.0};
  Eigen::VectorXd external(6);
  external << 5.0, -8.0, 3.0, 1.0, -0.5, 0.3;
  Eigen::VectorXd q(6), qd(6), qdd(6), tau(6);
  double worst_after_rise = 0.0, worst_rest = 0.0;
  for (int step = 0; step <= 3000; ++step) {
    const double t = step * dt;
    motion.at(t, q, qd, qdd);
    arm.inverse_dynamics(q, qd, qdd, tau);
    const bool pushed = t >= 1.0 && t < 2.0;
    if (pushed) tau -= external;
    const Eigen::VectorXd estimate = observer.update(q, qd, tau, dt);
    // A discrete first-order lag of rate K: within 1 % of the step after 5 / K.
    if (pushed && t > 1.0 + 5.0 / gain)
      worst_after_rise = std::max(worst_after_rise, (estimate - external).cwiseAbs().maxCoeff());
    if (!pushed && (t < 1.0 || t > 2.0 + 5.0 / gain))
      worst_rest = std::max(worst_rest, estimate.cwiseAbs().maxCoeff());
    if (pushed && std::abs(t - (1.0 + 1.0 / gain)) < 0.5 * dt) {
      // One time constant in, 11 pushed samples: the exact lag per step, whose first step
      // sees half the push (the trapezoid), gives 1 - exp(-10 K dt) (1 + exp(-K dt)) / 2 =
      // 0.650; the continuous lag's 1 - 1/e is 0.632.
      EXPECT_NEAR(estimate[1] / external[1],
                  1.0 - std::exp(-10.0 * gain * dt) * (1.0 + std::exp(-gain * dt)) / 2.0, 0.002);
    }
  }
  EXPECT_LT(worst_after_rise, 0.01 * external.cwiseAbs().maxCoeff());
  EXPECT_LT(worst_rest, 0.01 * external.cwiseAbs().maxCoeff());
  // Samples far apart for the gain (K dt = 3, where an Euler step diverges): still the step.
  observer.reset();
  for (int step = 0; step <= 100; ++step) {
    const double t = step * 0.03;
    motion.at(t, q, qd, qdd);
    arm.inverse_dynamics(q, qd, qdd, tau);
    const Eigen::VectorXd estimate = observer.update(q, qd, tau - external, 0.03);
    // The trapezoid's error over 30 ms steps of a moving arm stays within 5 % of the push.
    if (step > 5) {
      EXPECT_LT((estimate - external).cwiseAbs().maxCoeff(), 0.05 * 8.0) << t;
    }
  }
  EXPECT_THROW(sid::MomentumObserver(arm, Eigen::VectorXd::Constant(5, 1.0)),
               std::invalid_argument);
  EXPECT_THROW(sid::MomentumObserver(arm, Eigen::VectorXd::Constant(6, 0.0)),
               std::invalid_argument);
}

}  // namespace
