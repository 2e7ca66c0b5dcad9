#include <sid/torque_delay.hpp>

#include <sid/cvode/simulate_robot.hpp>
#include <sid/least_squares.hpp>

#include "chain_simulation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

namespace {

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// The SO-101, a light five-axis hobby arm (0.5 kg moving), to its gripper frame.
const sid::RobotDescription& so101() {
  static const sid::RobotDescription robot = sid::robot_description_from_urdf(
      file_text(SID_TEST_DATA_DIR "/urdf/real/so101.urdf"), "base_link", "gripper_frame_link");
  return robot;
}

/// The samples of the simulated truth inside the fit's window (the default skips, 0.1 s).
std::vector<Eigen::Index> window(const sid::ChainKinematics<double>& k) {
  std::vector<Eigen::Index> at;
  for (Eigen::Index i = 0; i < k.t.size(); ++i)
    if (k.t[i] >= k.t[0] + 0.1 && k.t[i] <= k.t[k.t.size() - 1] - 0.1) at.push_back(i);
  return at;
}

/// The exact motion's regressor on the base columns over the window, and the true torque.
void true_equations(const sid::SimulatedRobot& truth, const std::vector<Eigen::Index>& columns,
                    Eigen::MatrixXd& x, Eigen::VectorXd& tau) {
  const sid::ChainModel& model = truth.model;
  const int n = model.joints();
  const sid::ChainKinematics<double>& k = truth.truth;
  const std::vector<Eigen::Index> at = window(k);
  x.resize(static_cast<Eigen::Index>(at.size()) * n, static_cast<Eigen::Index>(columns.size()));
  tau.resize(x.rows());
  Eigen::MatrixXd y(n, model.parameters());
  for (std::size_t a = 0; a < at.size(); ++a) {
    const Eigen::Index i = at[a];
    model.regressor(k.q.row(i).transpose(), k.qd.row(i).transpose(), k.qdd.row(i).transpose(), y);
    x.middleRows(static_cast<Eigen::Index>(a) * n, n) = y(Eigen::all, columns);
    tau.segment(static_cast<Eigen::Index>(a) * n, n) = y * truth.theta;
  }
}

/// ‖X β − τ‖ / ‖τ‖ over the true equations: how well β predicts the true torque.
double true_torque_error(const Eigen::MatrixXd& x, const Eigen::VectorXd& tau,
                         const Eigen::VectorXd& beta) {
  return (x * beta - tau).norm() / tau.norm();
}

}  // namespace

// Exact torques logged 7 ms behind the angles (and 4 ms ahead of them) on a jittered 1 kHz grid.
// Smoothed at 32 Hz, where the spline follows the motion closely, the delay is found to 1 % of a
// sample. At the cutoff the cross-validation picks (5.7 Hz) the smoothing's own error moves it
// by a fraction of a millisecond, which its standard deviation covers.
TEST(TorqueDelay, FindsTheLagOfExactTorquesToAFractionOfASample) {
  const sid_test::SimulatedArm arm;
  for (const double delay : {0.007, -0.004}) {
    const std::vector<sid::ChainTrajectory<double>> runs = {arm.run(6.0, 1, 0.0, delay)};
    sid::ChainIdentifyOptions options;
    options.cutoff_hz = {32.0};
    const sid::TorqueDelayEstimate sharp = sid::estimate_torque_delay(arm.model, runs, options);
    EXPECT_NEAR(sharp.delay, delay, 1e-5);
    EXPECT_LT(sharp.std_dev, 1e-4);
    EXPECT_EQ(sharp.cutoff_hz, 32.0);
    EXPECT_FALSE(sharp.at_bound);
    ASSERT_EQ(sharp.delays.size(), 33);
    EXPECT_DOUBLE_EQ(sharp.delays[0], -0.02);
    EXPECT_DOUBLE_EQ(sharp.delays[32], 0.02);
    // The coarse profile's least residual lies next to the delay.
    Eigen::Index best = 0;
    sharp.mean_square_residual.minCoeff(&best);
    EXPECT_NEAR(sharp.delays[best], delay, 0.02 / 16.0);

    const sid::TorqueDelayEstimate chosen = sid::estimate_torque_delay(arm.model, runs);
    EXPECT_LT(chosen.cutoff_hz, 32.0);
    EXPECT_LT(std::abs(chosen.delay - delay), 3.0 * chosen.std_dev);
    EXPECT_LT(chosen.std_dev, 1e-3);
  }
}

