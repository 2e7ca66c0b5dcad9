#pragma once
// Definitions of sid/diagnosis/noise_floor.hpp (see sid/config.hpp).

#include <sid/diagnosis/noise_floor.hpp>

namespace sid {

SID_INLINE double noise_sigma_second_differences(const Eigen::Ref<const Eigen::VectorXd>& y) {
  const Eigen::Index n = y.size();
  if (n < 3)
    throw std::invalid_argument(
        "sid::noise_sigma_second_differences: needs at least 3 samples, got " + std::to_string(n));
  if (!y.allFinite())
    throw std::invalid_argument("sid::noise_sigma_second_differences: y must be finite");
  double sum = 0.0;
  for (Eigen::Index i = 1; i + 1 < n; ++i) {
    const double d = y[i + 1] - 2.0 * y[i] + y[i - 1];
    sum += d * d;
  }
  return std::sqrt(sum / (6.0 * static_cast<double>(n - 2)));
}

SID_INLINE double noise_sigma_gcv(const Eigen::Ref<const Eigen::VectorXd>& t,
                                  const Eigen::Ref<const Eigen::VectorXd>& y) {
  const SmoothingSpline<double> spline(t);
  return spline.fit_cross_validated(y, 1.0, SmoothingCriterion::Gcv).sigma;
}

}  // namespace sid
