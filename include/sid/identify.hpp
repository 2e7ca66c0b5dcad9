#pragma once
/// @file
/// @brief The identification pipeline of the paper: measured (t, q, τ) → q̇, q̈ by a chosen
/// method → window → regressor X, y (eq. 10) → QR least squares.

#include <sid/butterworth.hpp>
#include <sid/finite_difference.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

// The functions here are templates on an unused parameter, so that a file compiles only those
// it calls (README, "Tests"; src/precompiled/pipeline.cpp).

/// @brief How q̇ and q̈ are obtained from the measured q.
enum class DerivativeMethod {
  ForwardDifference,   ///< "raw": q̇ᵢ = (qᵢ₊₁ − qᵢ)/Ts, q̈ likewise from q̇ (paper eq. 47–48)
  FilteredDifference,  ///< "filtered": the same, then q, q̇, q̈ each filtered by filtfilt
  SmoothingSpline,     ///< "css": Reinsch spline per joint, derivatives analytic
};

/// @brief The method's short name as used by the apps and reports.
template <typename = void>
inline const char* method_name(DerivativeMethod method) {
  switch (method) {
    case DerivativeMethod::ForwardDifference: return "raw";
    case DerivativeMethod::FilteredDifference: return "filtered";
    case DerivativeMethod::SmoothingSpline: return "css";
  }
  return "unknown";
}

/// @brief Parses "raw", "filtered" or "css". @throws std::invalid_argument otherwise.
template <typename = void>
inline DerivativeMethod parse_derivative_method(const std::string& name) {
  if (name == "raw") return DerivativeMethod::ForwardDifference;
  if (name == "filtered") return DerivativeMethod::FilteredDifference;
  if (name == "css") return DerivativeMethod::SmoothingSpline;
  throw std::invalid_argument("sid::parse_derivative_method: unknown method '" + name +
                              "' (expected raw, filtered or css)");
}

/// @brief How CSS chooses its smoothing (the paper: the S constraint with δq = σq).
enum class SmoothingMode {
  SConstraint,  ///< F = Σ((g − q)/δq)² = S (default S = n): needs the noise level δq
  Gcv,          ///< λ minimising generalized cross-validation: needs no noise level
  Cv,           ///< λ minimising leave-one-out cross-validation
  Lambda,       ///< a given λ (penalty form, weights 1/δq²)
};

template <typename = void>
inline const char* smoothing_mode_name(SmoothingMode mode) {
  switch (mode) {
    case SmoothingMode::SConstraint: return "s-constraint";
    case SmoothingMode::Gcv: return "gcv";
    case SmoothingMode::Cv: return "cv";
    case SmoothingMode::Lambda: return "lambda";
  }
  return "unknown";
}

/// @throws std::invalid_argument for a name other than s-constraint, gcv, cv, lambda.
template <typename = void>
inline SmoothingMode parse_smoothing_mode(const std::string& name) {
  for (SmoothingMode m : {SmoothingMode::SConstraint, SmoothingMode::Gcv, SmoothingMode::Cv, SmoothingMode::Lambda})
    if (name == smoothing_mode_name(m)) return m;
  throw std::invalid_argument("sid::parse_smoothing_mode: unknown smoothing '" + name +
                              "' (expected s-constraint, gcv, cv or lambda)");
}

/// @brief What the CSS smoothing chose, per joint (NaN where a mode does not compute it).
struct SmoothingReport {
  Vector2<double> p = Vector2<double>::Constant(std::nan(""));       ///< Reinsch's p = 1/λ
  Vector2<double> lambda = Vector2<double>::Constant(std::nan(""));  ///< λ
  Vector2<double> trace = Vector2<double>::Constant(std::nan(""));   ///< tr A: degrees of freedom
  Vector2<double> sigma = Vector2<double>::Constant(std::nan(""));   ///< σ̂ [rad] (GCV/CV)
};

