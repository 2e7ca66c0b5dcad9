// Tests of sid::simulate (include/sid/cvode/simulator.hpp) on ODEs with known solutions and on
// ODEs that must fail cleanly.

#include <sid/cvode/simulator.hpp>

#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>

namespace {

// CVODE bounds the local error per step; the global error accumulated over a few periods of these
// O(1) solutions reaches about 2e-8 at rtol = atol = 1e-10 (BDF, measured; Adams about 1e-8).
constexpr double kAnalyticTol = 5e-8;
// At rtol = atol = 1e-12 the measured global error is below 6e-10 for every method (BDF worst).
constexpr double kTightAnalyticTol = 1e-9;

const sid::IntegrationMethod kAllMethods[] = {sid::IntegrationMethod::AdamsFixedPoint,
                                              sid::IntegrationMethod::AdamsNewton,
                                              sid::IntegrationMethod::Bdf};

// x'' = -w^2 x - 2 zeta w x' (underdamped), x(0) = 1, x'(0) = 0; closed-form solution.
struct DampedOscillator {
  double w = 3.0;
  double zeta = 0.1;
  void operator()(double, const Eigen::Map<const Eigen::VectorXd>& x,
                  Eigen::Map<Eigen::VectorXd>& xdot) const {
    xdot[0] = x[1];
    xdot[1] = -w * w * x[0] - 2.0 * zeta * w * x[1];
  }
  Eigen::Vector2d exact(double t) const {
    const double wd = w * std::sqrt(1.0 - zeta * zeta);
    const double a = zeta * w;
    const double e = std::exp(-a * t);
    return Eigen::Vector2d(e * (std::cos(wd * t) + a / wd * std::sin(wd * t)),
                           -e * (w * w / wd) * std::sin(wd * t));
  }
};

double max_error_to_oscillator(const sid::SimulationResult& r, const DampedOscillator& model) {
  double worst = 0.0;
  for (Eigen::Index k = 0; k < r.t.size(); ++k)
    worst =
        std::max(worst, (r.states.row(k).transpose() - model.exact(r.t[k])).cwiseAbs().maxCoeff());
  return worst;
}

TEST(CvodeSimulator, MatchesDampedOscillatorWithEveryMethod) {
  const DampedOscillator model;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(501, 0.0, 10.0);
  const Eigen::Vector2d x0(1.0, 0.0);
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SimulationResult r = sid::simulate(model, x0, t, options);
    ASSERT_TRUE(r.ok()) << sid::to_string(r.status) << " " << r.flag_name << " " << r.message;
    EXPECT_EQ(r.completed, t.size());
    EXPECT_EQ(r.states.rows(), t.size());
    EXPECT_EQ(r.states.cols(), 2);
    EXPECT_EQ(r.t_reached, t[t.size() - 1]);
    EXPECT_EQ(r.flag_name, "CV_SUCCESS");
    EXPECT_TRUE(r.message.empty());
    EXPECT_LT(max_error_to_oscillator(r, model), kAnalyticTol)
        << "method " << static_cast<int>(method);
    EXPECT_GT(r.statistics.steps, 0);
    EXPECT_GE(r.statistics.rhs_evaluations, r.statistics.steps);
    if (method == sid::IntegrationMethod::AdamsFixedPoint)
      EXPECT_EQ(r.statistics.jacobian_evaluations, 0);
    else
      EXPECT_GT(r.statistics.jacobian_evaluations, 0);
  }
}

TEST(CvodeSimulator, TighterTolerancesGiveSmallerErrors) {
  const DampedOscillator model;
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(101, 0.0, 10.0);
  sid::SimulatorOptions tight;
  tight.rtol = tight.atol = 1e-12;
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions loose;
    loose.method = tight.method = method;
    const sid::SimulationResult r = sid::simulate(model, Eigen::Vector2d(1.0, 0.0), t, tight);
    const sid::SimulationResult r_loose = sid::simulate(model, Eigen::Vector2d(1.0, 0.0), t, loose);
    ASSERT_TRUE(r.ok()) << r.message;
    ASSERT_TRUE(r_loose.ok()) << r_loose.message;
    const double error = max_error_to_oscillator(r, model);
    EXPECT_LT(error, kTightAnalyticTol) << "method " << static_cast<int>(method);
    // 100 times smaller tolerances must buy at least a decade of accuracy.
    EXPECT_LT(10.0 * error, max_error_to_oscillator(r_loose, model))
        << "method " << static_cast<int>(method);
    EXPECT_GT(r.statistics.steps, r_loose.statistics.steps);
  }
}

