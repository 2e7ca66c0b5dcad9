#pragma once
/// @file
/// @brief Whether a diagnosed chain model explains the measured motion, judged against what an
/// exact model does on the same arm, motion and noise (a parametric bootstrap).
///
/// A free simulation (sid/cvode/chain_free_simulation.hpp) of a model that fits the torques
/// still drifts from the measured angles: its parameters carry the noise's estimation error,
/// its segments start from smoothed states, and open-loop arms amplify all of it, far more on a
/// light wrist than on a heavy shoulder. How far an exact model drifts therefore depends on the
/// arm and the log, and no constant threshold holds on arms it was not tuned on. Here each
/// replicate is a log the final model explains exactly: the smoothed measured motion, its torque
/// from the final model's physically consistent fit, and white noise of the log's own levels on
/// angles and torques (the angles' from their smoothing residual, the torques' the diagnosis's
/// noise floor). Each replicate is identified, made consistent and freely simulated as the
/// measured log is, and a joint whose measured error exceeds `margin` times the largest
/// replicate's moves in a way the final model does not explain. The simulations cover the
/// window the identification trusts (its skips left out): at a log's ends the natural spline
/// bends a measured motion's rates, but not a replicate's, whose truth is already that spline,
/// and with the ends the measured UR5 logs' errors sat at 1.5-2x their replicates'.

#include <sid/chain_consistency.hpp>
#include <sid/cvode/chain_free_simulation.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/diagnose_chain.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Settings of check_chain_motion().
struct ChainMotionCheckOptions {
  /// Exact-model replicates of the log, >= 1.
  int replicates = 6;
  /// A joint is flagged when its final error exceeds this many times the largest replicate's,
  /// >= 1: the replicates give the scale, the margin the room for a measured log's own spread
  /// (see docs/discrepancy-workflow.md for the false-alarm rates it gives).
  double margin = 2.0;
  /// Replicate b draws its noise from std::mt19937_64(seed + b): results do not depend on the
  /// thread count.
  std::uint64_t seed = 20261205;
  /// Simulated angles are compared at most at this rate [Hz], > 0: enough for the motion, and
  /// the integrator stops at every output time.
  double compare_rate_hz = 500.0;
  /// Threads the replicates run on; 0: every core.
  int threads = 0;
  /// 1e-6: errors of the exact models are 1e-3 rad and more, which 1e-6 gives to three digits
  /// (as 1e-8) in a quarter of the time; the log and its replicates share it.
  ChainFreeSimulationOptions simulation = [] {
    ChainFreeSimulationOptions o;
    o.simulator.rtol = o.simulator.atol = 1e-6;
    return o;
  }();
  ChainConsistencyOptions consistency;
};

/// @brief What check_chain_motion() found. Angle errors are RMS per joint over every simulated
/// sample of every run [rad or m].
struct ChainMotionCheck {
  Eigen::VectorXd nominal_error, final_error;
  Eigen::MatrixXd replicate_error;  ///< one row per replicate (NaN where none ran)
  Eigen::VectorXd threshold;        ///< margin times each joint's largest replicate error
  Eigen::VectorXd angle_noise;      ///< σ of the angle noise per joint the replicates drew
  std::vector<int> beyond;          ///< joints (0-based) whose final error exceeds the threshold
  Eigen::Index segments = 0;        ///< per simulation over all runs
  Eigen::Index failed_nominal = 0, failed_final = 0, failed_replicates = 0;
  /// Why a model could not be fitted, else the first failed segment's message; empty if all ran.
  std::string failure;
};

