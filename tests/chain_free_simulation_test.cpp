// Tests of sid::free_chain_simulation: driven by the torque the simulator applied, the exact
// model reproduces the motion it made; a model without the Coulomb friction the arm has drifts,
// on the joint that has it.

#include <sid/cvode/chain_free_simulation.hpp>

#include <gtest/gtest.h>

#include <random>
#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>

#include "chain_hidden_terms.hpp"
#include "test_support.hpp"

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
