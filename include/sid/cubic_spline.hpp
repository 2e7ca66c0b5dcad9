#pragma once
/// @file
/// @brief A piecewise cubic with C² joins, as produced by the smoothing spline.

#include <Eigen/Core>

#include <algorithm>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

namespace sid {

/// @brief Piecewise cubic g(t) = aᵢ + bᵢ Δ + cᵢ Δ² + dᵢ Δ³, Δ = t − tᵢ, on [tᵢ, tᵢ₊₁].
///
/// So aᵢ = g(tᵢ), bᵢ = g'(tᵢ), cᵢ = g''(tᵢ)/2 (the paper's c, eq. 17) and dᵢ = g'''/6 on piece i.
/// Outside [t₀, tₙ₋₁] the spline is continued linearly with the value and slope of the end
/// knot: that is what a natural spline (g'' = 0 at both ends) minimising ∫g''² is on the whole
/// line, and it never explodes like a cubic continuation would.
///
/// Class invariant: knots strictly increasing, n >= 2, and n − 1 entries in each of a, b, c, d.
template <typename Scalar>
class CubicSpline {
 public:
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

  CubicSpline() = default;

  /// @param knots strictly increasing, n >= 2 (checked).
  /// @param a,b,c,d the n − 1 piece coefficients.
  CubicSpline(Vector knots, Vector a, Vector b, Vector c, Vector d)
      : CubicSpline(std::make_shared<const Vector>(std::move(knots)), std::move(a), std::move(b),
                    std::move(c), std::move(d)) {
    for (Eigen::Index i = 1; i < t_->size(); ++i)
      if (!((*t_)[i] > (*t_)[i - 1]))
        throw std::invalid_argument("sid::CubicSpline: knots must be strictly increasing (t[" +
                                    std::to_string(i) + "] <= t[" + std::to_string(i - 1) + "])");
  }

  /// @brief Shares knots that the caller has already checked (many splines on one grid keep one
  /// copy of t). @pre *knots strictly increasing.
  CubicSpline(std::shared_ptr<const Vector> knots, Vector a, Vector b, Vector c, Vector d)
      : t_(std::move(knots)),
        a_(std::move(a)),
        b_(std::move(b)),
        c_(std::move(c)),
        d_(std::move(d)) {
    if (!t_ || t_->size() < 2)
      throw std::invalid_argument("sid::CubicSpline: needs at least 2 knots, got " +
                                  std::to_string(t_ ? t_->size() : 0));
    const Eigen::Index pieces = t_->size() - 1;
    if (a_.size() != pieces || b_.size() != pieces || c_.size() != pieces || d_.size() != pieces)
      throw std::invalid_argument("sid::CubicSpline: need " + std::to_string(pieces) +
                                  " coefficients per kind for " + std::to_string(t_->size()) +
                                  " knots");
  }

  Eigen::Index size() const { return t_ ? t_->size() : 0; }
  const Vector& knots() const { return *t_; }
  const Vector& a() const { return a_; }
  const Vector& b() const { return b_; }
  const Vector& c() const { return c_; }
  const Vector& d() const { return d_; }

  /// @brief g(t); linear continuation outside the knots.
  Scalar value(Scalar t) const { return derivative(t, 0); }

  /// @brief The order-th derivative at t (order 0..3). At an interior knot the piece to the
  /// right is used (only the third derivative jumps there); at tₙ₋₁ the last piece.
  Scalar derivative(Scalar t, int order) const {
    check_order(order, "derivative");
    const Vector& knot = *t_;
    const Eigen::Index last = knot.size() - 1;
    if (t < knot[0] || t > knot[last]) {  // linear continuation
      const bool left = t < knot[0];
      const Scalar t_end = left ? knot[0] : knot[last];
      const Scalar g_end =
          left ? a_[0] : piece_derivative(last - 1, knot[last] - knot[last - 1], 0);
      const Scalar s_end =
          left ? b_[0] : piece_derivative(last - 1, knot[last] - knot[last - 1], 1);
      if (order == 0) return g_end + s_end * (t - t_end);
      return order == 1 ? s_end : Scalar(0);
    }
    const auto it = std::upper_bound(knot.data(), knot.data() + knot.size(), t);
    const Eigen::Index i =
        std::min<Eigen::Index>(static_cast<Eigen::Index>(it - knot.data()) - 1, last - 1);
    return piece_derivative(i, t - knot[i], order);
  }

  /// @brief The order-th derivative at every knot (order 0..3): the fast path, no search.
  /// The last knot's values come from the last piece (for order 3: the last piece's constant).
  Vector derivatives_at_knots(int order) const {
    Vector out(size());
    derivatives_at_knots(order, out);
    return out;
  }

  /// @brief The same into caller storage (no allocation). @pre out.size() == size().
  void derivatives_at_knots(int order, Eigen::Ref<Vector> out) const {
    check_order(order, "derivatives_at_knots");
    if (out.size() != size())
      throw std::invalid_argument("sid::CubicSpline::derivatives_at_knots: out has " +
                                  std::to_string(out.size()) + " entries, spline has " +
                                  std::to_string(size()) + " knots");
    const Vector& knot = *t_;
    const Eigen::Index pieces = knot.size() - 1;
    switch (order) {
      case 0:
        out.head(pieces) = a_;
        break;
      case 1:
        out.head(pieces) = b_;
        break;
      case 2:
        out.head(pieces) = Scalar(2) * c_;
        break;
      default:
        out.head(pieces) = Scalar(6) * d_;
        break;
    }
    out[pieces] = piece_derivative(pieces - 1, knot[pieces] - knot[pieces - 1], order);
  }

  /// @brief Evaluates the order-th derivative at many points.
  Vector evaluate(const Eigen::Ref<const Vector>& t, int order = 0) const {
    Vector out(t.size());
    for (Eigen::Index k = 0; k < t.size(); ++k) out[k] = derivative(t[k], order);
    return out;
  }

 private:
  static void check_order(int order, const char* who) {
    if (order < 0 || order > 3)
      throw std::invalid_argument(std::string("sid::CubicSpline::") + who +
                                  ": order must be 0..3, got " + std::to_string(order));
  }

  Scalar piece_derivative(Eigen::Index i, Scalar dt, int order) const {
    switch (order) {
      case 0:
        return a_[i] + dt * (b_[i] + dt * (c_[i] + dt * d_[i]));
      case 1:
        return b_[i] + dt * (Scalar(2) * c_[i] + dt * Scalar(3) * d_[i]);
      case 2:
        return Scalar(2) * c_[i] + Scalar(6) * d_[i] * dt;
      default:
        return Scalar(6) * d_[i];
    }
  }

  std::shared_ptr<const Vector> t_;
  Vector a_, b_, c_, d_;
};

}  // namespace sid