namespace detail {

/// Every k-th sample of kinematics, k so that the rate is at most rate_hz, within the window the
/// identification trusts: the smoothing spline's natural ends distort the angles' rates there,
/// far more on a measured motion than on a replicate's, whose truth is itself a natural spline.
inline ChainKinematics<double> at_most_rate(const ChainKinematics<double>& k, double rate_hz,
                                            const ChainIdentifyOptions& identify) {
  const double period = (k.t[k.size() - 1] - k.t[0]) / static_cast<double>(k.size() - 1);
  const auto stride =
      static_cast<Eigen::Index>(std::max(1.0, std::round(1.0 / (rate_hz * period))));
  Eigen::Index first = 0, last = k.size() - 1;
  while (first + 2 < last && k.t[first] < k.t[0] + identify.skip) ++first;
  while (last - 2 > first && k.t[last] > k.t[k.size() - 1] - identify.skip_end) --last;
  const auto every = Eigen::seqN(first, (last - first) / stride + 1, stride);
  return {k.t(every), k.q(every, Eigen::all), k.qd(every, Eigen::all), k.qdd(every, Eigen::all),
          k.tau(every, Eigen::all)};
}

/// A model's consistent fit to runs and its free simulations over kinematics, accumulated as
/// sums of squares per joint.
struct MotionSimulation {
  Eigen::VectorXd theta;  ///< the consistent fit, empty when the fit failed
  Eigen::VectorXd squares, counts;
  Eigen::Index segments = 0, failed = 0;
  std::string failure, note;

  Eigen::VectorXd error_rms() const {
    Eigen::VectorXd rms(squares.size());
    for (Eigen::Index j = 0; j < rms.size(); ++j)
      rms[j] = counts[j] > 0.0 ? std::sqrt(squares[j] / counts[j])
                               : std::numeric_limits<double>::quiet_NaN();
    return rms;
  }
};

/// `earlier`: refit its base parameters (a replicate), else identify from scratch.
inline MotionSimulation fit_and_simulate(
    const ChainModel& model, const std::vector<ChainTrajectory<double>>& runs,
    const std::vector<ChainKinematics<double>>& kinematics, const ChainIdentifyOptions& identify,
    const Eigen::VectorXd& prior, const ChainMotionCheckOptions& options,
    const ChainIdentification* earlier = nullptr, ChainIdentification* identification = nullptr) {
  MotionSimulation out;
  const int n = model.joints();
  out.squares = out.counts = Eigen::VectorXd::Zero(n);
  const ChainIdentification id = earlier ? refit_chain(model, *earlier, runs, identify)
                                         : identify_chain(model, runs, identify);
  if (identification) *identification = id;
  if (!id.fit.ok()) {
    out.note = id.fit.message;
    return out;
  }
  out.theta = consistent_chain_parameters(model, id, prior, options.consistency).theta;
  for (const auto& k : kinematics) {
    const ChainFreeSimulation sim = free_chain_simulation(
        model, out.theta, at_most_rate(k, options.compare_rate_hz, identify), options.simulation);
    out.segments += sim.segments;
    out.failed += sim.failed_segments;
    if (out.failure.empty() && !sim.ok()) out.failure = sim.message;
    for (Eigen::Index i = 0; i < sim.error.rows(); ++i)
      for (int j = 0; j < n; ++j)
        if (std::isfinite(sim.error(i, j))) {
          out.squares[j] += sim.error(i, j) * sim.error(i, j);
          out.counts[j] += 1.0;
        }
  }
  return out;
}

inline void check_motion_inputs(const ChainModel& nominal, const ChainDiagnosis& diagnosis,
                                const std::vector<ChainTrajectory<double>>& runs,
                                const ChainMotionCheckOptions& options) {
  const std::string who = "sid::check_chain_motion: ";
  const int n = nominal.joints();
  if (options.replicates < 1 || !(options.margin >= 1.0) || !(options.compare_rate_hz > 0.0))
    throw std::invalid_argument(who + "needs replicates >= 1, margin >= 1, compare_rate_hz > 0");
  if (runs.empty() || runs.size() != diagnosis.kinematics.size() ||
      diagnosis.cutoff_hz.size() != n || diagnosis.angle_offset.size() != n ||
      diagnosis.noise_floor.size() != n)
    throw std::invalid_argument(who + "the diagnosis does not belong to these runs and model");
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (runs[r].size() != diagnosis.kinematics[r].size() || runs[r].joints() != n)
      throw std::invalid_argument(who + "run " + std::to_string(r + 1) +
                                  " is not the one diagnosed");
}

/// The runs and their kinematics at the true angles: the measured ones plus the named offsets.
struct CorrectedRuns {
  std::vector<ChainTrajectory<double>> runs;
  std::vector<ChainKinematics<double>> kinematics;
};

inline CorrectedRuns corrected_runs(const std::vector<ChainTrajectory<double>>& runs,
                                    const ChainDiagnosis& diagnosis) {
  CorrectedRuns out;
  std::vector<ChainTrajectory<double>>& corrected = out.runs;
  std::vector<ChainKinematics<double>>& corrected_kinematics = out.kinematics;
  corrected = runs;
  for (auto& run : corrected) run.q.rowwise() += diagnosis.angle_offset.transpose();
  for (auto k : diagnosis.kinematics) {
    k.q.rowwise() += diagnosis.angle_offset.transpose();
    corrected_kinematics.push_back(std::move(k));
  }
  return out;
}

/// σ of the angle noise per joint: the measured angles' RMS distance from their smoothing.
inline Eigen::VectorXd motion_angle_noise(const std::vector<ChainTrajectory<double>>& runs,
                                          const ChainDiagnosis& diagnosis, int n) {
  Eigen::VectorXd angle_noise = Eigen::VectorXd::Zero(n);
  Eigen::Index samples = 0;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    angle_noise += (runs[r].q - diagnosis.kinematics[r].q).colwise().squaredNorm().transpose();
    samples += runs[r].size();
  }
  return (angle_noise / static_cast<double>(samples)).cwiseSqrt();
}

