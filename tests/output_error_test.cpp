// Tests of sid::fit_output_error: exact angles of a known arm are reproduced from wrong starting
// parameters and states; the score test of an added parameter predicts its refit's cost drop;
// a nested fit's first-order start; bad problems are refused with a message.

#include <gtest/gtest.h>

#include <cmath>
#include <sid/cvode/experiment.hpp>
#include <sid/cvode/output_error.hpp>
#include <sid/model/effects.hpp>
#include <string>
#include <utility>
#include <vector>

#include "test_support.hpp"

namespace {

constexpr double kVs = 0.2;  // Stribeck velocity of the true arm [rad/s]

/// The paper's arm with friction on joint 2 (by default Stribeck, Fc 0.1, Fs 0.3), simulated
/// exactly.
struct ExactRun {
  sid::EffectfulArm arm;
  sid::Kinematics<double> truth;
  explicit ExactRun(const std::string& effect = "stribeck_j2:0.1,0.3,0.2")
      : arm(sid::effectful_arm(sid::paper_arm_parameters<double>(), {sid::parse_effect(effect)})) {
    const auto fd = [this](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                           const sid::Vector2<double>& tau) {
      return arm.model.forward_dynamics(arm.theta, q, qd, tau);
    };
    const sid::ExperimentResult run = sid::simulate_arm_experiment(fd, sid::PaperInput());
    EXPECT_TRUE(run.ok()) << run.message;
    truth = run.truth;
  }
};

sid::Model<double> model_at(double vs) {
  sid::EffectSettings s;
  s.stribeck_velocity = vs;
  sid::Model<double> m = sid::two_link_arm_model<double>(sid::kPaperGravity);
  m.add(sid::effect_term("stribeck_j2", s));
  return m;
}

/// Three windows of 0.4 s around joint 2's reversals, started from states that are off.
sid::OutputErrorProblem exact_problem(const ExactRun& run) {
  sid::OutputErrorProblem p;
  p.model_at = model_at;
  p.t = run.truth.t;
  p.q_measured = run.truth.q;
  p.tau = run.truth.tau;
  p.sigma_q.setConstant(1e-3);
  const auto& k = run.truth;
  for (Eigen::Index i = 1; i < k.size() && p.windows.size() < 3; ++i) {
    if ((k.qd(i - 1, 1) > 0.0) == (k.qd(i, 1) > 0.0) || k.t[i] < 0.5) continue;
    sid::OutputErrorWindow w;
    w.begin = i - 60;
    w.end = i + 100;
    w.q0 = k.q.row(w.begin).transpose().array() + 2e-3;
    w.qd0 = k.qd.row(w.begin).transpose().array() - 0.02;
    p.windows.push_back(w);
  }
  EXPECT_EQ(p.windows.size(), 3u);
  p.theta0 = run.arm.theta;
  for (Eigen::Index u = 0; u < 6; ++u) p.fixed_parameters.push_back(u);  // θ7, Fc, Fs − Fc free
  p.theta0[6] *= 1.05;
  p.theta0[7] = 0.15;
  if (p.theta0.size() > 8) p.theta0[8] = 0.1;  // Fs − Fc of a Stribeck arm
  return p;
}

TEST(OutputError, RecoversFrictionAndStatesFromExactAngles) {
  const ExactRun run;
  sid::OutputErrorProblem p = exact_problem(run);
  p.estimate_nonlinear = true;
  p.s0 = 0.4;  // twice the truth
  // Exact data: converge until the cost stops falling at all, not just by what noise would
  // notice (the default 0.1 leaves θ7 and the window velocities a fraction of their std off).
  sid::OutputErrorOptions exact;
  exact.absolute_tolerance = 1e-9;
  const sid::OutputErrorFit fit = sid::fit_output_error(p, exact);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_TRUE(fit.converged) << fit.message;
  EXPECT_LT(fit.cost, 1e-2 * fit.initial_cost);
  EXPECT_LT(fit.cost, 1.0);  // the angles to well within σq = 1e-3 rad
  EXPECT_NEAR(fit.theta[6], run.arm.theta[6], 1e-3 * run.arm.theta[6]);
  EXPECT_NEAR(fit.theta[7], 0.1, 1e-3);
  EXPECT_NEAR(fit.theta[8], 0.2, 2e-3);
  EXPECT_NEAR(fit.s, kVs, 2e-3);
  for (Eigen::Index u = 0; u < 6; ++u) EXPECT_EQ(fit.theta[u], p.theta0[u]) << "fixed " << u;
  for (const auto& w : fit.windows) {
    EXPECT_NEAR(w.q0[0], run.truth.q(w.begin, 0), 1e-5);
    EXPECT_NEAR(w.qd0[1], run.truth.qd(w.begin, 1), 1e-3);
    EXPECT_NEAR(w.torque_offset[1], 0.0, 1e-3);
  }
  ASSERT_EQ(fit.covariance.rows(), p.theta0.size() + 1);
  EXPECT_GT(fit.covariance(9, 9), 0.0);
  EXPECT_EQ(fit.covariance(0, 0), 0.0) << "a fixed parameter has no variance";
}

// The Jacobian the fit steps with: forward sensitivities of one window against central
// differences of its simulation, for the free parameters, log vs and the window's own unknowns.
TEST(OutputError, WindowSensitivitiesMatchCentralDifferencesOfTheSimulation) {
  const ExactRun run;
  const sid::OutputErrorProblem p = exact_problem(run);
  const sid::OutputErrorWindow& w = p.windows[1];
  const sid::detail::TorqueInterpolator torque(p.t, p.tau);
  sid::SimulatorOptions tight = sid::OutputErrorOptions().simulator;
  tight.rtol = 1e-11;
  tight.atol = 1e-12;
  const Eigen::VectorXd theta = p.theta0;
  const sid::Model<double> model = model_at(kVs);
  const double log_step = 1e-6;
  const sid::Model<double> larger = model_at(kVs * std::exp(log_step));
  sid::detail::WindowParameters parameters;
  parameters.theta = {6, 7, 8};
  parameters.model_at_larger_s = &larger;
  parameters.log_step = log_step;
  const Eigen::Vector2d offset(0.01, -0.02), slope(0.05, 0.03);
  Eigen::MatrixXd jacobian;
  ASSERT_TRUE(sid::detail::window_jacobian(model, theta, parameters, torque, p.t, w, w.q0, w.qd0,
                                           offset, slope, p.sigma_q, tight, jacobian));
  const Eigen::Index m = w.end - w.begin;
  ASSERT_EQ(jacobian.rows(), 2 * m);
  ASSERT_EQ(jacobian.cols(), 3 + 1 + 8);
  // Unknown c moved by ±h: (theta, vs, q0, qd0, offset, slope).
  const auto simulated = [&](Eigen::Index c, double h) {
    Eigen::VectorXd th = theta;
    double vs = kVs;
    Eigen::Matrix<double, 8, 1> local;
    local << w.q0, w.qd0, offset, slope;
    if (c < 3)
      th[6 + c] += h;
    else if (c == 3)
      vs *= std::exp(h);
    else
      local[c - 4] += h;
    Eigen::MatrixXd q;
    EXPECT_TRUE(sid::detail::simulate_window(model_at(vs), th, torque, p.t, w, local.segment<2>(0),
                                             local.segment<2>(2), local.segment<2>(4),
                                             local.segment<2>(6), tight, q));
    Eigen::VectorXd stacked(2 * m);
    stacked << q.col(0) / p.sigma_q[0], q.col(1) / p.sigma_q[1];
    return stacked;
  };
  for (Eigen::Index c = 0; c < jacobian.cols(); ++c) {
    const double h = c < 3 ? 1e-4 * std::max(std::fabs(theta[6 + c]), 1e-2) : 1e-4;
    const Eigen::VectorXd difference = (simulated(c, h) - simulated(c, -h)) / (2 * h);
    const double scale = difference.cwiseAbs().maxCoeff();
    ASSERT_GT(scale, 0.0) << "column " << c;
    EXPECT_LT((jacobian.col(c) - difference).cwiseAbs().maxCoeff(), 1e-4 * scale) << "column " << c;
  }
}

TEST(OutputError, AbsorbsAConstantTorqueErrorInTheWindowOffsets) {
  // The applied torque is known only up to a smooth error (the caller smooths a noisy one):
  // the windows' offsets and slopes take it, not the friction.
  const ExactRun run;
  sid::OutputErrorProblem p = exact_problem(run);
  p.s0 = kVs;                    // held: only the linear parameters and the windows are fitted
  p.tau.col(1).array() += 0.02;  // the model sees 0.02 N m more than was applied
  const sid::OutputErrorFit fit = sid::fit_output_error(p);
  ASSERT_TRUE(fit.ok()) << fit.message;
  EXPECT_NEAR(fit.theta[7], 0.1, 2e-3);
  EXPECT_NEAR(fit.theta[8], 0.2, 4e-3);
  for (const auto& w : fit.windows) EXPECT_NEAR(w.torque_offset[1], -0.02, 1e-3);
}

/// The Coulomb version of exact_problem (θ7 and Fc free, θ1..θ6 held) for either arm.
sid::OutputErrorProblem coulomb_problem(const ExactRun& run) {
  sid::OutputErrorProblem p = exact_problem(run);
  p.model_at = [](double) {
    sid::Model<double> m = sid::two_link_arm_model<double>(sid::kPaperGravity);
    m.add(sid::effect_term("coulomb_j2", sid::EffectSettings()));
    return m;
  };
  p.theta0.conservativeResize(8);  // drops a Stribeck arm's Fs − Fc
  return p;
}

/// The score test at a Coulomb fit of a Stribeck bump at the true vs.
sid::OutputErrorScore bump_score(const sid::OutputErrorProblem& coulomb,
                                 const sid::OutputErrorFit& fit) {
  Eigen::VectorXd with_bump(9);
  with_bump << fit.theta, 0.0;
  return sid::output_error_score_test(coulomb, fit, model_at(kVs), with_bump, 8, 0.005);
}

// The score test at the Coulomb fit against the refit it stands for: to first order, its
// statistic is the cost drop that fitting a Stribeck bump (at the true vs) gives.
TEST(OutputError, ScoreTestPredictsTheCostDropOfARefitWithTheAddedParameter) {
  const ExactRun run("stribeck_j2:0.1,0.15,0.2");
  const sid::OutputErrorProblem coulomb = coulomb_problem(run);
  const sid::OutputErrorFit null_fit = sid::fit_output_error(coulomb);
  ASSERT_TRUE(null_fit.ok() && null_fit.converged) << null_fit.message;
  sid::OutputErrorProblem stribeck = exact_problem(run);
  stribeck.s0 = kVs;
  stribeck.theta0.head(8) = null_fit.theta;
  stribeck.theta0[8] = 0.0;
  stribeck.windows = null_fit.windows;
  const sid::OutputErrorFit full_fit = sid::fit_output_error(stribeck);
  ASSERT_TRUE(full_fit.ok() && full_fit.converged) << full_fit.message;
  const double drop = null_fit.cost - full_fit.cost;
  ASSERT_GT(drop, 10.0) << "the bump must matter for the comparison to mean something";

  const sid::OutputErrorScore score = bump_score(coulomb, null_fit);
  ASSERT_TRUE(score.ok());
  EXPECT_GT(score.direction, 0.0) << "a positive bump lowers the cost";
  EXPECT_NEAR(score.statistic, drop, 0.2 * drop);

  // Where the curve is exactly Coulomb, no bump helps.
  const ExactRun plain("coulomb_j2:0.1");
  const sid::OutputErrorProblem exact_coulomb = coulomb_problem(plain);
  const sid::OutputErrorFit exact_fit = sid::fit_output_error(exact_coulomb);
  ASSERT_TRUE(exact_fit.ok()) << exact_fit.message;
  const sid::OutputErrorScore none = bump_score(exact_coulomb, exact_fit);
  ASSERT_TRUE(none.ok());
  EXPECT_LT(none.statistic, 1e-2 * drop);

  Eigen::VectorXd wrong = Eigen::VectorXd::Zero(12);
  sid_test::expect_invalid_argument(
      [&] {
        (void)sid::output_error_score_test(coulomb, null_fit, model_at(kVs), wrong, 8, 0.005);
      },
      "sid::output_error_score_test: ", "plus one");
}

// The efficient score removes the part of the gradient the fit left: a fit stopped short of its
// minimum by a loose tolerance scores the added bump as the converged fit does. (Without that
// part, jᵀr alone, the early fit here scored 110 against 30.)
TEST(OutputError, ScoreTestDoesNotDependOnWhereTheFitStopped) {
  const ExactRun run("stribeck_j2:0.1,0.15,0.2");
  const sid::OutputErrorProblem coulomb = coulomb_problem(run);
  const sid::OutputErrorFit converged = sid::fit_output_error(coulomb);
  ASSERT_TRUE(converged.ok() && converged.converged) << converged.message;
  sid::OutputErrorOptions loose;
  loose.absolute_tolerance = 10.0;
  const sid::OutputErrorFit early = sid::fit_output_error(coulomb, loose);
  ASSERT_TRUE(early.ok()) << early.message;
  const sid::OutputErrorScore at_minimum_score = bump_score(coulomb, converged),
                              at_stop_score = bump_score(coulomb, early);
  ASSERT_TRUE(at_minimum_score.ok() && at_stop_score.ok());
  const double at_minimum = at_minimum_score.statistic, at_stop = at_stop_score.statistic;
  ASSERT_GT(early.cost - converged.cost, 0.1 * at_minimum)
      << "the early fit must stop short for the test to mean something";
  EXPECT_NEAR(at_stop, at_minimum, 0.02 * at_minimum);
}

// The start of a nested fit, the Coulomb curve from the Stribeck fit: with the bump dropped and
// the other unknowns re-adjusted to first order it starts at less than half the cost of the
// bump merely dropped (here 5800 against 13000), and the fit from there reaches the same minimum.
TEST(OutputError, NestedStartReadjustsTheOtherUnknownsToTheHeldValues) {
  const ExactRun run;  // Fs − Fc = 0.2: the Coulomb curve misfits
  sid::OutputErrorProblem stribeck = exact_problem(run);
  stribeck.estimate_nonlinear = true;
  stribeck.s0 = kVs;
  const sid::OutputErrorFit full = sid::fit_output_error(stribeck);
  ASSERT_TRUE(full.ok() && full.converged) << full.message;
  const sid::OutputErrorStart start = sid::nested_start(full, {8}, Eigen::VectorXd::Zero(1));
  EXPECT_EQ(start.theta[8], 0.0);
  for (Eigen::Index u = 0; u < 6; ++u)
    EXPECT_EQ(start.theta[u], full.theta[u]) << "held by the fit " << u;
  EXPECT_NE(start.theta[7], full.theta[7]) << "Fc takes up part of the bump";

  sid::OutputErrorProblem dropped = coulomb_problem(run), nested = coulomb_problem(run);
  dropped.theta0 = full.theta.head(8);
  dropped.windows = full.windows;
  nested.theta0 = start.theta.head(8);
  nested.windows = start.windows;
  const sid::OutputErrorFit from_dropped = sid::fit_output_error(dropped),
                            from_nested = sid::fit_output_error(nested);
  ASSERT_TRUE(from_dropped.converged && from_nested.converged);
  EXPECT_LT(from_nested.initial_cost, 0.6 * from_dropped.initial_cost);
  EXPECT_NEAR(from_nested.cost, from_dropped.cost, 1e-3 * from_dropped.cost);
  EXPECT_NEAR(from_nested.theta[7], from_dropped.theta[7], 1e-2 * from_dropped.theta[7]);

  sid_test::expect_invalid_argument(
      [&] { (void)sid::nested_start(full, {9}, Eigen::VectorXd::Zero(1)); },
      "sid::nested_start: ", "not one of the fit's parameters");
  sid_test::expect_invalid_argument(
      [&] { (void)sid::nested_start(full, {8}, Eigen::VectorXd::Zero(2)); },
      "sid::nested_start: ", "differ in size");
  sid_test::expect_invalid_argument(
      [&] { (void)sid::nested_start(sid::OutputErrorFit(), {}, Eigen::VectorXd()); },
      "sid::nested_start: ", "no normal matrix");
}

// The worse side of a likelihood ratio need only be known to a fraction of the gap: the Coulomb
// fit of a Stribeck arm, told the Stribeck fit's cost, stops sooner, and its cost is within
// twice that fraction of the gap from the Coulomb minimum.
TEST(OutputError, ComparedFitStopsOnceTheGapIsKnownToItsTolerance) {
  const ExactRun run;  // Fs − Fc = 0.2: the Coulomb curve misfits
  const sid::OutputErrorFit better = sid::fit_output_error(exact_problem(run));
  ASSERT_TRUE(better.ok() && better.converged) << better.message;
  const sid::OutputErrorProblem coulomb = coulomb_problem(run);
  const sid::OutputErrorFit alone = sid::fit_output_error(coulomb);
  ASSERT_TRUE(alone.ok() && alone.converged) << alone.message;
  sid::OutputErrorOptions against;
  against.comparison_cost = better.cost;
  const sid::OutputErrorFit compared = sid::fit_output_error(coulomb, against);
  ASSERT_TRUE(compared.ok() && compared.converged) << compared.message;
  const double gap = alone.cost - better.cost;
  ASSERT_GT(gap, 100.0);
  EXPECT_LT(compared.iterations, alone.iterations);
  EXPECT_LE(std::fabs(compared.cost - alone.cost), 2.0 * against.comparison_tolerance * gap)
      << "compared " << compared.cost << " alone " << alone.cost;
  EXPECT_EQ(compared.covariance.rows(), alone.covariance.rows());
  EXPECT_TRUE(compared.covariance.allFinite());
}

TEST(OutputError, RefusesBadProblems) {
  const ExactRun run;
  const sid::OutputErrorProblem good = exact_problem(run);
  auto bad = good;
  bad.windows.clear();
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "no windows");
  bad = good;
  bad.windows[0].end = good.t.size() + 5;
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "outside the data");
  bad = good;
  bad.tau.conservativeResize(10, 2);
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "same number of rows");
  bad = good;
  bad.s0 = 1e9;
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "s0");
  bad = good;
  bad.prior_mean = Eigen::VectorXd::Zero(3);
  bad.prior_std = Eigen::VectorXd::Ones(3);
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "prior");
  bad = good;
  bad.fixed_parameters = {42};
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "fixed parameter");
  bad = good;
  bad.sigma_q[0] = 0.0;
  sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(bad); },
                                    "sid::fit_output_error: ", "sigma_q");
  for (const auto& [cost, tolerance] :
       {std::pair{1.0, -0.1}, std::pair{1.0, 1.0}, std::pair{std::nan(""), 0.01}}) {
    sid::OutputErrorOptions options;
    options.comparison_cost = cost;
    options.comparison_tolerance = tolerance;
    sid_test::expect_invalid_argument([&] { (void)sid::fit_output_error(good, options); },
                                      "sid::fit_output_error: ", "comparison_tolerance");
  }
}

}  // namespace
