// Tests of sid::free_simulation (include/sid/cvode/free_simulation.hpp): against the exact
// trajectory of the paper's experiment, against independent simulations of a wrong model (one
// run and segment by segment), the restart grid, numerical failures and bad input.

#include <sid/cvode/diagnose.hpp>
#include <sid/cvode/experiment.hpp>
#include <sid/cvode/free_simulation.hpp>
#include <sid/model/effects.hpp>
#include <sid/model/two_link_arm.hpp>

#include "hidden_effect_data.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string>

namespace {

// The exact model on the exact kinematics: what is left is the interpolation of the sampled
// torque and CVODE at 1e-9 (the brief's bound; linear interpolation of the torque gives 5e-6).
constexpr double kExactTol = 1e-6;  // [rad]
// A free simulation with a wrong theta against an independent simulation of that wrong arm
// driven by the exact input: the same two error sources.
constexpr double kReferenceTol = 1e-6;  // [rad]
// The torque low-pass keeps the angle error that white torque noise causes: its RMS within
// 10 %, and the RMS of what it changes below 20 % of that error (measured: 5 % on joint 1,
// 14 % on joint 2, whose small inertia follows the noise up to ~30 Hz).
constexpr double kFilterRmsRelTol = 0.1;
constexpr double kFilterDifferenceFraction = 0.2;
// Doubling theta6 must be visible far above the exact-model error.
constexpr double kWrongModelFactor = 100.0;

sid::Kinematics<double> paper_truth(const sid::TwoLinkParameters<double>& theta) {
  auto fd = [&theta](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                     const sid::Vector2<double>& tau) {
    return sid::two_link_forward_dynamics(theta, q, qd, tau, sid::kPaperGravity);
  };
  const sid::ExperimentResult run = sid::simulate_arm_experiment(fd);
  EXPECT_TRUE(run.ok()) << run.message;
  return run.truth;
}

Eigen::VectorXd as_vector(const sid::TwoLinkParameters<double>& theta) { return theta; }

class FreeSimulationPaper : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    truth_ = new sid::Kinematics<double>(paper_truth(sid::paper_arm_parameters()));
  }
  static void TearDownTestSuite() {
    delete truth_;
    truth_ = nullptr;
  }
  static const sid::Kinematics<double>& truth() { return *truth_; }
  static sid::Kinematics<double>* truth_;
};
sid::Kinematics<double>* FreeSimulationPaper::truth_ = nullptr;

TEST_F(FreeSimulationPaper, ExactModelReproducesExactAnglesInEverySegmentLength) {
  const sid::Model<double> model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = as_vector(sid::paper_arm_parameters());
  for (double segment : {1.0, 0.37, std::numeric_limits<double>::infinity(), 0.0}) {
    sid::FreeSimulationOptions options;
    options.segment = segment;
    const sid::FreeSimulation sim = sid::free_simulation(model, theta, truth(), options);
    ASSERT_TRUE(sim.ok()) << sim.message;
    EXPECT_TRUE(sim.message.empty());
    EXPECT_EQ(sim.t.size(), truth().size());
    ASSERT_TRUE(sim.error.allFinite());
    EXPECT_LT(sim.error.cwiseAbs().maxCoeff(), kExactTol) << "segment " << segment;
    EXPECT_TRUE(sim.error.isApprox(truth().q - sim.q)) << "error = measured - simulated";
    for (int j = 0; j < 2; ++j)
      EXPECT_NEAR(sim.error_rms[j], std::sqrt(sim.error.col(j).squaredNorm() / sim.t.size()),
                  1e-15);
  }
}

