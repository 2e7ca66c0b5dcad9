#pragma once
/// @file
/// @brief Smoothing scattered data whose abscissae come very close: samples closer than a
/// tolerance merged into one (their weights summed, abscissa and value their weighted means),
/// as R's smooth.spline merges x within its `tol`.
///
/// Why: the Reinsch system QᵀD²Q + pR holds 1/hₖ². Among 10⁵–10⁶ sorted uniform-random points
/// the smallest gap is 10⁻¹¹–10⁻¹² of the range, and at a small p the LDLᵀ pivots then lose
/// every digit and the factorization refuses the system. Merging changes the penalized
/// criterion by terms of order f''·gap², far below any noise, and leaves the system
/// well conditioned: on 10⁶ such points a tolerance of 10⁻⁹ of the range merges 0.1 % of them
/// and the fit succeeds.

#include <sid/smoothing_spline.hpp>

#include <Eigen/Core>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace sid {

/// @brief Samples with close abscissae merged (see merge_close_abscissae()).
template <typename Scalar>
struct MergedSamples {
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  Vector t;                      ///< strictly increasing: each group's weighted mean abscissa
  Vector y;                      ///< each group's weighted mean value
  Vector dy;                     ///< each group's standard deviation, 1/√(Σ 1/δyᵢ²)
  Scalar tolerance = Scalar(0);  ///< the largest gap merged
};

/// @brief Merges runs of samples whose consecutive abscissae differ by at most tolerance
/// (tolerance 0: exact ties only), with weights wᵢ = 1/δyᵢ².
/// @throws std::invalid_argument on sizes that differ, non-finite values, δy <= 0, a negative
/// tolerance or decreasing t.
template <typename Scalar>
MergedSamples<Scalar> merge_close_abscissae(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& t,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& y,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& dy, Scalar tolerance) {
  const char* who = "sid::merge_close_abscissae: ";
  const Eigen::Index n = t.size();
  if (y.size() != n || dy.size() != n)
    throw std::invalid_argument(std::string(who) + "t, y and dy must have the same length (" +
                                std::to_string(n) + ", " + std::to_string(y.size()) + ", " +
                                std::to_string(dy.size()) + ")");
  using std::isfinite;
  if (!(tolerance >= Scalar(0)) || !isfinite(tolerance))
    throw std::invalid_argument(std::string(who) + "the tolerance must be finite and >= 0");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!isfinite(t[i]) || !isfinite(y[i]))
      throw std::invalid_argument(std::string(who) + "t[" + std::to_string(i) + "] or y[" +
                                  std::to_string(i) + "] is not finite");
    if (!(dy[i] > Scalar(0)) || !isfinite(dy[i]))
      throw std::invalid_argument(std::string(who) + "dy[" + std::to_string(i) +
                                  "] must be finite and > 0");
    if (i > 0 && t[i] < t[i - 1])
      throw std::invalid_argument(std::string(who) + "t must not decrease (t[" + std::to_string(i) +
                                  "] < t[" + std::to_string(i - 1) + "])");
  }
  MergedSamples<Scalar> m;
  m.tolerance = tolerance;
  m.t.resize(n);
  m.y.resize(n);
  m.dy.resize(n);
  Eigen::Index groups = 0;
  Scalar weight(0), wt(0), wy(0);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Scalar w = Scalar(1) / (dy[i] * dy[i]);
    if (i > 0 && t[i] - t[i - 1] > tolerance) {
      m.t[groups] = wt / weight;
      m.y[groups] = wy / weight;
      m.dy[groups] = Scalar(1) / std::sqrt(weight);
      ++groups;
      weight = wt = wy = Scalar(0);
    }
    weight += w;
    wt += w * t[i];
    wy += w * y[i];
  }
  if (n > 0) {
    m.t[groups] = wt / weight;
    m.y[groups] = wy / weight;
    m.dy[groups] = Scalar(1) / std::sqrt(weight);
    ++groups;
  }
  m.t.conservativeResize(groups);
  m.y.conservativeResize(groups);
  m.dy.conservativeResize(groups);
  return m;
}

/// @brief A fit of scattered data: the spline (knots at the merged abscissae) and the
/// tolerance it took.
template <typename Scalar>
struct ScatteredFit {
  SmoothingFit<Scalar> fit;
  Scalar merge_tolerance = Scalar(0);  ///< absolute; 0 when only exact ties were merged
  Eigen::Index knots = 0;              ///< samples left after merging
};

/// @brief fit(smoother, y, dy) on the samples with exact ties merged; where the banded system
/// is not numerically positive definite (SmoothingError), again on the samples merged within
/// 10⁻¹², 10⁻¹¹, … 10⁻⁶ of the abscissae's range, until one succeeds.
/// @tparam Fit callable (const SmoothingSpline<Scalar>&, const Vector& y, const Vector& dy) ->
/// SmoothingFit<Scalar>, e.g. a penalized or cross-validated fit.
/// @throws std::invalid_argument as merge_close_abscissae() or when fewer than 2 distinct
/// abscissae remain; SmoothingError when no tolerance up to 10⁻⁶ of the range helps.
template <typename Scalar, typename Fit>
ScatteredFit<Scalar> fit_merging_close_abscissae(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& t,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& y,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& dy, Fit&& fit) {
  const Scalar range = t.size() > 0 ? t[t.size() - 1] - t[0] : Scalar(0);
  Scalar relative(0);
  for (;;) {
    const MergedSamples<Scalar> m = merge_close_abscissae<Scalar>(t, y, dy, relative * range);
    if (m.t.size() < 2)
      throw std::invalid_argument(
          "sid::fit_merging_close_abscissae: fewer than 2 distinct abscissae");
    try {
      const SmoothingSpline<Scalar> smoother(m.t);
      return {fit(smoother, m.y, m.dy), m.tolerance, m.t.size()};
    } catch (const SmoothingError&) {
      relative = relative == Scalar(0) ? Scalar(1e-12) : relative * Scalar(10);
      if (relative > Scalar(1.5e-6)) throw;
    }
  }
}

}  // namespace sid
