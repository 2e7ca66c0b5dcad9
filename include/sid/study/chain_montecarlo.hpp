#pragma once
/// @file
/// @brief The paper's Monte Carlo study (section 3.1) for any serial chain: for each noise level
/// and run, draw noise on q and τ, estimate the kinematics by each method, stack the chain's
/// regressor on its base parameters, least squares; then the sample mean and variance of β̂ per
/// method and level, and how well each estimate predicts the true torque.
///
/// The study is sid::run_monte_carlo's on a sid::ChainModel: the same settings (StudySettings),
/// the same loop (a run's noise depends only on (seed, level, run), so any thread count gives the
/// same numbers), the same kinematics per method (detail::method_kinematics) and the same
/// summaries (MethodSummary). A chain's ten parameters per link are not identifiable, so the
/// study estimates and summarises the base parameters (sid::chain_base_parameters). Methods raw,
/// filtered, css, css_gcv, css_wls, css_iv (its IV step given as a function, e.g.
/// sid::chain_instrumental_variable_step() of sid/cvode/chain_instrumental_variables.hpp),
/// css_tcv and oracle.
///
/// The true trajectory is an input (e.g. sid::simulate_chain_experiment) and the IV step a
/// function, so this header needs no SUNDIALS. A cheap arm's sensors (sid::LoggedSensors:
/// encoders that round the angles, a torque channel behind them) may stand between the truth
/// and each run's log.

#include <sid/base_parameters.hpp>
#include <sid/chain_regression.hpp>
#include <sid/config.hpp>
#include <sid/identify_chain.hpp>
#include <sid/least_squares.hpp>
#include <sid/logged_sensors.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/study/montecarlo.hpp>
#include <sid/torque_delay.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace sid {

/// @brief The chain study's css_iv smooths with GCV's own λ, not the two-link arm's 0.25 × λ
/// (kInstrumentalVariableLambdaScale): on a six-axis arm the noisier first estimate of the
/// smaller λ leaves the IV iteration unconverged. UR5, 6 runs at σq² = 1e-4: mean torque error
/// 1.53 % at 0.25 (one run 7.8 %), 0.21 % at 1, css_gcv 0.31 %; at 1e-6: 0.052 % and 0.036 %.
inline constexpr double kChainInstrumentalVariableLambdaScale = 1.0;

/// @brief Settings of the chain study; runs, levels, methods, seed and threads as the paper's.
struct ChainMonteCarloOptions : StudySettings {
  /// The kinematics of the methods: skip, skip_end, filtered_skip, filters (cutoffs relative to
  /// Nyquist), cross_validation_skip, S. Not used: method, smoothing and sigma_q (set per method
  /// and level, δq = σq), gravity (the model's), weighted and least_squares.
  IdentifyOptions kinematics = default_kinematics();
  /// The base parameters (chain_base_parameters), the equations' rate (regression_rate_hz) and
  /// the whole of method css_tcv, which is sid::identify_chain on the run as measured.
  ChainIdentifyOptions identify;
  LeastSquaresOptions least_squares;
  /// The IV step of method css_iv (sid::chain_instrumental_variable_step()); required by css_iv.
  ChainEstimateRefinement refine;
  /// The sensors every run is logged through after its noise is drawn: the torque channel's
  /// delay, then the encoders' rounding. The methods smooth with δq² = σq² + step² / 12 (the
  /// rounding's variance) and, but for css_tcv, pair the torque with the angles of its own
  /// sample; the oracle takes the exact motion and the torque as logged without the delay.
  LoggedSensors sensors;
  /// css_tcv estimates the torque's delay (sid::estimate_torque_delay, on options.identify) and
  /// fits paired at it, as sid_identify --robot --estimate-torque-delay does; unset, it pairs
  /// at identify.torque_delay.
  std::optional<TorqueDelaySearch> estimate_torque_delay;

  /// The paper's windows, and the last 0.25 s left out too: a natural spline's q̈ is wrong
  /// over its last samples unless the motion stops there, and a random excitation does not.
  static IdentifyOptions default_kinematics() {
    IdentifyOptions k;
    k.skip_end = 0.25;
    return k;
  }
};

/// @brief The chain study's result: per level and method the estimates of the base parameters
/// (MethodSummary::estimates, runs × base parameters) and their statistics against the true ones.
struct ChainMonteCarloResult {
  std::vector<std::string> parameter_names;         ///< the base parameters, shortened
  std::vector<std::string> parameter_combinations;  ///< the same in full
  Eigen::VectorXd beta;                             ///< the true base parameters
  Eigen::VectorXd theta;                            ///< the true parameters of the model
  /// Base parameters with no relative figures: true value 0 (within 1e-9 of the largest |β|),
  /// e.g. a friction the description does not have. Their bias_pct and std_pct are NaN.
  std::vector<bool> zero_in_truth;
  int runs = 0;
  std::uint64_t seed = 0;
  Eigen::Index equations = 0;  ///< rows of the true regression (samples × joints in the window)
  std::vector<LevelSummary> levels;
  /// Per level, css_tcv's estimate of the torque's delay on each run [s] (NaN where it failed);
  /// empty unless options.estimate_torque_delay and css_tcv is among the methods.
  std::vector<Eigen::VectorXd> torque_delays;
  double wall_seconds = 0.0;
  int threads_used = 1;
};

/// @brief One method's estimate on one noisy data set of the chain study.
struct ChainStudyFit {
  LeastSquaresResult<double> fit;
  /// Why the refinement (css_iv's IV step) declined, so that fit is the first one; "" otherwise.
  std::string declined;
  /// css_tcv with options.estimate_torque_delay: the delay it found and fitted at [s].
  std::optional<double> torque_delay;
};

/// @brief β̂ of one method on one noisy data set (windowed as options say); NaN-free on success.
/// @param base the base parameters (chain_base_parameters(model, options.identify)).
/// @param measured the run as logged (options.sensors applied); for the oracle, the torque
///        without the delay.
/// @throws std::invalid_argument for css_iv without options.refine, too few equations, or a
///         css_tcv fit whose run leaves a base parameter undetermined.
SID_INLINE ChainStudyFit fit_chain_study_method(StudyMethod method, const ChainModel& model,
                                                const BaseParameters<double>& base,
                                                const ChainKinematics<double>& truth,
                                                const ChainTrajectory<double>& measured,
                                                double sigma_q2,
                                                const ChainMonteCarloOptions& options);

/// @brief Runs the study on the true trajectory of model at parameters theta (t, q, q̇, q̈, τ at
/// the samples, τ = Y θ).
/// @throws std::invalid_argument on the settings run_monte_carlo refuses, css_iv among the
///         methods without options.refine, a theta or a truth whose sizes disagree with the model,
///         or a window too short.
SID_INLINE ChainMonteCarloResult run_chain_monte_carlo(const ChainModel& model,
                                                       const Eigen::VectorXd& theta,
                                                       const ChainKinematics<double>& truth,
                                                       const ChainMonteCarloOptions& options);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/study/chain_montecarlo-inl.hpp>
#endif