TEST_F(FreeSimulationPaper, WrongModelMatchesAnIndependentSimulationOfThatModel) {
  sid::TwoLinkParameters<double> wrong = sid::paper_arm_parameters();
  wrong[5] *= 2.0;
  const sid::Kinematics<double> reference = paper_truth(wrong);  // same input, same start
  sid::FreeSimulationOptions options;
  options.segment = std::numeric_limits<double>::infinity();
  const sid::FreeSimulation sim =
      sid::free_simulation(sid::two_link_arm_model<double>(), as_vector(wrong), truth(), options);
  ASSERT_TRUE(sim.ok()) << sim.message;
  EXPECT_LT((sim.q - reference.q).cwiseAbs().maxCoeff(), kReferenceTol);

  const sid::FreeSimulation exact = sid::free_simulation(
      sid::two_link_arm_model<double>(), as_vector(sid::paper_arm_parameters()), truth(), options);
  ASSERT_TRUE(exact.ok()) << exact.message;
  EXPECT_GT(sim.error_rms[0], kWrongModelFactor * exact.error_rms[0]);
  EXPECT_GT(sim.error_rms[1], kWrongModelFactor * exact.error_rms[1]);
}

TEST_F(FreeSimulationPaper, SegmentsRestartFromTheMeasuredState) {
  // Each segment of a wrong model equals an independent simulation of that model started at the
  // segment's true state and driven by the (time-shifted) exact input.
  sid::TwoLinkParameters<double> wrong = sid::paper_arm_parameters();
  wrong[6] *= 2.0;
  wrong[3] *= 1.1;
  sid::FreeSimulationOptions options;
  options.segment = 2.0;
  const sid::FreeSimulation sim =
      sid::free_simulation(sid::two_link_arm_model<double>(), as_vector(wrong), truth(), options);
  ASSERT_TRUE(sim.ok()) << sim.message;
  ASSERT_EQ(sim.segment_starts.size(), 5u);  // 10 s in 2 s segments
  auto fd = [&wrong](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                     const sid::Vector2<double>& tau) {
    return sid::two_link_forward_dynamics(wrong, q, qd, tau, sid::kPaperGravity);
  };
  for (std::size_t s = 0; s < sim.segment_starts.size(); ++s) {
    const Eigen::Index begin = sim.segment_starts[s];
    EXPECT_NEAR(truth().t[begin], 2.0 * static_cast<double>(s), 1e-12);
    const Eigen::Index end =
        s + 1 < sim.segment_starts.size() ? sim.segment_starts[s + 1] : truth().size();
    EXPECT_EQ(sim.error.row(begin).norm(), 0.0) << "a segment starts on the measured angles";
    const double t0 = truth().t[begin];
    sid::ArmExperiment experiment;
    experiment.duration = truth().t[end - 1] - t0;
    experiment.q0 = truth().q.row(begin).transpose();
    experiment.qd0 = truth().qd.row(begin).transpose();
    const auto shifted = [t0](double t) { return sid::PaperInput()(t + t0); };
    const sid::ExperimentResult run = sid::simulate_arm_experiment(fd, shifted, experiment);
    ASSERT_TRUE(run.ok()) << run.message;
    ASSERT_EQ(run.truth.size(), end - begin);
    EXPECT_LT((sim.q.middleRows(begin, end - begin) - run.truth.q).cwiseAbs().maxCoeff(),
              kReferenceTol)
        << "segment " << s;
  }
}

