#pragma once
// Definitions of sid/identify.hpp (see sid/config.hpp).

#include <sid/detail/kinematics_estimation.hpp>
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
  return kinematics_rows(data, begin, count);
}

}  // namespace detail

SID_INLINE Kinematics<double> estimate_kinematics(const Trajectory<double>& data,
                                                  const IdentifyOptions& options,
                                                  SmoothingReport* report) {
  return detail::estimate_joint_kinematics(data, options, options.sigma_q, report,
                                           "sid::estimate_kinematics");
}

SID_INLINE Kinematics<double> window(const Kinematics<double>& k, double t_from, double t_to) {
  return detail::window_rows(k, t_from, t_to);
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