/// @brief Butterworth low-pass settings of the filtered method (order, cutoff relative to
/// Nyquist). Defaults are the paper's: 10 Hz, 3 Hz and 2 Hz at 400 Hz sampling.
struct DifferenceFilters {
  int q_order = 3;
  double q_cutoff = 0.05;
  int qd_order = 3;
  double qd_cutoff = 0.015;
  int qdd_order = 4;
  double qdd_cutoff = 0.01;
};

/// @brief IdentifyOptions::cross_validation_lambda_scale for the IV step (study method css_iv,
/// sid_identify --estimator iv): GCV's λ is optimal for q, but the smoothing bias it leaves in
/// q̇ and q̈ (θ5 −2.3 %, θ2 −3 % at σq² = 1e-4) is systematic and the IV step cannot remove it,
/// while the extra noise of a 4× smaller λ is exactly what IV does remove. Measured over
/// 300 runs at σq² = 1e-4: RMS relative error 2.39 % (scale 1), 2.30 % (0.5), 2.29 % (0.25),
/// oracle 2.04 %; scale 0.1 is worse again (the first LS estimate degrades).
inline constexpr double kInstrumentalVariableLambdaScale = 0.25;

/// @brief Options of the identification pipeline.
struct IdentifyOptions {
  DerivativeMethod method = DerivativeMethod::SmoothingSpline;
  /// δq per joint [rad]: the standard deviation the CSS constraint assumes (paper: δq = σq).
  Vector2<double> sigma_q = Vector2<double>::Constant(1e-3);
  /// S of the CSS constraint; empty = number of samples (the paper's choice).
  std::optional<double> S;
  /// How CSS smooths; GCV and CV ignore sigma_q (all samples weigh the same).
  SmoothingMode smoothing = SmoothingMode::SConstraint;
  /// GCV and CV choose one λ for the whole record, so a sharp start transient (which the
  /// window drops anyway) would pull λ toward interpolation everywhere. They therefore smooth
  /// only the samples with t >= t₀ + cross_validation_skip [s] (keep it below `skip`: the
  /// natural end condition distorts q̈ over the first few samples of the fit).
  double cross_validation_skip = 0.125;
  /// GCV and CV use λ_chosen × this factor [-], > 0. GCV's λ is optimal for q itself; q̇ and q̈
  /// are best estimated with less smoothing, whose extra noise the IV step tolerates while the
  /// smoothing bias it removes would otherwise stay in θ̂ (see study method css_iv).
  double cross_validation_lambda_scale = 1.0;
  /// λ for SmoothingMode::Lambda (SciPy's `lam` with w = 1/δq²) [rad⁻² s³ units of ∫g''²].
  double lambda = std::nan("");
  /// Samples with t < t₀ + skip are dropped (the start transient) [s].
  double skip = 0.25;
  /// The filtered method drops t < t₀ + filtered_skip instead (filter start-up) [s].
  double filtered_skip = 1.7475;
  /// Samples with t > t_last − skip_end are dropped too [s]. The paper keeps them (0), but a
  /// natural spline has g'' = 0 at the last knot, so CSS's q̈ is wrong over the last few
  /// samples unless the motion happens to stop there.
  double skip_end = 0.0;
  DifferenceFilters filters;
  /// Gautier's weighted least squares (per-joint noise from a first fit) instead of plain LS.
  bool weighted = false;
  double gravity = kPaperGravity;  ///< [m/s²]
  LeastSquaresOptions least_squares;
};

/// @brief What the pipeline found, with everything needed to report it.
struct Identification {
  DerivativeMethod method = DerivativeMethod::SmoothingSpline;
  Kinematics<double> kinematics;  ///< the samples used (after the window)
  LeastSquaresResult<double> fit;
  /// Reinsch's p per joint (CSS only; NaN otherwise).
  Vector2<double> smoothing_p = Vector2<double>::Constant(std::nan(""));
  /// Everything the CSS smoothing chose (CSS only).
  SmoothingReport smoothing;

  Eigen::Index samples_used() const { return kinematics.size(); }
};