TEST_F(FreeSimulationPaper, TorqueFilterKeepsWhatTheNoiseDoesToTheAngles) {
  // White torque noise of sid_simulate's default sigma_tau = 0.1 N m on the exact experiment:
  // the error is then the response to the noise alone. The 20 Hz low-pass that lets CVODE take
  // long steps must keep it: the low-frequency content drives the random walk.
  sid::Kinematics<double> noisy = truth();
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 0.1);
  for (Eigen::Index i = 0; i < noisy.size(); ++i)
    for (int j = 0; j < 2; ++j) noisy.tau(i, j) += normal(rng);
  const sid::Model<double> model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = as_vector(sid::paper_arm_parameters());
  const sid::FreeSimulation filtered = sid::free_simulation(model, theta, noisy);
  sid::FreeSimulationOptions raw_options;
  raw_options.torque_bandwidth = 0.0;
  const sid::FreeSimulation raw = sid::free_simulation(model, theta, noisy, raw_options);
  ASSERT_TRUE(filtered.ok() && raw.ok()) << filtered.message << raw.message;
  EXPECT_TRUE(filtered.torque_filtered);
  EXPECT_FALSE(raw.torque_filtered);
  for (int j = 0; j < 2; ++j) {
    // Theory for the viscous random walk: sigma_tau sqrt(Ts t) / theta_friction ~ 5e-3 rad
    // after 1 s; the RMS over a segment is below that, gravity and coupling change it little.
    EXPECT_GT(raw.error_rms[j], 1e-3) << j;
    EXPECT_LT(raw.error_rms[j], 1e-2) << j;
    EXPECT_NEAR(filtered.error_rms[j] / raw.error_rms[j], 1.0, kFilterRmsRelTol) << j;
  }
  for (int j = 0; j < 2; ++j) {
    const double difference =
        std::sqrt((filtered.q - raw.q).col(j).squaredNorm() / static_cast<double>(raw.q.rows()));
    EXPECT_LT(difference, kFilterDifferenceFraction * raw.error_rms[j]) << j;
  }
  EXPECT_LT(filtered.statistics.steps, raw.statistics.steps / 2) << "the point of the filter";

  // A non-uniform grid is not filtered (a Butterworth filter needs uniform sampling).
  sid::Kinematics<double> uneven = truth();
  uneven.t[5] += 1e-4;
  const sid::FreeSimulation unfiltered = sid::free_simulation(model, theta, uneven);
  EXPECT_TRUE(unfiltered.ok()) << unfiltered.message;
  EXPECT_FALSE(unfiltered.torque_filtered);
}

TEST_F(FreeSimulationPaper, BlowUpIsReportedNotThrownAndDoesNotHang) {
  sid::TwoLinkParameters<double> unstable = sid::paper_arm_parameters();
  unstable[5] = -5.0;  // negative damping: growth ~ 5 / theta1 ~ 150 1/s
  unstable[6] = -5.0;  // ~ 5 / theta2 ~ 1600 1/s
  const auto start = std::chrono::steady_clock::now();
  const sid::FreeSimulation sim =
      sid::free_simulation(sid::two_link_arm_model<double>(), as_vector(unstable), truth());
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(sim.ok());
  EXPECT_GT(sim.failed_segments, 0);
  EXPECT_NE(sim.message.find("segment 1 of 10"), std::string::npos) << sim.message;
  EXPECT_LT(seconds, 20.0) << "a diverging model must stop early";
  // The rows a failed segment did not reach are NaN; every segment starts on the measured state.
  EXPECT_FALSE(sim.q.allFinite());
  for (Eigen::Index begin : sim.segment_starts) EXPECT_EQ(sim.error.row(begin).norm(), 0.0);
}

TEST_F(FreeSimulationPaper, SingularMassMatrixIsAStatusNotACrash) {
  // theta1 = theta2 = theta3 = 0: D = 0, qdd = 0/0.
  sid::TwoLinkParameters<double> singular = sid::paper_arm_parameters();
  singular.head<3>().setZero();
  const sid::FreeSimulation sim =
      sid::free_simulation(sid::two_link_arm_model<double>(), as_vector(singular), truth());
  EXPECT_FALSE(sim.ok());
  EXPECT_FALSE(sim.message.empty());
}

