// One model for every arm: sid::Model holds the paper's closed-form two-link term and a chain's
// Newton-Euler term alike, and everything that follows from a model (inverse and forward
// dynamics, mass matrix, state derivative) is the same code for both. Checked against the
// closed-form two-link dynamics, the O(n^3) chain dynamics and a round trip.

#include <sid/model/articulated_body.hpp>
#include <sid/model/chain_dynamics.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/model.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/model/two_link_chain.hpp>
#include <sid/model/urdf.hpp>

#include "test_support.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace {

using ChainVector = sid::JointVector<double, Eigen::Dynamic>;

sid::Transmission direct(int joints) {
  return sid::Transmission(Eigen::MatrixXd::Identity(joints, joints),
                           Eigen::VectorXd::Zero(joints));
}

}  // namespace

// The paper's arm written as a two-joint chain with viscous drives is the same model as the
// paper's closed form at θ(φ): same torque, mass matrix and accelerations at any state.
TEST(OneModel, PaperArmAsAChainIsThePapersModel) {
  const sid::TwoLinkPhysical<double> p = sid::paper_arm_physical();
  const sid::ChainModel chain(sid::two_link_chain(p.l1), {"shoulder", "elbow"},
                              sid::drive_terms({sid::DriveTermKind::Viscous}, direct(2)),
                              direct(2));
  ASSERT_EQ(chain.model().joints(), 2);
  ASSERT_EQ(chain.parameters(), 22);
  Eigen::VectorXd phi = Eigen::VectorXd::Zero(22);
  phi[0] = p.m1;
  phi[1] = p.m1 * p.lc1;
  phi[9] = p.I1 + p.m1 * p.lc1 * p.lc1;
  phi[10] = p.m2;
  phi[11] = p.m2 * p.lc2;
  phi[19] = p.I2 + p.m2 * p.lc2 * p.lc2;
  phi[20] = p.mu1;  // fv_1
  phi[21] = p.mu2;  // fv_2
  const sid::Model<double> paper = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::two_link_parameters(p);

  std::mt19937 g(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const sid::Vector2<double> q(3 * u(g), 3 * u(g)), qd(2 * u(g), 2 * u(g)),
        qdd(5 * u(g), 5 * u(g));
    const ChainVector cq = q, cqd = qd, cqdd = qdd;
    const sid::Vector2<double> tau = paper.inverse_dynamics(theta, q, qd, qdd);
    EXPECT_LT((chain.model().inverse_dynamics(phi, cq, cqd, cqdd) - tau).norm(), 1e-14);
    EXPECT_LT((chain.model().mass_matrix(phi, cq) - paper.mass_matrix(theta, q)).norm(), 1e-15);
    const ChainVector qdd_chain = chain.model().forward_dynamics(phi, cq, cqd, tau);
    EXPECT_LT((qdd_chain - qdd).norm(), 1e-11 * (1 + qdd.norm())) << "trial " << trial;
    sid::JointState<double, Eigen::Dynamic> x(4);
    x << cq, cqd;
    sid::ArmState<double> x2;
    x2 << q, qd;
    EXPECT_LT((chain.model().state_derivative(phi, x, tau) - paper.state_derivative(theta, x2, tau))
                  .norm(),
              1e-11 * (1 + qdd.norm()));
  }
}