TEST(CvodeSimulator, FirstRowIsInitialStateExactly) {
  const DampedOscillator model;
  const Eigen::Vector2d x0(0.123456789, -9.87654321);
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(11, 0.5, 1.5);  // t0 need not be 0
  const sid::SimulationResult r = sid::simulate(model, x0, t);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.states(0, 0), x0[0]);
  EXPECT_EQ(r.states(0, 1), x0[1]);
  EXPECT_EQ(r.t, t);
}

TEST(CvodeSimulator, SingleTimeReturnsInitialState) {
  const Eigen::VectorXd t = Eigen::VectorXd::Constant(1, 2.0);
  const sid::SimulationResult r = sid::simulate(DampedOscillator(), Eigen::Vector2d(1.0, 2.0), t);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.states, Eigen::RowVector2d(1.0, 2.0));
  EXPECT_EQ(r.statistics.steps, 0);
}

TEST(CvodeSimulator, AcceptsRhsReturningTheDerivative) {
  // x' = -k x, x(0) = 2: exponential decay, in the returning form of the callable.
  const double k = 0.7;
  auto decay = [k](double, const Eigen::Ref<const Eigen::VectorXd>& x) -> Eigen::VectorXd {
    return -k * x;
  };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(21, 0.0, 5.0);
  const sid::SimulationResult r = sid::simulate(decay, Eigen::VectorXd::Constant(1, 2.0), t);
  ASSERT_TRUE(r.ok()) << r.message;
  for (Eigen::Index i = 0; i < t.size(); ++i)
    EXPECT_NEAR(r.states(i, 0), 2.0 * std::exp(-k * t[i]), kAnalyticTol) << "t = " << t[i];
}

TEST(CvodeSimulator, AcceptsRhsWithEigenRefArguments) {
  // x' = A x with a rotation generator: the state stays on the circle of radius |x0|, and
  // x(t) = (cos t, sin t) for x0 = (1, 0).
  auto rotation = [](double, const Eigen::Ref<const Eigen::VectorXd>& x,
                     Eigen::Ref<Eigen::VectorXd> xdot) {
    xdot[0] = -x[1];
    xdot[1] = x[0];
  };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(64, 0.0, 2.0 * M_PI);
  const sid::SimulationResult r = sid::simulate(rotation, Eigen::Vector2d(1.0, 0.0), t);
  ASSERT_TRUE(r.ok()) << r.message;
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(r.states(i, 0), std::cos(t[i]), kAnalyticTol);
    EXPECT_NEAR(r.states(i, 1), std::sin(t[i]), kAnalyticTol);
  }
}

TEST(CvodeSimulator, MethodsAgreeOnTimeVaryingInput) {
  // x' = -x + sin(3t): the input folded into the right-hand side.
  auto forced = [](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                   Eigen::Map<Eigen::VectorXd>& xdot) { xdot[0] = -x[0] + std::sin(3.0 * time); };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(201, 0.0, 4.0);
  const Eigen::VectorXd x0 = Eigen::VectorXd::Zero(1);
  // Exact: x = (sin 3t - 3 cos 3t)/10 + 3/10 e^{-t}.
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SimulationResult r = sid::simulate(forced, x0, t, options);
    ASSERT_TRUE(r.ok()) << r.message;
    for (Eigen::Index i = 0; i < t.size(); ++i) {
      const double exact =
          (std::sin(3.0 * t[i]) - 3.0 * std::cos(3.0 * t[i])) / 10.0 + 0.3 * std::exp(-t[i]);
      EXPECT_NEAR(r.states(i, 0), exact, kAnalyticTol) << "t = " << t[i];
    }
  }
}

