#pragma once
/// @file
/// @brief The diagnosis of sid/diagnose.hpp plus the free-simulation check: the nominal and the
/// final model, each simulated open loop from the measured torque, compared with the measured
/// angles, and the time windows where a model drifts further than the torque noise explains.

#include <sid/cvode/free_simulation.hpp>
#include <sid/cvode/friction_refinement.hpp>
#include <sid/cvode/simulation_check.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/diagnose.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <future>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace sid {

// The functions here are templates on an unused parameter, so that a file compiles only those
// it calls (README, "Tests"; src/precompiled/pipeline.cpp).

/// @brief How simulation windows are judged.
///
/// An open-loop simulation driven by a noisy torque drifts even with the exact model (a random
/// walk, see free_simulation), so a fixed threshold in radians would be wrong for every noise
/// level but one. The threshold is calibrated on the data instead: the final model (the
/// nominal one when nothing is named) is simulated `noise_runs` more times with white noise of
/// the estimated torque noise floor added to the measured torque, and the difference to the
/// plain simulation is what the torque noise alone does. The final model because it is the one
/// that fits: a nominal model that misses a spring on joint 1 blew up in every noise run, and
/// the samples no run reached had no scale (the final model, at the noise level there, had 24
/// windows flagged). Its mean square over the runs at each sample (not pooled over segments: how
/// much the noise moves the arm depends on where the arm is, e.g. joint 1 near the top) gives
/// the expected error of every window; a window is flagged when its error RMS exceeds
/// `threshold` times that. The noise is drawn from std::mt19937_64(seed), so the result depends
/// only on the data and these settings.
struct SimulationCheckOptions {
  int noise_runs = 8;  ///< simulations of the noise alone, >= 1
  /// Flag when window RMS > threshold x the RMS the noise alone gives, > 0. The noise alone is
  /// not all an exact model leaves: the restart state is smoothed and theta is estimated, which
  /// the calibration does not simulate. On effect-free data (paper and multisine excitation,
  /// sigma_q^2 = 1e-6 and 1e-4, 2 seeds each; 40 windows each) the largest ratio measured was
  /// 4.6, on joint 1 (with 8 runs as with 16); 6 (36x in mean square) leaves that margin, and
  /// the effects near their detection limit still exceed it (coulomb_j2 0.05 N m on the
  /// multisine data: 5.9-7.8; armature_j2 = 2 theta2: 7.8-8.6).
  double threshold = 6.0;
  /// Errors below this are never flagged [rad]: on noise-free data the noise alone gives 0, and
  /// the smoothing of q leaves errors of this order.
  double min_error = 1e-4;
  std::uint64_t seed = 20261122;
  /// CVODE's rtol = atol for the noise-alone simulations (the plain one they are compared
  /// with included): they only set a statistical scale. 1e-5 leaves errors of at most 8e-5 rad
  /// (against the checked simulation, Stribeck and Coulomb test sets), against a noise effect
  /// of ~5e-3 rad RMS: under 0.1 % of the expected mean square. It takes 4400 steps where 1e-6
  /// took 6800 (7.5 against 11.5 ms per run).
  double noise_tolerance = 1e-5;
  /// CVODE's rtol = atol for the checked simulations of the nominal and the final model (0:
  /// those of the FreeSimulationOptions given). The free simulation's own default, 1e-9, bounds
  /// the exact model's error on the exact experiment at 1.4e-7 rad; 1e-7 gives 9e-6 rad, still
  /// a tenth of min_error and far below the noise effect (~5e-3 rad), and takes a third of the
  /// steps (17000 instead of 51500 on the paper's noisy record).
  double checked_tolerance = 1e-7;
  /// Test each named friction curve by output error (sid/cvode/friction_refinement.hpp):
  /// Coulomb or Stribeck, and the Stribeck values from the angles.
  bool refine_friction = true;
  FrictionRefinementOptions friction;
};

namespace detail {

/// Mean square per sample over the noise-alone runs (NaN entries of failed runs left out).
template <typename = void>
inline MatrixX2<double> mean_square(const std::vector<MatrixX2<double>>& runs, Eigen::Index n) {
  MatrixX2<double> ms = MatrixX2<double>::Zero(n, 2);
  for (Eigen::Index i = 0; i < n; ++i)
    for (int j = 0; j < 2; ++j) {
      double sum = 0.0;
      int count = 0;
      for (const auto& e : runs)
        if (std::isfinite(e(i, j))) {
          sum += e(i, j) * e(i, j);
          ++count;
        }
      ms(i, j) = count > 0 ? sum / count : 0.0;
    }
  return ms;
}

}  // namespace detail

