#pragma once
// Definitions of sid/study/montecarlo.hpp (see sid/config.hpp).

#include <sid/study/montecarlo.hpp>

namespace sid {

SID_INLINE const char* study_method_name(StudyMethod method) {
  switch (method) {
    case StudyMethod::Raw:
      return "raw";
    case StudyMethod::Filtered:
      return "filtered";
    case StudyMethod::Css:
      return "css";
    case StudyMethod::CssGcv:
      return "css_gcv";
    case StudyMethod::CssWls:
      return "css_wls";
    case StudyMethod::CssIv:
      return "css_iv";
    case StudyMethod::CssTorqueCv:
      return "css_tcv";
    case StudyMethod::Oracle:
      return "oracle";
  }
  return "unknown";
}

SID_INLINE StudyMethod parse_study_method(const std::string& name) {
  for (StudyMethod m :
       {StudyMethod::Raw, StudyMethod::Filtered, StudyMethod::Css, StudyMethod::CssGcv,
        StudyMethod::CssWls, StudyMethod::CssIv, StudyMethod::CssTorqueCv, StudyMethod::Oracle})
    if (name == study_method_name(m)) return m;
  throw std::invalid_argument(
      "sid::parse_study_method: unknown method '" + name +
      "' (expected raw, filtered, css, css_gcv, css_wls, css_iv, css_tcv or oracle)");
}

SID_INLINE std::mt19937_64 run_generator(std::uint64_t seed, std::size_t level, int run) {
  std::seed_seq seq{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32),
                    static_cast<std::uint32_t>(level), static_cast<std::uint32_t>(run)};
  return std::mt19937_64(seq);
}

SID_INLINE Kinematics<double> study_kinematics(StudyMethod method, const Kinematics<double>& truth,
                                               const Trajectory<double>& measured, double sigma_q2,
                                               const IdentifyOptions& base) {
  if (method == StudyMethod::Oracle) {
    Kinematics<double> k = truth;
    k.tau = measured.tau;
    return k;
  }
  if (method == StudyMethod::CssTorqueCv) {
    // The study already runs one data set per thread; the cutoff search stays on it.
    RunsIdentifyOptions choice;
    choice.skip = base.skip;
    choice.skip_end = base.skip_end;
    choice.threads = 1;
    const std::vector<Trajectory<double>> runs{measured};
    return kinematics_at_cutoff(
        measured, choose_cutoff(runs, two_link_arm_model<double>(base.gravity), choice).cutoff_hz);
  }
  IdentifyOptions options = base;
  options.method = method == StudyMethod::Raw        ? DerivativeMethod::ForwardDifference
                   : method == StudyMethod::Filtered ? DerivativeMethod::FilteredDifference
                                                     : DerivativeMethod::SmoothingSpline;
  options.sigma_q = Vector2<double>::Constant(std::sqrt(sigma_q2));
  const bool gcv = method == StudyMethod::CssGcv || method == StudyMethod::CssWls ||
                   method == StudyMethod::CssIv;
  options.smoothing = gcv ? SmoothingMode::Gcv : SmoothingMode::SConstraint;
  if (method == StudyMethod::CssIv)
    options.cross_validation_lambda_scale = kInstrumentalVariableLambdaScale;
  return estimate_kinematics(measured, options);
}

SID_INLINE LeastSquaresResult<double> fit_study_method(StudyMethod method,
                                                       const Kinematics<double>& truth,
                                                       const Trajectory<double>& measured,
                                                       double sigma_q2, const IdentifyOptions& base,
                                                       const EstimateRefinement& refine) {
  if (method == StudyMethod::CssIv && !refine)
    throw std::invalid_argument(
        "sid::fit_study_method: css_iv needs the IV step (sid::instrumental_variable_step() from "
        "sid/cvode/instrumental_variables.hpp)");
  const Kinematics<double> k = study_kinematics(method, truth, measured, sigma_q2, base);
  const double skip = method == StudyMethod::Filtered ? base.filtered_skip : base.skip;
  const Kinematics<double> kept = window(k, truth.t[0] + skip);
  if (method == StudyMethod::CssWls)
    return fit_two_link_weighted(kept, base.gravity, base.least_squares);
  LeastSquaresResult<double> fit = fit_two_link(kept, base.gravity, base.least_squares);
  if (method == StudyMethod::CssIv && fit.ok()) return refine(kept, fit);
  return fit;
}