/// The nominal and the final model's fits and simulations, and the final model's
/// identification (the replicates refit its base parameters).
struct NominalAndFinal {
  MotionSimulation nominal_fit, final_fit;
  ChainIdentification final_identification;
};

inline NominalAndFinal fit_nominal_and_final(
    const ChainModel& nominal, const ChainModel& final_model, const ChainDiagnosis& diagnosis,
    const std::vector<ChainTrajectory<double>>& runs, const CorrectedRuns& true_angles,
    const ChainIdentifyOptions& identify, const Eigen::VectorXd& prior,
    const ChainMotionCheckOptions& options, int threads) {
  const std::vector<ChainTrajectory<double>>& corrected = true_angles.runs;
  const std::vector<ChainKinematics<double>>& corrected_kinematics = true_angles.kinematics;
  // Where the diagnosis named nothing the final model is the nominal one: fitted once.
  const bool same = diagnosis.final_terms.size() == nominal.terms().size() &&
                    (diagnosis.angle_offset.array() == 0.0).all();
  std::vector<MotionSimulation> models(2);
  ChainIdentification final_identification;
  for_each_index(same ? 1 : 2, threads, [&](Eigen::Index task, int) {
    const Eigen::Index m = same ? 1 : task;
    models[static_cast<std::size_t>(m)] =
        m == 0 ? fit_and_simulate(nominal, runs, diagnosis.kinematics, identify,
                                  prior.size() ? Eigen::VectorXd(prior.head(nominal.parameters()))
                                               : Eigen::VectorXd(),
                                  options)
               : fit_and_simulate(final_model, corrected, corrected_kinematics, identify, prior,
                                  options, nullptr, &final_identification);
  });
  if (same) models[0] = models[1];
  return {std::move(models[0]), std::move(models[1]), std::move(final_identification)};
}

/// What every replicate's noise is added to: the smoothed motion and the final model's torque
/// along it.
inline std::vector<ChainTrajectory<double>> exact_logs(
    const ChainModel& final_model, const Eigen::VectorXd& theta,
    const std::vector<ChainKinematics<double>>& corrected_kinematics, int threads) {
  const int n = final_model.joints();
  std::vector<ChainTrajectory<double>> exact;
  for (const ChainKinematics<double>& k : corrected_kinematics) {
    ChainTrajectory<double> log{k.t, k.q, k.tau};
    for_each_index(threads, threads, [&](Eigen::Index block, int) {
      Eigen::MatrixXd y(n, final_model.parameters());
      for (Eigen::Index i = k.size() * block / threads; i < k.size() * (block + 1) / threads; ++i) {
        final_model.regressor(k.q.row(i), k.qd.row(i), k.qdd.row(i), y);
        log.tau.row(i) = (y * theta).transpose();
      }
    });
    exact.push_back(std::move(log));
  }
  return exact;
}

