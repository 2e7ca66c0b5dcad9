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
  return detail::method_kinematics(method, truth, measured, sigma_q2, base);
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
  summarize_estimates(s, theta);
}

SID_INLINE void check_study_settings(const StudySettings& options, const char* who) {
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
}

SID_INLINE std::vector<LevelSummary> empty_levels(const StudySettings& options,
                                                  Eigen::Index parameters) {
  const std::size_t levels = options.sigma_q2_levels.size(), methods = options.methods.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<LevelSummary> result(levels);
  for (std::size_t l = 0; l < levels; ++l) {
    result[l].sigma_q2 = options.sigma_q2_levels[l];
    result[l].methods.resize(methods);
    for (std::size_t m = 0; m < methods; ++m) {
      result[l].methods[m].method = options.methods[m];
      result[l].methods[m].estimates = Eigen::MatrixXd::Constant(options.runs, parameters, nan);
    }
  }
  return result;
}

SID_INLINE void check_monte_carlo_input(const Kinematics<double>& truth,
                                        const MonteCarloOptions& options) {
  const char* who = "sid::run_monte_carlo";
  check_study_settings(options, who);
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

/// Run `run` of level `l`: one noisy data set, every method fitted to it, each estimate stored in
/// its row of result.
SID_INLINE void run_monte_carlo_job(const Kinematics<double>& truth,
                                    const MonteCarloOptions& options, std::size_t l, int run,
                                    MonteCarloResult& result,
                                    const std::function<void(std::size_t, std::string)>& fail) {
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
    if (!failure.empty()) fail(m, std::move(failure));
  }
}

/// The first few failures of each summary, in run order.
SID_INLINE void record_failures(std::vector<StudyFailure> failures,
                                std::vector<LevelSummary>& levels) {
  constexpr std::size_t kKeptPerSummary = 5;
  std::sort(failures.begin(), failures.end(), [](const StudyFailure& a, const StudyFailure& b) {
    return std::tie(a.level, a.method, a.run) < std::tie(b.level, b.method, b.run);
  });
  for (auto& f : failures) {
    auto& kept = levels[f.level].methods[f.method].failures;
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
  MonteCarloResult result;
  result.theta = options.theta;
  result.runs = options.runs;
  result.seed = options.seed;
  result.levels = detail::empty_levels(options, 7);
  result.threads_used = detail::run_study_jobs(
      options, result.levels,
      [&](std::size_t l, int run, const std::function<void(std::size_t, std::string)>& fail) {
        detail::run_monte_carlo_job(truth, options, l, run, result, fail);
      });
  for (auto& level : result.levels)
    for (auto& summary : level.methods) detail::summarize(summary, options.theta);
  result.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace sid
