#pragma once
// Test-only: the true trajectory of the paper's experiment, simulated once per test program.

#include <sid/cvode/experiment.hpp>
#include <sid/model/two_link_arm.hpp>

#include <stdexcept>

namespace sid_test {

inline const sid::Kinematics<double>& paper_truth() {
  static const sid::Kinematics<double> k = [] {
    const auto theta = sid::paper_arm_parameters<double>();
    const auto run =
        sid::simulate_arm_experiment([&](const auto& q, const auto& qd, const auto& tau) {
          return sid::two_link_forward_dynamics(theta, q, qd, tau);
        });
    if (!run.ok()) throw std::runtime_error("simulation failed: " + run.message);
    return run.truth;
  }();
  return k;
}

}  // namespace sid_test
