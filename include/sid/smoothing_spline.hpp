#pragma once
/// @file
/// @brief The Reinsch cubic smoothing spline (Reinsch 1967; Green & Silverman 1994, ch. 2), in
/// O(n) per fit through a pentadiagonal LDLᵀ.
///
/// Two equivalent forms, with δyᵢ > 0 the standard deviation of yᵢ and wᵢ = 1/δyᵢ²:
/// - constraint form (Reinsch): minimise ∫g''² subject to F(g) = Σ((g(tᵢ) − yᵢ)/δyᵢ)² ≤ S.
///   The residuals are squared (the paper's eq. 14 drops the square). Default S = n.
/// - penalty form: minimise ∫g''² + p Σ((g(tᵢ) − yᵢ)/δyᵢ)², i.e. Σ wᵢ(yᵢ − g(tᵢ))² + λ∫g''²
///   with λ = 1/p. So λ is SciPy's `make_smoothing_spline(t, y, w=1/δy², lam=λ)`, and csaps'
///   `smooth = 1/(1 + λ)` with the same weights.
/// The paper writes the spline with c = g''/2, which makes its p twice the p used here.
///
/// Linear algebra (h = knot spacing, D = diag(δy), γ = g'' at the interior knots):
///   (QᵀD²Q + pR) u = Qᵀy,  g = y − D²Q u,  γ = p u,  F(p) = ‖DQu‖²,
/// with R tridiagonal ((hₖ + hₖ₊₁)/3, hₖ₊₁/6) and Qᵀ rows (1/hₖ, −1/hₖ − 1/hₖ₊₁, 1/hₖ₊₁).

#include <sid/banded.hpp>
#include <sid/cubic_spline.hpp>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>

namespace sid {

/// @brief Raised when the smoothing parameter search fails on valid input (it never returns a
/// fit that does not satisfy F = S).
class SmoothingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// @brief A smoothing fit: the spline, its parameters and how it was found.
template <typename Scalar>
struct SmoothingFit {
  CubicSpline<Scalar> spline;
  /// Reinsch's multiplier of the data term (0 = straight line, +∞ = interpolation).
  Scalar p = Scalar(0);
  /// λ = 1/p, the penalty weight (SciPy's `lam` with w = 1/δy²).
  Scalar lambda = std::numeric_limits<Scalar>::infinity();
  /// F = Σ((g(tᵢ) − yᵢ)/δyᵢ)² of the fit.
  Scalar F = Scalar(0);
  /// Newton (or bracketing) steps taken for the constraint form; 0 for the penalty form.
  int iterations = 0;
  /// Banded factorizations done, the unit of cost.
  int factorizations = 0;
  /// tr A, the equivalent degrees of freedom of the fit (A: the hat matrix, g = A y). Computed
  /// by the GCV/CV fits and by hat_diagonal(); NaN otherwise.
  Scalar trace = std::numeric_limits<Scalar>::quiet_NaN();
  /// The minimised criterion (GCV or ordinary leave-one-out CV score); NaN for other fits.
  Scalar criterion = std::numeric_limits<Scalar>::quiet_NaN();
  /// σ̂ = √(F / (n − tr A)), the noise level the fit implies, in units of δy (so in the data's
  /// units when δy = 1). NaN when tr A is not computed.
  Scalar sigma = std::numeric_limits<Scalar>::quiet_NaN();
};

/// @brief The criterion a data-driven smoothing choice minimises over log λ.
enum class SmoothingCriterion {
  Gcv,  ///< generalized cross-validation, n F / (n − tr A)² (Craven & Wahba 1979)
  Cv,   ///< ordinary leave-one-out cross-validation, (1/n) Σ wᵢ (rᵢ / (1 − Aᵢᵢ))²
};

namespace detail {

/// Brent's minimisation of f on [a, b] from the inner point x (value fx): golden sections with
/// parabolic steps (Brent 1973, ch. 5). Returns the best point found.
template <typename Scalar, typename F>
Scalar brent_minimize(F&& f, Scalar a, Scalar b, Scalar x, Scalar fx, Scalar tolerance) {
  using std::abs;
  using std::sqrt;
  const Scalar golden = Scalar(0.5) * (Scalar(3) - sqrt(Scalar(5)));
  Scalar w = x, v = x, fw = fx, fv = fx, d = Scalar(0), e = Scalar(0);
  for (int it = 0; it < 100; ++it) {
    const Scalar mid = Scalar(0.5) * (a + b), tol1 = tolerance, tol2 = Scalar(2) * tol1;
    if (abs(x - mid) <= tol2 - Scalar(0.5) * (b - a)) break;
    bool golden_step = true;
    if (abs(e) > tol1) {  // try a parabola through x, w, v
      Scalar r = (x - w) * (fx - fv), q = (x - v) * (fx - fw), p = (x - v) * q - (x - w) * r;
      q = Scalar(2) * (q - r);
      if (q > Scalar(0)) p = -p;
      q = abs(q);
      if (abs(p) < abs(Scalar(0.5) * q * e) && p > q * (a - x) && p < q * (b - x)) {
        e = d;
        d = p / q;
        const Scalar u = x + d;
        if (u - a < tol2 || b - u < tol2) d = x < mid ? tol1 : -tol1;
        golden_step = false;
      }
    }
    if (golden_step) {
      e = (x < mid ? b : a) - x;
      d = golden * e;
    }
    const Scalar u = abs(d) >= tol1 ? x + d : x + (d > Scalar(0) ? tol1 : -tol1);
    const Scalar fu = f(u);
    if (fu <= fx) {
      (u < x ? b : a) = x;
      v = w, fv = fw, w = x, fw = fx, x = u, fx = fu;
    } else {
      (u < x ? a : b) = u;
      if (fu <= fw || w == x) {
        v = w, fv = fw, w = u, fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u, fv = fu;
      }
    }
  }
  return x;
}

}  // namespace detail

/// @brief Reinsch smoothing on one time grid; the grid set-up is shared by every signal fitted.
///
/// Class invariant: t has n >= 2 finite, strictly increasing entries.
/// @tparam Scalar float or double.
template <typename Scalar>
class SmoothingSpline {
 public:
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  using Fit = SmoothingFit<Scalar>;

