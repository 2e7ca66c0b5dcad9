// One model for every arm: sid::Model holds the paper's closed-form two-link term and a chain's
// Newton-Euler term alike, and everything that follows from a model (inverse and forward
// dynamics, mass matrix, state derivative) is the same code for both. Checked against the
// closed-form two-link dynamics, the O(n^3) chain dynamics and a round trip.

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

std::string read_text(const std::string& name) {
  std::ifstream in(sid_test::data_path(name));
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
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
  const sid::UrdfChain arm =
      sid::chain_from_urdf(read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
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
