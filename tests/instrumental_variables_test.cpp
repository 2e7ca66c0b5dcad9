#include <sid/cvode/instrumental_variables.hpp>

#include <sid/cvode/experiment.hpp>
#include <sid/study/montecarlo.hpp>

#include <gtest/gtest.h>

#include "paper_truth.hpp"

#include <cmath>
#include <string>

#include "test_support.hpp"

namespace {

const sid::Kinematics<double>& truth() { return sid_test::paper_truth(); }

const sid::MethodSummary& summary(const sid::MonteCarloResult& r, sid::StudyMethod m) {
  for (const auto& s : r.levels.at(0).methods)
    if (s.method == m) return s;
  throw std::runtime_error("method not in result");
}

}  // namespace

// With exact kinematics and torques y = X theta holds exactly, so any instruments with W^T X
// regular give theta back: a check of the IV algebra and of the column scaling.
TEST(InstrumentalVariables, ExactDataGiveTheTrueParametersAndConvergeAtOnce) {
  const sid::Kinematics<double> k = sid::window(truth(), 0.25);
  const auto first = sid::fit_two_link(k, sid::kPaperGravity);
  ASSERT_TRUE(first.ok());
  const auto iv = sid::refine_instrumental_variables(k, first);
  ASSERT_TRUE(iv.ok()) << iv.message;
  EXPECT_TRUE(iv.converged);
  EXPECT_LE(iv.iterations, 2);
  const auto theta = sid::paper_arm_parameters<double>();
  for (int p = 0; p < 7; ++p)
    EXPECT_NEAR(iv.fit.theta[p], theta[p], 1e-8 * std::abs(theta[p])) << "theta" << p + 1;
  EXPECT_LT(iv.fit.residual_rms.maxCoeff(), 1e-8);
}

// The case the IV step exists for: the GCV-smoothed accelerations carry noise, and least squares
// attenuates theta2 (by about 3 % at sigma_q^2 = 1e-4, 9 % at 1e-3: here 5 standard errors of
// 30 runs). The instruments, from simulations that never see the angle noise, remove most of it.
TEST(InstrumentalVariables, ReducesTheErrorsInVariablesBiasOfTheta2) {
  sid::MonteCarloOptions options;
  options.runs = 30;
  options.sigma_q2_levels = {1e-3};
  options.methods = {sid::StudyMethod::CssGcv, sid::StudyMethod::CssIv};
  options.refine = sid::instrumental_variable_step();
  const auto r = sid::run_monte_carlo(truth(), options);
  const auto& ls = summary(r, sid::StudyMethod::CssGcv);
  const auto& iv = summary(r, sid::StudyMethod::CssIv);
  ASSERT_EQ(iv.failed_runs, 0) << (iv.failures.empty() ? "" : iv.failures[0]);
  const double theta2 = r.theta[1];
  const double ls_bias = ls.mean[1] - theta2, iv_bias = iv.mean[1] - theta2;
  EXPECT_LT(ls_bias, -3.0 * ls.standard_error[1])
      << "least squares is no longer biased: the test lost its point";
  EXPECT_LT(std::abs(iv_bias), std::abs(ls_bias) / 2.0);
  EXPECT_LT(std::abs(iv_bias), 3.0 * iv.standard_error[1]);
  EXPECT_LT(iv.rms_rel_error_pct, ls.rms_rel_error_pct);
}

TEST(InstrumentalVariables, AFailedSimulationKeepsTheFirstEstimateAndSaysWhy) {
  const sid::Kinematics<double> k = sid::window(truth(), 0.25, 2.0);
  const auto first = sid::fit_two_link(k, sid::kPaperGravity);
  sid::InstrumentalVariableOptions options;
  options.simulator.max_steps = 1;
  const auto iv = sid::refine_instrumental_variables(k, first, options);
  EXPECT_FALSE(iv.ok());
  EXPECT_EQ(iv.iterations, 0);
  EXPECT_NE(iv.message.find("CV_TOO_MUCH_WORK"), std::string::npos) << iv.message;
  EXPECT_EQ(iv.fit.theta, first.theta);
  const auto step = sid::instrumental_variable_step(options);
  EXPECT_THROW((void)step(k, first), std::runtime_error);
}

TEST(InstrumentalVariables, BadInputIsRefusedWithItsReason) {
  const sid::Kinematics<double> k = sid::window(truth(), 0.25, 1.0);
  const auto first = sid::fit_two_link(k, sid::kPaperGravity);
  sid::InstrumentalVariableOptions options;
  options.segment = 0.0;
  sid_test::expect_invalid_argument(
      [&] { (void)sid::refine_instrumental_variables(k, first, options); },
      "sid::refine_instrumental_variables", "segment");
  options = {};
  options.max_iterations = 0;
  sid_test::expect_invalid_argument(
      [&] { (void)sid::refine_instrumental_variables(k, first, options); },
      "sid::refine_instrumental_variables", "max_iterations");
  sid::LeastSquaresResult<double> short_fit = first;
  short_fit.theta.conservativeResize(6);
  sid_test::expect_invalid_argument([&] { (void)sid::refine_instrumental_variables(k, short_fit); },
                                    "sid::refine_instrumental_variables", "7-parameter");
  const sid::Kinematics<double> tiny = sid::window(truth(), 0.25, 0.26);
  sid_test::expect_invalid_argument([&] { (void)sid::refine_instrumental_variables(tiny, first); },
                                    "sid::refine_instrumental_variables", "at least 8");
}

TEST(InstrumentalVariables, TheStudyRefusesCssIvWithoutTheStep) {
  sid::MonteCarloOptions options;
  options.methods = {sid::StudyMethod::CssIv};
  sid_test::expect_invalid_argument([&] { (void)sid::run_monte_carlo(truth(), options); },
                                    "sid::run_monte_carlo", "css_iv");
  EXPECT_EQ(sid::parse_study_method("css_iv"), sid::StudyMethod::CssIv);
  EXPECT_EQ(sid::parse_study_method("css_wls"), sid::StudyMethod::CssWls);
}