  /// @param t sample times [any unit], strictly increasing, finite, at least 2.
  explicit SmoothingSpline(const Eigen::Ref<const Vector>& t)
      : t_(std::make_shared<const Vector>(t)) {
    if (t.size() < 2)
      throw std::invalid_argument("sid::SmoothingSpline: t needs at least 2 samples, got " +
                                  std::to_string(t.size()));
    for (Eigen::Index i = 0; i < t.size(); ++i) {
      using std::isfinite;
      if (!isfinite(t[i]))
        throw std::invalid_argument("sid::SmoothingSpline: t[" + std::to_string(i) +
                                    "] is not finite");
      if (i > 0 && !(t[i] > t[i - 1]))
        throw std::invalid_argument("sid::SmoothingSpline: t must be strictly increasing (t[" +
                                    std::to_string(i) + "] <= t[" + std::to_string(i - 1) + "])");
    }
    h_ = t.tail(size() - 1) - t.head(size() - 1);
    inv_h_ = h_.cwiseInverse();
  }

  Eigen::Index size() const { return t_->size(); }
  const Vector& t() const { return *t_; }

  /// @brief Constraint form with per-point δy: the smoothest g with F(g) <= S.
  /// S = 0 interpolates; S at or above the weighted straight-line fit's F gives that line.
  /// @throws std::invalid_argument on bad sizes, non-finite y, δy <= 0 or S < 0;
  /// SmoothingError if the search for p does not converge.
  Fit fit_constrained(const Eigen::Ref<const Vector>& y, const Eigen::Ref<const Vector>& dy,
                      Scalar S) const {
    check_signal(y, "fit_constrained");
    check_weights(dy, "fit_constrained");
    return constrained(y, Weights{dy.data(), Scalar(0)}, S);
  }
  /// @brief Constraint form with one δy for all points.
  Fit fit_constrained(const Eigen::Ref<const Vector>& y, Scalar dy, Scalar S) const {
    check_signal(y, "fit_constrained");
    check_scalar_weight(dy, "fit_constrained");
    return constrained(y, Weights{nullptr, dy * dy}, S);
  }
  /// @brief Constraint form with the default S = n.
  Fit fit_constrained(const Eigen::Ref<const Vector>& y, Scalar dy) const {
    return fit_constrained(y, dy, static_cast<Scalar>(size()));
  }

  /// @brief Penalty form for a given p >= 0 (p = 0: the weighted straight line; p = +∞:
  /// interpolation). @throws std::invalid_argument on bad input.
  Fit fit_penalized(const Eigen::Ref<const Vector>& y, const Eigen::Ref<const Vector>& dy,
                    Scalar p) const {
    check_signal(y, "fit_penalized");
    check_weights(dy, "fit_penalized");
    return penalized(y, Weights{dy.data(), Scalar(0)}, p);
  }
  Fit fit_penalized(const Eigen::Ref<const Vector>& y, Scalar dy, Scalar p) const {
    check_signal(y, "fit_penalized");
    check_scalar_weight(dy, "fit_penalized");
    return penalized(y, Weights{nullptr, dy * dy}, p);
  }

  /// @brief Penalty form with λ chosen from the data by minimising GCV (default) or leave-one-out
  /// CV over log λ (a bracket by decades, then Brent's minimisation), so no noise level is
  /// needed: δy only sets relative weights (1 when all points are alike). Reports λ, tr A and
  /// σ̂ = √(RSS_w / (n − tr A)). Needs n >= 4. Each criterion evaluation is one O(n)
  /// factorization plus the central band of the inverse (Hutchinson & de Hoog 1985).
  /// @throws std::invalid_argument on bad input.
  Fit fit_cross_validated(const Eigen::Ref<const Vector>& y, Scalar dy = Scalar(1),
                          SmoothingCriterion criterion = SmoothingCriterion::Gcv) const {
    check_signal(y, "fit_cross_validated");
    check_scalar_weight(dy, "fit_cross_validated");
    return cross_validated(y, Weights{nullptr, dy * dy}, criterion);
  }
  Fit fit_cross_validated(const Eigen::Ref<const Vector>& y, const Eigen::Ref<const Vector>& dy,
                          SmoothingCriterion criterion = SmoothingCriterion::Gcv) const {
    check_signal(y, "fit_cross_validated");
    check_weights(dy, "fit_cross_validated");
    return cross_validated(y, Weights{dy.data(), Scalar(0)}, criterion);
  }

