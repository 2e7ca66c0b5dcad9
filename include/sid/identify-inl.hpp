#pragma once
// Definitions of sid/identify.hpp (see sid/config.hpp).

#include <sid/identify.hpp>

namespace sid {

SID_INLINE const char* method_name(DerivativeMethod method) {
  switch (method) {
    case DerivativeMethod::ForwardDifference:
      return "raw";
    case DerivativeMethod::FilteredDifference:
      return "filtered";
    case DerivativeMethod::SmoothingSpline:
      return "css";
  }
  return "unknown";
}

SID_INLINE DerivativeMethod parse_derivative_method(const std::string& name) {
  if (name == "raw") return DerivativeMethod::ForwardDifference;
  if (name == "filtered") return DerivativeMethod::FilteredDifference;
  if (name == "css") return DerivativeMethod::SmoothingSpline;
  throw std::invalid_argument("sid::parse_derivative_method: unknown method '" + name +
                              "' (expected raw, filtered or css)");
}

SID_INLINE const char* smoothing_mode_name(SmoothingMode mode) {
  switch (mode) {
    case SmoothingMode::SConstraint:
      return "s-constraint";
    case SmoothingMode::Gcv:
      return "gcv";
    case SmoothingMode::Cv:
      return "cv";
    case SmoothingMode::Lambda:
      return "lambda";
  }
  return "unknown";
}

SID_INLINE SmoothingMode parse_smoothing_mode(const std::string& name) {
  for (SmoothingMode m :
       {SmoothingMode::SConstraint, SmoothingMode::Gcv, SmoothingMode::Cv, SmoothingMode::Lambda})
    if (name == smoothing_mode_name(m)) return m;
  throw std::invalid_argument("sid::parse_smoothing_mode: unknown smoothing '" + name +
                              "' (expected s-constraint, gcv, cv or lambda)");
}

namespace detail {

SID_INLINE double uniform_period(const VectorX<double>& t, const char* who) {
  const Eigen::Index n = t.size();
  const double ts = (t[n - 1] - t[0]) / static_cast<double>(n - 1);
  constexpr double kUniformTolerance = 1e-6;  // relative jitter a logged time stamp may have
  for (Eigen::Index i = 1; i < n; ++i)
    if (std::abs((t[i] - t[i - 1]) - ts) > kUniformTolerance * ts)
      throw std::invalid_argument(std::string(who) +
                                  ": finite differences need uniform sampling, but t[" +
                                  std::to_string(i) + "] - t[" + std::to_string(i - 1) +
                                  "] = " + std::to_string(t[i] - t[i - 1]) +
                                  " differs from the mean period " + std::to_string(ts));
  return ts;
}

SID_INLINE Kinematics<double> rows_of(const Trajectory<double>& data, Eigen::Index begin,
                                      Eigen::Index count) {
  Kinematics<double> k;
  k.t = data.t.segment(begin, count);
  k.q = data.q.middleRows(begin, count);
  k.tau = data.tau.middleRows(begin, count);
  return k;
}

/// The first sample the cross-validated smoothing uses: the first at or after
/// options.cross_validation_skip.
SID_INLINE Eigen::Index cross_validation_first_sample(const Trajectory<double>& data,
                                                      const IdentifyOptions& options,
                                                      const char* who) {
  const Eigen::Index n = data.size();
  if (!(options.cross_validation_skip >= 0.0) || !std::isfinite(options.cross_validation_skip))
    throw std::invalid_argument(std::string(who) +
                                ": cross_validation_skip must be finite and >= 0");
  Eigen::Index first = 0;
  while (first < n && data.t[first] < data.t[0] + options.cross_validation_skip - 1e-9) ++first;
  if (n - first < 4)
    throw std::invalid_argument(std::string(who) +
                                ": fewer than 4 samples after cross_validation_skip");
  return first;
}

/// The smoothing spline of one joint's angles qj (j the joint's index) as options.smoothing
/// chooses it.
SID_INLINE SmoothingFit<double> fit_joint_spline(const SmoothingSpline<double>& spline,
                                                 const VectorX<double>& qj,
                                                 const IdentifyOptions& options, int j) {
  const Eigen::Index used = qj.size();
  SmoothingFit<double> fit;
  switch (options.smoothing) {
    case SmoothingMode::SConstraint:
      fit = spline.fit_constrained(qj, options.sigma_q[j],
                                   options.S.value_or(static_cast<double>(used)));
      break;
    case SmoothingMode::Gcv:
    case SmoothingMode::Cv: {
      fit = spline.fit_cross_validated(qj, 1.0,
                                       options.smoothing == SmoothingMode::Gcv
                                           ? SmoothingCriterion::Gcv
                                           : SmoothingCriterion::Cv);
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
  return fit;
}

/// estimate_kinematics with DerivativeMethod::SmoothingSpline.
SID_INLINE Kinematics<double> spline_kinematics(const Trajectory<double>& data,
                                                const IdentifyOptions& options,
                                                SmoothingReport* report, const char* who) {
  const Eigen::Index n = data.size();
  if (n < 3)
    throw std::invalid_argument(std::string(who) + ": CSS needs at least 3 samples, got " +
                                std::to_string(n));
  const bool cross_validated =
      options.smoothing == SmoothingMode::Gcv || options.smoothing == SmoothingMode::Cv;
  const Eigen::Index first =
      cross_validated ? cross_validation_first_sample(data, options, who) : 0;
  const Eigen::Index used = n - first;
  const SmoothingSpline<double> spline(data.t.tail(used));
  Kinematics<double> k = rows_of(data, first, used);
  k.qd.resize(used, 2);
  k.qdd.resize(used, 2);
  if (cross_validated && (!(options.cross_validation_lambda_scale > 0.0) ||
                          !std::isfinite(options.cross_validation_lambda_scale)))
    throw std::invalid_argument(std::string(who) +
                                ": cross_validation_lambda_scale must be finite and > 0");
  if (options.smoothing == SmoothingMode::Lambda &&
      (!(options.lambda > 0.0) || !std::isfinite(options.lambda)))
    throw std::invalid_argument(std::string(who) +
                                ": smoothing 'lambda' needs a finite lambda > 0");
  for (int j = 0; j < 2; ++j) {
    if (!cross_validated && (!(options.sigma_q[j] > 0.0) || !std::isfinite(options.sigma_q[j])))
      throw std::invalid_argument(std::string(who) + ": sigma_q of joint " + std::to_string(j + 1) +
                                  " must be finite and > 0");
    const VectorX<double> qj = data.q.col(j).tail(used);
    const SmoothingFit<double> fit = fit_joint_spline(spline, qj, options, j);
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

/// estimate_kinematics with DerivativeMethod::ForwardDifference or FilteredDifference.
SID_INLINE Kinematics<double> difference_kinematics(const Trajectory<double>& data,
                                                    const IdentifyOptions& options,
                                                    const char* who) {
  const Eigen::Index n = data.size();
  const Eigen::Index min_samples = options.method == DerivativeMethod::ForwardDifference
                                       ? 3
                                       : 3 * (options.filters.qdd_order + 1) + 3;
  if (n < min_samples)
    throw std::invalid_argument(std::string(who) + ": method " + method_name(options.method) +
                                " needs at least " + std::to_string(min_samples) +
                                " samples, got " + std::to_string(n));
  const double ts = uniform_period(data.t, who);
  const auto d = forward_differences(data.q, ts);
  const Eigen::Index m = n - 2;  // samples with q̈
  Kinematics<double> k = rows_of(data, 0, m);
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

}  // namespace detail

SID_INLINE Kinematics<double> estimate_kinematics(const Trajectory<double>& data,
                                                  const IdentifyOptions& options,
                                                  SmoothingReport* report) {
  const char* who = "sid::estimate_kinematics";
  data.validate(who);
  switch (options.method) {
    case DerivativeMethod::SmoothingSpline:
      return detail::spline_kinematics(data, options, report, who);
    case DerivativeMethod::ForwardDifference:
    case DerivativeMethod::FilteredDifference:
      return detail::difference_kinematics(data, options, who);
  }
  throw std::invalid_argument(std::string(who) + ": unknown method");
}

SID_INLINE Kinematics<double> window(const Kinematics<double>& k, double t_from, double t_to) {
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

SID_INLINE std::vector<std::string> two_link_parameter_names() {
  std::vector<std::string> names;
  for (int k = 1; k <= 7; ++k) names.push_back("theta" + std::to_string(k));
  return names;
}

SID_INLINE LeastSquaresResult<double> fit_two_link(const Kinematics<double>& k, double gravity,
                                                   LeastSquaresOptions options) {
  if (2 * k.size() <= 7)
    throw std::invalid_argument("sid::fit_two_link: " + std::to_string(k.size()) +
                                " samples give too few equations for 7 parameters");
  if (options.column_names.empty()) options.column_names = two_link_parameter_names();
  const auto regression = stack_two_link_regression(k, gravity);
  return least_squares(regression.X, regression.y, 2, options);
}

SID_INLINE LeastSquaresResult<double> fit_two_link_weighted(const Kinematics<double>& k,
                                                            double gravity,
                                                            LeastSquaresOptions options) {
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

SID_INLINE Identification identify(const Trajectory<double>& data, const IdentifyOptions& options) {
  Identification result;
  result.method = options.method;
  const Kinematics<double> all = estimate_kinematics(data, options, &result.smoothing);
  result.smoothing_p = result.smoothing.p;
  const double skip =
      options.method == DerivativeMethod::FilteredDifference ? options.filtered_skip : options.skip;
  if (!(skip >= 0.0) || !std::isfinite(skip))
    throw std::invalid_argument("sid::identify: skip must be finite and >= 0");
  if (!(options.skip_end >= 0.0) || !std::isfinite(options.skip_end))
    throw std::invalid_argument("sid::identify: skip_end must be finite and >= 0");
  result.kinematics = window(all, data.t[0] + skip, data.t[data.size() - 1] - options.skip_end);
  if (2 * result.kinematics.size() <= 7)
    throw std::invalid_argument("sid::identify: only " + std::to_string(result.kinematics.size()) +
                                " samples are left after skipping " + std::to_string(skip) +
                                " s; 7 parameters need at least 4");
  result.fit =
      options.weighted
          ? fit_two_link_weighted(result.kinematics, options.gravity, options.least_squares)
          : fit_two_link(result.kinematics, options.gravity, options.least_squares);
  return result;
}

}  // namespace sid