TEST(CvodeSimulator, BlowUpGivesFailureStatusNotCrash) {
  // x' = x^2, x(0) = 1 has x = 1/(1 - t): it leaves every bound at t = 1.
  auto blow_up = [](double, const Eigen::Map<const Eigen::VectorXd>& x,
                    Eigen::Map<Eigen::VectorXd>& xdot) { xdot[0] = x[0] * x[0]; };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(5, 0.0, 2.0);  // 0, .5, 1, 1.5, 2
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SimulationResult r = sid::simulate(blow_up, Eigen::VectorXd::Ones(1), t, options);
    EXPECT_FALSE(r.ok()) << "method " << static_cast<int>(method);
    // x overflows to infinity just before t = 1, which the simulator reports as such.
    EXPECT_EQ(r.status, sid::SimulationStatus::NonFinite) << sid::to_string(r.status);
    EXPECT_NE(r.flag_name, "CV_SUCCESS");
    EXPECT_FALSE(r.message.empty());
    EXPECT_LE(r.t_reached, 1.0);
    EXPECT_EQ(r.completed, 2);  // t = 0 and t = 0.5 are fine
    EXPECT_NEAR(r.states(1, 0), 2.0, kAnalyticTol);
    EXPECT_TRUE(std::isnan(r.states(2, 0)));  // unreached rows are NaN, not stale numbers
    EXPECT_TRUE(std::isnan(r.states(4, 0)));
  }
}

TEST(CvodeSimulator, TooFewStepsGivesTooMuchWork) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(2, 0.0, 100.0);
  sid::SimulatorOptions options;
  options.max_steps = 10;
  const sid::SimulationResult r =
      sid::simulate(DampedOscillator(), Eigen::Vector2d(1.0, 0.0), t, options);
  EXPECT_EQ(r.status, sid::SimulationStatus::TooMuchWork);
  EXPECT_EQ(r.flag_name, "CV_TOO_MUCH_WORK");
  EXPECT_EQ(r.completed, 1);
  EXPECT_GT(r.t_reached, 0.0);
  EXPECT_LT(r.t_reached, 100.0);
}

TEST(CvodeSimulator, ThrowingRhsGivesRhsFailureWithMessage) {
  auto throws_late = [](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                        Eigen::Map<Eigen::VectorXd>& xdot) {
    if (time > 0.75) throw std::runtime_error("model undefined beyond 0.75 s");
    xdot = -x;
  };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(5, 0.0, 2.0);
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SimulationResult r =
        sid::simulate(throws_late, Eigen::VectorXd::Ones(1), t, options);
    EXPECT_EQ(r.status, sid::SimulationStatus::RhsFailure);
    EXPECT_NE(r.message.find("model undefined beyond 0.75 s"), std::string::npos) << r.message;
    // CVODE names the consequence (CV_RHSFUNC_FAIL for Newton, CV_CONV_FAILURE for fixed point).
    EXPECT_NE(r.flag_name, "CV_SUCCESS");
    EXPECT_EQ(r.completed, 2);
  }
}

TEST(CvodeSimulator, ThrowingNonStandardExceptionIsCaught) {
  auto throws_int = [](double, const Eigen::Map<const Eigen::VectorXd>&,
                       Eigen::Map<Eigen::VectorXd>&) { throw 42; };
  const sid::SimulationResult r =
      sid::simulate(throws_int, Eigen::VectorXd::Ones(1), Eigen::Vector2d(0.0, 1.0));
  EXPECT_EQ(r.status, sid::SimulationStatus::RhsFailure);
  EXPECT_NE(r.message.find("unknown exception"), std::string::npos) << r.message;
}

TEST(CvodeSimulator, NonFiniteDerivativeGivesNonFiniteStatus) {
  auto nan_late = [](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                     Eigen::Map<Eigen::VectorXd>& xdot) {
    xdot = -x;
    if (time > 0.75) xdot[0] = std::numeric_limits<double>::quiet_NaN();
  };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(5, 0.0, 2.0);
  for (const auto method : kAllMethods) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SimulationResult r = sid::simulate(nan_late, Eigen::VectorXd::Ones(1), t, options);
    EXPECT_EQ(r.status, sid::SimulationStatus::NonFinite)
        << sid::to_string(r.status) << " " << r.flag_name << " " << r.message;
    EXPECT_NE(r.message.find("non-finite"), std::string::npos) << r.message;
    EXPECT_EQ(r.completed, 2);
  }
}