namespace detail {

SID_INLINE void summarize(MethodSummary& s, const TwoLinkParameters<double>& theta) {
  const Eigen::Index p = theta.size();
  s.mean = Eigen::VectorXd::Zero(p);
  s.variance = Eigen::VectorXd::Zero(p);
  int good = 0;
  double sum_sq_rel = 0.0;
  for (Eigen::Index r = 0; r < s.estimates.rows(); ++r) {
    if (!s.estimates.row(r).allFinite()) continue;
    ++good;
    s.mean += s.estimates.row(r).transpose();
    sum_sq_rel += ((s.estimates.row(r).transpose() - theta).cwiseQuotient(theta)).squaredNorm();
  }
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
  s.rms_rel_error_pct =
      good > 0 ? 100.0 * std::sqrt(sum_sq_rel / (good * static_cast<double>(p))) : nan;
  s.worst_abs_bias_pct = s.bias_pct.cwiseAbs().maxCoeff();
}

SID_INLINE void check_monte_carlo_input(const Kinematics<double>& truth,
                                        const MonteCarloOptions& options) {
  const char* who = "sid::run_monte_carlo";
  if (options.runs < 2)
    throw std::invalid_argument(std::string(who) + ": runs must be >= 2 (a variance needs two)");
  if (options.sigma_q2_levels.empty())
    throw std::invalid_argument(std::string(who) + ": no noise levels");
  for (double v : options.sigma_q2_levels)
    if (!(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument(std::string(who) +
                                  ": every sigma_q2 level must be finite and > 0 (CSS needs "
                                  "δq = σq > 0), got " +
                                  std::to_string(v));
  if (!(options.sigma_tau2 >= 0.0) || !std::isfinite(options.sigma_tau2))
    throw std::invalid_argument(std::string(who) + ": sigma_tau2 must be finite and >= 0");
  if (options.methods.empty()) throw std::invalid_argument(std::string(who) + ": no methods");
  for (StudyMethod m : options.methods)
    if (m == StudyMethod::CssIv && !options.refine)
      throw std::invalid_argument(
          std::string(who) +
          ": method css_iv needs options.refine (the IV step, "
          "sid::instrumental_variable_step() from sid/cvode/instrumental_variables.hpp)");
  const Eigen::Index n = truth.size();
  if (truth.q.rows() != n || truth.qd.rows() != n || truth.qdd.rows() != n || truth.tau.rows() != n)
    throw std::invalid_argument(std::string(who) + ": truth has columns of different lengths");
}

/// The result before any run: one summary per level and method, every estimate NaN.
SID_INLINE MonteCarloResult empty_monte_carlo_result(const MonteCarloOptions& options) {
  MonteCarloResult result;
  result.theta = options.theta;
  result.runs = options.runs;
  result.seed = options.seed;
  const std::size_t levels = options.sigma_q2_levels.size(), methods = options.methods.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  result.levels.resize(levels);
  for (std::size_t l = 0; l < levels; ++l) {
    result.levels[l].sigma_q2 = options.sigma_q2_levels[l];
    result.levels[l].methods.resize(methods);
    for (std::size_t m = 0; m < methods; ++m) {
      result.levels[l].methods[m].method = options.methods[m];
      result.levels[l].methods[m].estimates = Eigen::MatrixXd::Constant(options.runs, 7, nan);
    }
  }
  return result;
}

/// A fit that failed, kept with its place in the study: the summaries list failures in run
/// order, whichever thread met them first.
struct StudyFailure {
  std::size_t level = 0, method = 0;
  int run = 0;
  std::string message;
};

/// Job `job` of the study (level job / runs, run job % runs): one noisy data set, every method
/// fitted to it, each estimate stored in its row of result. Jobs write disjoint rows; `mutex`
/// guards `failures`, which all jobs share.
SID_INLINE void run_monte_carlo_job(const Kinematics<double>& truth,
                                    const MonteCarloOptions& options, int job,
                                    MonteCarloResult& result, std::vector<StudyFailure>& failures,
                                    std::mutex& mutex) {
  const std::size_t l = static_cast<std::size_t>(job / options.runs);
  const int run = job % options.runs;
  const double sigma_q2 = options.sigma_q2_levels[l];
  std::mt19937_64 rng = run_generator(options.seed, l, run);
  const Trajectory<double> measured =
      add_measurement_noise(truth, MeasurementNoise<double>{sigma_q2, options.sigma_tau2}, rng);
  for (std::size_t m = 0; m < options.methods.size(); ++m) {
    MethodSummary& summary = result.levels[l].methods[m];
    std::string failure;
    try {
      const auto fit = fit_study_method(options.methods[m], truth, measured, sigma_q2,
                                        options.identify, options.refine);
      if (fit.ok())
        summary.estimates.row(run) = fit.theta.transpose();
      else
        failure = fit.message;
    } catch (const std::exception& e) {
      failure = e.what();
    }
    if (!failure.empty()) {
      std::lock_guard<std::mutex> lock(mutex);
      failures.push_back({l, m, run, std::move(failure)});
    }
  }
}

/// The first few failures of each summary, in run order.
SID_INLINE void record_failures(std::vector<StudyFailure> failures, MonteCarloResult& result) {
  constexpr std::size_t kKeptPerSummary = 5;
  std::sort(failures.begin(), failures.end(), [](const StudyFailure& a, const StudyFailure& b) {
    return std::tie(a.level, a.method, a.run) < std::tie(b.level, b.method, b.run);
  });
  for (auto& f : failures) {
    auto& kept = result.levels[f.level].methods[f.method].failures;
    if (kept.size() < kKeptPerSummary)
      kept.push_back("run " + std::to_string(f.run) + ": " + std::move(f.message));
  }
}

/// options.threads (0: all cores), at least 1 and at most one per job.
SID_INLINE int monte_carlo_threads(int requested, int total) {
  return std::max(1, std::min(thread_count(requested), total));
}

}  // namespace detail

SID_INLINE MonteCarloResult run_monte_carlo(const Kinematics<double>& truth,
                                            const MonteCarloOptions& options) {
  detail::check_monte_carlo_input(truth, options);
  const auto start = std::chrono::steady_clock::now();
  MonteCarloResult result = detail::empty_monte_carlo_result(options);

  const int total = static_cast<int>(options.sigma_q2_levels.size()) * options.runs;
  const int threads = detail::monte_carlo_threads(options.threads, total);
  result.threads_used = threads;
  std::vector<detail::StudyFailure> failures;
  std::mutex mutex;  // guards `failures` and the progress callback
  std::atomic<int> done{0};
  detail::for_each_index(total, threads, [&](Eigen::Index job, int) {
    detail::run_monte_carlo_job(truth, options, static_cast<int>(job), result, failures, mutex);
    const int finished = ++done;
    if (options.progress) {
      std::lock_guard<std::mutex> lock(mutex);
      options.progress(finished, total);
    }
  });
  detail::record_failures(std::move(failures), result);
  for (auto& level : result.levels)
    for (auto& summary : level.methods) detail::summarize(summary, options.theta);
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace sid