// A six-joint arm's model gives the chain's own dynamics (the O(n^3) path of
// sid/model/chain_dynamics.hpp), with its drive terms on top, and forward dynamics inverts
// inverse dynamics.
TEST(OneModel, SixJointModelHasTheChainsDynamics) {
  const sid::UrdfChain arm = sid::chain_from_urdf(
      sid_test::read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
  const sid::ChainModel model(
      arm.chain, arm.joint_names,
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature}, direct(6)),
      direct(6));
  ASSERT_EQ(model.model().joints(), 6);
  ASSERT_EQ(model.model().terms().front().name, "rigid_body");
  Eigen::VectorXd theta(model.parameters()), chain_theta = Eigen::VectorXd::Zero(72);
  theta.head(60) = arm.theta.head(60);
  chain_theta.head(60) = arm.theta.head(60);
  for (int j = 0; j < 6; ++j) {
    theta[60 + 2 * j] = 0.5 + 0.2 * j;   // fv_j
    theta[61 + 2 * j] = 0.01 * (j + 1);  // Ia_j
    chain_theta[60 + j] = theta[60 + 2 * j];
  }
  std::mt19937 g(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    ChainVector q(6), qd(6), qdd(6);
    for (int j = 0; j < 6; ++j) {
      q[j] = 3 * u(g);
      qd[j] = 2 * u(g);
      qdd[j] = 5 * u(g);
    }
    const Eigen::VectorXd armature = theta.segment(60, 12)(Eigen::seqN(1, 6, 2));
    const Eigen::VectorXd expected =
        sid::chain_inverse_dynamics(arm.chain, chain_theta, q, qd, qdd) +
        armature.cwiseProduct(Eigen::VectorXd(qdd));
    const ChainVector tau = model.model().inverse_dynamics(theta, q, qd, qdd);
    EXPECT_LT((tau - expected).norm(), 1e-12 * (1 + expected.norm()));
    Eigen::MatrixXd mass = sid::chain_mass_matrix(arm.chain, chain_theta, q);
    mass.diagonal() += armature;
    EXPECT_LT((model.model().mass_matrix(theta, q) - mass).norm(), 1e-12 * mass.norm());
    EXPECT_LT((model.model().forward_dynamics(theta, q, qd, tau) - qdd).norm(),
              1e-10 * (1 + qdd.norm()))
        << "trial " << trial;
  }
}

TEST(OneModel, RefusesWhatDoesNotFit) {
  sid_test::expect_invalid_argument([] { sid::Model<double, Eigen::Dynamic> m(0); }, "sid::Model",
                                    "0 joints");
  sid_test::expect_invalid_argument([] { sid::Model<double, Eigen::Dynamic> m(13); }, "sid::Model",
                                    "13 joints");
  sid_test::expect_invalid_argument([] { sid::Model<double> m(3); }, "sid::Model", "exactly 2");
  const sid::ChainModel model(sid::two_link_chain(0.3), {},
                              sid::drive_terms({sid::DriveTermKind::Offset}, direct(2)), direct(2));
  const ChainVector three = ChainVector::Zero(3), two = ChainVector::Zero(2);
  const Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
  sid_test::expect_invalid_argument(
      [&] { model.model().inverse_dynamics(theta, three, three, three); },
      "sid::Model::inverse_dynamics", "3, 3 and 3 entries for a model of 2 joints");
  sid_test::expect_invalid_argument(
      [&] { model.model().inverse_dynamics(theta.head(5), two, two, two); },
      "sid::Model::inverse_dynamics", "theta has 5 entries");
  // A singular mass matrix (no links, no armature) gives NaN accelerations, not an exception
  // inside a simulator's right-hand side.
  EXPECT_TRUE(model.model().forward_dynamics(theta, two, two, two).array().isNaN().all());
}

namespace {

ChainVector random_joints(std::mt19937& g, int n, double scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  ChainVector v(n);
  for (int j = 0; j < n; ++j) v[j] = scale * u(g);
  return v;
}

}  // namespace

// The O(n) articulated-body algorithm against the O(n^3) route on a seven-joint arm (Panda with
// its hand held) and on a chain with a prismatic joint (PR2's torso lift), friction included.
TEST(OneModel, ArticulatedBodyMatchesTheCubicRouteOnSevenJointsAndASlide) {
  struct Case {
    const char* file;
    const char* base;
    const char* tip;
  };
  for (const Case& c : {Case{"urdf/real/panda.urdf", "panda_link0", "panda_link8"},
                        Case{"urdf/real/pr2.urdf", "base_footprint", "r_elbow_flex_link"}}) {
    const sid::UrdfChain arm = sid::chain_from_urdf(sid_test::read_text(c.file), c.base, c.tip);
    const int n = arm.chain.joints();
    Eigen::VectorXd theta = arm.theta;
    for (int j = 0; j < n; ++j) {
      theta[sid::kLinkParameters * n + j] = 0.3 + 0.1 * j;         // Fv_j
      theta[(sid::kLinkParameters + 1) * n + j] = 0.05 * (j + 1);  // Fc_j
    }
    std::mt19937 g(17);
    for (int trial = 0; trial < 20; ++trial) {
      const ChainVector q = random_joints(g, n, 1.5), qd = random_joints(g, n, 2.0),
                        tau = random_joints(g, n, 20.0);
      const Eigen::VectorXd aba = sid::chain_forward_dynamics_aba(arm.chain, theta, q, qd, tau);
      const Eigen::VectorXd cubic = sid::chain_forward_dynamics(arm.chain, theta, q, qd, tau);
      EXPECT_LT((aba - cubic).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + cubic.cwiseAbs().maxCoeff()))
          << c.file << ", trial " << trial;
      const Eigen::VectorXd back = sid::chain_inverse_dynamics(arm.chain, theta, q, qd, aba);
      EXPECT_LT((back - tau).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + tau.cwiseAbs().maxCoeff()));
    }
  }
}

