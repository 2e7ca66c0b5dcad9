// Tests of sid/fourier_trajectory.hpp and sid/cvode/chain_experiment.hpp: the excitation's
// derivatives are its series' own (finite differences), random excitations keep their bounds,
// and a simulated six-axis arm with drive terms and a coupled wrist tracks its excitation, records
// the torques its model gives and is identified back from them.

#include <sid/cvode/chain_experiment.hpp>
#include <sid/cvode/chain_free_simulation.hpp>
#include <sid/cvode/chain_motion_check.hpp>
#include <sid/diagnose_chain.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/urdf.hpp>

#include "chain_hidden_terms.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

namespace {

sid::FourierTrajectory three_joint_series() {
  sid::FourierTrajectory f;
  f.base_frequency = 0.2;
  f.q0 = Eigen::Vector3d(0.1, -0.4, 0.3);
  f.a = Eigen::MatrixXd::Zero(3, 2);
  f.b = Eigen::MatrixXd::Zero(3, 2);
  f.a << 0.5, -0.2, 0.3, 0.1, -0.4, 0.25;
  f.b << 0.1, 0.3, -0.2, 0.05, 0.15, -0.35;
  return f;
}

}  // namespace

TEST(FourierTrajectory, RatesAreTheDerivativesAndTheRunRepeats) {
  const sid::FourierTrajectory f = three_joint_series();
  Eigen::VectorXd q(3), qd(3), qdd(3), qp(3), qdp(3), qddp(3), qm(3), qdm(3), qddm(3);
  constexpr double h = 1e-5;
  for (const double t : {0.0, 0.7, 2.3, 4.9}) {
    f.evaluate(t, q, qd, qdd);
    f.evaluate(t + h, qp, qdp, qddp);
    f.evaluate(t - h, qm, qdm, qddm);
    EXPECT_LT(((qp - qm) / (2 * h) - qd).cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_LT(((qdp - qdm) / (2 * h) - qdd).cwiseAbs().maxCoeff(), 1e-7);
    f.evaluate(t + 1.0 / f.base_frequency, qp, qdp, qddp);
    EXPECT_LT((qp - q).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((qdp - qd).cwiseAbs().maxCoeff(), 1e-12);
  }
  // One period of a pure series averages to its offset.
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(3);
  for (int k = 0; k < 1000; ++k) {
    f.evaluate(k / (1000 * f.base_frequency), q, qd, qdd);
    mean += q / 1000;
  }
  EXPECT_LT((mean - f.q0).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(FourierTrajectory, RandomSeriesKeepTheirBoundsAndRepeatForASeed) {
  const Eigen::Vector3d q0(0.0, 0.5, -0.2), range(0.8, 0.3, 1.2), rate(1.0, 2.0, 0.4);
  std::mt19937_64 a(5), b(5);
  const sid::FourierTrajectory f = sid::random_fourier_trajectory(q0, 5, 0.1, range, rate, a);
  const sid::FourierTrajectory g = sid::random_fourier_trajectory(q0, 5, 0.1, range, rate, b);
  EXPECT_EQ(f.a, g.a);
  EXPECT_EQ(f.b, g.b);
  Eigen::VectorXd q(3), qd(3), qdd(3), largest_q = Eigen::VectorXd::Zero(3),
                                       largest_qd = Eigen::VectorXd::Zero(3);
  for (int k = 0; k < 20000; ++k) {
    f.evaluate(k / (20000 * f.base_frequency), q, qd, qdd);
    largest_q = largest_q.cwiseMax((q - q0).cwiseAbs());
    largest_qd = largest_qd.cwiseMax(qd.cwiseAbs());
  }
  for (int j = 0; j < 3; ++j) {
    EXPECT_LE(largest_q[j], range[j]) << "joint " << j;
    EXPECT_LE(largest_qd[j], rate[j]) << "joint " << j;
    // one of the two bounds binds
    EXPECT_GT(std::max(largest_q[j] / range[j], largest_qd[j] / rate[j]), 0.998) << "joint " << j;
  }
  std::mt19937_64 rng(1);
  sid_test::expect_invalid_argument(
      [&] { (void)sid::random_fourier_trajectory(q0, 0, 0.1, range, rate, rng); },
      "sid::random_fourier_trajectory", "harmonics");
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::random_fourier_trajectory(q0, 3, 0.1, Eigen::Vector3d(1, 0, 1), rate, rng);
      },
      "sid::random_fourier_trajectory", "> 0");
  sid::FourierTrajectory bad = three_joint_series();
  bad.b.resize(2, 2);
  sid_test::expect_invalid_argument([&] { bad.validate(); }, "sid::FourierTrajectory",
                                    "joints x harmonics");
}

// The TX40 with every drive term and its coupled wrist motor, simulated under computed torque:
// it tracks the excitation, its recorded torques are its model's, and the identification finds
// a model that explains them.
TEST(ChainExperiment, SimulatedSixAxisArmTracksAndIsIdentifiedBack) {
  const sid::UrdfChain arm = sid::chain_from_urdf(
      sid_test::read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
  Eigen::MatrixXd gear = Eigen::MatrixXd::Zero(6, 6);
  gear.diagonal() << 32, 32, 45, -48, 45, 32;
  gear(5, 4) = 32;
  const sid::Transmission drives(gear, Eigen::VectorXd::Zero(6));
  const sid::ChainModel model(
      arm.chain, arm.joint_names,
      sid::drive_terms(
          {sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb, sid::DriveTermKind::Armature},
          drives),
      drives, 0.05);
  Eigen::VectorXd theta(model.parameters());
  theta.head(60) = arm.theta.head(60);
  for (Eigen::Index k = 60; k < theta.size(); ++k) {
    const std::string& name = model.parameter_names()[static_cast<std::size_t>(k)];
    theta[k] = name.rfind("Ia_", 0) == 0 ? 0.01 : name.rfind("fc_", 0) == 0 ? 0.3 : 0.8;
  }
  std::mt19937_64 rng(40);
  const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
      Eigen::VectorXd::Zero(6), 5, 0.25, Eigen::VectorXd::Constant(6, 1.0),
      Eigen::VectorXd::Constant(6, 1.5), rng);
  sid::ChainExperiment experiment;
  experiment.duration = 4.0;
  const sid::ChainExperimentResult run =
      sid::simulate_chain_experiment(model, theta, desired, experiment);
  ASSERT_TRUE(run.ok()) << run.message;
  ASSERT_EQ(run.truth.t.size(), 4001);
  Eigen::VectorXd q(6), qd(6), qdd(6);
  double tracking = 0.0, consistency = 0.0;
  for (Eigen::Index k = 0; k < run.truth.t.size(); k += 50) {
    desired.evaluate(run.truth.t[k], q, qd, qdd);
    tracking = std::max(tracking, (run.truth.q.row(k).transpose() - q).cwiseAbs().maxCoeff());
    const sid::ChainModel::Vector qk = run.truth.q.row(k).transpose(),
                                  qdk = run.truth.qd.row(k).transpose(),
                                  qddk = run.truth.qdd.row(k).transpose();
    consistency = std::max(consistency, (model.model().inverse_dynamics(theta, qk, qdk, qddk) -
                                         run.truth.tau.row(k).transpose())
                                            .cwiseAbs()
                                            .maxCoeff());
  }
  EXPECT_LT(tracking, 1e-7);      // the feedforward is exact; CVODE's error is what is left
  EXPECT_LT(consistency, 1e-10);  // the recorded torque is the model's at the recorded state
  const sid::ChainIdentification id = sid::identify_chain(model, {run.trajectory()});
  EXPECT_LT(id.fitted.relative_residual, 1e-3);
}

TEST(ChainExperiment, RefusesWhatDoesNotFit) {
  const sid::UrdfChain arm = sid::chain_from_urdf(
      sid_test::read_text("staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
  const sid::Transmission direct(Eigen::MatrixXd::Identity(6, 6), Eigen::VectorXd::Zero(6));
  const sid::ChainModel model(arm.chain, arm.joint_names,
                              sid::drive_terms({sid::DriveTermKind::Armature}, direct), direct);
  const Eigen::VectorXd theta = Eigen::VectorXd::Ones(model.parameters());
  sid_test::expect_invalid_argument(
      [&] { (void)sid::simulate_chain_experiment(model, theta, three_joint_series()); },
      "sid::simulate_chain_experiment", "the trajectory 3 joints");
  sid::FourierTrajectory six = three_joint_series();
  six.q0 = Eigen::VectorXd::Zero(6);
  six.a = six.b = Eigen::MatrixXd::Zero(6, 2);
  sid_test::expect_invalid_argument(
      [&] { (void)sid::simulate_chain_experiment(model, theta.head(10), six); },
      "sid::simulate_chain_experiment", "theta 10 entries");
  sid::ChainExperiment bad;
  bad.sample_time = -1.0;
  sid_test::expect_invalid_argument(
      [&] { (void)sid::simulate_chain_experiment(model, theta, six, bad); }, "sid::sample_grid",
      "sample_time");
}

// sid::free_chain_simulation: driven by the torque the simulator applied, the exact model
// reproduces the motion it made; a model without the Coulomb friction the arm has drifts, on
// the joint that has it.

namespace {

struct Experiment {
  sid::ChainModel model = sid_test::tx40_nominal();
  Eigen::VectorXd theta;
  sid::ChainKinematics<double> truth;

  explicit Experiment(double coulomb_j3) {
    const sid::Transmission direct(6);
    std::vector<sid::DriveTerm> terms = model.terms();
    terms.push_back({sid::DriveTermKind::Coulomb, 2, false});
    model = sid::ChainModel(sid_test::tx40_arm().chain, sid_test::tx40_arm().joint_names, terms,
                            direct, 0.05);
    theta = Eigen::VectorXd::Zero(model.parameters());
    theta.head(60) = sid_test::tx40_arm().theta.head(60);
    theta.segment(60, 6).setConstant(0.5);   // viscous
    theta.segment(66, 6).setConstant(0.01);  // rotors
    theta[72] = coulomb_j3;
    std::mt19937_64 rng(7);
    const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
        Eigen::VectorXd::Zero(6), 5, 0.25, Eigen::VectorXd::Constant(6, 1.0),
        Eigen::VectorXd::Constant(6, 1.5), rng);
    sid::ChainExperiment experiment;
    experiment.duration = 3.0;
    experiment.sample_time = 0.002;
    const sid::ChainExperimentResult run =
        sid::simulate_chain_experiment(model, theta, desired, experiment);
    EXPECT_TRUE(run.ok()) << run.message;
    truth = run.truth;
  }
};

TEST(ChainFreeSimulation, ExactModelReproducesTheMotionAndAMissingFrictionDrifts) {
  const Experiment e(1.0);
  const sid::ChainFreeSimulation exact = sid::free_chain_simulation(e.model, e.theta, e.truth);
  ASSERT_TRUE(exact.ok()) << exact.message;
  EXPECT_GE(exact.segments, 3);  // 1 s each; the grid may put the third boundary just past 3 s
  EXPECT_LE(exact.segments, 4);
  // What is left is the torque's linear interpolation between the 2 ms samples (2e-5 rad).
  for (int j = 0; j < 6; ++j) EXPECT_LT(exact.error_rms[j], 1e-4) << j;

  Eigen::VectorXd without = e.theta;
  without[72] = 0.0;
  const sid::ChainFreeSimulation missing = sid::free_chain_simulation(e.model, without, e.truth);
  ASSERT_TRUE(missing.ok()) << missing.message;
  EXPECT_GT(missing.error_rms[2], 1e-3);
  EXPECT_GT(missing.error_rms[2], 100.0 * exact.error_rms[2]);

  // One segment over the whole run: the same start, so the first samples agree with the above.
  sid::ChainFreeSimulationOptions whole;
  whole.segment = 10.0;
  const sid::ChainFreeSimulation one = sid::free_chain_simulation(e.model, e.theta, e.truth, whole);
  EXPECT_EQ(one.segments, 1);
  EXPECT_LT((one.q.topRows(100) - exact.q.topRows(100)).cwiseAbs().maxCoeff(), 1e-6);
}

// The motion check against exact-model replicates: on a log the nominal model explains no joint
// is flagged, and every threshold is the margin over replicates that ran; where a spring the
// model lacks moves joint 5 (the nominal model kept), that joint is flagged. The replicates'
// figures do not depend on the thread count.
TEST(ChainMotionCheck, FlagsOnlyAMotionTheModelLacksAgainstItsExactModelReplicates) {
#ifdef SID_SANITIZED_TESTS  // the sanitizers check memory, not the numbers: a short log
  const double duration = 3.0;
#else
  const double duration = 8.0;
#endif
  const sid::ChainModel nominal = sid_test::tx40_nominal();
  Eigen::VectorXd prior = Eigen::VectorXd::Zero(nominal.parameters());
  prior.head(60) = sid_test::tx40_arm().theta.head(60);
  sid::ChainMotionCheckOptions options;
  options.replicates = 3;

  const sid::ChainTrajectory<double> exact = sid_test::tx40_hidden_term_run({}, 1, duration);
  const sid::ChainDiagnosis d = sid::diagnose_chain(nominal, {exact});
  ASSERT_TRUE(d.named.empty());
  options.threads = 1;
  const sid::ChainMotionCheck serial =
      sid::check_chain_motion(nominal, d, {exact}, {}, prior, options);
  options.threads = 2;
  const sid::ChainMotionCheck m = sid::check_chain_motion(nominal, d, {exact}, {}, prior, options);
  ASSERT_EQ(m.replicate_error.rows(), 3);
  EXPECT_EQ(m.replicate_error, serial.replicate_error);
  EXPECT_EQ(m.final_error, serial.final_error);
  EXPECT_EQ(m.nominal_error, m.final_error) << "nothing named: one model";
  EXPECT_GT(m.segments, 0);
  for (int j = 0; j < 6; ++j) {
    // The angle noise as drawn (1e-4 rad), from the smoothing's residual.
    EXPECT_NEAR(m.angle_noise[j], 1e-4, 2e-5) << j;
    EXPECT_GT(m.replicate_error.col(j).minCoeff(), 0.0) << j;
    EXPECT_DOUBLE_EQ(m.threshold[j], options.margin * m.replicate_error.col(j).maxCoeff()) << j;
  }
#ifndef SID_SANITIZED_TESTS
  EXPECT_TRUE(m.beyond.empty()) << "joint " << m.beyond.front() + 1;

  const sid::DriveTerm spring{sid::DriveTermKind::Spring, 4, false};
  const sid::ChainTrajectory<double> sprung =
      sid_test::tx40_hidden_term_run({{spring, 1.5}}, 1, duration);
  // The nominal model kept as if nothing had been named, at the exact log's cutoffs and noise.
  sid::ChainDiagnosis lacking = d;
  lacking.kinematics = {sid::smooth_chain_run(sprung, d.cutoff_hz)};
  const sid::ChainMotionCheck flagged =
      sid::check_chain_motion(nominal, lacking, {sprung}, {}, prior, options);
  EXPECT_NE(std::find(flagged.beyond.begin(), flagged.beyond.end(), 4), flagged.beyond.end())
      << "joint 5: " << flagged.final_error[4] << " against " << flagged.threshold[4];
#endif

  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::check_chain_motion(nominal, d, {exact, exact}, {}, prior, options);
      },
      "sid::check_chain_motion", "does not belong");
  sid_test::expect_invalid_argument(
      [&] { (void)sid::check_chain_motion(nominal, d, {exact}, {}, prior.head(10), options); },
      "sid::check_chain_motion", "prior");
  options.margin = 0.5;
  sid_test::expect_invalid_argument(
      [&] { (void)sid::check_chain_motion(nominal, d, {exact}, {}, prior, options); },
      "sid::check_chain_motion", "margin");
}

TEST(ChainExperiment, GivenTorqueDrivesTheArmWhereTheTrackedRunWent) {
  // The torque a tracked run applied, given back open loop from the same start: the same motion,
  // up to the torque's linear interpolation between the 2 ms samples.
  const Experiment e(1.0);
  const Eigen::Index m = 501;  // the first second
  Eigen::VectorXd x0(12);
  x0 << e.truth.q.row(0).transpose(), e.truth.qd.row(0).transpose();
  const sid::ChainExperimentResult run =
      sid::simulate_chain_torque(e.model, e.theta, e.truth.t.head(m), e.truth.tau.topRows(m), x0);
  ASSERT_TRUE(run.ok()) << run.message;
  ASSERT_EQ(run.truth.t.size(), m);
  EXPECT_LT((run.truth.q - e.truth.q.topRows(m)).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_LT((run.truth.qd - e.truth.qd.topRows(m)).cwiseAbs().maxCoeff(), 1e-3);
  EXPECT_EQ(run.truth.tau, e.truth.tau.topRows(m));
  // The recorded accelerations are the model's at the recorded states.
  for (Eigen::Index k = 0; k < m; k += 100) {
    const sid::ChainModel::Vector q = run.truth.q.row(k).transpose(),
                                  qd = run.truth.qd.row(k).transpose(),
                                  qdd = run.truth.qdd.row(k).transpose();
    EXPECT_LT(
        (e.model.model().inverse_dynamics(e.theta, q, qd, qdd) - run.truth.tau.row(k).transpose())
            .cwiseAbs()
            .maxCoeff(),
        1e-8);
  }
  // A torque that spins the first joint away stops at the blow-up bound, as a failure.
  Eigen::MatrixXd spin = e.truth.tau.topRows(m);
  spin.col(0).setConstant(1e7);
  const sid::ChainExperimentResult away =
      sid::simulate_chain_torque(e.model, e.theta, e.truth.t.head(m), spin, x0);
  EXPECT_FALSE(away.ok());
  EXPECT_NE(away.message.find("blow-up"), std::string::npos) << away.message;
  EXPECT_LT(away.truth.t.size(), m);
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::simulate_chain_torque(e.model, e.theta, e.truth.t.head(m),
                                         e.truth.tau.topRows(m - 1), x0);
      },
      "sid::simulate_chain_torque", "times");
}

TEST(ChainFreeSimulation, ThrowsOnBadInput) {
  const Experiment e(0.5);
  sid_test::expect_invalid_argument(
      [&] { (void)sid::free_chain_simulation(e.model, e.theta.head(10), e.truth); },
      "sid::free_chain_simulation", "parameters");
  sid::ChainKinematics<double> backwards = e.truth;
  backwards.t[5] = backwards.t[4];
  sid_test::expect_invalid_argument(
      [&] { (void)sid::free_chain_simulation(e.model, e.theta, backwards); },
      "sid::free_chain_simulation", "increase");
  sid::ChainFreeSimulationOptions bad;
  bad.segment = 0.0;
  sid_test::expect_invalid_argument(
      [&] { (void)sid::free_chain_simulation(e.model, e.theta, e.truth, bad); },
      "sid::free_chain_simulation", "segment");
}

}  // namespace