TEST(TorqueDelay, SaysWhenTheLagLiesBeyondTheSearch) {
  const sid_test::SimulatedArm arm;
  sid::TorqueDelaySearch search;
  search.max_delay = 0.01;
  const sid::TorqueDelayEstimate d =
      sid::estimate_torque_delay(arm.model, {arm.run(4.0, 1, 0.0, 0.02)}, {}, search);
  EXPECT_TRUE(d.at_bound);
  EXPECT_GT(d.delay, 0.009);
}

TEST(TorqueDelay, RefusesASearchItCannotMake) {
  const sid_test::SimulatedArm arm;
  const std::vector<sid::ChainTrajectory<double>> runs = {arm.run(2.0, 1, 0.0)};
  for (const double max : {0.0, -0.01, 0.2, std::nan("")}) {
    sid::TorqueDelaySearch search;
    search.max_delay = max;
    EXPECT_THROW((void)sid::estimate_torque_delay(arm.model, runs, {}, search),
                 std::invalid_argument)
        << max;
  }
  EXPECT_THROW((void)sid::estimate_torque_delay(arm.model, {}), std::invalid_argument);
  sid::ChainTrajectory<double> two_joints = runs[0];
  two_joints.q = two_joints.q.leftCols(2).eval();
  two_joints.tau = two_joints.tau.leftCols(2).eval();
  EXPECT_THROW((void)sid::estimate_torque_delay(arm.model, {two_joints}), std::invalid_argument);
}

// A cheap arm's log: 12-bit encoders on the joints (1.5e-3 rad steps), servo torques 2 ms
// behind the angles with 1e-3 N m of noise. The delay is found within 0.5 ms, and the fit
// paired at it predicts the true torque about as well as least squares on the exact motion
// and torque (the oracle), where the fit that ignores the delay has five times its error.
TEST(TorqueDelay, FindsA2msLagOfALightArmWith12BitEncoders) {
  sid::RobotSimulationOptions o;
  o.noise = {0.0, 1e-6};
  o.sensors.encoder_bits = {12};
  // The same draws of noise: the torque as logged without the delay.
  const sid::SimulatedRobotLog plain = sid::simulate_robot(so101(), o, 1);
  o.sensors.torque_delay = 0.002;
  const sid::SimulatedRobotLog log = sid::simulate_robot(so101(), o, 1);
  const sid::ChainModel& model = log.simulated.model;

  sid::ChainIdentifyOptions options;
  const sid::TorqueDelayEstimate d = sid::estimate_torque_delay(model, {log.measured}, options);
  EXPECT_NEAR(d.delay, 0.002, 5e-4);
  EXPECT_LT(std::abs(d.delay - 0.002), 3.0 * d.std_dev);
  EXPECT_LT(d.std_dev, 5e-4);

  options.torque_delay = d.delay;
  const sid::ChainIdentification id = sid::identify_chain(model, {log.measured}, options);
  ASSERT_TRUE(id.fit.ok()) << id.fit.message;
  // The encoders' staircase keeps one cutoff for every joint.
  EXPECT_EQ(id.cutoff_hz.maxCoeff(), id.cutoff_hz.minCoeff());
  const auto error_of = [&](const sid::ChainIdentification& fit) {
    Eigen::MatrixXd x;
    Eigen::VectorXd tau;
    true_equations(log.simulated, fit.base.independent, x, tau);
    return true_torque_error(x, tau, fit.fit.theta);
  };
  Eigen::MatrixXd x;
  Eigen::VectorXd tau;
  true_equations(log.simulated, id.base.independent, x, tau);
  const std::vector<Eigen::Index> at = window(log.simulated.truth);
  Eigen::VectorXd logged(tau.size());
  for (std::size_t a = 0; a < at.size(); ++a)
    logged.segment(static_cast<Eigen::Index>(a) * 5, 5) = plain.measured.tau.row(at[a]).transpose();
  const double oracle = true_torque_error(x, tau, sid::least_squares(x, logged).theta);
  const double estimated = error_of(id);
  EXPECT_LT(estimated, 1.3 * oracle);

  sid::ChainIdentifyOptions ignoring = options;
  ignoring.torque_delay = 0.0;
  EXPECT_GT(error_of(sid::identify_chain(model, {log.measured}, ignoring)), 3.0 * estimated);

  // No delay: none found.
  const sid::TorqueDelayEstimate none = sid::estimate_torque_delay(model, {plain.measured});
  EXPECT_LT(std::abs(none.delay), 3.0 * none.std_dev);
  EXPECT_LT(std::abs(none.delay), 5e-4);
}
