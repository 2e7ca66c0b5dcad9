#include <sid/model/joint_dynamics.hpp>

#include "test_support.hpp"

#include <sid/model/chain_model.hpp>
#include <sid/model/serial_chain.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace {

// Three joints; motor 2 (index 1) turns joint 2 alone through a gear of 50, motor 3 turns joints
// 2 and 3 (a coupled wrist).
sid::ChainModel geared_arm() {
  const sid::SerialChain<double> chain(
      sid::DhConvention::Standard,
      {{0.0, 1.5707963267948966, 0.3, 0.0}, {0.4, 0.0, 0.0, 0.0}, {0.3, 0.0, 0.0, 0.0}});
  Eigen::Matrix3d ratio;
  ratio << 100.0, 0.0, 0.0, 0.0, 50.0, 0.0, 0.0, 20.0, 20.0;
  using K = sid::DriveTermKind;
  const auto term = [](K kind, int index, bool on_motor) {
    sid::DriveTerm t;
    t.kind = kind;
    t.index = index;
    t.on_motor = on_motor;
    return t;
  };
  return sid::ChainModel(
      chain, {"a", "b", "c"},
      {term(K::Viscous, 0, false), term(K::Coulomb, 0, false), term(K::Viscous, 1, true),
       term(K::Coulomb, 1, true), term(K::Viscous, 1, false), term(K::Armature, 1, true),
       term(K::Viscous, 2, true), term(K::Coulomb, 2, true), term(K::Spring, 0, false),
       term(K::Spring, 1, true), term(K::Offset, 0, false)},
      sid::Transmission(ratio, Eigen::Vector3d::Zero()), 1e-4);
}

Eigen::VectorXd drive_values(const sid::ChainModel& model) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
  theta.tail(11) << 0.5, 1.2, 0.3, 0.8, 0.2, 0.01, 0.4, 0.6, 2.0, 3.0, 0.7;
  return theta;
}

TEST(JointDynamics, IsTheTorqueTheModelGivesEachJointAloneInMotion) {
  // The model's own torque (no links: theta's link parameters are zero): turning joint j alone at
  // rate v gives damping_j v + friction_j tanh(v / eps) + stiffness_j q_j on that joint, tanh = 1
  // at v >= 1.
  const sid::ChainModel model = geared_arm();
  const Eigen::VectorXd theta = drive_values(model);
  const sid::JointDynamics f = sid::joint_dynamics(model, theta);
  ASSERT_EQ(f.coupled.size(), 3u);
  EXPECT_EQ(f.coupled[0], "fv_m3");
  EXPECT_EQ(f.coupled[1], "fc_m3");
  // The coupled motor's terms act on joints 2 and 3 at once, a motor's spring on its angle (the
  // transmission's zero included), an offset on no motion: what is written leaves them out.
  Eigen::VectorXd per_joint = theta;
  per_joint.segment(per_joint.size() - 5, 2).setZero();
  per_joint.tail(2).setZero();
  const Eigen::Vector3d q(0.2, -0.3, 0.4), zero = Eigen::Vector3d::Zero();
  for (int j = 0; j < 2; ++j) {
    for (double v : {1.0, 2.0}) {
      Eigen::Vector3d qd = zero;
      qd[j] = v;
      Eigen::MatrixXd y(3, model.parameters());
      model.regressor(q, qd, zero, y);
      const double tau = (y * per_joint)[j];
      EXPECT_NEAR(tau, f.damping[j] * v + f.friction[j] + f.stiffness[j] * q[j], 1e-12)
          << "joint " << j << " at " << v;
    }
  }
  // Each joint accelerated alone from rest at zero angle, then held still at an angle.
  for (int j = 0; j < 2; ++j) {
    Eigen::Vector3d qdd = zero, at = zero;
    qdd[j] = 2.0;
    at[j] = 0.3;
    Eigen::MatrixXd y(3, model.parameters());
    model.regressor(zero, zero, qdd, y);
    EXPECT_NEAR((y * per_joint)[j], f.armature[j] * 2.0, 1e-12) << "joint " << j;
    model.regressor(at, zero, zero, y);
    EXPECT_NEAR((y * per_joint)[j], f.stiffness[j] * 0.3, 1e-12) << "joint " << j;
  }
  EXPECT_DOUBLE_EQ(f.armature[1], 0.01);
  EXPECT_DOUBLE_EQ(f.stiffness[0], 2.0);
  EXPECT_EQ(f.stiffness[1], 0.0);             // the motor's spring is listed apart
  EXPECT_DOUBLE_EQ(f.damping[1], 0.3 + 0.2);  // the motor's and the joint's own
  EXPECT_DOUBLE_EQ(f.friction[1], 0.8);
  EXPECT_EQ(f.damping[2], 0.0);  // only the coupled motor acts there
}

TEST(JointDynamics, RefusesParametersOfAnotherModel) {
  const sid::ChainModel model = geared_arm();
  sid_test::expect_invalid_argument(
      [&] { (void)sid::joint_dynamics(model, Eigen::VectorXd::Zero(3)); }, "sid::joint_dynamics",
      "parameters");
}

}  // namespace
