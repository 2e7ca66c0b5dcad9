// Built against an installed sid through find_package(sid), once per build mode: header-only
// (sid::sid) and compiled (sid::compiled). Diagnoses an arm whose torques the paper's model
// explains exactly and checks that the nominal parameters come back.
#include <sid/diagnose.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters<double>();
  constexpr Eigen::Index kSamples = 2000;
  sid::Trajectory<double> data;
  data.t = Eigen::VectorXd::LinSpaced(kSamples, 0.0, 10.0);
  data.q.resize(kSamples, 2);
  data.tau.resize(kSamples, 2);
  for (Eigen::Index i = 0; i < kSamples; ++i) {
    const double t = data.t[i];
    const sid::Vector2<double> q(std::sin(1.3 * t) + 0.3 * std::sin(3.1 * t),
                                 0.8 * std::cos(1.7 * t)),
        qd(1.3 * std::cos(1.3 * t) + 0.93 * std::cos(3.1 * t), -1.36 * std::sin(1.7 * t)),
        qdd(-1.69 * std::sin(1.3 * t) - 2.883 * std::sin(3.1 * t), -2.312 * std::cos(1.7 * t));
    data.q.row(i) = q.transpose();
    data.tau.row(i) = sid::two_link_inverse_dynamics(theta, q, qd, qdd).transpose();
  }
  const sid::DiagnosisResult result = sid::diagnose(data);
  const double error =
      ((result.nominal.theta.head(7) - theta).array() / theta.array()).abs().maxCoeff();
  std::printf("nominal theta: largest relative error %.2e, %zu effects named\n", error,
              result.effects.size());
  return error < 1e-2 ? 0 : 1;
}