/// Replicate b's logs: the exact ones with white noise of the log's levels on angles and
/// torques, from std::mt19937_64(seed + b).
inline std::vector<ChainTrajectory<double>> replicate_logs(
    const std::vector<ChainTrajectory<double>>& exact,
    const std::vector<ChainKinematics<double>>& corrected_kinematics,
    const Eigen::VectorXd& angle_noise, const ChainDiagnosis& diagnosis, std::uint64_t seed,
    Eigen::Index b) {
  const auto n = static_cast<int>(angle_noise.size());
  std::mt19937_64 rng(seed + static_cast<std::uint64_t>(b));
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<ChainTrajectory<double>> logs;
  for (std::size_t r = 0; r < corrected_kinematics.size(); ++r) {
    const ChainKinematics<double>& k = corrected_kinematics[r];
    ChainTrajectory<double> log = exact[r];
    for (Eigen::Index i = 0; i < k.size(); ++i)
      for (int j = 0; j < n; ++j) {
        log.q(i, j) += angle_noise[j] * normal(rng);
        log.tau(i, j) += diagnosis.noise_floor[j] * normal(rng);
      }
    logs.push_back(std::move(log));
  }
  // A named encoder offset is known only to its standard deviation: the replicate's angles
  // carry an error of that size, as the log's corrected angles do.
  for (const ChainEffectTest& e : diagnosis.named)
    if (e.angle_offset) {
      const double error = e.std * normal(rng);
      for (auto& log : logs) log.q.col(e.term.index).array() += error;
    }
  return logs;
}

/// Every replicate identified, made consistent and freely simulated as the measured log is.
inline std::vector<MotionSimulation> replicate_simulations(
    const ChainModel& final_model, const ChainDiagnosis& diagnosis,
    const std::vector<ChainTrajectory<double>>& exact,
    const std::vector<ChainKinematics<double>>& corrected_kinematics,
    const Eigen::VectorXd& angle_noise, const ChainIdentifyOptions& identify,
    const Eigen::VectorXd& prior, const ChainMotionCheckOptions& options,
    const ChainIdentification& final_identification, int threads) {
  std::vector<MotionSimulation> replicates(static_cast<std::size_t>(options.replicates));
  for_each_index(options.replicates, threads, [&](Eigen::Index b, int) {
    const std::vector<ChainTrajectory<double>> logs =
        replicate_logs(exact, corrected_kinematics, angle_noise, diagnosis, options.seed, b);
    std::vector<ChainKinematics<double>> smoothed;
    for (const auto& log : logs)
      smoothed.push_back(smooth_chain_run(log, diagnosis.cutoff_hz, identify));
    replicates[static_cast<std::size_t>(b)] = fit_and_simulate(
        final_model, logs, smoothed, identify, prior, options, &final_identification);
  });
  return replicates;
}

/// The replicates' errors into out, each joint's threshold (margin times its largest
/// replicate error) and the joints whose final error exceeds it.
inline void judge_motion(ChainMotionCheck& out, const std::vector<MotionSimulation>& replicates,
                         const ChainMotionCheckOptions& options) {
  const auto n = static_cast<int>(out.final_error.size());
  const auto nan = std::numeric_limits<double>::quiet_NaN();
  for (int b = 0; b < options.replicates; ++b) {
    const MotionSimulation& s = replicates[static_cast<std::size_t>(b)];
    out.failed_replicates += s.failed;
    if (s.theta.size()) out.replicate_error.row(b) = s.error_rms().transpose();
  }
  for (int j = 0; j < n; ++j) {
    double largest = nan;
    for (int b = 0; b < options.replicates; ++b)
      if (std::isfinite(out.replicate_error(b, j)))
        largest = std::isfinite(largest) ? std::max(largest, out.replicate_error(b, j))
                                         : out.replicate_error(b, j);
    out.threshold[j] = options.margin * largest;
    if (out.final_error[j] > out.threshold[j]) out.beyond.push_back(j);
  }
}

}  // namespace detail

