#pragma once
// Definitions of sid/diagnosis/hac.hpp (see sid/config.hpp).

#include <sid/diagnosis/hac.hpp>

#include <algorithm>

namespace sid {

namespace detail {

SID_INLINE double gamma_p_series(double a, double x) {
  double term = 1.0 / a, sum = term;
  for (int k = 1; k < 1000; ++k) {
    term *= x / (a + k);
    sum += term;
    if (std::fabs(term) < std::fabs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

SID_INLINE double gamma_q_continued_fraction(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::fabs(delta - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

}  // namespace detail

SID_INLINE double regularized_gamma_q(double a, double x) {
  if (!(a > 0.0) || !std::isfinite(a))
    throw std::invalid_argument("sid::regularized_gamma_q: a must be finite and > 0");
  if (!(x >= 0.0)) throw std::invalid_argument("sid::regularized_gamma_q: x must be >= 0");
  if (x == 0.0) return 1.0;
  if (std::isinf(x)) return 0.0;
  if (x < a + 1.0) return 1.0 - detail::gamma_p_series(a, x);
  return detail::gamma_q_continued_fraction(a, x);
}

SID_INLINE double chi_square_tail(double x, double df) {
  if (!(df > 0.0)) throw std::invalid_argument("sid::chi_square_tail: df must be > 0");
  if (!(x >= 0.0)) throw std::invalid_argument("sid::chi_square_tail: x must be >= 0");
  return regularized_gamma_q(0.5 * df, 0.5 * x);
}

SID_INLINE double chi_square_critical(double alpha, double df) {
  if (!(alpha > 0.0 && alpha < 1.0))
    throw std::invalid_argument("sid::chi_square_critical: alpha must be in (0, 1)");
  if (!(df > 0.0)) throw std::invalid_argument("sid::chi_square_critical: df must be > 0");
  double lo = 0.0, hi = std::max(1.0, df);
  while (chi_square_tail(hi, df) > alpha) hi *= 2.0;
  for (int i = 0; i < 200 && hi - lo > 1e-12 * hi; ++i) {
    const double mid = 0.5 * (lo + hi);
    (chi_square_tail(mid, df) > alpha ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

SID_INLINE int newey_west_bandwidth(const Eigen::Ref<const Eigen::MatrixXd>& scores) {
  const Eigen::Index n = scores.rows();
  if (n < 8) return 1;
  double num = 0.0, den = 0.0;
  for (Eigen::Index a = 0; a < scores.cols(); ++a) {
    const auto x = scores.col(a);
    const double xx = x.head(n - 1).squaredNorm();
    if (!(xx > 0.0)) continue;
    double rho = x.tail(n - 1).dot(x.head(n - 1)) / xx;
    rho = std::clamp(rho, -0.97, 0.97);
    const double s2 =
        (x.tail(n - 1) - rho * x.head(n - 1)).squaredNorm() / static_cast<double>(n - 1);
    const double s4 = s2 * s2;
    num += 4.0 * rho * rho * s4 / (std::pow(1.0 - rho, 6) * (1.0 + rho) * (1.0 + rho));
    den += s4 / std::pow(1.0 - rho, 4);
  }
  if (!(den > 0.0)) return 1;
  const double lag = 1.1447 * std::cbrt(num / den * static_cast<double>(n));
  return static_cast<int>(
      std::clamp(std::ceil(lag), 1.0, std::max(1.0, static_cast<double>(n / 4))));
}

SID_INLINE Eigen::MatrixXd newey_west_sum(const Eigen::Ref<const Eigen::MatrixXd>& scores,
                                          int lag) {
  if (lag < 0) throw std::invalid_argument("sid::newey_west_sum: lag must be >= 0");
  const Eigen::Index n = scores.rows();
  Eigen::MatrixXd s = scores.transpose() * scores;
  for (Eigen::Index l = 1; l <= lag && l < n; ++l) {
    const double w = 1.0 - static_cast<double>(l) / static_cast<double>(lag + 1);
    const Eigen::MatrixXd gamma = scores.bottomRows(n - l).transpose() * scores.topRows(n - l);
    s += w * (gamma + gamma.transpose());
  }
  return s;
}

namespace detail {

/// The prewhitening VAR(1) coefficient B of scores (s_t ≈ s_{t−1} B), its singular values capped
/// at 0.97 so that the recolouring stays finite; not finite where the fit fails.
inline Eigen::MatrixXd prewhitening(const Eigen::Ref<const Eigen::MatrixXd>& before,
                                    const Eigen::Ref<const Eigen::MatrixXd>& after) {
  Eigen::MatrixXd b = (before.transpose() * before).ldlt().solve(before.transpose() * after);
  if (!b.allFinite()) return b;
  // B is square: Eigen's QR preconditioner would never run, and instantiating it costs
  // seconds of compile time in every file that includes this header.
  Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::NoQRPreconditioner> svd(
      b, Eigen::ComputeFullU | Eigen::ComputeFullV);
  constexpr double kMaxRoot = 0.97;
  if (svd.singularValues().maxCoeff() > kMaxRoot)
    b = svd.matrixU() * svd.singularValues().cwiseMin(kMaxRoot).asDiagonal() *
        svd.matrixV().transpose();
  return b;
}

}  // namespace detail

SID_INLINE Eigen::MatrixXd hac_long_run_sum(const Eigen::Ref<const Eigen::MatrixXd>& scores) {
  const Eigen::Index n = scores.rows(), k = scores.cols();
  if (n < 3 * k + 8) return newey_west_sum(scores, newey_west_bandwidth(scores));
  const auto before = scores.topRows(n - 1);
  const auto after = scores.bottomRows(n - 1);
  const Eigen::MatrixXd b = detail::prewhitening(before, after);
  if (!b.allFinite()) return newey_west_sum(scores, newey_west_bandwidth(scores));
  const Eigen::MatrixXd u = after - before * b;
  const Eigen::MatrixXd s_u = newey_west_sum(u, newey_west_bandwidth(u));
  const Eigen::MatrixXd recolour = (Eigen::MatrixXd::Identity(k, k) - b.transpose())
                                       .partialPivLu()
                                       .solve(Eigen::MatrixXd::Identity(k, k));
  return recolour * s_u * recolour.transpose() *
         (static_cast<double>(n) / static_cast<double>(n - 1));
}

namespace detail {

/// The Newey–West sum of one series: sᵀs + 2 Σ_l (1 − l/(lag + 1)) Σ_t s_t s_{t−l}.
inline double newey_west_scalar(const Eigen::Ref<const Eigen::VectorXd>& s, int lag) {
  const Eigen::Index n = s.size();
  double sum = s.squaredNorm();
  for (Eigen::Index l = 1; l <= lag && l < n; ++l) {
    const double w = 1.0 - static_cast<double>(l) / static_cast<double>(lag + 1);
    sum += 2.0 * w * s.tail(n - l).dot(s.head(n - l));
  }
  return sum;
}

}  // namespace detail

SID_INLINE Eigen::VectorXd hac_long_run_quadratic(
    const Eigen::Ref<const Eigen::MatrixXd>& scores,
    const Eigen::Ref<const Eigen::MatrixXd>& directions) {
  const Eigen::Index n = scores.rows(), k = scores.cols();
  if (directions.rows() != k)
    throw std::invalid_argument("sid::hac_long_run_quadratic: directions need one row per column");
  Eigen::VectorXd out(directions.cols());
  const auto plain = [&] {
    const int lag = newey_west_bandwidth(scores);
    for (Eigen::Index i = 0; i < directions.cols(); ++i)
      out[i] = detail::newey_west_scalar(scores * directions.col(i), lag);
    return out;
  };
  // As hac_long_run_sum, step by step.
  if (n < 3 * k + 8) return plain();
  const auto before = scores.topRows(n - 1);
  const auto after = scores.bottomRows(n - 1);
  const Eigen::MatrixXd b = detail::prewhitening(before, after);
  if (!b.allFinite()) return plain();
  const Eigen::MatrixXd u = after - before * b;
  const int lag = newey_west_bandwidth(u);
  const Eigen::MatrixXd recolour = (Eigen::MatrixXd::Identity(k, k) - b.transpose())
                                       .partialPivLu()
                                       .solve(Eigen::MatrixXd::Identity(k, k));
  const double factor = static_cast<double>(n) / static_cast<double>(n - 1);
  for (Eigen::Index i = 0; i < directions.cols(); ++i)
    out[i] =
        detail::newey_west_scalar(u * (recolour.transpose() * directions.col(i)), lag) * factor;
  return out;
}

SID_INLINE double wald_statistic(const Eigen::Ref<const Eigen::VectorXd>& gamma,
                                 const Eigen::Ref<const Eigen::MatrixXd>& covariance) {
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(covariance);
  if (ldlt.info() == Eigen::Success && ldlt.isPositive() && (ldlt.vectorD().array() > 0.0).all())
    return gamma.dot(ldlt.solve(gamma));
  // Moore–Penrose by the SVD (square: no QR preconditioner), singular values below
  // k eps σ_max taken as zero.
  const Eigen::JacobiSVD<Eigen::MatrixXd, Eigen::NoQRPreconditioner> svd(
      covariance, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd& sv = svd.singularValues();
  const double cut = sv.size() > 0 ? static_cast<double>(sv.size()) *
                                         std::numeric_limits<double>::epsilon() * sv[0]
                                   : 0.0;
  const Eigen::VectorXd projected = svd.matrixU().transpose() * gamma;
  const Eigen::VectorXd back = svd.matrixV().transpose() * gamma;
  double statistic = 0.0;
  for (Eigen::Index i = 0; i < sv.size(); ++i)
    if (sv[i] > cut) statistic += projected[i] * back[i] / sv[i];
  return statistic;
}

SID_INLINE std::vector<double> holm_adjusted(const std::vector<double>& p) {
  std::vector<std::size_t> order(p.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p[a] < p[b]; });
  std::vector<double> adjusted(p.size());
  double running = 0.0;
  const double count = static_cast<double>(p.size());
  for (std::size_t r = 0; r < order.size(); ++r) {
    running = std::max(running, std::min(1.0, (count - static_cast<double>(r)) * p[order[r]]));
    adjusted[order[r]] = running;
  }
  return adjusted;
}

SID_INLINE Eigen::MatrixXd hac_sandwich(const std::vector<HacRun>& runs,
                                        const Eigen::Ref<const Eigen::MatrixXd>& bread) {
  const Eigen::Index p = bread.rows();
  if (bread.cols() != p) throw std::invalid_argument("sid::hac_sandwich: the bread must be square");
  Eigen::MatrixXd long_run = Eigen::MatrixXd::Zero(p, p);
  for (const HacRun& run : runs) {
    if (run.x.cols() != p || run.weighted_residual.size() != run.x.rows() ||
        static_cast<Eigen::Index>(run.at.size()) != run.x.rows())
      throw std::invalid_argument(
          "sid::hac_sandwich: a run's rows, residuals and samples disagree");
    Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(run.positions, p);
    for (Eigen::Index r = 0; r < run.x.rows(); ++r) {
      const Eigen::Index sample = run.at[static_cast<std::size_t>(r)];
      if (sample < 0 || sample >= run.positions)
        throw std::invalid_argument("sid::hac_sandwich: a row's sample is out of range");
      scores.row(sample) += run.weighted_residual[r] * run.x.row(r);
    }
    long_run += hac_long_run_sum(scores);
  }
  return bread * long_run * bread;
}

}  // namespace sid
