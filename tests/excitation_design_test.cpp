#include <sid/excitation_design.hpp>

#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/serial_chain.hpp>

#include <gtest/gtest.h>

#include "small_arm.hpp"

#include <Eigen/Core>
#include <Eigen/SVD>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using sid_test::small_arm;
using sid_test::small_options;
using sid_test::SmallArm;

constexpr double kPi = 3.14159265358979323846;
// Rest at t = 0 and t = 1 / f: sums of at most 2H terms of size ~1 cancel to round-off.
constexpr double kRestTol = 1e-12;
// The rates from central differences of q (step 1e-5 s): O(h^2) truncation and round-off.
constexpr double kDifferenceTol = 1e-6;
// Limits checked on a grid 10 times finer than the design's: between its points the design's
// guard keeps q, qd and qdd inside; the torque's guard is a heuristic, checked here.
constexpr double kLimitTol = 1e-9;
// Gradient against central differences of the objective (step 1e-6 in the coefficients): the
// Coulomb columns' tanh(qd / 0.01) bends sharply where a joint turns, so both differences carry
// truncation errors of ~1e-5 relative there; a wrong term would be off by O(1).
constexpr double kGradientTol = 1e-4;

sid::FourierTrajectory random_coefficients(int joints, int harmonics, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  sid::FourierTrajectory f;
  f.base_frequency = 0.25;
  f.q0 = Eigen::VectorXd::NullaryExpr(joints, [&] { return u(rng); });
  f.a = Eigen::MatrixXd::NullaryExpr(joints, harmonics, [&] { return u(rng); });
  f.b = Eigen::MatrixXd::NullaryExpr(joints, harmonics, [&] { return u(rng); });
  return f;
}

// The condition number of the column-scaled base regressor, built here sample by sample from
// ChainModel::regressor and an SVD, independently of excitation_regressor and the design.
double condition_number(const SmallArm& arm, const sid::FourierTrajectory& f, int samples) {
  const int n = arm.model.joints();
  Eigen::MatrixXd w(samples * n, static_cast<Eigen::Index>(arm.columns.size()));
  Eigen::MatrixXd y(n, arm.model.parameters());
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (int k = 0; k < samples; ++k) {
    f.evaluate(k / (samples * f.base_frequency), q, qd, qdd);
    arm.model.regressor(q, qd, qdd, y);
    for (std::size_t c = 0; c < arm.columns.size(); ++c)
      w.block(k * n, static_cast<Eigen::Index>(c), n, 1) = y.col(arm.columns[c]);
  }
  for (Eigen::Index c = 0; c < w.cols(); ++c) w.col(c).normalize();
  const Eigen::VectorXd s = Eigen::JacobiSVD<Eigen::MatrixXd>(w).singularValues();
  return s[0] / s[s.size() - 1];
}

// Every limit on a fine grid, the torque from the model's inverse dynamics (not the regressor).
void expect_within_limits(const SmallArm& arm, const sid::FourierTrajectory& f, int samples) {
  const int n = arm.model.joints();
  sid::ChainModel::Vector q(n), qd(n), qdd(n);
  for (int k = 0; k < samples; ++k) {
    const double t = k / (samples * f.base_frequency);
    f.evaluate(t, q, qd, qdd);
    const Eigen::VectorXd tau = arm.model.model().inverse_dynamics(arm.theta, q, qd, qdd);
    for (int j = 0; j < n; ++j) {
      ASSERT_LE(std::abs(q[j] - arm.q0[j]), arm.limits.q_range[j] + kLimitTol) << t << " " << j;
      ASSERT_LE(std::abs(qd[j]), arm.limits.qd_max[j] + kLimitTol) << t << " " << j;
      ASSERT_LE(std::abs(qdd[j]), arm.limits.qdd_max[j] + kLimitTol) << t << " " << j;
      ASSERT_LE(std::abs(tau[j]), arm.limits.tau_max[j] + kLimitTol) << t << " " << j;
    }
  }
}