  /// @brief The leverages Aᵢᵢ (diagonal of the hat matrix) of the penalty form at p, in O(n).
  /// @pre 0 < p < ∞.
  Vector hat_diagonal(const Eigen::Ref<const Vector>& dy, Scalar p) const {
    check_weights(dy, "hat_diagonal");
    using std::isfinite;
    if (!(p > Scalar(0)) || !isfinite(p))
      throw std::invalid_argument("sid::SmoothingSpline::hat_diagonal: p must be finite and > 0");
    if (size() < 3) throw std::invalid_argument("sid::SmoothingSpline::hat_diagonal: needs n >= 3");
    const Weights w{dy.data(), Scalar(0)};
    Workspace& ws = thread_workspace();
    prepare(ws, Vector::Zero(size()), w, false);
    if (!solve_at(ws, w, p))
      throw SmoothingError(
          "sid::SmoothingSpline::hat_diagonal: system not numerically positive definite");
    Vector leverages(size());
    hat(ws, w, &leverages);
    return leverages;
  }

 private:
  /// δyᵢ² per point, or one value for all.
  struct Weights {
    const Scalar* dy;
    Scalar dy2_all;
    Scalar dy2(Eigen::Index i) const { return dy ? dy[i] * dy[i] : dy2_all; }
  };

  using Band = typename BandedLDLT<Scalar, 2>::Band;

  /// Buffers of one fit, reused by every step of the p search (no allocation per step).
  struct Workspace {
    BandedLDLT<Scalar, 2> ldlt;
    Band m_band;  // QᵀD²Q (lower band), kept only while p is searched
    Vector qty;
    Vector u, v;    // on all n knots, zero at both ends (natural spline): u = γ/p
    Vector qu, qv;  // Q u, Q v
    Scalar F = Scalar(0), dF = Scalar(0);
    int factorizations = 0;
    bool has_m = false;
    Band sigma_band;   // central band of B⁻¹ (GCV)
    Vector leverages;  // CV
  };

  /// One workspace per thread, reused by every fit on that thread: fresh buffers per fit cost
  /// more in page faults than the fit itself (glibc trims the freed heap top after each fit).
  /// The memory (about 9 n scalars of the largest fit) stays until the thread ends.
  static Workspace& thread_workspace() {
    thread_local Workspace ws;
    return ws;
  }

  void check_signal(const Eigen::Ref<const Vector>& y, const char* who) const {
    if (y.size() != size())
      throw std::invalid_argument(std::string("sid::SmoothingSpline::") + who + ": y has " +
                                  std::to_string(y.size()) + " samples but t has " +
                                  std::to_string(size()));
    for (Eigen::Index i = 0; i < y.size(); ++i) {
      using std::isfinite;
      if (!isfinite(y[i]))
        throw std::invalid_argument(std::string("sid::SmoothingSpline::") + who + ": y[" +
                                    std::to_string(i) + "] is not finite");
    }
  }
  void check_weights(const Eigen::Ref<const Vector>& dy, const char* who) const {
    if (dy.size() != size())
      throw std::invalid_argument(std::string("sid::SmoothingSpline::") + who + ": dy has " +
                                  std::to_string(dy.size()) + " entries but t has " +
                                  std::to_string(size()));
    for (Eigen::Index i = 0; i < dy.size(); ++i) {
      using std::isfinite;
      if (!(dy[i] > Scalar(0)) || !isfinite(dy[i]))
        throw std::invalid_argument(std::string("sid::SmoothingSpline::") + who + ": dy[" +
                                    std::to_string(i) + "] must be finite and > 0, got " +
                                    std::to_string(static_cast<double>(dy[i])));
    }
  }
  static void check_scalar_weight(Scalar dy, const char* who) {
    using std::isfinite;
    if (!(dy > Scalar(0)) || !isfinite(dy))
      throw std::invalid_argument(std::string("sid::SmoothingSpline::") + who +
                                  ": dy must be finite and > 0, got " +
                                  std::to_string(static_cast<double>(dy)));
  }

  Eigen::Index interior() const { return size() - 2; }

  // ---- the straight line (p = 0) -------------------------------------------------------------

  Fit line_fit(const Eigen::Ref<const Vector>& y, const Weights& w) const {
    const Vector& t = *t_;
    const Eigen::Index n = size();
    Scalar sw(0), st(0), sy(0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Scalar wi = Scalar(1) / w.dy2(i);
      sw += wi;
      st += wi * t[i];
      sy += wi * y[i];
    }
    const Scalar t_mean = st / sw, y_mean = sy / sw;  // centred: no cancellation for large t
    Scalar stt(0), sty(0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Scalar wi = Scalar(1) / w.dy2(i), dt = t[i] - t_mean;
      stt += wi * dt * dt;
      sty += wi * dt * (y[i] - y_mean);
    }
    const Scalar slope = sty / stt;
    Vector a(n - 1), b = Vector::Constant(n - 1, slope), zero = Vector::Zero(n - 1);
    for (Eigen::Index i = 0; i < n - 1; ++i) a[i] = y_mean + slope * (t[i] - t_mean);
    Scalar F(0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const Scalar r = y_mean + slope * (t[i] - t_mean) - y[i];
      F += r * r / w.dy2(i);
    }
    Fit fit;
    fit.spline = CubicSpline<Scalar>(t_, std::move(a), std::move(b), zero, zero);
    fit.F = F;
    return fit;
  }

