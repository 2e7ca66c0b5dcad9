#pragma once
/// @file
/// @brief The noise level of a measured signal from the signal alone: what a perfect model's
/// residual RMS would be. A model whose torque residual exceeds this floor misses something.

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <sid/config.hpp>
#include <sid/smoothing_spline.hpp>
#include <stdexcept>
#include <string>

namespace sid {

/// @brief σ of white noise on a smooth signal from second differences:
/// E[(y_{i+1} − 2y_i + y_{i−1})²] = 6σ² + O(Ts⁴ (y'''')²). Cheap, but only 51 % efficient
/// (its variance is 35/18 times that of the mean of the true squared noise).
/// @throws std::invalid_argument for fewer than 3 samples or non-finite y.
SID_INLINE double noise_sigma_second_differences(const Eigen::Ref<const Eigen::VectorXd>& y);

/// @brief σ of white noise on a smooth signal from a GCV smoothing spline:
/// σ̂² = RSS / (n − tr A) (Wahba 1990, eq. 4.3.1). Nearly fully efficient, and its residual is
/// almost the noise itself, so σ̂² tracks the noise actually present in a record (what a model's
/// residual RMS is compared with) far more closely than a difference estimator.
/// @param t strictly increasing times [s]; y the signal (n >= 4).
/// @throws std::invalid_argument as SmoothingSpline does (too few samples, bad t, non-finite y).
SID_INLINE double noise_sigma_gcv(const Eigen::Ref<const Eigen::VectorXd>& t,
                                  const Eigen::Ref<const Eigen::VectorXd>& y);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/diagnosis/noise_floor-inl.hpp>
#endif
