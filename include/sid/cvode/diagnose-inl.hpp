#pragma once
// Definitions of sid/cvode/diagnose.hpp (see sid/config.hpp).

#include <sid/cvode/diagnose.hpp>

namespace sid {

namespace detail {

SID_INLINE MatrixX2<double> mean_square(const std::vector<MatrixX2<double>>& runs, Eigen::Index n) {
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

SID_INLINE std::vector<FlaggedWindow> simulation_windows(
    const FreeSimulation& sim, const Eigen::Ref<const MatrixX2<double>>& expected_ms,
    double window_length, const SimulationCheckOptions& check) {
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
          windows.push_back(
              {j + 1, w_begin, std::min(w_end, sim.t[n - 1]),
               reference > 0.0 ? rms / reference : std::numeric_limits<double>::infinity()});
      }
      begin = end;
    }
  }
  return windows;
}

namespace detail {

SID_INLINE void check_simulation_check_options(const SimulationCheckOptions& check) {
  const std::string who = "sid::diagnose_with_simulation: ";
  if (check.noise_runs < 1) throw std::invalid_argument(who + "check.noise_runs must be >= 1");
  if (check.threads < 0)
    throw std::invalid_argument(who + "check.threads must be >= 0 (0: every core)");
  if (!(check.threshold > 0.0) || !std::isfinite(check.threshold))
    throw std::invalid_argument(who + "check.threshold must be finite and > 0");
  if (!(check.min_error >= 0.0) || !std::isfinite(check.min_error))
    throw std::invalid_argument(who + "check.min_error must be finite and >= 0 [rad]");
  if (!(check.noise_tolerance > 0.0) || !std::isfinite(check.noise_tolerance))
    throw std::invalid_argument(who + "check.noise_tolerance must be finite and > 0");
  if (!(check.checked_tolerance >= 0.0) || !std::isfinite(check.checked_tolerance))
    throw std::invalid_argument(who + "check.checked_tolerance must be finite and >= 0 (0: sim's)");
}

/// Copies of k whose torques carry white noise at the floor. The draws come first, in order, so
/// that the simulations (independent) can run on every core and still be reproducible.
SID_INLINE std::vector<Kinematics<double>> with_torque_noise(const Kinematics<double>& k,
                                                             const Vector2<double>& sigma, int runs,
                                                             std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<Kinematics<double>> noisy(static_cast<std::size_t>(runs), k);
  for (auto& run : noisy)
    for (int j = 0; j < 2; ++j)
      for (Eigen::Index i = 0; i < k.size(); ++i)
        run.tau(i, j) = k.tau(i, j) + sigma[j] * normal(rng);
  return noisy;
}

}  // namespace detail

SID_INLINE DiagnosisResult diagnose_with_simulation(const Trajectory<double>& data,
                                                    const DiagnoseOptions& options,
                                                    const FreeSimulationOptions& sim,
                                                    const SimulationCheckOptions& check,
                                                    SimulationCheck* details) {
  detail::check_simulation_check_options(check);
  const auto start = std::chrono::steady_clock::now();
  DiagnosisResult result = diagnose(data, options);
  const Kinematics<double>& k = result.kinematics;
  const Eigen::Index n = k.size();
  SimulationCheck check_result;
  FreeSimulationOptions checked = sim;
  if (check.checked_tolerance > 0.0)
    checked.simulator.rtol = checked.simulator.atol = check.checked_tolerance;
  // The friction test does not change the nominal model, and its fits leave a core idle part
  // of the time (a handful of windows on two threads): the nominal simulation runs beside it,
  // as a second task of the pool. Both only read the result; the refined one replaces it after.
  const bool nominal_beside_friction_test =
      check.refine_friction &&
      (detail::names_friction_of(result, 1) || detail::names_friction_of(result, 2));
  if (nominal_beside_friction_test) {
    DiagnosisResult refined;
    detail::for_each_index(2, detail::thread_count(check.threads), [&](Eigen::Index task, int) {
      if (task == 0)
        refined = refine_named_friction(result, data, options, check.friction);
      else
        check_result.nominal =
            free_simulation(result.nominal_model, result.nominal.theta, k, checked);
    });
    result = std::move(refined);
  }

  // The noise alone: (sim with tau + w) - (sim with tau), w white at the noise floor.
  FreeSimulationOptions loose = sim;
  loose.simulator.rtol = loose.simulator.atol = check.noise_tolerance;
  const std::vector<Kinematics<double>> noisy =
      detail::with_torque_noise(k, result.noise_floor, check.noise_runs, check.seed);
  FreeSimulation base;
  std::vector<FreeSimulation> perturbed(noisy.size());
  const bool named = !result.effects.empty();
  // The two checked simulations (the tighter tolerance, the longest) first.
  std::vector<std::function<void()>> runs;
  if (!nominal_beside_friction_test)
    runs.emplace_back([&] {
      check_result.nominal =
          free_simulation(result.nominal_model, result.nominal.theta, k, checked);
    });
  if (named)
    runs.emplace_back([&] {
      check_result.final = free_simulation(result.final_model, result.final.theta, k, checked);
    });
  const Model<double>& calibrated = named ? result.final_model : result.nominal_model;
  const Eigen::VectorXd& calibrated_theta = named ? result.final.theta : result.nominal.theta;
  runs.emplace_back([&] { base = free_simulation(calibrated, calibrated_theta, k, loose); });
  for (std::size_t r = 0; r < noisy.size(); ++r)
    runs.emplace_back(
        [&, r] { perturbed[r] = free_simulation(calibrated, calibrated_theta, noisy[r], loose); });
  detail::for_each_index(static_cast<Eigen::Index>(runs.size()),
                         detail::thread_count(check.threads),
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

}  // namespace sid
