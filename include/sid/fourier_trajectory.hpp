#pragma once
/// @file
/// @brief The periodic excitation trajectories identification experiments use (Swevers et al.
/// 1997; the form FIGAROH and BIRDy take): per joint a finite Fourier series about an offset,
///   q_j(t) = q0_j + sum_{l=1..H} a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t),
/// w = 2 pi f, so that q_j, its rate and its acceleration are analytic and the run repeats
/// every 1 / f seconds.

#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace sid {

/// @brief A finite Fourier series per joint. Class invariant (checked by validate()):
/// base_frequency finite and > 0; q0 one entry per joint; a and b joints x harmonics, at least
/// one of each; every value finite.
struct FourierTrajectory {
  double base_frequency = 0.1;  ///< f [Hz]; the trajectory's period is 1 / f
  Eigen::VectorXd q0;           ///< offsets [rad or m]
  Eigen::MatrixXd a, b;         ///< coefficients [rad/s or m/s], joints x harmonics

  int joints() const noexcept { return static_cast<int>(q0.size()); }
  int harmonics() const noexcept { return static_cast<int>(a.cols()); }

  /// @throws std::invalid_argument naming the first violated invariant.
  void validate(const char* who = "sid::FourierTrajectory") const {
    const std::string prefix = std::string(who) + ": ";
    if (!(base_frequency > 0.0) || !std::isfinite(base_frequency))
      throw std::invalid_argument(prefix + "base_frequency must be finite and > 0");
    if (q0.size() < 1 || q0.size() > kMaxChainJoints)
      throw std::invalid_argument(prefix + "q0 has " + std::to_string(q0.size()) + " entries; 1.." +
                                  std::to_string(kMaxChainJoints) + " joints are supported");
    if (a.rows() != q0.size() || b.rows() != q0.size() || a.cols() != b.cols() || a.cols() < 1)
      throw std::invalid_argument(
          prefix + "a and b must both be joints x harmonics (" + std::to_string(q0.size()) +
          " x H, H >= 1); a is " + std::to_string(a.rows()) + " x " + std::to_string(a.cols()) +
          ", b " + std::to_string(b.rows()) + " x " + std::to_string(b.cols()));
    if (!q0.allFinite() || !a.allFinite() || !b.allFinite())
      throw std::invalid_argument(prefix + "q0, a or b holds a value that is not finite");
  }

  /// @brief q, its rate and its acceleration at time t [s], each of joints() entries.
  template <typename Vector>
  void evaluate(double t, Vector& q, Vector& qd, Vector& qdd) const {
    constexpr double kTwoPi = 6.28318530717958647692;
    const double w = kTwoPi * base_frequency;
    q = q0;
    qd.setZero(joints());
    qdd.setZero(joints());
    for (int l = 1; l <= harmonics(); ++l) {
      const double lw = l * w, s = std::sin(lw * t), c = std::cos(lw * t);
      for (int j = 0; j < joints(); ++j) {
        const double aj = a(j, l - 1), bj = b(j, l - 1);
        q[j] += (aj * s - bj * c) / lw;
        qd[j] += aj * c + bj * s;
        qdd[j] += lw * (bj * c - aj * s);
      }
    }
  }
};

/// @brief Random coefficients (uniform in [-1, 1]), then each joint's series scaled so that
/// |q_j - q0_j| <= q_range_j and |qd_j| <= qd_max_j at every time, whichever binds, to within
/// 0.12 % (the maxima are taken on 64 points per period of the highest harmonic and bounded
/// between them). Deterministic for a given generator state.
/// @param q_range, qd_max one positive finite entry per joint [rad or m, rad/s or m/s].
/// @throws std::invalid_argument for sizes that disagree or a bound that is not positive.
template <typename Generator>
FourierTrajectory random_fourier_trajectory(const Eigen::Ref<const Eigen::VectorXd>& q0,
                                            int harmonics, double base_frequency,
                                            const Eigen::Ref<const Eigen::VectorXd>& q_range,
                                            const Eigen::Ref<const Eigen::VectorXd>& qd_max,
                                            Generator& rng) {
  const char* who = "sid::random_fourier_trajectory";
  const Eigen::Index n = q0.size();
  if (harmonics < 1) throw std::invalid_argument(std::string(who) + ": harmonics must be >= 1");
  if (q_range.size() != n || qd_max.size() != n)
    throw std::invalid_argument(std::string(who) + ": q0, q_range and qd_max must have one " +
                                "entry per joint");
  if (!((q_range.array() > 0.0).all() && (qd_max.array() > 0.0).all() && q_range.allFinite() &&
        qd_max.allFinite()))
    throw std::invalid_argument(std::string(who) + ": q_range and qd_max must be finite and > 0");
  FourierTrajectory f;
  f.base_frequency = base_frequency;
  f.q0 = q0;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  f.a = Eigen::MatrixXd::NullaryExpr(n, harmonics, [&] { return u(rng); });
  f.b = Eigen::MatrixXd::NullaryExpr(n, harmonics, [&] { return u(rng); });
  f.validate(who);
  const int points = 64 * harmonics;
  Eigen::VectorXd largest_q = Eigen::VectorXd::Zero(n), largest_qd = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (int k = 0; k < points; ++k) {
    f.evaluate(k / (points * base_frequency), q, qd, qdd);
    largest_q = largest_q.cwiseMax((q - q0).cwiseAbs());
    largest_qd = largest_qd.cwiseMax(qd.cwiseAbs());
  }
  // q - q0 and qd are trigonometric polynomials of degree H; on N equispaced points of a period
  // their largest value is at least cos(pi H / N) of the true one, so this bound is safe.
  constexpr double kPi = 3.14159265358979323846;
  const double guard = 1.0 / std::cos(kPi * harmonics / points);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double scale =
        std::min(q_range[j] / (guard * largest_q[j]), qd_max[j] / (guard * largest_qd[j]));
    f.a.row(j) *= scale;
    f.b.row(j) *= scale;
  }
  return f;
}

}  // namespace sid