  // ---- the banded system ---------------------------------------------------------------------

  /// Column j of QᵀD²Q, i.e. entries (j, j), (j+1, j), (j+2, j); column j of Q (interior knot
  /// j + 1) is (1/hⱼ, −1/hⱼ − 1/hⱼ₊₁, 1/hⱼ₊₁) at rows j, j+1, j+2.
  void m_column(const Weights& w, Eigen::Index j, Scalar& m0, Scalar& m1, Scalar& m2) const {
    const Eigen::Index m = interior();
    if (j + 2 < m) {
      full_m_column(w, j, m0, m1, m2);
      return;
    }
    const Scalar q0 = inv_h_[j], q2 = inv_h_[j + 1], q1 = -(q0 + q2);
    const Scalar w1 = w.dy2(j + 1), w2 = w.dy2(j + 2);
    m0 = w.dy2(j) * q0 * q0 + w1 * q1 * q1 + w2 * q2 * q2;
    m1 =
        j + 1 < m ? w1 * q1 * inv_h_[j + 1] - w2 * q2 * (inv_h_[j + 1] + inv_h_[j + 2]) : Scalar(0);
    m2 = Scalar(0);
  }
  /// m_column for j + 2 < m, without the end-of-matrix branches (the hot loop).
  void full_m_column(const Weights& w, Eigen::Index j, Scalar& m0, Scalar& m1, Scalar& m2) const {
    const Scalar q0 = inv_h_[j], q2 = inv_h_[j + 1], q1 = -(q0 + q2);
    const Scalar w1 = w.dy2(j + 1), w2 = w.dy2(j + 2);
    m0 = w.dy2(j) * q0 * q0 + w1 * q1 * q1 + w2 * q2 * q2;
    m1 = w1 * q1 * inv_h_[j + 1] - w2 * q2 * (inv_h_[j + 1] + inv_h_[j + 2]);
    m2 = w2 * q2 * inv_h_[j + 2];
  }

  void prepare(Workspace& ws, const Eigen::Ref<const Vector>& y, const Weights& w,
               bool keep_m) const {
    const Eigen::Index m = interior();
    ws.factorizations = 0;
    ws.has_m = keep_m;
    ws.ldlt.resize(m);
    ws.qty.resize(m);
    ws.u.setZero(size());
    ws.qu.resize(size());
    for (Eigen::Index j = 0; j < m; ++j)
      ws.qty[j] = (y[j + 2] - y[j + 1]) * inv_h_[j + 1] - (y[j + 1] - y[j]) * inv_h_[j];
    if (!keep_m) return;
    ws.v.setZero(size());
    ws.qv.resize(size());
    ws.m_band.resize(3, m);
    for (Eigen::Index j = 0; j < m; ++j)
      m_column(w, j, ws.m_band(0, j), ws.m_band(1, j), ws.m_band(2, j));
  }

  /// out = Q x for x on all knots with x₀ = xₙ₋₁ = 0 (natural spline), in one branch-free pass.
  void apply_q(const Vector& x, Vector& out) const {
    const Eigen::Index n = size();
    out[0] = x[1] * inv_h_[0];
    for (Eigen::Index i = 1; i + 1 < n; ++i)
      out[i] = (x[i + 1] - x[i]) * inv_h_[i] - (x[i] - x[i - 1]) * inv_h_[i - 1];
    out[n - 1] = x[n - 2] * inv_h_[n - 2];
  }

  /// Factorizes QᵀD²Q + pR and solves for u; sets F. False if not numerically SPD.
  bool solve_at(Workspace& ws, const Weights& w, Scalar p) const {
    const Eigen::Index m = interior();
    Band& a = ws.ldlt.band();
    const bool have_m = ws.has_m;
    const Scalar p3 = p / Scalar(3), p6 = p / Scalar(6);
    for (Eigen::Index j = 0; j < m; ++j) {
      Scalar m0, m1, m2;
      if (have_m) {
        m0 = ws.m_band(0, j), m1 = ws.m_band(1, j), m2 = ws.m_band(2, j);
      } else if (j + 2 < m) {
        full_m_column(w, j, m0, m1, m2);
      } else {
        m_column(w, j, m0, m1, m2);
      }
      a(0, j) = m0 + p3 * (h_[j] + h_[j + 1]);
      a(1, j) = m1 + p6 * h_[j + 1];  // the entry past the last row is never read
      a(2, j) = m2;
    }
    ++ws.factorizations;
    if (!ws.ldlt.factorize()) return false;
    auto u = ws.u.segment(1, m);
    u = ws.qty;
    ws.ldlt.solve_in_place(u);
    apply_q(ws.u, ws.qu);
    Scalar F(0);
    for (Eigen::Index i = 0; i < size(); ++i) F += w.dy2(i) * ws.qu[i] * ws.qu[i];
    using std::isfinite;
    ws.F = F;
    return isfinite(F);
  }