namespace detail {

/// Sampling period of a uniform grid. @throws std::invalid_argument if t is not uniform.
template <typename = void>
inline double uniform_period(const VectorX<double>& t, const char* who) {
  const Eigen::Index n = t.size();
  const double ts = (t[n - 1] - t[0]) / static_cast<double>(n - 1);
  constexpr double kUniformTolerance = 1e-6;  // relative jitter a logged time stamp may have
  for (Eigen::Index i = 1; i < n; ++i)
    if (std::abs((t[i] - t[i - 1]) - ts) > kUniformTolerance * ts)
      throw std::invalid_argument(std::string(who) + ": finite differences need uniform sampling, but t[" +
                                  std::to_string(i) + "] - t[" + std::to_string(i - 1) + "] = " +
                                  std::to_string(t[i] - t[i - 1]) + " differs from the mean period " +
                                  std::to_string(ts));
  return ts;
}

template <typename = void>
inline Kinematics<double> rows_of(const Trajectory<double>& data, Eigen::Index begin, Eigen::Index count) {
  Kinematics<double> k;
  k.t = data.t.segment(begin, count);
  k.q = data.q.middleRows(begin, count);
  k.tau = data.tau.middleRows(begin, count);
  return k;
}

}  // namespace detail

/// @brief q, q̇, q̈ (and τ) at every sample the method can produce: all n for CSS, the first
/// n − 2 for the difference methods (q̈ needs qᵢ₊₂). For the filtered method q, q̇, q̈ are the
/// filtered signals. Smoothing parameters p are written to *p_out when given.
/// @throws std::invalid_argument on an invalid trajectory, too few samples, non-uniform sampling
/// for the difference methods, or δq <= 0.
template <typename = void>
inline Kinematics<double> estimate_kinematics(const Trajectory<double>& data, const IdentifyOptions& options,
                                              SmoothingReport* report = nullptr) {
  const char* who = "sid::estimate_kinematics";
  data.validate(who);
  const Eigen::Index n = data.size();
  switch (options.method) {
    case DerivativeMethod::SmoothingSpline: {
      if (n < 3) throw std::invalid_argument(std::string(who) + ": CSS needs at least 3 samples, got " + std::to_string(n));
      const bool cross_validated =
          options.smoothing == SmoothingMode::Gcv || options.smoothing == SmoothingMode::Cv;
      Eigen::Index first = 0;
      if (cross_validated) {
        if (!(options.cross_validation_skip >= 0.0) || !std::isfinite(options.cross_validation_skip))
          throw std::invalid_argument(std::string(who) + ": cross_validation_skip must be finite and >= 0");
        while (first < n && data.t[first] < data.t[0] + options.cross_validation_skip - 1e-9) ++first;
        if (n - first < 4)
          throw std::invalid_argument(std::string(who) + ": fewer than 4 samples after cross_validation_skip");
      }
      const Eigen::Index used = n - first;
      const SmoothingSpline<double> spline(data.t.tail(used));
      Kinematics<double> k = detail::rows_of(data, first, used);
      k.qd.resize(used, 2);
      k.qdd.resize(used, 2);
      if (cross_validated && (!(options.cross_validation_lambda_scale > 0.0) ||
                              !std::isfinite(options.cross_validation_lambda_scale)))
        throw std::invalid_argument(std::string(who) + ": cross_validation_lambda_scale must be finite and > 0");
      if (options.smoothing == SmoothingMode::Lambda && (!(options.lambda > 0.0) || !std::isfinite(options.lambda)))
        throw std::invalid_argument(std::string(who) + ": smoothing 'lambda' needs a finite lambda > 0");
      for (int j = 0; j < 2; ++j) {
        if (!cross_validated && (!(options.sigma_q[j] > 0.0) || !std::isfinite(options.sigma_q[j])))
          throw std::invalid_argument(std::string(who) + ": sigma_q of joint " + std::to_string(j + 1) +
                                      " must be finite and > 0");
        const VectorX<double> qj = data.q.col(j).tail(used);
        SmoothingFit<double> fit;
        switch (options.smoothing) {
          case SmoothingMode::SConstraint:
            fit = spline.fit_constrained(qj, options.sigma_q[j], options.S.value_or(static_cast<double>(used)));
            break;
          case SmoothingMode::Gcv:
          case SmoothingMode::Cv: {
            fit = spline.fit_cross_validated(
                qj, 1.0, options.smoothing == SmoothingMode::Gcv ? SmoothingCriterion::Gcv : SmoothingCriterion::Cv);
            const double scale = options.cross_validation_lambda_scale;
            if (scale != 1.0) {
              const SmoothingFit<double> chosen = fit;
              fit = spline.fit_penalized(qj, 1.0, chosen.p / scale);
              fit.sigma = chosen.sigma;  // the noise estimate belongs to the λ the criterion chose
              fit.trace = spline.hat_diagonal(VectorX<double>::Ones(used), fit.p).sum();
            }
            break;
          }
          case SmoothingMode::Lambda:
            fit = spline.fit_penalized(qj, options.sigma_q[j], 1.0 / options.lambda);
            break;
        }
        fit.spline.derivatives_at_knots(0, k.q.col(j));
        fit.spline.derivatives_at_knots(1, k.qd.col(j));
        fit.spline.derivatives_at_knots(2, k.qdd.col(j));
        if (report) {
          report->p[j] = fit.p;
          report->lambda[j] = fit.lambda;
          report->trace[j] = fit.trace;
          report->sigma[j] = fit.sigma;
        }
      }
      return k;
    }
    case DerivativeMethod::ForwardDifference:
    case DerivativeMethod::FilteredDifference: {
      const Eigen::Index min_samples =
          options.method == DerivativeMethod::ForwardDifference ? 3 : 3 * (options.filters.qdd_order + 1) + 3;
      if (n < min_samples)
        throw std::invalid_argument(std::string(who) + ": method " + method_name(options.method) + " needs at least " +
                                    std::to_string(min_samples) + " samples, got " + std::to_string(n));
      const double ts = detail::uniform_period(data.t, who);
      const auto d = forward_differences(data.q, ts);
      const Eigen::Index m = n - 2;  // samples with q̈
      Kinematics<double> k = detail::rows_of(data, 0, m);
      if (options.method == DerivativeMethod::ForwardDifference) {
        k.qd = d.first.topRows(m);
        k.qdd = d.second;
        return k;
      }
      const auto& f = options.filters;
      // Each signal is filtered over all the samples it has, then cut to the common range.
      k.q = filtfilt(butterworth_lowpass(f.q_order, f.q_cutoff), data.q).topRows(m);
      k.qd = filtfilt(butterworth_lowpass(f.qd_order, f.qd_cutoff), d.first).topRows(m);
      k.qdd = filtfilt(butterworth_lowpass(f.qdd_order, f.qdd_cutoff), d.second);
      return k;
    }
  }
  throw std::invalid_argument(std::string(who) + ": unknown method");
}

