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
#include <sid/detail/kinematics_estimation.hpp>
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

/// @brief What every study shares, the two-link arm's and a chain's: how many runs, the noise,
/// the methods, the seed, the threads; the defaults are the paper's.
struct StudySettings {
  int runs = 30;
  std::vector<double> sigma_q2_levels = {1e-8, 1e-6, 1e-4};  ///< angle noise variances [rad²]
  double sigma_tau2 = 1e-2;                                  ///< torque noise variance [N²m²]
  /// The paper's three and the oracle; CssGcv is available but not part of the paper's study.
  std::vector<StudyMethod> methods = {StudyMethod::Raw, StudyMethod::Filtered, StudyMethod::Css,
                                      StudyMethod::Oracle};
  std::uint64_t seed = 20240601;
  int threads = 0;  ///< 0 = all cores
  /// Called as runs complete (done, total), from worker threads but never concurrently.
  std::function<void(int, int)> progress;
};

/// @brief Settings of the paper's study of the two-link arm.
struct MonteCarloOptions : StudySettings {
  TwoLinkParameters<double> theta = paper_arm_parameters<double>();
  /// Windows, filters and gravity; method and sigma_q are set per run by the study.
  IdentifyOptions identify;
  /// The IV step of method css_iv (e.g. sid::instrumental_variable_step()); required by css_iv.
  EstimateRefinement refine;
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
  /// Per run (NaN where it failed): how the estimate predicts the true torque over the window,
  /// 100 ‖τ − Y θ̂‖ / ‖τ‖ at the true motion. Filled by the chain study, empty in the two-link one.
  Eigen::VectorXd torque_error_pct;
  /// Per run: why the method's refinement (the chain study's css_iv) declined, so that its first
  /// fit stands; "" where it was used. Filled by the chain study, empty in the two-link one.
  std::vector<std::string> declined;