  /// dF/dp = −2 (DQu)ᵀ(DQv), v = A⁻¹Ru: written this way it has no cancellation at large p.
  void derivative_at(Workspace& ws, const Weights& w) const {
    const Eigen::Index m = interior();
    for (Eigen::Index k = 1; k <= m; ++k)  // knot k = interior unknown k − 1; u is zero at the ends
      ws.v[k] = (h_[k - 1] + h_[k]) / Scalar(3) * ws.u[k] + h_[k - 1] / Scalar(6) * ws.u[k - 1] +
                h_[k] / Scalar(6) * ws.u[k + 1];
    auto v = ws.v.segment(1, m);
    ws.ldlt.solve_in_place(v);
    apply_q(ws.v, ws.qv);
    Scalar s(0);
    for (Eigen::Index i = 0; i < size(); ++i) s += w.dy2(i) * ws.qu[i] * ws.qv[i];
    ws.dF = Scalar(-2) * s;
  }

  /// The spline through g(tᵢ) = yᵢ − δyᵢ²(Q x)ᵢ (or yᵢ when qx is null) with g'' = scale·x at
  /// the knots (x on all knots, zero at both ends: natural), built in one pass.
  Fit assemble(const Eigen::Ref<const Vector>& y, const Weights* w, const Vector* qx,
               const Vector& x, Scalar scale) const {
    const Eigen::Index n = size();
    auto g = [&](Eigen::Index k) { return qx ? y[k] - w->dy2(k) * (*qx)[k] : y[k]; };
    Vector a(n - 1), b(n - 1), c(n - 1), d(n - 1);
    Scalar g_here = g(0), gamma_here = Scalar(0);
    const Scalar sixth = Scalar(1) / Scalar(6);
    for (Eigen::Index i = 0; i < n - 1; ++i) {
      const Scalar g_next = g(i + 1), gamma_next = scale * x[i + 1];
      a[i] = g_here;
      b[i] = (g_next - g_here) * inv_h_[i] - h_[i] * (Scalar(2) * gamma_here + gamma_next) * sixth;
      c[i] = Scalar(0.5) * gamma_here;
      d[i] = (gamma_next - gamma_here) * inv_h_[i] * sixth;
      g_here = g_next;
      gamma_here = gamma_next;
    }
    Fit fit;
    fit.spline = CubicSpline<Scalar>(t_, std::move(a), std::move(b), std::move(c), std::move(d));
    return fit;
  }

  Fit fit_from(const Workspace& ws, const Eigen::Ref<const Vector>& y, const Weights& w,
               Scalar p) const {
    Fit fit = assemble(y, &w, &ws.qu, ws.u, p);
    fit.p = p;
    fit.lambda = Scalar(1) / p;
    fit.F = ws.F;
    fit.factorizations = ws.factorizations;
    return fit;
  }

  Fit interpolate(const Eigen::Ref<const Vector>& y) const {
    const Eigen::Index m = interior();
    BandedLDLT<Scalar, 1> r(m);
    Vector gamma = Vector::Zero(size());  // natural: zero at both ends
    auto interior_gamma = gamma.segment(1, m);
    for (Eigen::Index j = 0; j < m; ++j) {
      r.band()(0, j) = (h_[j] + h_[j + 1]) / Scalar(3);
      r.band()(1, j) = j + 1 < m ? h_[j + 1] / Scalar(6) : Scalar(0);
      interior_gamma[j] = (y[j + 2] - y[j + 1]) * inv_h_[j + 1] - (y[j + 1] - y[j]) * inv_h_[j];
    }
    if (!r.factorize())  // R is diagonally dominant: this cannot fail for increasing t
      throw SmoothingError("sid::SmoothingSpline: interpolation system is singular");
    r.solve_in_place(interior_gamma);
    Fit fit = assemble(y, nullptr, nullptr, gamma, Scalar(1));
    fit.p = std::numeric_limits<Scalar>::infinity();
    fit.lambda = Scalar(0);
    fit.F = Scalar(0);
    fit.factorizations = 1;
    return fit;
  }

  Fit penalized(const Eigen::Ref<const Vector>& y, const Weights& w, Scalar p) const {
    using std::isnan;
    if (!(p >= Scalar(0)) || isnan(p))
      throw std::invalid_argument("sid::SmoothingSpline::fit_penalized: p must be >= 0, got " +
                                  std::to_string(static_cast<double>(p)));
    using std::isinf;
    if (size() == 2 || p == Scalar(0)) return line_fit(y, w);
    if (isinf(p)) return interpolate(y);
    Workspace& ws = thread_workspace();
    prepare(ws, y, w, false);
    if (!solve_at(ws, w, p))
      throw SmoothingError(
          "sid::SmoothingSpline::fit_penalized: the system for p = " +
          std::to_string(static_cast<double>(p)) +
          " is not numerically positive definite (p too small for this data's scale)");
    return fit_from(ws, y, w, p);
  }