TEST(FreeSimulation, ThrowsOnBadInput) {
  const sid::Model<double> model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters();
  sid::Kinematics<double> k;
  k.t = Eigen::VectorXd::LinSpaced(5, 0.0, 0.01);
  k.q = sid::MatrixX2<double>::Zero(5, 2);
  k.qd = k.q;
  k.qdd = k.q;
  k.tau = k.q;
  const std::string who = "sid::free_simulation";
  using sid_test::expect_invalid_argument;
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta.head(6), k); }, who,
                          "theta");
  Eigen::VectorXd nan_theta = theta;
  nan_theta[2] = std::nan("");
  expect_invalid_argument([&] { (void)sid::free_simulation(model, nan_theta, k); }, who, "theta");
  auto bad = k;
  bad.tau(3, 1) = std::nan("");
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, bad); }, who, "k.tau");
  bad = k;
  bad.t[3] = bad.t[2];
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, bad); }, who,
                          "strictly increasing");
  bad = k;
  bad.qd.conservativeResize(4, 2);
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, bad); }, who, "qd");
  bad = k;
  bad.q(0, 0) = std::numeric_limits<double>::infinity();
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, bad); }, who, "k.q");
  bad.t.resize(1);
  bad.q = k.q.topRows(1);
  bad.qd = k.qd.topRows(1);
  bad.tau = k.tau.topRows(1);
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, bad); }, who, "2 samples");
  sid::FreeSimulationOptions options;
  options.segment = std::nan("");
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, k, options); }, who,
                          "segment");
  options = {};
  options.blow_up = 0.0;
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, k, options); }, who,
                          "blow_up");
  options = {};
  options.simulator.rtol = -1.0;
  expect_invalid_argument([&] { (void)sid::free_simulation(model, theta, k, options); },
                          "sid::simulate", "rtol");
}

TEST(FreeSimulation, SegmentStartsFollowTheClockAndSkipGaps) {
  Eigen::VectorXd t(9);
  t << 0.0, 0.4, 0.8, 1.0, 1.2, 3.5, 3.9, 4.1, 5.0;
  const auto starts = sid::detail::segment_starts(t, 1.0);
  // Boundaries at 1, 2 (in the gap: starts at 3.5 with the next one at 4) and 4; 5 is the last
  // sample, where a segment would simulate nothing.
  ASSERT_EQ(starts.size(), 4u);
  EXPECT_EQ(starts[0], 0);
  EXPECT_EQ(starts[1], 3);
  EXPECT_EQ(starts[2], 5);
  EXPECT_EQ(starts[3], 7);
  EXPECT_EQ(sid::detail::segment_starts(t, 0.0).size(), 1u);
  EXPECT_EQ(sid::detail::segment_starts(t, -1.0).size(), 1u);
}

// simulation_windows (sid/cvode/diagnose.hpp) is the CVODE layer's window check; it has no
// CVODE of its own, so it is tested here on a hand-made error profile.
// The C2 torque (the natural interpolating spline) against independent facts: it passes
// through every sample, reproduces a straight line exactly, is O(h^4) accurate inside a smooth
// curve (the C1 Hermite only O(h^3)), and its second derivative has no jumps at the samples.
TEST(TorqueInterpolator, C2JoinsInterpolateReproduceLinesAndAreFourthOrderInside) {
  const Eigen::Index n = 201;
  const double h = 0.01;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(n, 0.0, h * static_cast<double>(n - 1));
  sid::MatrixX2<double> tau(n, 2);
  tau.col(0) = (1.3 * t.array()).sin();
  tau.col(1) = 0.5 - 2.0 * t.array();
  const sid::detail::TorqueInterpolator c2(t, tau, sid::detail::TorqueJoins::C2);
  const sid::detail::TorqueInterpolator c1(t, tau, sid::detail::TorqueJoins::C1);
  double knot_error = 0.0, line_error = 0.0, inner_c2 = 0.0, inner_c1 = 0.0, curvature_jump = 0.0;
  for (Eigen::Index i = 0; i + 1 < n; ++i) {
    knot_error = std::max(knot_error, (c2(t[i]) - tau.row(i).transpose()).cwiseAbs().maxCoeff());
    const double middle = t[i] + 0.37 * h;
    line_error = std::max(line_error, std::fabs(c2(middle)[1] - (0.5 - 2.0 * middle)));
    if (i >= 50 && i < n - 50) {  // away from the natural ends, whose zero curvature is not sin's
      inner_c2 = std::max(inner_c2, std::fabs(c2(middle)[0] - std::sin(1.3 * middle)));
      inner_c1 = std::max(inner_c1, std::fabs(c1(middle)[0] - std::sin(1.3 * middle)));
      // Second differences just left and right of the sample t[i].
      const double e = 1e-3 * h;
      const auto second = [&](double at) {
        return (c2(at + e)[0] - 2.0 * c2(at)[0] + c2(at - e)[0]) / (e * e);
      };
      curvature_jump =
          std::max(curvature_jump, std::fabs(second(t[i] - 2 * e) - second(t[i] + 2 * e)));
    }
  }
  EXPECT_LT(knot_error, 1e-14);
  EXPECT_LT(line_error, 1e-13);
  // The spline's error bound inside: 5/384 h^4 max|f^(4)| = 5/384 1e-8 1.3^4 = 3.7e-10.
  EXPECT_LT(inner_c2, 3.7e-10);
  EXPECT_GT(inner_c1, 10.0 * inner_c2);
  // One interval changes f'' by |f'''| h = 0.022: a jump at the samples would be of that order.
  EXPECT_LT(curvature_jump, 1e-3);
}

