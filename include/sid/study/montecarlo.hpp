#pragma once
/// @file
/// @brief The paper's Monte Carlo study (section 3.1): for each noise level and run, draw noise
/// on q and τ, estimate the kinematics by each method, window, least squares; then the sample
/// mean and variance of θ̂ per method and level.
///
/// The true trajectory is an input (simulate it once, e.g. with sid/cvode/experiment.hpp), so
/// this header needs no SUNDIALS. A run's noise depends only on (seed, level index, run index):
/// the numbers are the same for any thread count, and runs can be split across machines.

#include <sid/config.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/identify.hpp>
#include <sid/identify_runs.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

namespace sid {

/// @brief The estimators the study compares.
enum class StudyMethod {
  Raw,          ///< forward differences
  Filtered,     ///< forward differences + Butterworth filtfilt (paper's filters)
  Css,          ///< Reinsch smoothing spline, δq = σq, S = n
  CssGcv,       ///< Reinsch smoothing spline with λ chosen by GCV: no noise level needed
  CssWls,       ///< css_gcv kinematics, Gautier's IDIM-WLS (per-joint noise from a first fit)
  CssIv,        ///< GCV's λ × kInstrumentalVariableLambdaScale, LS, then the IDIM-IV step (needs
                ///< MonteCarloOptions::refine)
  CssTorqueCv,  ///< the spline at the cutoff chosen by cross-validating the torque prediction
                ///< (sid::choose_cutoff): no noise level needed; the default on measured data
  Oracle,       ///< exact q, q̇, q̈ with the noisy τ: the floor no estimator beats on average
};

SID_INLINE const char* study_method_name(StudyMethod method);

/// @throws std::invalid_argument for a name other than raw, filtered, css, css_gcv, css_wls,
/// css_iv, css_tcv, oracle.
SID_INLINE StudyMethod parse_study_method(const std::string& name);

/// @brief A refinement of a first least-squares fit on the windowed kinematics, such as the
/// IDIM-IV step of sid/cvode/instrumental_variables.hpp (sid::instrumental_variable_step()).
/// The study stays free of SUNDIALS by taking it as a function. It may throw to fail a run.
using EstimateRefinement = std::function<LeastSquaresResult<double>(
    const Kinematics<double>&, const LeastSquaresResult<double>&)>;

/// @brief Settings of the study; the defaults are the paper's.
struct MonteCarloOptions {
  int runs = 30;
  std::vector<double> sigma_q2_levels = {1e-8, 1e-6, 1e-4};  ///< angle noise variances [rad²]
  double sigma_tau2 = 1e-2;                                  ///< torque noise variance [N²m²]
  /// The paper's three and the oracle; CssGcv is available but not part of the paper's study.
  std::vector<StudyMethod> methods = {StudyMethod::Raw, StudyMethod::Filtered, StudyMethod::Css,
                                      StudyMethod::Oracle};
  std::uint64_t seed = 20240601;
  int threads = 0;  ///< 0 = all cores
  TwoLinkParameters<double> theta = paper_arm_parameters<double>();
  /// Windows, filters and gravity; method and sigma_q are set per run by the study.
  IdentifyOptions identify;
  /// The IV step of method css_iv (e.g. sid::instrumental_variable_step()); required by css_iv.
  EstimateRefinement refine;
  /// Called as runs complete (done, total), from worker threads but never concurrently.
  std::function<void(int, int)> progress;
};

/// @brief θ̂ of every run of one method at one level, and their statistics.
struct MethodSummary {
  StudyMethod method = StudyMethod::Raw;
  Eigen::MatrixXd estimates;       ///< runs × 7; a failed run's row is NaN
  Eigen::VectorXd mean, variance;  ///< sample mean, variance (ddof = 1) over the good runs
  Eigen::VectorXd bias_pct;        ///< 100 (mean − θ) / |θ|
  Eigen::VectorXd std_pct;         ///< 100 √variance / |θ|
  Eigen::VectorXd standard_error;  ///< √(variance / runs): the uncertainty of mean
  /// √(mean over runs and parameters of ((θ̂ − θ)/θ)²) in %: one number that ranks methods.
  double rms_rel_error_pct = std::numeric_limits<double>::quiet_NaN();
  double worst_abs_bias_pct = std::numeric_limits<double>::quiet_NaN();
  int failed_runs = 0;
  std::vector<std::string> failures;  ///< why runs failed (at most a few kept)
};

struct LevelSummary {
  double sigma_q2 = 0.0;
  std::vector<MethodSummary> methods;  ///< in the order of MonteCarloOptions::methods
};

struct MonteCarloResult {
  TwoLinkParameters<double> theta;
  int runs = 0;
  std::uint64_t seed = 0;
  std::vector<LevelSummary> levels;
  double wall_seconds = 0.0;
  int threads_used = 1;
};

/// @brief The generator of one run: seeded from (seed, level, run) only.
SID_INLINE std::mt19937_64 run_generator(std::uint64_t seed, std::size_t level, int run);

/// @brief The kinematics one method estimates from one noisy data set (before the window is
/// applied by fit_study_method; useful for plots).
SID_INLINE Kinematics<double> study_kinematics(StudyMethod method, const Kinematics<double>& truth,
                                               const Trajectory<double>& measured, double sigma_q2,
                                               const IdentifyOptions& base);

/// @brief θ̂ of one method on one noisy data set (the paper's windows); NaN-free on success.
/// @param refine the IV step for StudyMethod::CssIv (ignored by the other methods).
/// @throws std::invalid_argument for css_iv without refine.
SID_INLINE LeastSquaresResult<double> fit_study_method(StudyMethod method,
                                                       const Kinematics<double>& truth,
                                                       const Trajectory<double>& measured,
                                                       double sigma_q2, const IdentifyOptions& base,
                                                       const EstimateRefinement& refine = {});

namespace detail {

SID_INLINE void summarize(MethodSummary& s, const TwoLinkParameters<double>& theta);

}  // namespace detail

/// @brief Runs the study on a true trajectory (t, q, q̇, q̈, τ at the sample times).
/// @throws std::invalid_argument on runs < 2, an empty or negative noise level, σ_τ² < 0, no
/// methods, or a truth with inconsistent sizes.
SID_INLINE MonteCarloResult run_monte_carlo(const Kinematics<double>& truth,
                                            const MonteCarloOptions& options);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/study/montecarlo-inl.hpp>
#endif
