#pragma once
/// @file
/// @brief Additive Gaussian measurement noise on joint angles and torques (the paper's
/// section 3.1: q + v_q, v_q ~ N(0, sigma_q^2) per joint; tau + v_tau, v_tau ~ N(0, sigma_tau^2)).

#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace sid {

/// @brief Variances of the measurement noise. Class invariant (checked where used): both finite
/// and >= 0; 0 means that signal is measured exactly.
template <typename Scalar>
struct MeasurementNoise {
  /// sigma_q^2, the variance of the noise on each joint angle [rad^2].
  Scalar q_variance = Scalar(0);
  /// sigma_tau^2, the variance of the noise on each joint torque [(N m)^2].
  Scalar tau_variance = Scalar(0);
};

/// @brief Returns truth with independent zero-mean Gaussian noise added to q and tau; t is
/// copied unchanged.
///
/// Draw order (part of the contract, so a run is reproducible from its seed): one standard normal
/// z per entry, column by column: q1 for all samples, then q2 (... qn), then tau1, tau2 (...
/// taun); each entry becomes value + sqrt(variance) * z. A zero variance therefore returns the
/// exact values while still consuming its draws, so the q noise of a seed does not depend on the
/// tau variance.
///
/// Reproducibility: the numbers depend on the generator and on std::normal_distribution, whose
/// algorithm the C++ standard leaves to the library. The same seed gives the same noise on every
/// run with one standard library, but different noise on libstdc++, libc++ and MSVC's library.
/// Statistics (mean, variance) are the same; exact digits are not.
///
/// @tparam Rng a uniform random bit generator, typically std::mt19937_64 seeded by the caller
///   (never a global one: a run depends only on its seed).
/// @param[in] truth noise-free samples; validated (see Trajectory::validate()).
/// @param[in] noise variances, finite and >= 0.
/// @param[in,out] rng the generator; advanced by 2 joints x samples draws of
///   std::normal_distribution.
/// @throws std::invalid_argument for a negative or non-finite variance or an invalid truth.
template <typename Scalar, int Joints, typename Rng>
Trajectory<Scalar, Joints> add_measurement_noise(const Trajectory<Scalar, Joints>& truth,
                                                 const MeasurementNoise<Scalar>& noise, Rng& rng) {
  static_assert(std::is_floating_point_v<Scalar>,
                "sid::add_measurement_noise: std::normal_distribution needs float, double or "
                "long double");
  using std::isfinite;
  using std::sqrt;
  if (!(noise.q_variance >= Scalar(0)) || !isfinite(noise.q_variance))
    throw std::invalid_argument(
        "sid::add_measurement_noise: noise.q_variance must be finite and >= 0");
  if (!(noise.tau_variance >= Scalar(0)) || !isfinite(noise.tau_variance))
    throw std::invalid_argument(
        "sid::add_measurement_noise: noise.tau_variance must be finite and >= 0");
  truth.validate("sid::add_measurement_noise: truth");

  std::normal_distribution<Scalar> standard_normal(Scalar(0), Scalar(1));
  const Scalar sigma_q = sqrt(noise.q_variance);
  const Scalar sigma_tau = sqrt(noise.tau_variance);
  Trajectory<Scalar, Joints> measured = truth;
  const Eigen::Index n = truth.size();
  for (Eigen::Index j = 0; j < truth.joints(); ++j)
    for (Eigen::Index i = 0; i < n; ++i) measured.q(i, j) += sigma_q * standard_normal(rng);
  for (Eigen::Index j = 0; j < truth.joints(); ++j)
    for (Eigen::Index i = 0; i < n; ++i) measured.tau(i, j) += sigma_tau * standard_normal(rng);
  return measured;
}

/// @brief The same for a true trajectory given as kinematics (its qd and qdd are not measured
/// and are dropped).
template <typename Scalar, int Joints, typename Rng>
Trajectory<Scalar, Joints> add_measurement_noise(const Kinematics<Scalar, Joints>& truth,
                                                 const MeasurementNoise<Scalar>& noise, Rng& rng) {
  return add_measurement_noise(Trajectory<Scalar, Joints>{truth.t, truth.q, truth.tau}, noise, rng);
}

}  // namespace sid