void expect_at_rest(const sid::FourierTrajectory& f) {
  Eigen::VectorXd q(f.joints()), qd(f.joints()), qdd(f.joints());
  for (const double t : {0.0, 1.0 / f.base_frequency, 3.0 / f.base_frequency}) {
    f.evaluate(t, q, qd, qdd);
    EXPECT_LT(qd.cwiseAbs().maxCoeff(), kRestTol) << "t = " << t;
    EXPECT_LT(qdd.cwiseAbs().maxCoeff(), kRestTol) << "t = " << t;
  }
}

TEST(FourierTrajectoryAtRest, StartsAndEndsEveryPeriodAtRest) {
  const sid::FourierTrajectory raw = random_coefficients(4, 5, 3);
  const sid::FourierTrajectory f = sid::fourier_trajectory_at_rest(raw);
  expect_at_rest(f);
  // Only the first harmonic changes.
  EXPECT_EQ(f.a.rightCols(4), raw.a.rightCols(4));
  EXPECT_EQ(f.b.rightCols(4), raw.b.rightCols(4));
  EXPECT_EQ(f.q0, raw.q0);
  // The rates evaluate() reports at rest agree with differences of q itself: q is flat there.
  const double h = 1e-5, t = 1.0 / f.base_frequency;
  Eigen::VectorXd qm(4), qc(4), qp(4), unused(4), unused2(4);
  f.evaluate(t - h, qm, unused, unused2);
  f.evaluate(t, qc, unused, unused2);
  f.evaluate(t + h, qp, unused, unused2);
  EXPECT_LT(((qp - qm) / (2 * h)).cwiseAbs().maxCoeff(), kDifferenceTol);
  EXPECT_LT(((qp - 2 * qc + qm) / (h * h)).cwiseAbs().maxCoeff(), 1e3 * kDifferenceTol);
  // A series not at rest is moved: the check above can fail.
  Eigen::VectorXd q(4), qd(4), qdd(4);
  raw.evaluate(0.0, q, qd, qdd);
  EXPECT_GT(qd.cwiseAbs().maxCoeff(), 0.1);
}

TEST(ExcitationDesign, GradientsMatchCentralDifferences) {
  const SmallArm arm = small_arm();
  const sid::ExcitationDesignOptions options = small_options();
  std::mt19937_64 rng(5);
  const sid::FourierTrajectory start =
      sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, options, rng);
  sid::detail::ExcitationProblem problem(arm.model, arm.theta, arm.columns, arm.q0, arm.limits,
                                         options);
  const Eigen::VectorXd x = problem.variables_of(start);
  problem.evaluate(x.data(), true);
  const Eigen::VectorXd gradient = problem.objective_gradient();
  const Eigen::MatrixXd jacobian = problem.constraint_gradient();
  // The objective is the smooth stand-in for log cond: below it, within (log p) / k.
  const double log_cond = std::log(condition_number(arm, start, options.samples));
  EXPECT_LE(problem.objective(), log_cond + 1e-9);
  EXPECT_GE(problem.objective(),
            log_cond - std::log(double(arm.columns.size())) / options.sharpness - 1e-9);
  const double h = 1e-6;
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    Eigen::VectorXd plus = x, minus = x;
    plus[i] += h;
    minus[i] -= h;
    problem.evaluate(plus.data(), false);
    const double f_plus = problem.objective();
    const Eigen::VectorXd c_plus = problem.constraint_values();
    problem.evaluate(minus.data(), false);
    const double f_minus = problem.objective();
    const Eigen::VectorXd c_minus = problem.constraint_values();
    EXPECT_NEAR(gradient[i], (f_plus - f_minus) / (2 * h),
                kGradientTol * std::max(1.0, std::abs(gradient[i])))
        << "variable " << i;
    const Eigen::VectorXd difference = (c_plus - c_minus) / (2 * h);
    EXPECT_LT((jacobian.col(i) - difference).cwiseAbs().maxCoeff(),
              kGradientTol * std::max(1.0, difference.cwiseAbs().maxCoeff()))
        << "variable " << i;
  }
}