  /// tr A (and the leverages when asked) at the factorization in ws, in O(n): the central band of
  /// B⁻¹ (B = QᵀD²Q + pR = L D Lᵀ) by the Hutchinson–de Hoog recurrence
  /// Σᵢⱼ = δᵢⱼ/Dᵢ − Σₗ Lₗᵢ Σₗⱼ (j >= i, from the last row up), then Aᵢᵢ = 1 − δyᵢ² (Q Σ Qᵀ)ᵢᵢ.
  Scalar hat(Workspace& ws, const Weights& w, Vector* leverages) const {
    const Eigen::Index m = interior(), n = size();
    const auto& f = ws.ldlt.band();  // f(0, j) = D(j), f(k, j) = L(j + k, j)
    ws.sigma_band.resize(3, m);
    auto& sb = ws.sigma_band;  // sb(k, i) = Σ(i, i + k)
    for (Eigen::Index i = m - 1; i >= 0; --i) {
      const Scalar l1 = i + 1 < m ? f(1, i) : Scalar(0), l2 = i + 2 < m ? f(2, i) : Scalar(0);
      const Scalar s11 = i + 1 < m ? sb(0, i + 1) : Scalar(0),
                   s22 = i + 2 < m ? sb(0, i + 2) : Scalar(0);
      const Scalar s12 = i + 2 < m ? sb(1, i + 1) : Scalar(0);
      sb(1, i) = -l1 * s11 - l2 * s12;  // Σ(i, i+1)
      sb(2, i) = -l1 * s12 - l2 * s22;  // Σ(i, i+2)
      sb(0, i) = Scalar(1) / f(0, i) - l1 * sb(1, i) - l2 * sb(2, i);
    }
    // Row i of Q: Q(i, i−2) = 1/h(i−1), Q(i, i−1) = −(1/h(i−1) + 1/h(i)), Q(i, i) = 1/h(i), for
    // the interior columns that exist.
    auto S = [&](Eigen::Index a, Eigen::Index b) {  // Σ(a, b), |a − b| <= 2, zero outside
      if (a < 0 || b < 0 || a >= m || b >= m) return Scalar(0);
      return a <= b ? sb(b - a, a) : sb(a - b, b);
    };
    Scalar trace(0);
    auto leverage = [&](Eigen::Index i, Scalar c0, Scalar c1, Scalar c2, Scalar s00, Scalar s11,
                        Scalar s22, Scalar s01, Scalar s12, Scalar s02) {
      const Scalar q = c0 * c0 * s00 + c1 * c1 * s11 + c2 * c2 * s22 +
                       Scalar(2) * (c0 * c1 * s01 + c1 * c2 * s12 + c0 * c2 * s02);
      const Scalar a_ii = Scalar(1) - w.dy2(i) * q;
      trace += a_ii;
      if (leverages) (*leverages)[i] = a_ii;
    };
    auto edge = [&](Eigen::Index i) {  // rows whose Q entries fall partly outside the interior
      const Scalar c0 = (i >= 2 && i - 2 < m) ? inv_h_[i - 1] : Scalar(0);
      const Scalar c1 = (i >= 1 && i - 1 < m) ? -(inv_h_[i - 1] + inv_h_[i]) : Scalar(0);
      const Scalar c2 = i < m ? inv_h_[i] : Scalar(0);
      leverage(i, c0, c1, c2, S(i - 2, i - 2), S(i - 1, i - 1), S(i, i), S(i - 2, i - 1),
               S(i - 1, i), S(i - 2, i));
    };
    for (Eigen::Index i = 0; i < std::min<Eigen::Index>(2, n); ++i) edge(i);
    for (Eigen::Index i = 2; i < m; ++i)  // the hot loop: all of Σ(i−2..i, i−2..i) exists
      leverage(i, inv_h_[i - 1], -(inv_h_[i - 1] + inv_h_[i]), inv_h_[i], sb(0, i - 2),
               sb(0, i - 1), sb(0, i), sb(1, i - 2), sb(1, i - 1), sb(2, i - 2));
    for (Eigen::Index i = std::max<Eigen::Index>(2, m); i < n; ++i) edge(i);
    return trace;
  }

  /// The criterion at ws's current fit (solve_at done). Leverages go to ws.leverages for CV.
  Scalar criterion_value(Workspace& ws, const Weights& w, SmoothingCriterion criterion,
                         Scalar& trace) const {
    const Scalar n = static_cast<Scalar>(size());
    if (criterion == SmoothingCriterion::Gcv) {
      trace = hat(ws, w, nullptr);
      const Scalar dof = n - trace;
      return n * ws.F / (dof * dof);
    }
    ws.leverages.resize(size());
    trace = hat(ws, w, &ws.leverages);
    Scalar cv(0);
    for (Eigen::Index i = 0; i < size(); ++i) {
      const Scalar r = w.dy2(i) * ws.qu[i] / (Scalar(1) - ws.leverages[i]);  // y − g = δy² Q u
      cv += r * r / w.dy2(i);
    }
    return cv / n;
  }