  /// The runs where the refinement declined.
  int declined_runs() const {
    return static_cast<int>(std::count_if(declined.begin(), declined.end(),
                                          [](const std::string& s) { return !s.empty(); }));
  }
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

/// The statistics of s.estimates against the true values theta (any parameter count). A true
/// value of exactly 0 has no relative figures: its bias_pct and std_pct are NaN, and it is left
/// out of rms_rel_error_pct and worst_abs_bias_pct.
template <typename Derived>
void summarize_estimates(MethodSummary& s, const Eigen::MatrixBase<Derived>& theta) {
  const Eigen::Index p = theta.size();
  const bool has_zero = (theta.array() == 0.0).any();
  s.mean = Eigen::VectorXd::Zero(p);
  s.variance = Eigen::VectorXd::Zero(p);
  int good = 0;
  Eigen::Index relative = p;
  double sum_sq_rel = 0.0;
  for (Eigen::Index r = 0; r < s.estimates.rows(); ++r) {
    if (!s.estimates.row(r).allFinite()) continue;
    ++good;
    s.mean += s.estimates.row(r).transpose();
    if (!has_zero) {
      sum_sq_rel += ((s.estimates.row(r).transpose() - theta).cwiseQuotient(theta)).squaredNorm();
      continue;
    }
    for (Eigen::Index k = 0; k < p; ++k)
      if (theta[k] != 0.0) {
        const double e = (s.estimates(r, k) - theta[k]) / theta[k];
        sum_sq_rel += e * e;
      }
  }
  if (has_zero) relative = (theta.array() != 0.0).count();
  s.failed_runs = static_cast<int>(s.estimates.rows()) - good;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (good == 0) {
    s.mean.setConstant(nan);
    s.variance.setConstant(nan);
  } else {
    s.mean /= good;
    for (Eigen::Index r = 0; r < s.estimates.rows(); ++r)
      if (s.estimates.row(r).allFinite())
        s.variance += (s.estimates.row(r).transpose() - s.mean).cwiseAbs2();
    s.variance /= good > 1 ? good - 1 : nan;
  }
  const Eigen::VectorXd abs_theta = theta.cwiseAbs();
  s.bias_pct = 100.0 * (s.mean - theta).cwiseQuotient(abs_theta);
  s.std_pct = 100.0 * s.variance.cwiseSqrt().cwiseQuotient(abs_theta);
  s.standard_error = (s.variance / std::max(good, 1)).cwiseSqrt();
  s.rms_rel_error_pct = good > 0 && relative > 0
                            ? 100.0 * std::sqrt(sum_sq_rel / (good * static_cast<double>(relative)))
                            : nan;
  if (!has_zero) {
    s.worst_abs_bias_pct = s.bias_pct.cwiseAbs().maxCoeff();
    return;
  }
  double worst = -1.0;
  for (Eigen::Index k = 0; k < p; ++k) {
    if (theta[k] == 0.0)
      s.bias_pct[k] = s.std_pct[k] = nan;
    else if (std::isfinite(s.bias_pct[k]))
      worst = std::max(worst, std::abs(s.bias_pct[k]));
  }
  s.worst_abs_bias_pct = worst >= 0.0 ? worst : nan;
}

/// A fit that failed, kept with its place in the study: the summaries list failures in run
/// order, whichever thread met them first.
struct StudyFailure {
  std::size_t level = 0, method = 0;
  int run = 0;
  std::string message;
};

/// The first few failures of each summary, in run order.
SID_INLINE void record_failures(std::vector<StudyFailure> failures,
                                std::vector<LevelSummary>& levels);

/// options.threads (0: all cores), at least 1 and at most one per job.
SID_INLINE int monte_carlo_threads(int requested, int total);

/// Checks what every study shares. @throws std::invalid_argument naming the problem, as who.
SID_INLINE void check_study_settings(const StudySettings& settings, const char* who);

/// One summary per level and method of settings, every estimate (runs × parameters) NaN.
SID_INLINE std::vector<LevelSummary> empty_levels(const StudySettings& settings,
                                                  Eigen::Index parameters);

/// The study's loop, for any model: job k is level k / runs, run k % runs, run by
/// fit_run(level, run, fail) on some thread; fit_run stores its estimates in its own rows of
/// levels and calls fail(method index, message) for a method that failed. Returns the threads
/// used. A run's result depends only on (seed, level, run), never on the thread that ran it.
template <typename FitRun>
int run_study_jobs(const StudySettings& settings, std::vector<LevelSummary>& levels,
                   const FitRun& fit_run) {
  const int runs = settings.runs;
  const int total = static_cast<int>(levels.size()) * runs;
  const int threads = monte_carlo_threads(settings.threads, total);
  std::vector<StudyFailure> failures;
  std::mutex mutex;  // guards `failures` and the progress callback
  std::atomic<int> done{0};
  for_each_index(total, threads, [&](Eigen::Index job, int) {
    const auto l = static_cast<std::size_t>(job / runs);
    const int run = static_cast<int>(job % runs);
    fit_run(l, run, [&](std::size_t method, std::string message) {
      std::lock_guard<std::mutex> lock(mutex);
      failures.push_back({l, method, run, std::move(message)});
    });
    const int finished = ++done;
    if (settings.progress) {
      std::lock_guard<std::mutex> lock(mutex);
      settings.progress(finished, total);
    }
  });
  record_failures(std::move(failures), levels);
  return threads;
}

/// The kinematics of every method but css_tcv (which needs the model to choose its cutoff) for
/// any joint count: the paper's arm (Joints = 2) and a chain (Eigen::Dynamic) alike. `base`
/// gives the filters and the cross-validation's settings; δq_j = the square root of each
/// joint's angle error variance; css_iv smooths with GCV's λ times iv_lambda_scale.
template <int Joints>
Kinematics<double, Joints> method_kinematics(
    StudyMethod method, const Kinematics<double, Joints>& truth,
    const Trajectory<double, Joints>& measured, const Eigen::VectorXd& q_error_variance,
    const IdentifyOptions& base, double iv_lambda_scale = kInstrumentalVariableLambdaScale) {
  if (method == StudyMethod::Oracle) {
    Kinematics<double, Joints> k = truth;
    k.tau = measured.tau;
    return k;
  }
  if (method == StudyMethod::CssTorqueCv)
    throw std::invalid_argument(
        "sid::detail::method_kinematics: css_tcv chooses its cutoff with the model");
  IdentifyOptions options = base;
  options.method = method == StudyMethod::Raw        ? DerivativeMethod::ForwardDifference
                   : method == StudyMethod::Filtered ? DerivativeMethod::FilteredDifference
                                                     : DerivativeMethod::SmoothingSpline;
  const bool gcv = method == StudyMethod::CssGcv || method == StudyMethod::CssWls ||
                   method == StudyMethod::CssIv;
  options.smoothing = gcv ? SmoothingMode::Gcv : SmoothingMode::SConstraint;
  if (method == StudyMethod::CssIv) options.cross_validation_lambda_scale = iv_lambda_scale;
  const Eigen::VectorXd sigma_q = q_error_variance.cwiseSqrt();
  return estimate_joint_kinematics(measured, options, sigma_q, nullptr, "sid::estimate_kinematics");
}

/// The same with σq² on every joint.
template <int Joints>
Kinematics<double, Joints> method_kinematics(
    StudyMethod method, const Kinematics<double, Joints>& truth,
    const Trajectory<double, Joints>& measured, double sigma_q2, const IdentifyOptions& base,
    double iv_lambda_scale = kInstrumentalVariableLambdaScale) {
  const Eigen::VectorXd variance = Eigen::VectorXd::Constant(measured.joints(), sigma_q2);
  return method_kinematics(method, truth, measured, variance, base, iv_lambda_scale);
}

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
