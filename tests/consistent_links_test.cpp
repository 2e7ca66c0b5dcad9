#include <sid/cvode/identify_robot.hpp>

#include <gtest/gtest.h>

#include <string>

namespace {

// A converged consistent fit that does not reproduce the estimate (misfit test failed), whose
// fitted torque error is 5.4 % against least squares' 5.0 %.
sid::RobotIdentification fitted_only() {
  sid::RobotIdentification r;
  r.consistent.converged = true;
  r.consistent.fits_estimate = false;
  r.consistent.relative_residual = 0.054;
  r.consistent.least_squares_relative_residual = 0.050;
  return r;
}

sid::ChainPrediction prediction(double relative_residual) {
  sid::ChainPrediction p;
  p.relative_residual = relative_residual;
  return p;
}

TEST(ConsistentCost, IsTheHeldOutRunsMeanElseTheCrossValidationElseTheFittedEquations) {
  sid::RobotIdentification r = fitted_only();
  sid::ConsistentCost cost = sid::consistent_cost(r);
  EXPECT_FALSE(cost.held_out);
  EXPECT_EQ(cost.folds, 0);
  EXPECT_EQ(cost.measured_on(), "fitted equations");
  EXPECT_DOUBLE_EQ(cost.consistent, 0.054);
  EXPECT_DOUBLE_EQ(cost.estimate, 0.050);
  EXPECT_NEAR(cost.extra(), 0.08, 1e-12);
  r.consistent_cross_validation.folds = 5;
  r.consistent_cross_validation.consistent = 0.061;
  r.consistent_cross_validation.estimate = 0.066;
  cost = sid::consistent_cost(r);
  EXPECT_EQ(cost.folds, 5);
  EXPECT_EQ(cost.measured_on(), "5 blocks of the fitted equations, each predicted from the others");
  EXPECT_DOUBLE_EQ(cost.consistent, 0.061);
  EXPECT_DOUBLE_EQ(cost.estimate, 0.066);
  r.validation = {prediction(0.10), prediction(0.20)};
  r.consistent_validation = {prediction(0.12), prediction(0.24)};
  cost = sid::consistent_cost(r);
  EXPECT_TRUE(cost.held_out);
  EXPECT_EQ(cost.measured_on(), "held-out runs");
  EXPECT_DOUBLE_EQ(cost.consistent, 0.18);
  EXPECT_DOUBLE_EQ(cost.estimate, 0.15);
}

TEST(ConsistentLinks, AreWrittenUnlessTheyCostMoreThanAllowedOrDidNotConverge) {
  sid::RobotIdentification r = fitted_only();
  EXPECT_EQ(sid::consistent_links_problem(r), "");  // 8 % more error: within 10 %
  sid::ConsistentLinksPolicy strict;
  strict.strict = true;
  EXPECT_NE(sid::consistent_links_problem(r, strict).find("do not reproduce the estimate"),
            std::string::npos);
  sid::ConsistentLinksPolicy tight;
  tight.max_extra_error = 0.05;
  const std::string costly = sid::consistent_links_problem(r, tight);
  EXPECT_NE(costly.find("torque (fitted equations) with 5.4 % error against the estimate's 5 %"),
            std::string::npos)
      << costly;
  r.validation = {prediction(0.10)};
  r.consistent_validation = {prediction(0.20)};
  EXPECT_NE(sid::consistent_links_problem(r).find("torque (held-out runs)"), std::string::npos);
  r.consistent_validation = {prediction(0.09)};  // better than the estimate on held-out data
  EXPECT_EQ(sid::consistent_links_problem(r, tight), "");
  r.consistent.converged = false;
  EXPECT_NE(sid::consistent_links_problem(r).find("did not converge"), std::string::npos);
}

}  // namespace