  Fit cross_validated(const Eigen::Ref<const Vector>& y, const Weights& w,
                      SmoothingCriterion criterion) const {
    using std::exp;
    using std::isfinite;
    using std::log;
    using std::sqrt;
    if (size() < 4)
      throw std::invalid_argument(
          "sid::SmoothingSpline::fit_cross_validated: needs at least 4 samples, got " +
          std::to_string(size()));
    Workspace& ws = thread_workspace();
    prepare(ws, y, w, true);
    Scalar tr_m(0), tr_r(0);
    for (Eigen::Index j = 0; j < interior(); ++j) {
      tr_m += ws.m_band(0, j);
      tr_r += (h_[j] + h_[j + 1]) / Scalar(3);
    }
    const Scalar inf = std::numeric_limits<Scalar>::infinity();
    int evaluations = 0;
    Scalar last_x = std::numeric_limits<Scalar>::quiet_NaN(), last_trace(0), last_v = inf;
    auto value_at = [&](Scalar x) {  // criterion at p = eˣ; +∞ where not numerically SPD
      ++evaluations;
      last_x = x;
      last_v = solve_at(ws, w, exp(x)) ? criterion_value(ws, w, criterion, last_trace) : inf;
      if (!isfinite(last_v)) last_v = inf;
      return last_v;
    };
    // Bracket by decades (unit-free, unlike a grid in λ): start a thousand times below the
    // trace-balanced p (noisy data put the minimum far below it), walk downhill, and stop once
    // the criterion has risen twice in a row past the best point, so a shallow dip is not
    // taken for the minimum.
    const Scalar decade = log(Scalar(10));
    Scalar best_x = log(tr_m / tr_r) - Scalar(3) * decade, best_v = value_at(best_x);
    const Scalar down_v = value_at(best_x - decade);
    const Scalar step = down_v < best_v ? -decade : decade;
    if (down_v < best_v) {
      best_x -= decade;
      best_v = down_v;
    }
    Scalar x = best_x;
    int rises = 0;
    constexpr int kMaxDecades = 40;
    for (int k = 0; k < kMaxDecades && rises < 2; ++k) {
      x += step;
      const Scalar v = value_at(x);
      if (v < best_v) {
        best_v = v;
        best_x = x;
        rises = 0;
      } else {
        ++rises;
      }
    }
    // Brent's minimisation on [best − 1 decade, best + 1 decade]; the criterion is smooth and
    // flat near its minimum, so a tolerance of 0.5 % in p is plenty.
    Scalar chosen = detail::brent_minimize(value_at, best_x - decade, best_x + decade, best_x,
                                           best_v, Scalar(5e-3));
    if (!(chosen == last_x)) value_at(chosen);  // the workspace must hold the chosen fit
    if (!(last_v < inf))
      throw SmoothingError(
          "sid::SmoothingSpline::fit_cross_validated: no smoothing parameter gives a "
          "numerically stable fit");
    Fit fit = fit_from(ws, y, w, exp(chosen));
    fit.iterations = evaluations;
    fit.factorizations = evaluations;
    fit.criterion = last_v;
    fit.trace = last_trace;
    fit.sigma = sqrt(ws.F / (static_cast<Scalar>(size()) - last_trace));
    return fit;
  }

  /// A point of the search: x = log p, u = 1/p, r = F/S − 1 and dr/du.
  struct SearchPoint {
    Scalar x = Scalar(0), u = Scalar(0), r = Scalar(0), dr_du = Scalar(0);
    bool known = false;
  };

  /// The root between a and b (r of opposite signs) of the cubic Hermite interpolant of r(u)
  /// through both points, found by bisection on the cubic itself; returned as log p.
  static Scalar hermite_root(const SearchPoint& a, const SearchPoint& b) {
    using std::log;
    const Scalar h = b.u - a.u;
    auto cubic = [&](Scalar s) {
      const Scalar s2 = s * s, s3 = s2 * s;
      return (Scalar(2) * s3 - Scalar(3) * s2 + Scalar(1)) * a.r +
             (s3 - Scalar(2) * s2 + s) * h * a.dr_du + (Scalar(-2) * s3 + Scalar(3) * s2) * b.r +
             (s3 - s2) * h * b.dr_du;
    };
    Scalar lo(0), hi(1);
    const bool rising = a.r < Scalar(0);
    for (int i = 0; i < 60; ++i) {
      const Scalar mid = Scalar(0.5) * (lo + hi);
      ((cubic(mid) < Scalar(0)) == rising ? lo : hi) = mid;
    }
    return -log(a.u + Scalar(0.5) * (lo + hi) * h);
  }

