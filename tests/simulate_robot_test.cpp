#include <sid/cvode/simulate_robot.hpp>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace {

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

const sid::RobotDescription& ur5() {
  static const sid::RobotDescription robot = sid::robot_description_from_urdf(
      file_text(SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf"), "base_link", "tool0");
  return robot;
}

Eigen::Index parameter(const sid::ChainModel& model, const std::string& name) {
  const auto& names = model.parameter_names();
  const auto found = std::find(names.begin(), names.end(), name);
  EXPECT_NE(found, names.end()) << name;
  return found - names.begin();
}

sid::RobotEffect effect(sid::RobotEffectKind kind, int joint, double value) {
  sid::RobotEffect e;
  e.kind = kind;
  e.joint = joint;
  e.value = value;
  return e;
}

sid::RobotSimulationOptions short_run() {
  sid::RobotSimulationOptions o;
  o.duration = 2.0;
  return o;
}

}  // namespace

// The effects land on the description's <dynamics> in the parameters named for them, and the
// samples satisfy the model's inverse dynamics (the simulator integrated the forward dynamics of
// the same parameters).
TEST(SimulateRobot, EffectsAddToTheDescriptionAndTheTruthObeysTheModel) {
  sid::RobotSimulationOptions o = short_run();
  sid::RobotEffect stribeck = effect(sid::RobotEffectKind::Stribeck, 4, 0.2);
  stribeck.stribeck_static = 0.5;
  stribeck.stribeck_velocity = 0.05;
  o.effects = {effect(sid::RobotEffectKind::Viscous, 1, 0.3),
               effect(sid::RobotEffectKind::Coulomb, 2, 0.4),
               effect(sid::RobotEffectKind::Spring, 3, 5.0), stribeck};
  std::mt19937_64 rng(3);
  const sid::SimulatedRobot s = sid::simulate_robot_truth(ur5(), o, rng);
  EXPECT_DOUBLE_EQ(s.theta[parameter(s.model, "fv_2")], ur5().damping[1] + 0.3);
  EXPECT_DOUBLE_EQ(s.theta[parameter(s.model, "fc_3")], ur5().friction[2] + 0.4);
  EXPECT_DOUBLE_EQ(s.theta[parameter(s.model, "k_4")], 5.0);
  EXPECT_DOUBLE_EQ(s.theta[parameter(s.model, "fc_5")], ur5().friction[4] + 0.2);
  EXPECT_DOUBLE_EQ(s.theta.tail(1)[0], 0.5 - 0.2);  // the Stribeck excess Fs - Fc
  EXPECT_TRUE(s.theta.head(s.model.rigid_body_parameters()).isApprox(ur5().link_parameters));
  ASSERT_EQ(s.truth.size(), 801);
  double worst = 0.0, largest = 0.0;
  for (Eigen::Index k = 0; k < s.truth.size(); k += 40) {
    const Eigen::VectorXd q = s.truth.q.row(k), qd = s.truth.qd.row(k), qdd = s.truth.qdd.row(k);
    const Eigen::VectorXd tau = s.model.model().inverse_dynamics(s.theta, q, qd, qdd);
    worst = std::max(worst, (tau - s.truth.tau.row(k).transpose()).cwiseAbs().maxCoeff());
    largest = std::max(largest, tau.cwiseAbs().maxCoeff());
  }
  EXPECT_GT(largest, 1.0);
  EXPECT_LT(worst, 1e-8 * largest);
}

// The log is the truth with the encoder offset subtracted, the torque bias added and noise of
// the asked variances; one seed gives one log.
TEST(SimulateRobot, TheLogIsTheTruthWithTheSensorsFaultsAndNoise) {
  sid::RobotSimulationOptions o = short_run();
  o.effects = {effect(sid::RobotEffectKind::AngleOffset, 1, 0.02),
               effect(sid::RobotEffectKind::TorqueOffset, 3, -0.3)};
  o.noise = {1e-6, 4e-2};
  const sid::SimulatedRobotLog log = sid::simulate_robot(ur5(), o, 11);
  const sid::SimulatedRobot& s = log.simulated;
  Eigen::MatrixXd angle_error = log.measured.q - s.truth.q;
  Eigen::MatrixXd torque_error = log.measured.tau - s.truth.tau;
  angle_error.col(1).array() += 0.02;
  torque_error.col(3).array() -= -0.3;
  const auto samples = static_cast<double>(angle_error.size());
  EXPECT_NEAR(angle_error.squaredNorm() / samples, 1e-6, 0.05e-6);
  EXPECT_NEAR(torque_error.squaredNorm() / samples, 4e-2, 0.05 * 4e-2);
  EXPECT_LT(std::abs(angle_error.mean()), 4.0 * 1e-3 / std::sqrt(samples));

  const sid::SimulatedRobotLog again = sid::simulate_robot(ur5(), o, 11);
  EXPECT_EQ(again.measured.q, log.measured.q);
  EXPECT_EQ(again.measured.tau, log.measured.tau);
  EXPECT_NE(sid::simulate_robot(ur5(), o, 12).measured.q, log.measured.q);

  o.noise = {0.0, 0.0};
  const sid::SimulatedRobotLog exact = sid::simulate_robot(ur5(), o, 11);
  EXPECT_EQ(exact.measured.q.col(1), (exact.simulated.truth.q.col(1).array() - 0.02).matrix());
  EXPECT_EQ(exact.measured.tau.col(3), (exact.simulated.truth.tau.col(3).array() - 0.3).matrix());
  EXPECT_EQ(exact.measured.q.col(0), exact.simulated.truth.q.col(0));
}

// A cheap arm's sensors: each encoder rounds its angle to 2π / (2^bits · ratio) (on the motor,
// through the gear ratio), and the torque channel lags the angles: the torque logged at t is
// the truth at t − delay, linear between samples (checked here against the two samples around
// t − delay, by hand), the first sample's before the start.
TEST(SimulateRobot, EncodersRoundTheAnglesAndTheTorqueChannelLags) {
  sid::RobotSimulationOptions o = short_run();
  o.noise = {1e-8, 0.0};
  const sid::SimulatedRobotLog plain = sid::simulate_robot(ur5(), o, 5);
  o.sensors.encoder_bits = {10};
  o.sensors.encoder_ratio = {1.0, 50.0, 1.0, 1.0, 1.0, 1.0};
  o.sensors.torque_delay = 0.004;  // 1.6 samples of 2.5 ms
  const sid::SimulatedRobotLog log = sid::simulate_robot(ur5(), o, 5);
  for (Eigen::Index j = 0; j < 6; ++j) {
    const double step = 2.0 * M_PI / (1024.0 * (j == 1 ? 50.0 : 1.0));
    for (Eigen::Index k = 0; k < log.measured.size(); ++k) {
      const double steps = log.measured.q(k, j) / step;
      ASSERT_NEAR(steps, std::round(steps), 1e-6) << "joint " << j + 1 << ", sample " << k;
      // The same noise is drawn, then rounded.
      ASSERT_LE(std::abs(log.measured.q(k, j) - plain.measured.q(k, j)), 0.5 * step * (1 + 1e-9));
    }
  }
  const Eigen::MatrixXd& tau = log.simulated.truth.tau;
  const Eigen::Index k = 100;  // t − 0.004 lies 0.4 of the way from sample 98 to sample 99
  const Eigen::RowVectorXd expected = 0.6 * tau.row(98) + 0.4 * tau.row(99);
  EXPECT_LT((log.measured.tau.row(k) - expected).norm(), 1e-9 * expected.norm());
  EXPECT_EQ(log.measured.tau.row(0), tau.row(0));  // before the start: the first sample's
  EXPECT_EQ(log.measured.tau.row(1), tau.row(0));
  o.sensors.torque_delay = -0.0025;  // one sample's lead
  EXPECT_EQ(sid::simulate_robot(ur5(), o, 5).measured.tau.row(k), tau.row(k + 1));

  o.sensors.encoder_bits = {10, 10};
  EXPECT_THROW((void)sid::simulate_robot(ur5(), o, 5), std::invalid_argument);
  o.sensors.encoder_bits = {0};
  EXPECT_THROW((void)sid::simulate_robot(ur5(), o, 5), std::invalid_argument);
  o.sensors.encoder_bits = {12};
  o.sensors.encoder_ratio = {-1.0};
  EXPECT_THROW((void)sid::simulate_robot(ur5(), o, 5), std::invalid_argument);
}

// A push is J(q)^T F for the point's Jacobian, here by central differences of its position.
TEST(SimulateRobot, APushAtTheToolIsTheTransposedJacobianTimesItsForce) {
  sid::ToolPushes pushes;
  pushes.pushes = {{0.5, 1.5, Eigen::Vector3d(10.0, -4.0, 6.0)}};
  pushes.point = Eigen::Vector3d(0.01, 0.02, 0.1);
  const auto push = sid::tool_push_torque(ur5().chain, pushes);
  ASSERT_TRUE(push);
  const Eigen::VectorXd q = (Eigen::VectorXd(6) << 0.3, -1.1, 1.4, -0.2, 0.7, 0.5).finished();
  const auto position = [&](const Eigen::VectorXd& at) {
    const sid::FramePose<double> tip = ur5().chain.forward_kinematics(at).back();
    return Eigen::Vector3d(tip.translation + tip.rotation * pushes.point);
  };
  Eigen::VectorXd expected(6);
  for (int j = 0; j < 6; ++j) {
    const double h = 1e-6;
    Eigen::VectorXd up = q, down = q;
    up[j] += h;
    down[j] -= h;
    expected[j] = (position(up) - position(down)).dot(pushes.pushes[0].force) / (2.0 * h);
  }
  const Eigen::VectorXd full = push(1.0, q);
  EXPECT_LT((full - expected).cwiseAbs().maxCoeff(), 1e-6 * expected.cwiseAbs().maxCoeff());
  EXPECT_LT((push(0.51, q) - 0.5 * full).norm(), 1e-12 * full.norm());  // half-way up the ramp
  EXPECT_EQ(push(0.2, q), Eigen::VectorXd::Zero(6));

  sid::RobotSimulationOptions o = short_run();
  o.pushes = pushes;
  std::mt19937_64 rng(5);
  const sid::SimulatedRobot s = sid::simulate_robot_truth(ur5(), o, rng);
  ASSERT_EQ(s.external.rows(), s.truth.size());
  const Eigen::Index k = 400;  // t = 1 s
  EXPECT_LT((s.external.row(k).transpose() - push(1.0, s.truth.q.row(k).transpose())).norm(),
            1e-9 * full.norm());
}

// A torque drives the arm open loop from rest at q0, and the run's torque is the one given.
TEST(SimulateRobot, ADrivingTorqueStartsFromRestAtQ0) {
  sid::RobotSimulationOptions tracked = short_run();
  std::mt19937_64 rng(2);
  const sid::SimulatedRobot reference = sid::simulate_robot_truth(ur5(), tracked, rng);
  sid::RobotSimulationOptions o;
  o.torque = sid::DrivingTorque{reference.truth.t.head(201), reference.truth.tau.topRows(201),
                                reference.truth.q.row(0).transpose()};
  const sid::SimulatedRobot driven = sid::simulate_robot_truth(ur5(), o, rng);
  ASSERT_EQ(driven.truth.size(), 201);
  EXPECT_EQ(driven.truth.q.row(0), reference.truth.q.row(0));
  EXPECT_EQ(driven.truth.qd.row(0), Eigen::RowVectorXd::Zero(6));
  EXPECT_LT((driven.truth.tau - o.torque->tau).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(SimulateRobot, JointsTakenBeyondTheirLimitsAreListed) {
  sid::RobotSimulationOptions o;
  o.torque = sid::DrivingTorque{Eigen::Vector2d(0.0, 1.0), Eigen::MatrixXd::Zero(2, 6), {}};
  o.torque->tau.col(0).setConstant(400.0);  // above shoulder_pan_joint's <limit effort>
  const sid::SimulatedRobotLog log = sid::simulate_robot(ur5(), o, 1);
  ASSERT_FALSE(log.beyond_limits.empty());
  EXPECT_EQ(log.beyond_limits.front().joint, 0);
  EXPECT_TRUE(log.beyond_limits.front().effort);
  EXPECT_DOUBLE_EQ(log.beyond_limits.front().peak_effort, 400.0);
}

TEST(SimulateRobot, RefusesWhatCannotBeSimulated) {
  sid::RobotDescription dh = ur5();
  dh.link_parameters.resize(0);
  EXPECT_THROW(sid::simulated_robot_model(dh, {}, 0.01), std::invalid_argument);
  EXPECT_THROW(
      sid::simulated_robot_model(ur5(), {effect(sid::RobotEffectKind::Coulomb, 6, 0.1)}, 0.01),
      std::invalid_argument);
  EXPECT_THROW(sid::simulated_robot_model(ur5(),
                                          {effect(sid::RobotEffectKind::Coulomb, 1, 0.1),
                                           effect(sid::RobotEffectKind::Coulomb, 1, 0.2)},
                                          0.01),
               std::invalid_argument);
  EXPECT_THROW(
      sid::simulated_robot_model(ur5(), {effect(sid::RobotEffectKind::Armature, 1, -1.0)}, 0.01),
      std::invalid_argument);

  // The TX40's last link has no inertia about its axis until a rotor is added.
  const sid::RobotDescription tx40 = sid::robot_description_from_urdf(
      file_text(SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "link_6");
  sid::RobotSimulationOptions o;
  o.duration = 0.5;
  std::mt19937_64 rng(1);
  try {
    sid::simulate_robot_truth(tx40, o, rng);
    ADD_FAILURE() << "a joint without inertia was simulated";
  } catch (const sid::JointWithoutInertia& e) {
    EXPECT_EQ(e.joint, 5);
  }
  o.effects = {effect(sid::RobotEffectKind::Armature, 5, 0.01)};
  EXPECT_EQ(sid::simulate_robot_truth(tx40, o, rng).truth.size(), 201);

  o.simulator.rtol = o.simulator.atol = 1e-30;
  EXPECT_THROW(sid::simulate_robot_truth(tx40, o, rng), sid::RobotSimulationFailed);
  o.simulator = sid::SimulatorOptions{1e-9, 1e-9};
  o.random.harmonics = 0;
  EXPECT_THROW(sid::simulate_robot_truth(tx40, o, rng), std::invalid_argument);
}