TEST(SimulationWindows, FlagsExactlyTheWindowsBeyondThresholdTimesTheNoise) {
  sid::FreeSimulation sim;
  const Eigen::Index n = 400;  // t = 0 .. 3.99 s, windows of 1 s
  sim.t = Eigen::VectorXd::LinSpaced(n, 0.0, 3.99);
  sim.error = sid::MatrixX2<double>::Constant(n, 2, 1e-3);
  sid::MatrixX2<double> expected_ms = sid::MatrixX2<double>::Constant(n, 2, 1e-6);  // RMS 1e-3
  // Joint 1, window [1, 2): RMS 7e-3 = 7x the noise; joint 2, window [3, 4): 5x (below 6).
  sim.error.col(0).segment(100, 100).setConstant(7e-3);
  sim.error.col(1).segment(300, 100).setConstant(-5e-3);
  sid::SimulationCheckOptions check;  // threshold 6, min_error 1e-4
  auto windows = sid::simulation_windows(sim, expected_ms, 1.0, check);
  ASSERT_EQ(windows.size(), 1u);
  EXPECT_EQ(windows[0].joint, 1);
  EXPECT_NEAR(windows[0].t_begin, 1.0, 1e-12);
  EXPECT_NEAR(windows[0].t_end, 2.0, 1e-12);
  EXPECT_NEAR(windows[0].ratio, 7.0, 1e-12);
  check.threshold = 4.0;
  windows = sid::simulation_windows(sim, expected_ms, 1.0, check);
  ASSERT_EQ(windows.size(), 2u);
  EXPECT_EQ(windows[1].joint, 2);
  EXPECT_NEAR(windows[1].ratio, 5.0, 1e-12);
  EXPECT_NEAR(windows[1].t_end, 3.99, 1e-12) << "the last window ends at the last sample";
  // NaN errors (a failed segment) are left out; a window of fewer than 2 finite samples is not
  // judged. Zero expected noise: any error above min_error is flagged with an infinite ratio.
  sim.error.col(0).segment(100, 99).setConstant(std::nan(""));
  expected_ms.setZero();
  sim.error.col(1).setConstant(5e-5);  // below min_error
  windows = sid::simulation_windows(sim, expected_ms, 1.0, check);
  ASSERT_EQ(windows.size(), 3u);  // joint 1: [0, 1), [2, 3), [3, 4)
  for (const auto& w : windows) {
    EXPECT_EQ(w.joint, 1);
    EXPECT_TRUE(std::isinf(w.ratio));
    EXPECT_NE(w.t_begin, 1.0);
  }
  sid_test::expect_invalid_argument(
      [&] { (void)sid::simulation_windows(sim, expected_ms.topRows(3), 1.0, check); },
      "sid::simulation_windows", "rows");
  sid_test::expect_invalid_argument(
      [&] { (void)sid::simulation_windows(sim, expected_ms, 0.0, check); },
      "sid::simulation_windows", "window_length");
}