TEST(ExcitationDesign, RandomExcitationIsAtRestWithinTheLimitsAndRepeatsForASeed) {
  const SmallArm arm = small_arm();
  const sid::ExcitationDesignOptions options = small_options();
  std::mt19937_64 rng(2), again(2);
  const sid::FourierTrajectory f =
      sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, options, rng);
  expect_at_rest(f);
  expect_within_limits(arm, f, 10 * options.samples);
  const sid::FourierTrajectory g =
      sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, options, again);
  EXPECT_EQ(f.a, g.a);
  EXPECT_EQ(f.b, g.b);
}

TEST(ExcitationDesign, HalvesTheConditionNumberOfARandomExcitationWithinTheLimits) {
  const SmallArm arm = small_arm();
  const sid::ExcitationDesignOptions options = small_options();
  std::mt19937_64 rng(1);
  const sid::FourierTrajectory random =
      sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, options, rng);
  const sid::ExcitationDesign design = sid::design_excitation(arm.model, arm.theta, arm.columns,
                                                              arm.q0, arm.limits, random, options);
  const double before = condition_number(arm, random, options.samples);
  const double after = condition_number(arm, design.trajectory, options.samples);
  ::testing::Test::RecordProperty("condition_random", std::to_string(before));
  ::testing::Test::RecordProperty("condition_designed", std::to_string(after));
  EXPECT_LE(after, 0.5 * before) << design.stop_reason;
  EXPECT_NEAR(after,
              sid::scaled_condition_number(sid::excitation_regressor(
                  arm.model, arm.columns, design.trajectory,
                  sid::excitation_grid(options.base_frequency, options.samples))),
              1e-9 * after);
  EXPECT_LT(design.objective, design.start_objective);
  EXPECT_EQ(design.trajectory.q0, arm.q0);
  expect_at_rest(design.trajectory);
  expect_within_limits(arm, design.trajectory, 10 * options.samples);
  // The same inputs give the same design (the budget is in evaluations, not time).
  const sid::ExcitationDesign again = sid::design_excitation(arm.model, arm.theta, arm.columns,
                                                             arm.q0, arm.limits, random, options);
  EXPECT_EQ(again.trajectory.a, design.trajectory.a);
  EXPECT_EQ(again.trajectory.b, design.trajectory.b);
}

TEST(ExcitationDesign, ThrowsOnInvalidInput) {
  const SmallArm arm = small_arm();
  sid::ExcitationDesignOptions options = small_options();
  std::mt19937_64 rng(1);
  const sid::FourierTrajectory start =
      sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, options, rng);
  const auto design = [&](const sid::ExcitationLimits& limits,
                          const sid::ExcitationDesignOptions& o) {
    return sid::design_excitation(arm.model, arm.theta, arm.columns, arm.q0, limits, start, o);
  };
  sid::ExcitationLimits bad = arm.limits;
  bad.qd_max[1] = 0.0;
  EXPECT_THROW((void)design(bad, options), std::invalid_argument);
  bad = arm.limits;
  bad.qdd_max.resize(2);
  EXPECT_THROW((void)design(bad, options), std::invalid_argument);
  sid::ExcitationDesignOptions o = options;
  o.samples = 10;  // fewer than 8 H
  EXPECT_THROW((void)design(arm.limits, o), std::invalid_argument);
  o = options;
  o.harmonics = 5;  // the start has 4
  EXPECT_THROW((void)design(arm.limits, o), std::invalid_argument);
  o.harmonics = 1;
  EXPECT_THROW((void)sid::random_excitation(arm.model, arm.theta, arm.q0, arm.limits, o, rng),
               std::invalid_argument);
  // Holding the arm still already takes more than tau_max: no excitation can stay within it.
  bad = arm.limits;
  bad.tau_max[1] = 1e-3;
  EXPECT_THROW((void)sid::random_excitation(arm.model, arm.theta, arm.q0, bad, options, rng),
               std::invalid_argument);
}

}  // namespace
