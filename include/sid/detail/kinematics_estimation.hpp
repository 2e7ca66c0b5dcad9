#pragma once
/// @file
/// @brief The derivative methods of sid::estimate_kinematics for any joint count: the paper's
/// arm (Joints = 2) and a chain (Eigen::Dynamic) run the same code, so the two-link study and
/// the chain study estimate q̇ and q̈ alike. Templates, hence in a header in both build modes.

#include <sid/butterworth.hpp>
#include <sid/finite_difference.hpp>
#include <sid/identify.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace sid::detail {

template <int Joints>
Kinematics<double, Joints> kinematics_rows(const Trajectory<double, Joints>& data,
                                           Eigen::Index begin, Eigen::Index count) {
  Kinematics<double, Joints> k;
  k.t = data.t.segment(begin, count);
  k.q = data.q.middleRows(begin, count);
  k.tau = data.tau.middleRows(begin, count);
  return k;
}

/// The first sample the cross-validated smoothing uses: the first at or after
/// options.cross_validation_skip.
template <int Joints>
Eigen::Index cross_validation_first_sample(const Trajectory<double, Joints>& data,
                                           const IdentifyOptions& options, const char* who) {
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

/// The smoothing spline of one joint's angles qj as options.smoothing chooses it; sigma is the
/// joint's δq (S constraint, λ form).
inline SmoothingFit<double> fit_joint_spline(const SmoothingSpline<double>& spline,
                                             const VectorX<double>& qj,
                                             const IdentifyOptions& options, double sigma) {
  const Eigen::Index used = qj.size();
  SmoothingFit<double> fit;
  switch (options.smoothing) {
    case SmoothingMode::SConstraint:
      fit = spline.fit_constrained(qj, sigma, options.S.value_or(static_cast<double>(used)));
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
      fit = spline.fit_penalized(qj, sigma, 1.0 / options.lambda);
      break;
  }
  return fit;
}

/// DerivativeMethod::SmoothingSpline on every joint; sigma_q holds each joint's δq. The report,
/// when given, receives the first joints' choices (as many as it has room for).
template <int Joints>
Kinematics<double, Joints> spline_kinematics(const Trajectory<double, Joints>& data,
                                             const IdentifyOptions& options,
                                             const Eigen::Ref<const Eigen::VectorXd>& sigma_q,
                                             SmoothingReport* report, const char* who) {
  const Eigen::Index n = data.size(), joints = data.joints();
  if (n < 3)
    throw std::invalid_argument(std::string(who) + ": CSS needs at least 3 samples, got " +
                                std::to_string(n));
  const bool cross_validated =
      options.smoothing == SmoothingMode::Gcv || options.smoothing == SmoothingMode::Cv;
  const Eigen::Index first =
      cross_validated ? cross_validation_first_sample(data, options, who) : 0;
  const Eigen::Index used = n - first;
  const SmoothingSpline<double> spline(data.t.tail(used));
  Kinematics<double, Joints> k = kinematics_rows(data, first, used);
  k.qd.resize(used, joints);
  k.qdd.resize(used, joints);
  if (cross_validated && (!(options.cross_validation_lambda_scale > 0.0) ||
                          !std::isfinite(options.cross_validation_lambda_scale)))
    throw std::invalid_argument(std::string(who) +
                                ": cross_validation_lambda_scale must be finite and > 0");
  if (options.smoothing == SmoothingMode::Lambda &&
      (!(options.lambda > 0.0) || !std::isfinite(options.lambda)))
    throw std::invalid_argument(std::string(who) +
                                ": smoothing 'lambda' needs a finite lambda > 0");
  if (!cross_validated && sigma_q.size() != joints)
    throw std::invalid_argument(std::string(who) + ": sigma_q has " +
                                std::to_string(sigma_q.size()) + " entries for " +
                                std::to_string(joints) + " joints");
  for (Eigen::Index j = 0; j < joints; ++j) {
    const double sigma = cross_validated ? 1.0 : sigma_q[j];
    if (!cross_validated && (!(sigma > 0.0) || !std::isfinite(sigma)))
      throw std::invalid_argument(std::string(who) + ": sigma_q of joint " + std::to_string(j + 1) +
                                  " must be finite and > 0");
    const VectorX<double> qj = data.q.col(j).tail(used);
    const SmoothingFit<double> fit = fit_joint_spline(spline, qj, options, sigma);
    fit.spline.derivatives_at_knots(0, k.q.col(j));
    fit.spline.derivatives_at_knots(1, k.qd.col(j));
    fit.spline.derivatives_at_knots(2, k.qdd.col(j));
    if (report && j < report->p.size()) {
      report->p[j] = fit.p;
      report->lambda[j] = fit.lambda;
      report->trace[j] = fit.trace;
      report->sigma[j] = fit.sigma;
    }
  }
  return k;
}

/// DerivativeMethod::ForwardDifference or FilteredDifference on every joint.
template <int Joints>
Kinematics<double, Joints> difference_kinematics(const Trajectory<double, Joints>& data,
                                                 const IdentifyOptions& options, const char* who) {
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
  Kinematics<double, Joints> k = kinematics_rows(data, 0, m);
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

/// sid::estimate_kinematics for any joint count (sigma_q: each joint's δq).
template <int Joints>
Kinematics<double, Joints> estimate_joint_kinematics(
    const Trajectory<double, Joints>& data, const IdentifyOptions& options,
    const Eigen::Ref<const Eigen::VectorXd>& sigma_q, SmoothingReport* report, const char* who) {
  data.validate(who);
  switch (options.method) {
    case DerivativeMethod::SmoothingSpline:
      return spline_kinematics(data, options, sigma_q, report, who);
    case DerivativeMethod::ForwardDifference:
    case DerivativeMethod::FilteredDifference:
      return difference_kinematics(data, options, who);
  }
  throw std::invalid_argument(std::string(who) + ": unknown method");
}

/// sid::window for any joint count.
template <int Joints>
Kinematics<double, Joints> window_rows(const Kinematics<double, Joints>& k, double t_from,
                                       double t_to) {
  const double tol_from = 1e-9 * (1.0 + std::abs(t_from));
  const double tol_to = std::isfinite(t_to) ? 1e-9 * (1.0 + std::abs(t_to)) : 0.0;
  Eigen::Index begin = 0, end = k.size();
  while (begin < end && k.t[begin] < t_from - tol_from) ++begin;
  while (end > begin && k.t[end - 1] > t_to + tol_to) --end;
  const Eigen::Index count = end - begin;
  Kinematics<double, Joints> w;
  w.t = k.t.segment(begin, count);
  w.q = k.q.middleRows(begin, count);
  w.qd = k.qd.middleRows(begin, count);
  w.qdd = k.qdd.middleRows(begin, count);
  w.tau = k.tau.middleRows(begin, count);
  return w;
}

}  // namespace sid::detail