/// @brief Free simulations of the nominal and the final model of a diagnosis, and the final
/// model's verdict against its exact-model replicates (see the file comment).
/// @param runs the runs diagnosed (joint side, at the measured angles)
/// @param identify the diagnosis's identification options (its cutoffs are taken from diagnosis)
/// @param prior the final model's full parameter vector to stay near where the data say nothing
///        (its head serves the nominal model, whose parameters come first); empty: see
///        consistent_chain_parameters
/// @throws std::invalid_argument if the diagnosis does not belong to nominal and runs, or for
///         invalid options.
inline ChainMotionCheck check_chain_motion(const ChainModel& nominal,
                                           const ChainDiagnosis& diagnosis,
                                           const std::vector<ChainTrajectory<double>>& runs,
                                           ChainIdentifyOptions identify,
                                           const Eigen::VectorXd& prior = {},
                                           const ChainMotionCheckOptions& options = {}) {
  const std::string who = "sid::check_chain_motion: ";
  const int n = nominal.joints();
  detail::check_motion_inputs(nominal, diagnosis, runs, options);
  const ChainModel final_model(nominal.chain(), nominal.joint_names(), diagnosis.final_terms,
                               nominal.transmission(), nominal.coulomb_epsilon());
  if (prior.size() != 0 && prior.size() != final_model.parameters())
    throw std::invalid_argument(who + "the prior needs the final model's " +
                                std::to_string(final_model.parameters()) + " parameters");
  identify.cutoff_hz.assign(diagnosis.cutoff_hz.data(),
                            diagnosis.cutoff_hz.data() + diagnosis.cutoff_hz.size());
  identify.statistics = false;  // the fits' standard deviations serve nothing here

  // The final model lives at the true angles: the measured ones plus the named offsets.
  const detail::CorrectedRuns corrected = detail::corrected_runs(runs, diagnosis);
  ChainMotionCheck out;
  out.angle_noise = detail::motion_angle_noise(runs, diagnosis, n);

  const int threads = detail::thread_count(options.threads);
  const detail::NominalAndFinal fits = detail::fit_nominal_and_final(
      nominal, final_model, diagnosis, runs, corrected, identify, prior, options, threads);
  const detail::MotionSimulation& nominal_sim = fits.nominal_fit;
  const detail::MotionSimulation& final_sim = fits.final_fit;
  out.nominal_error = nominal_sim.error_rms();
  out.final_error = final_sim.error_rms();
  out.segments = final_sim.segments;
  out.failed_nominal = nominal_sim.failed;
  out.failed_final = final_sim.failed;
  out.failure = !final_sim.note.empty()        ? "final model not fitted: " + final_sim.note
                : !nominal_sim.note.empty()    ? "nominal model not fitted: " + nominal_sim.note
                : !nominal_sim.failure.empty() ? "nominal model, " + nominal_sim.failure
                : !final_sim.failure.empty()   ? "final model, " + final_sim.failure
                                               : std::string();
  const auto nan = std::numeric_limits<double>::quiet_NaN();
  out.replicate_error = Eigen::MatrixXd::Constant(options.replicates, n, nan);
  out.threshold = Eigen::VectorXd::Constant(n, nan);
  if (final_sim.theta.size() == 0) return out;

  const std::vector<ChainTrajectory<double>> exact =
      detail::exact_logs(final_model, final_sim.theta, corrected.kinematics, threads);
  const std::vector<detail::MotionSimulation> replicates = detail::replicate_simulations(
      final_model, diagnosis, exact, corrected.kinematics, out.angle_noise, identify, prior,
      options, fits.final_identification, threads);
  detail::judge_motion(out, replicates, options);
  return out;
}

}  // namespace sid