/// @brief Windows of length window_length [s] (from t[0]) in which a joint's simulation error
/// RMS exceeds max(threshold x the expected RMS, min_error); expected_ms is the expected mean
/// square per sample and joint. ratio = window RMS / expected RMS (infinite when that is 0).
/// NaN errors (a failed simulation) are left out; a window needs 2 finite samples.
/// @throws std::invalid_argument for sizes that differ or a window_length that is not > 0.
template <typename = void>
inline std::vector<FlaggedWindow> simulation_windows(const FreeSimulation& sim,
                                                     const Eigen::Ref<const MatrixX2<double>>& expected_ms,
                                                     double window_length,
                                                     const SimulationCheckOptions& check = {}) {
  const std::string who = "sid::simulation_windows: ";
  const Eigen::Index n = sim.t.size();
  if (sim.error.rows() != n || expected_ms.rows() != n)
    throw std::invalid_argument(who + "sim.t, sim.error and expected_ms must have the same rows");
  if (!(window_length > 0.0) || !std::isfinite(window_length))
    throw std::invalid_argument(who + "window_length must be finite and > 0 [s]");
  std::vector<FlaggedWindow> windows;
  if (n == 0) return windows;
  const double t0 = sim.t[0];
  for (int j = 0; j < 2; ++j) {
    Eigen::Index begin = 0;
    while (begin < n) {
      const auto m = std::floor((sim.t[begin] - t0) / window_length + 1e-9);
      const double w_begin = t0 + m * window_length, w_end = w_begin + window_length;
      Eigen::Index end = begin;
      double observed = 0.0, expected = 0.0;
      Eigen::Index count = 0;
      while (end < n && sim.t[end] < w_end - 1e-9 * window_length) {
        const double e = sim.error(end, j);
        if (std::isfinite(e)) {
          observed += e * e;
          expected += expected_ms(end, j);
          ++count;
        }
        ++end;
      }
      if (end == begin) ++end;  // cannot happen for increasing t; guards the loop
      if (count >= 2) {
        const double rms = std::sqrt(observed / static_cast<double>(count));
        const double reference = std::sqrt(expected / static_cast<double>(count));
        if (rms > check.threshold * reference && rms > check.min_error)
          windows.push_back({j + 1, w_begin, std::min(w_end, sim.t[n - 1]),
                             reference > 0.0 ? rms / reference
                                             : std::numeric_limits<double>::infinity()});
      }
      begin = end;
    }
  }
  return windows;
}