// The model's own O(n) forward dynamics, with every drive term, the TX40's coupled wrist motor
// (its rotor a rank-one term of the mass matrix) included, equals the model's O(n^3) route and
// inverts its inverse dynamics.
TEST(OneModel, ChainModelForwardDynamicsWithACoupledRotorIsTheCubicRoutes) {
  const sid::UrdfChain arm = sid::chain_from_urdf(
      sid_test::read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
  Eigen::MatrixXd gear = Eigen::MatrixXd::Zero(6, 6);
  gear.diagonal() << 32, 32, 45, -48, 45, 32;
  gear(5, 4) = 32;  // the sixth motor turns with q5 + q6
  const sid::Transmission drives(gear, Eigen::VectorXd::Zero(6));
  const sid::ChainModel model(
      arm.chain, arm.joint_names,
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb,
                        sid::DriveTermKind::CoulombAsymmetry, sid::DriveTermKind::Offset,
                        sid::DriveTermKind::Armature},
                       drives),
      drives, 0.05);
  std::mt19937 g(23);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Eigen::VectorXd theta(model.parameters());
  theta.head(60) = arm.theta.head(60);
  for (Eigen::Index k = 60; k < theta.size(); ++k) theta[k] = 0.05 + 0.2 * u(g);
  for (int trial = 0; trial < 20; ++trial) {
    const ChainVector q = random_joints(g, 6, 2.0), qd = random_joints(g, 6, 1.5),
                      tau = random_joints(g, 6, 30.0);
    const ChainVector fast = model.forward_dynamics(theta, q, qd, tau);
    const ChainVector cubic = model.model().forward_dynamics(theta, q, qd, tau);
    EXPECT_LT((fast - cubic).cwiseAbs().maxCoeff(), 1e-10 * (1.0 + cubic.cwiseAbs().maxCoeff()))
        << "trial " << trial;
    EXPECT_LT((model.model().inverse_dynamics(theta, q, qd, fast) - tau).cwiseAbs().maxCoeff(),
              1e-9 * (1.0 + tau.cwiseAbs().maxCoeff()));
  }
  // Not a body: NaN accelerations from the model, an exception from the free function.
  EXPECT_TRUE(model
                  .forward_dynamics(Eigen::VectorXd::Zero(model.parameters()), ChainVector::Zero(6),
                                    ChainVector::Zero(6), ChainVector::Ones(6))
                  .array()
                  .isNaN()
                  .all());
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::chain_forward_dynamics_aba(arm.chain, Eigen::VectorXd::Zero(72),
                                              Eigen::VectorXd::Zero(6), Eigen::VectorXd::Zero(6),
                                              Eigen::VectorXd::Ones(6));
      },
      "sid::chain_forward_dynamics_aba", "not a physical arm");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::chain_forward_dynamics_aba(arm.chain, Eigen::VectorXd::Zero(72),
                                              Eigen::VectorXd::Zero(5), Eigen::VectorXd::Zero(6),
                                              Eigen::VectorXd::Ones(6));
      },
      "sid::chain_forward_dynamics_aba", "q has 5 entries");
  sid_test::expect_invalid_argument(
      [&] {
        (void)model.forward_dynamics(theta, ChainVector::Zero(5), ChainVector::Zero(6),
                                     ChainVector::Zero(6));
      },
      "sid::ChainModel::forward_dynamics", "sizes do not match");
}