TEST(CvodeSimulator, RhsReturningWrongSizeGivesRhsFailure) {
  auto wrong = [](double, const Eigen::Map<const Eigen::VectorXd>&) -> Eigen::VectorXd {
    return Eigen::VectorXd::Zero(3);
  };
  const sid::SimulationResult r =
      sid::simulate(wrong, Eigen::VectorXd::Ones(2), Eigen::Vector2d(0.0, 1.0));
  EXPECT_EQ(r.status, sid::SimulationStatus::RhsFailure);
  EXPECT_NE(r.message.find("3 derivatives for 2 states"), std::string::npos) << r.message;
}

void expect_invalid_argument_naming(const std::function<void()>& call, const std::string& what) {
  try {
    call();
    ADD_FAILURE() << "no exception; expected one naming " << what;
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("sid::simulate", 0), 0u) << message;
    EXPECT_NE(message.find(what), std::string::npos) << message;
  }
}

TEST(CvodeSimulator, ThrowsOnBadInput) {
  const DampedOscillator model;
  const Eigen::Vector2d x0(1.0, 0.0);
  const Eigen::VectorXd good_t = Eigen::VectorXd::LinSpaced(3, 0.0, 1.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  auto run = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& t, sid::SimulatorOptions o) {
    return [=] { static_cast<void>(sid::simulate(model, x, t, o)); };
  };
  const sid::SimulatorOptions defaults;
  expect_invalid_argument_naming(run(Eigen::Vector2d(nan, 0.0), good_t, defaults), "x0");
  expect_invalid_argument_naming(run(Eigen::Vector2d(inf, 0.0), good_t, defaults), "x0");
  expect_invalid_argument_naming(run(Eigen::VectorXd(), good_t, defaults), "x0");
  expect_invalid_argument_naming(run(x0, Eigen::VectorXd(), defaults), "t");
  expect_invalid_argument_naming(run(x0, Eigen::Vector3d(0.0, 1.0, 1.0), defaults),
                                 "strictly increasing");
  expect_invalid_argument_naming(run(x0, Eigen::Vector3d(0.0, 2.0, 1.0), defaults),
                                 "strictly increasing");
  expect_invalid_argument_naming(run(x0, Eigen::Vector3d(0.0, nan, 1.0), defaults), "t[1]");
  sid::SimulatorOptions bad = defaults;
  bad.rtol = 0.0;
  expect_invalid_argument_naming(run(x0, good_t, bad), "rtol");
  bad = defaults;
  bad.atol = -1e-10;
  expect_invalid_argument_naming(run(x0, good_t, bad), "atol");
  bad = defaults;
  bad.atol = nan;
  expect_invalid_argument_naming(run(x0, good_t, bad), "atol");
  bad = defaults;
  bad.max_steps = 0;
  expect_invalid_argument_naming(run(x0, good_t, bad), "max_steps");
  bad = defaults;
  bad.max_step = -1.0;
  expect_invalid_argument_naming(run(x0, good_t, bad), "max_step");
  bad = defaults;
  bad.initial_step = inf;
  expect_invalid_argument_naming(run(x0, good_t, bad), "initial_step");
}

TEST(CvodeSimulator, MaxStepLimitsTheStepSize) {
  // With hmax = 0.01 s over 10 s at least 1000 steps are needed; without it far fewer.
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(2, 0.0, 10.0);
  const sid::SimulationResult free_run =
      sid::simulate(DampedOscillator(), Eigen::Vector2d(1.0, 0.0), t);
  sid::SimulatorOptions limited;
  limited.max_step = 0.01;
  const sid::SimulationResult limited_run =
      sid::simulate(DampedOscillator(), Eigen::Vector2d(1.0, 0.0), t, limited);
  ASSERT_TRUE(free_run.ok());
  ASSERT_TRUE(limited_run.ok());
  EXPECT_LT(free_run.statistics.steps, 1000);
  EXPECT_GE(limited_run.statistics.steps, 1000);
}

}  // namespace