// The whole check judges both models against what the torque noise does to the final one. A
// nominal model that misses a spring on joint 1 blew up in its own noise runs, and the samples
// none of them reached had no scale: the final model, at the noise level there, had 24 of its
// windows flagged.
TEST(DiagnoseWithSimulation, JudgesTheWindowsOfAHiddenSpringAgainstTheFinalModelsNoise) {
  const sid::Trajectory<double> data =
      sid::test::simulate({sid::parse_effect("spring_j1:0.05")}, sid::test::Excitation::Paper, 1);
  sid::SimulationCheck details;
  const sid::DiagnosisResult r = sid::diagnose_with_simulation(data, {}, {}, {}, &details);
  ASSERT_EQ(r.effects.size(), 1u);
  EXPECT_EQ(r.effects[0].effect.id(), "spring_j1");
  const Eigen::Index n = details.noise_rms.rows();
  ASSERT_EQ(n, r.kinematics.size());
  for (int j = 0; j < 2; ++j) {
    // Zero only where a segment restarts from the state every run shares.
    EXPECT_GT((details.noise_rms.col(j).array() > 0.0).count(), n - 20) << "joint " << j + 1;
    // The nominal model drifts open loop, by how much hangs on rounding (joint 2: 0.062 rad
    // here, 0.025 without FMA contraction and vectorisation); the final one stays at the noise
    // (0.005 rad on both). The behaviour: it is several times closer, and no window is flagged.
    EXPECT_LT(r.final.sim_error_rms[j], 0.5 * r.nominal.sim_error_rms[j]) << "joint " << j + 1;
  }
  EXPECT_FALSE(r.nominal.sim_windows.empty());
  EXPECT_TRUE(r.final.sim_windows.empty()) << r.final.sim_windows.size() << " windows flagged";
}

// Where friction is named, the nominal model's simulation runs beside the friction test, which
// replaces the result: it must still be the nominal model's, at the checked tolerance, as if
// run on its own.
TEST(DiagnoseWithSimulation, SimulatesTheNominalModelBesideTheFrictionTestAsOnItsOwn) {
  const sid::Trajectory<double> data =
      sid::test::simulate({sid::parse_effect("coulomb_j2:0.2")}, sid::test::Excitation::Paper, 1);
  const sid::SimulationCheckOptions check;
  sid::SimulationCheck details;
  const sid::DiagnosisResult r = sid::diagnose_with_simulation(data, {}, {}, check, &details);
  ASSERT_EQ(r.effects.size(), 1u);
  EXPECT_EQ(r.effects[0].effect.id(), "coulomb_j2");
  ASSERT_EQ(r.friction_checks.size(), 1u);  // the friction test ran
  EXPECT_EQ(r.friction_checks[0].joint, 2);

  const sid::DiagnosisResult alone = sid::diagnose(data);
  sid::FreeSimulationOptions checked;
  checked.simulator.rtol = checked.simulator.atol = check.checked_tolerance;
  const sid::FreeSimulation nominal =
      sid::free_simulation(alone.nominal_model, alone.nominal.theta, alone.kinematics, checked);
  ASSERT_EQ(details.nominal.q.rows(), nominal.q.rows());
  EXPECT_EQ((details.nominal.q - nominal.q).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(details.nominal.statistics.steps, nominal.statistics.steps);
  for (int j = 0; j < 2; ++j)
    EXPECT_EQ(r.nominal.sim_error_rms[j], nominal.error_rms[j]) << "joint " << j + 1;
  // And the final model's simulation is another one: it fits where the nominal one drifts.
  EXPECT_LT(r.final.sim_error_rms[1], 0.5 * r.nominal.sim_error_rms[1]);

  // One thread runs the two tasks one after the other, to the same numbers.
  sid::SimulationCheckOptions one_thread = check;
  one_thread.threads = 1;
  sid::SimulationCheck serial_details;
  const sid::DiagnosisResult serial =
      sid::diagnose_with_simulation(data, {}, {}, one_thread, &serial_details);
  EXPECT_EQ(serial.final.theta, r.final.theta);
  EXPECT_EQ(serial.friction_checks[0].chosen, r.friction_checks[0].chosen);
  EXPECT_EQ((serial_details.nominal.q - details.nominal.q).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(serial.final.sim_error_rms, r.final.sim_error_rms);
}

}  // namespace