/// @brief The samples with t_from <= t <= t_to (a small tolerance keeps a sample that sits on a
/// bound despite rounding, e.g. 100 · 0.0025).
template <typename = void>
inline Kinematics<double> window(const Kinematics<double>& k, double t_from,
                                 double t_to = std::numeric_limits<double>::infinity()) {
  const double tol_from = 1e-9 * (1.0 + std::abs(t_from));
  const double tol_to = std::isfinite(t_to) ? 1e-9 * (1.0 + std::abs(t_to)) : 0.0;
  Eigen::Index begin = 0, end = k.size();
  while (begin < end && k.t[begin] < t_from - tol_from) ++begin;
  while (end > begin && k.t[end - 1] > t_to + tol_to) --end;
  const Eigen::Index count = end - begin;
  Kinematics<double> w;
  w.t = k.t.segment(begin, count);
  w.q = k.q.middleRows(begin, count);
  w.qd = k.qd.middleRows(begin, count);
  w.qdd = k.qdd.middleRows(begin, count);
  w.tau = k.tau.middleRows(begin, count);
  return w;
}

/// @brief The paper's 7 parameter names, "theta1".."theta7".
template <typename = void>
inline std::vector<std::string> two_link_parameter_names() {
  std::vector<std::string> names;
  for (int k = 1; k <= 7; ++k) names.push_back("theta" + std::to_string(k));
  return names;
}