  /// Finds p with F(p) = S. F falls monotonically from the straight line's F (p → 0) to 0
  /// (p → ∞), steeply left of the root and very flatly right of it (S − F grows only like
  /// p^(1/4) there when S = n). Reinsch's Newton on F^(−1/2) from p = 0 is safe but slow (and
  /// p ≈ 0 is not numerically SPD for large n), so: start a million times below the
  /// trace-balanced p; from the right jump left by 10⁴; from the left take Newton steps on the
  /// model that fits there; once the root is bracketed, step to the root of the cubic Hermite
  /// interpolant of F(1/p) between the bracket ends (values and slopes both known).
  Fit constrained(const Eigen::Ref<const Vector>& y, const Weights& w, Scalar S) const {
    using std::abs;
    using std::exp;
    using std::isfinite;
    using std::log;
    if (!(S >= Scalar(0)) || !isfinite(S))
      throw std::invalid_argument(
          "sid::SmoothingSpline::fit_constrained: S must be finite and >= 0, got " +
          std::to_string(static_cast<double>(S)));
    Fit line = line_fit(y, w);
    if (line.F <= S) return line;
    if (S == Scalar(0)) return interpolate(y);

    Workspace& ws = thread_workspace();
    prepare(ws, y, w, true);
    // Start where the data and roughness terms have equal trace, a scale-free guess; noisy data
    // put the root far below it, hence the first jump.
    Scalar tr_m(0), tr_r(0);
    for (Eigen::Index j = 0; j < interior(); ++j) {
      tr_m += ws.m_band(0, j);
      tr_r += (h_[j] + h_[j + 1]) / Scalar(3);
    }
    Scalar x = log(tr_m / tr_r) - log(Scalar(1e6));
    SearchPoint lo, hi;  // lo: F > S (left of the root), hi: F < S
    const Scalar jump = log(Scalar(1e4));
    const Scalar eps = std::numeric_limits<Scalar>::epsilon();
    const Scalar f_tol = Scalar(16) * eps, x_tol = Scalar(8) * eps;
    const Scalar kNoiseFloorCheck = Scalar(1e-6);
    Scalar previous_miss = std::numeric_limits<Scalar>::infinity();
    constexpr int kMaxIterations = 100;
    for (int it = 1; it <= kMaxIterations; ++it) {
      const Scalar p = exp(x);
      Scalar next;
      if (!solve_at(ws, w, p)) {
        // Not SPD in floating point: p is far too small. Treat as left of the root.
        lo = SearchPoint{x, exp(-x), std::numeric_limits<Scalar>::infinity(), Scalar(0), true};
        next = hi.known ? Scalar(0.5) * (x + hi.x) : x + jump;
      } else {
        const Scalar ratio = ws.F / S;
        const Scalar miss = abs(ratio - Scalar(1));
        // Near the root the miss shrinks fast; when it stops shrinking, F has hit its rounding
        // floor (for large n each (Qu)ᵢ is a second difference of a smooth u and loses digits)
        // and further steps would only chase noise.
        if (miss <= f_tol || (miss < kNoiseFloorCheck && miss > Scalar(0.25) * previous_miss))
          return finish(ws, y, w, p, it);
        previous_miss = miss;
        derivative_at(ws, w);
        const Scalar g = p * ws.dF / ws.F;  // d log F / d log p
        const SearchPoint here{x, Scalar(1) / p, ratio - Scalar(1), -ratio * g * p, true};
        (here.r > Scalar(0) ? lo : hi) = here;
        // Left of the root the signal's residual dominates F − S: far left F ∝ p⁻² (Newton on
        // log F is exact for a power law), nearer F − S ∝ 1/p (Newton in 1/p is exact).
        // Right of it F is flat and Newton creeps, so jump. Once bracketed, interpolate.
        const Scalar u_next = Scalar(1) + here.r / (ratio * g);  // in units of 1/p
        const Scalar newton = ratio > Scalar(2) ? x - log(ratio) / g
                                                : (u_next > Scalar(0) ? x - log(u_next) : x + jump);
        if (lo.known && hi.known)
          next = isfinite(lo.r) ? hermite_root(lo, hi) : Scalar(0.5) * (lo.x + hi.x);
        else if (lo.known)
          next = std::min(newton, x + jump);
        else
          next = std::min(newton, x - jump);
        if (lo.known && hi.known && !(next > lo.x && next < hi.x))
          next = Scalar(0.5) * (lo.x + hi.x);
        if (abs(next - x) <= x_tol * (Scalar(1) + abs(x))) return finish(ws, y, w, p, it);
      }
      x = next;
    }
    throw SmoothingError(
        "sid::SmoothingSpline::fit_constrained: the search for p did not converge in " +
        std::to_string(kMaxIterations) + " steps (S = " + std::to_string(static_cast<double>(S)) +
        ", last p = " + std::to_string(static_cast<double>(exp(x))) + ")");
  }

  Fit finish(const Workspace& ws, const Eigen::Ref<const Vector>& y, const Weights& w, Scalar p,
             int iterations) const {
    Fit fit = fit_from(ws, y, w, p);
    fit.iterations = iterations;
    return fit;
  }

  std::shared_ptr<const Vector> t_;
  Vector h_, inv_h_;
};

/// @brief One-shot constraint-form fit (see SmoothingSpline::fit_constrained).
template <typename Scalar>
SmoothingFit<Scalar> smooth_constrained(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& t,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& y,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& dy, Scalar S) {
  return SmoothingSpline<Scalar>(t).fit_constrained(y, dy, S);
}

/// @brief One-shot penalty-form fit (see SmoothingSpline::fit_penalized).
template <typename Scalar>
SmoothingFit<Scalar> smooth_penalized(
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& t,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& y,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>& dy, Scalar p) {
  return SmoothingSpline<Scalar>(t).fit_penalized(y, dy, p);
}

}  // namespace sid