/// @brief Runs diagnose(data, options), then the free simulations of the nominal and the final
/// model on the result's kinematics (restarted every sim.segment seconds), and fills
/// nominal/final sim_error_rms and sim_windows (windows of options.window_length judged as
/// SimulationCheckOptions describes, with one threshold for both models).
/// A simulation that fails numerically does not throw: its error covers the samples it reached
/// and `details->nominal/final.message` says what failed.
/// @param[out] details when not null, the simulations and the noise calibration.
/// @throws std::invalid_argument as diagnose() does, for bad simulation options, or for bad
///   check options (noise_runs < 1, threshold or min_error not > 0 / >= 0).
template <typename = void>
DiagnosisResult diagnose_with_simulation(const Trajectory<double>& data,
                                         const DiagnoseOptions& options = {},
                                         const FreeSimulationOptions& sim = {},
                                         const SimulationCheckOptions& check = {},
                                         SimulationCheck* details = nullptr) {
  const std::string who = "sid::diagnose_with_simulation: ";
  if (check.noise_runs < 1) throw std::invalid_argument(who + "check.noise_runs must be >= 1");
  if (!(check.threshold > 0.0) || !std::isfinite(check.threshold))
    throw std::invalid_argument(who + "check.threshold must be finite and > 0");
  if (!(check.min_error >= 0.0) || !std::isfinite(check.min_error))
    throw std::invalid_argument(who + "check.min_error must be finite and >= 0 [rad]");
  if (!(check.noise_tolerance > 0.0) || !std::isfinite(check.noise_tolerance))
    throw std::invalid_argument(who + "check.noise_tolerance must be finite and > 0");
  if (!(check.checked_tolerance >= 0.0) || !std::isfinite(check.checked_tolerance))
    throw std::invalid_argument(who + "check.checked_tolerance must be finite and >= 0 (0: sim's)");
  const auto start = std::chrono::steady_clock::now();
  DiagnosisResult result = diagnose(data, options);
  const Kinematics<double>& k = result.kinematics;
  const Eigen::Index n = k.size();
  SimulationCheck check_result;
  FreeSimulationOptions checked = sim;
  if (check.checked_tolerance > 0.0) checked.simulator.rtol = checked.simulator.atol = check.checked_tolerance;
  // The friction test does not change the nominal model, and its fits leave a core idle part
  // of the time (a handful of windows on two threads): the nominal simulation runs beside it.
  // It works on copies: the friction test rewrites the result.
  const bool nominal_beside_friction_test =
      check.refine_friction && (detail::names_friction_of(result, 1) || detail::names_friction_of(result, 2));
  if (nominal_beside_friction_test) {
    std::future<FreeSimulation> nominal = std::async(
        std::launch::async, [model = result.nominal_model, theta = result.nominal.theta, kinematics = k, &checked] {
          return free_simulation(model, theta, kinematics, checked);
        });
    refine_named_friction(result, data, options, check.friction);
    check_result.nominal = nominal.get();
  }

  // The noise alone: (sim with tau + w) - (sim with tau), w white at the noise floor. The draws
  // come first, in order, so that the simulations (independent) can run on every core.
  FreeSimulationOptions loose = sim;
  loose.simulator.rtol = loose.simulator.atol = check.noise_tolerance;
  std::mt19937_64 rng(check.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Kinematics<double>> noisy(static_cast<std::size_t>(check.noise_runs), k);
  for (auto& run : noisy)
    for (int j = 0; j < 2; ++j)
      for (Eigen::Index i = 0; i < n; ++i) run.tau(i, j) = k.tau(i, j) + result.noise_floor[j] * normal(rng);
  FreeSimulation base;
  std::vector<FreeSimulation> perturbed(noisy.size());
  const bool named = !result.effects.empty();
  // The two checked simulations (the tighter tolerance, the longest) first.
  std::vector<std::function<void()>> runs;
  if (!nominal_beside_friction_test)
    runs.emplace_back([&] { check_result.nominal = free_simulation(result.nominal_model, result.nominal.theta, k, checked); });
  if (named)
    runs.emplace_back([&] { check_result.final = free_simulation(result.final_model, result.final.theta, k, checked); });
  const Model<double>& calibrated = named ? result.final_model : result.nominal_model;
  const Eigen::VectorXd& calibrated_theta = named ? result.final.theta : result.nominal.theta;
  runs.emplace_back([&] { base = free_simulation(calibrated, calibrated_theta, k, loose); });
  for (std::size_t r = 0; r < noisy.size(); ++r)
    runs.emplace_back([&, r] { perturbed[r] = free_simulation(calibrated, calibrated_theta, noisy[r], loose); });
  detail::for_each_index(static_cast<Eigen::Index>(runs.size()),
                         static_cast<int>(std::max(1u, std::thread::hardware_concurrency())),
                         [&](Eigen::Index task, int) { runs[static_cast<std::size_t>(task)](); });
  std::vector<MatrixX2<double>> noise_errors;
  for (const auto& p : perturbed) noise_errors.push_back(p.q - base.q);
  const MatrixX2<double> expected_ms = detail::mean_square(noise_errors, n);
  check_result.noise_rms = expected_ms.cwiseSqrt();
  for (int j = 0; j < 2; ++j)
    check_result.noise_error_rms[j] = n > 0 ? std::sqrt(expected_ms.col(j).mean()) : 0.0;

  result.nominal.sim_error_rms = check_result.nominal.error_rms;
  result.nominal.sim_windows =
      simulation_windows(check_result.nominal, expected_ms, options.window_length, check);
  if (!named) check_result.final = check_result.nominal;
  result.final.sim_error_rms = check_result.final.error_rms;
  result.final.sim_windows =
      simulation_windows(check_result.final, expected_ms, options.window_length, check);
  // The whole wall time, diagnose() included.
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (details) *details = std::move(check_result);
  return result;
}

#ifdef SID_PRECOMPILED
// Compiled once, in src/precompiled/pipeline.cpp, for the programs that link it.
extern template DiagnosisResult diagnose_with_simulation<>(const Trajectory<double>&, const DiagnoseOptions&,
                                                         const FreeSimulationOptions&, const SimulationCheckOptions&,
                                                         SimulationCheck*);
#endif

}  // namespace sid