/// @brief Least squares of the two-link arm on given kinematics (joint 1's rows, then joint 2's).
/// @throws std::invalid_argument if there are not more equations than parameters.
template <typename = void>
inline LeastSquaresResult<double> fit_two_link(const Kinematics<double>& k, double gravity,
                                               LeastSquaresOptions options = {}) {
  if (2 * k.size() <= 7)
    throw std::invalid_argument("sid::fit_two_link: " + std::to_string(k.size()) +
                                " samples give too few equations for 7 parameters");
  if (options.column_names.empty()) options.column_names = two_link_parameter_names();
  const auto regression = stack_two_link_regression(k, gravity);
  return least_squares(regression.X, regression.y, 2, options);
}

/// @brief Gautier's IDIM-WLS: an ordinary fit first, then each joint's rows weighted by
/// 1/σ̂ⱼ² from that fit's per-joint residual variance, so a joint with noisier torques counts
/// less. The result's covariance is then σ̂²(XᵀWX)⁻¹ with σ̂² ≈ 1, and its relative standard
/// deviations are the ones Gautier reports. A rank-deficient first fit is returned as it is.
template <typename = void>
inline LeastSquaresResult<double> fit_two_link_weighted(const Kinematics<double>& k, double gravity,
                                                        LeastSquaresOptions options = {}) {
  const LeastSquaresResult<double> first = fit_two_link(k, gravity, options);
  if (!first.ok() || !(first.sigma2_per_joint.array() > 0.0).all()) return first;
  if (options.column_names.empty()) options.column_names = two_link_parameter_names();
  const auto regression = stack_two_link_regression(k, gravity);
  const Eigen::Index n = k.size();
  VectorX<double> weights(2 * n);
  weights.head(n).setConstant(1.0 / first.sigma2_per_joint[0]);
  weights.tail(n).setConstant(1.0 / first.sigma2_per_joint[1]);
  return weighted_least_squares(regression.X, regression.y, weights, 2, options);
}

/// @brief The whole pipeline: derivatives by options.method, window, least squares.
/// A rank-deficient regressor is reported in result.fit.status (not thrown).
/// @throws std::invalid_argument on bad input (see estimate_kinematics) or when the window
/// leaves too few samples.
template <typename = void>
Identification identify(const Trajectory<double>& data, const IdentifyOptions& options = {}) {
  Identification result;
  result.method = options.method;
  const Kinematics<double> all = estimate_kinematics(data, options, &result.smoothing);
  result.smoothing_p = result.smoothing.p;
  const double skip = options.method == DerivativeMethod::FilteredDifference ? options.filtered_skip : options.skip;
  if (!(skip >= 0.0) || !std::isfinite(skip))
    throw std::invalid_argument("sid::identify: skip must be finite and >= 0");
  if (!(options.skip_end >= 0.0) || !std::isfinite(options.skip_end))
    throw std::invalid_argument("sid::identify: skip_end must be finite and >= 0");
  result.kinematics = window(all, data.t[0] + skip, data.t[data.size() - 1] - options.skip_end);
  if (2 * result.kinematics.size() <= 7)
    throw std::invalid_argument("sid::identify: only " + std::to_string(result.kinematics.size()) +
                                " samples are left after skipping " + std::to_string(skip) +
                                " s; 7 parameters need at least 4");
  result.fit = options.weighted ? fit_two_link_weighted(result.kinematics, options.gravity, options.least_squares)
                                : fit_two_link(result.kinematics, options.gravity, options.least_squares);
  return result;
}

#ifdef SID_PRECOMPILED
// Compiled once, in src/precompiled/pipeline.cpp, for the programs that link it.
extern template Identification identify<>(const Trajectory<double>&, const IdentifyOptions&);
#endif

}  // namespace sid
