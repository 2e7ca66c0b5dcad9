#pragma once
// Data of the paper's arm with hidden effects (sid/model/effects.hpp), for the diagnosis tests.

#include <gtest/gtest.h>

#include <random>
#include <sid/cvode/experiment.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/effects.hpp>
#include <string>
#include <utility>
#include <vector>

namespace sid::test {

constexpr double kTauVariance = 1e-2;  // σ_τ² [N² m²] of the diagnosis test data
constexpr double kQVariance = 1e-6;    // σq² [rad²]

enum class Excitation { Paper, Multisine };

inline std::string excitation_name(Excitation e) {
  return e == Excitation::Paper ? "paper" : "multisine";
}

/// Measured data of the paper's arm with hidden effects: CVODE through effectful_arm's model,
/// then measured τ = applied + b, measured q = true q − δ, then Gaussian noise.
inline Trajectory<double> simulate(const std::vector<EffectSpec>& effects, Excitation excitation,
                                   unsigned seed, double q_variance = kQVariance) {
  const EffectfulArm arm = effectful_arm(paper_arm_parameters<double>(), effects);
  const auto fd = [&arm](const Vector2<double>& q, const Vector2<double>& qd,
                         const Vector2<double>& tau) {
    return arm.model.forward_dynamics(arm.theta, q, qd, tau);
  };
  const ExperimentResult run = excitation == Excitation::Paper
                                   ? simulate_arm_experiment(fd, PaperInput())
                                   : simulate_arm_experiment(fd, MultisineInput());
  EXPECT_TRUE(run.ok()) << run.message;
  Trajectory<double> truth = run.trajectory();
  for (int j = 0; j < 2; ++j) {
    truth.q.col(j).array() -= arm.angle_offset[j];
    truth.tau.col(j).array() += arm.torque_offset[j];
  }
  std::mt19937_64 rng(seed);
  return add_measurement_noise(truth, MeasurementNoise<double>{q_variance, kTauVariance}, rng);
}

/// The data sets a case runs: both excitations with both seeds, or under the sanitizers (which
/// check memory and undefined behaviour, not the numbers, at about 18 times the run time) two
/// that still cover both excitations and both seeds.
inline std::vector<std::pair<Excitation, unsigned>> case_data_sets(unsigned first_seed,
                                                                   unsigned second_seed) {
#ifdef SID_SANITIZED_TESTS
  return {{Excitation::Paper, first_seed}, {Excitation::Multisine, second_seed}};
#else
  return {{Excitation::Paper, first_seed},
          {Excitation::Paper, second_seed},
          {Excitation::Multisine, first_seed},
          {Excitation::Multisine, second_seed}};
#endif
}

}  // namespace sid::test
