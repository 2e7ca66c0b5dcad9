#pragma once
// Definitions of sid/diagnosis/kinematic_floor.hpp (see sid/config.hpp).

#include <sid/diagnosis/kinematic_floor.hpp>

namespace sid {

SID_INLINE Vector2<double> kinematic_noise_rms(const Model<double>& model,
                                               const Eigen::Ref<const Eigen::VectorXd>& theta,
                                               const Kinematics<double>& knots_kinematics,
                                               const Vector2<double>& sigma_q,
                                               const Vector2<double>& p, Eigen::Index first,
                                               Eigen::Index count, const Eigen::VectorXd& weight,
                                               int runs, std::uint64_t seed) {
  constexpr const char* who = "sid::kinematic_noise_rms";
  const Kinematics<double>& k = knots_kinematics;
  const Eigen::Index n = k.size();
  if (first < 0 || count < 1 || first + count > n)
    throw std::invalid_argument(std::string(who) + ": rows " + std::to_string(first) + " + " +
                                std::to_string(count) + " do not lie within the " +
                                std::to_string(n) + " knots");
  if (weight.size() != 2 * count)
    throw std::invalid_argument(std::string(who) + ": weight needs " + std::to_string(2 * count) +
                                " entries, got " + std::to_string(weight.size()));
  for (int j = 0; j < 2; ++j)
    if (!(sigma_q[j] > 0.0) || !std::isfinite(sigma_q[j]) || !(p[j] > 0.0) || !std::isfinite(p[j]))
      throw std::invalid_argument(std::string(who) + ": sigma_q and p must be finite and > 0");
  if (runs < 1) throw std::invalid_argument(std::string(who) + ": runs must be >= 1");

  const SmoothingSpline<double> spline(k.t);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd noise(n);
  MatrixX2<double> dq(n, 2), dqd(n, 2), dqdd(n, 2);
  Vector2<double> sum = Vector2<double>::Zero(), rows = Vector2<double>::Zero();
  for (int r = 0; r < runs; ++r) {
    for (int j = 0; j < 2; ++j) {
      for (Eigen::Index i = 0; i < n; ++i) noise[i] = sigma_q[j] * normal(rng);
      const SmoothingFit<double> fit = spline.fit_penalized(noise, 1.0, p[j]);
      fit.spline.derivatives_at_knots(0, dq.col(j));
      fit.spline.derivatives_at_knots(1, dqd.col(j));
      fit.spline.derivatives_at_knots(2, dqdd.col(j));
    }
    for (Eigen::Index i = first; i < first + count; ++i) {
      const Vector2<double> q = k.q.row(i).transpose(), qd = k.qd.row(i).transpose(),
                            qdd = k.qdd.row(i).transpose();
      const Vector2<double> error =
          model.inverse_dynamics(theta, q + dq.row(i).transpose(), qd + dqd.row(i).transpose(),
                                 qdd + dqdd.row(i).transpose()) -
          model.inverse_dynamics(theta, q, qd, qdd);
      for (int j = 0; j < 2; ++j) {
        const double w = weight[j * count + (i - first)];
        sum[j] += w * error[j] * error[j];
        rows[j] += w;
      }
    }
  }
  Vector2<double> rms;
  for (int j = 0; j < 2; ++j) rms[j] = rows[j] > 0.0 ? std::sqrt(sum[j] / rows[j]) : 0.0;
  return rms;
}

}  // namespace sid
