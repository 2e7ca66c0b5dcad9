// Tests of sid::simulate_with_sensitivities: the sensitivities of a damped oscillator with a
// constant force against their closed form, by parameter and by initial state; failures and
// bad arguments are reported, not crashed on.

#include <sid/cvode/sensitivity.hpp>

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

namespace {

using ConstMap = Eigen::Map<const Eigen::VectorXd>;
using Map = Eigen::Map<Eigen::VectorXd>;

// x'' = -k x + f: x(t) = f/k + (x0 - f/k) cos(w t) + v0/w sin(w t), w = sqrt(k).
constexpr double kStiffness = 4.0, kForce = 1.5, kX0 = 0.3, kV0 = -0.2;

struct Oscillator {
  void operator()(double, const ConstMap& x, Map& xdot) const {
    xdot[0] = x[1];
    xdot[1] = -kStiffness * x[0] + kForce;
  }
};

// Parameters (k, f, x0, v0): ṡ = A s + ∂f/∂p with A = [[0, 1], [-k, 0]].
struct OscillatorSensitivity {
  void operator()(double, const ConstMap& x, const ConstMap&, const Eigen::MatrixXd& s,
                  Eigen::MatrixXd& sdot) const {
    sdot.row(0) = s.row(1);
    sdot.row(1) = -kStiffness * s.row(0);
    sdot(1, 0) -= x[0];
    sdot(1, 1) += 1.0;
  }
};

double position(double k, double f, double x0, double v0, double t) {
  const double w = std::sqrt(k);
  return f / k + (x0 - f / k) * std::cos(w * t) + v0 / w * std::sin(w * t);
}

Eigen::MatrixXd initial_sensitivities() {
  Eigen::MatrixXd s0 = Eigen::MatrixXd::Zero(2, 4);
  s0(0, 2) = 1.0;  // dx0/dx0
  s0(1, 3) = 1.0;  // dv0/dv0
  return s0;
}

TEST(Sensitivity, MatchesTheClosedFormByParameterAndInitialState) {
  const Eigen::Vector2d x0(kX0, kV0);
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(41, 0.0, 4.0);
  for (const auto method : {sid::IntegrationMethod::AdamsNewton, sid::IntegrationMethod::Bdf}) {
    sid::SimulatorOptions options;
    options.method = method;
    const sid::SensitivityResult r = sid::simulate_with_sensitivities(
        Oscillator(), OscillatorSensitivity(), x0, initial_sensitivities(), t, options);
    ASSERT_TRUE(r.ok()) << r.simulation.message;
    ASSERT_EQ(r.sensitivities.rows(), t.size());
    ASSERT_EQ(r.sensitivities.cols(), 8);
    double worst = 0.0;
    for (Eigen::Index k = 0; k < t.size(); ++k) {
      // The closed form's derivatives by central differences of the closed form itself.
      const double h = 1e-6;
      const double p[4] = {kStiffness, kForce, kX0, kV0};
      const Eigen::MatrixXd s = r.at(k);
      for (int i = 0; i < 4; ++i) {
        double up[4] = {p[0], p[1], p[2], p[3]}, down[4] = {p[0], p[1], p[2], p[3]};
        up[i] += h;
        down[i] -= h;
        const double expected = (position(up[0], up[1], up[2], up[3], t[k]) -
                                 position(down[0], down[1], down[2], down[3], t[k])) /
                                (2 * h);
        worst = std::max(worst, std::fabs(s(0, i) - expected));
      }
      EXPECT_NEAR(r.simulation.states(k, 0), position(kStiffness, kForce, kX0, kV0, t[k]), 1e-7);
    }
    // Out of the error test, the sensitivities are as accurate as the state's steps allow.
    EXPECT_LT(worst, 1e-6) << static_cast<int>(method);
  }
}

TEST(Sensitivity, FirstRowIsTheInitialSensitivity) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(3, 0.0, 1.0);
  const sid::SensitivityResult r = sid::simulate_with_sensitivities(
      Oscillator(), OscillatorSensitivity(), Eigen::Vector2d(kX0, kV0), initial_sensitivities(), t);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.at(0), initial_sensitivities());
}

TEST(Sensitivity, ThrowingSensitivityRhsIsReportedAsRhsFailure) {
  const auto throwing = [](double time, const ConstMap&, const ConstMap&, const Eigen::MatrixXd&,
                           Eigen::MatrixXd& sdot) {
    if (time > 0.5) throw std::runtime_error("sensitivity model broke");
    sdot.setZero();
  };
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(11, 0.0, 1.0);
  const sid::SensitivityResult r = sid::simulate_with_sensitivities(
      Oscillator(), throwing, Eigen::Vector2d(kX0, kV0), initial_sensitivities(), t);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.simulation.status, sid::SimulationStatus::RhsFailure);
  EXPECT_NE(r.simulation.message.find("sensitivity model broke"), std::string::npos)
      << r.simulation.message;
  EXPECT_LT(r.simulation.completed, t.size());
  EXPECT_TRUE(r.sensitivities.bottomRows(1).array().isNaN().all());
}

TEST(Sensitivity, RefusesBadArguments) {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(3, 0.0, 1.0);
  const Eigen::Vector2d x0(kX0, kV0);
  const auto call = [&](const Eigen::MatrixXd& s0, sid::SimulatorOptions options = {}) {
    return sid::simulate_with_sensitivities(Oscillator(), OscillatorSensitivity(), x0, s0, t,
                                            options);
  };
  EXPECT_THROW((void)call(Eigen::MatrixXd::Zero(3, 4)), std::invalid_argument);  // rows != states
  EXPECT_THROW((void)call(Eigen::MatrixXd::Zero(2, 0)), std::invalid_argument);  // no parameter
  Eigen::MatrixXd nan = initial_sensitivities();
  nan(0, 0) = std::nan("");
  EXPECT_THROW((void)call(nan), std::invalid_argument);
  sid::SimulatorOptions fixed_point;
  fixed_point.method = sid::IntegrationMethod::AdamsFixedPoint;
  EXPECT_THROW((void)call(initial_sensitivities(), fixed_point), std::invalid_argument);
  const Eigen::VectorXd decreasing = Eigen::Vector3d(0.0, 1.0, 0.5);
  EXPECT_THROW((void)sid::simulate_with_sensitivities(Oscillator(), OscillatorSensitivity(), x0,
                                                      initial_sensitivities(), decreasing),
               std::invalid_argument);
}

}  // namespace
