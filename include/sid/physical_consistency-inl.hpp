#pragma once
// Definitions of sid/physical_consistency.hpp (see sid/config.hpp).

#include <sid/physical_consistency.hpp>

#include <sid/least_squares.hpp>

namespace sid {

SID_INLINE PhysicalConstraints default_physical_constraints(const Model<double>& model) {
  const auto ends_with = [](const std::string& s, const std::string& tail) {
    return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
  };
  std::vector<std::string> names;
  for (const auto& name : model.parameter_names())
    if (name == "theta4" || name == "theta5" || name == "theta6" || name == "theta7" ||
        ends_with(name, ".Fc") || ends_with(name, ".Ia"))
      names.push_back(name);
  PhysicalConstraints c;
  c.nonnegative = std::move(names);
  return c;
}

namespace detail {

/// The barrier problem of a primal interior-point method (Boyd & Vandenberghe, Convex
/// Optimization, sec. 11.3 and 11.6 for matrix inequalities):
///   minimise t (||w (z - z0)||^2 + c'z) - sum_g log det S_g(z) - sum_i log h_i(z),
///   S_g(z) = 2 x 2 symmetric with entries (11, 12, 22) = lmi.middleRows(3 g, 3) z + lmi_offset,
///   h(z) = lin z + lin_offset.
/// nu = 2 G + rows(lin) is the barrier's parameter: a centred point is nu / t from optimal.
struct BarrierProblem {
  Eigen::MatrixXd lmi;
  Eigen::VectorXd lmi_offset;
  Eigen::MatrixXd lin;
  Eigen::VectorXd lin_offset;
  Eigen::MatrixXd w;
  Eigen::VectorXd z0;
  Eigen::VectorXd c;

  double nu() const { return static_cast<double>(lmi.rows() / 3 * 2 + lin.rows()); }
};

/// Newton's method on the barrier problem with buffers sized once, so that the loops over grid
/// points and constraints allocate nothing. Only the columns of lmi that are not zero enter the
/// O(G n^2) Hessian sums (for the arm 3 of 7: friction and gravity are absent from D).
///
/// The line search compares CHANGES of the barrier objective, each formed without cancellation:
///   cost:     2 a (W d)'(W s) + a^2 ||W s||^2 + a c's   (d = z - z0, s the step, a its length)
///   log det:  log1p(a tr(P E) + a^2 det E / det S)      (E = the step's change of S)
///   log h:    log1p(a (lin s)_i / h_i).
/// Near the end t ||X theta - y||^2 reaches 1e12 or more while the decrease sought is 1e-9;
/// differencing objective values would drown it in rounding and stall the method.
class BarrierSolver {
 public:
  explicit BarrierSolver(const BarrierProblem& problem) : p_(problem) {
    const Eigen::Index n = p_.lmi.cols(), rows = p_.lmi.rows(), grid = rows / 3;
    for (Eigen::Index k = 0; k < n; ++k)
      if (!p_.lmi.col(k).isZero(0.0)) columns_.push_back(k);
    const Eigen::Index nj = static_cast<Eigen::Index>(columns_.size());
    lmi_j_.resize(rows, nj);
    for (Eigen::Index j = 0; j < nj; ++j) lmi_j_.col(j) = p_.lmi.col(columns_[j]);
    wtw2_ = 2.0 * p_.w.transpose() * p_.w;
    s_.resize(rows);
    v_.resize(rows);
    e_.resize(rows);
    y_.resize(rows, nj);
    det_.resize(grid);
    det_linear_.resize(grid);
    det_quadratic_.resize(grid);
    h_.resize(p_.lin.rows());
    r_.resize(p_.lin.rows());
    h_linear_.resize(p_.lin.rows());
    grad_.resize(n);
    grad_j_.resize(nj);
    hess_.resize(n, n);
    hess_j_.resize(nj, nj);
    step_.resize(n);
    trial_.resize(n);
    diff_.resize(n);
    wdiff_.resize(p_.w.rows());
    wstep_.resize(p_.w.rows());
    llt_.compute(Eigen::MatrixXd::Identity(n, n));  // sized once here, and its status set
  }

  /// ||w (z - z0)||^2 + c'z, the cost without the barrier.
  double cost(const Eigen::VectorXd& z) {
    diff_ = z - p_.z0;
    wdiff_.noalias() = p_.w * diff_;
    return wdiff_.squaredNorm() + p_.c.dot(z);
  }

  bool strictly_feasible(const Eigen::VectorXd& z) { return evaluate_constraints(z); }

  /// Centres z at t (Newton with backtracking that never leaves the interior) until the Newton
  /// decrement is negligible or done_early(z) holds. Counts steps into iterations, stopping at
  /// max_iterations. @pre z strictly feasible.
  ///
  /// Near the boundary the slack of S_g is computed from entries ~1e12 times larger, so the
  /// barrier's gradient carries relative noise growing with t and the decrement meets a floor
  /// (1e-8 at t ~ 1e11 on the arm). Inside the quadratic region (decrement < 1e-3) a step that
  /// fails to cut the decrement fourfold shows that floor, and the centring stops there.
  template <typename DoneEarly>
  void centre(Eigen::VectorXd& z, double t, int& iterations, int max_iterations,
              const DoneEarly& done_early) {
    constexpr double decrement_tol = 1e-10, quadratic_region = 1e-3, armijo = 0.25;
    constexpr double min_step = 1e-14;
    double previous = std::numeric_limits<double>::infinity();
    while (iterations < max_iterations) {
      if (!newton_direction(z, t)) return;
      const double slope = grad_.dot(step_);  // -(Newton decrement)^2
      const double decrement = -0.5 * slope;
      if (!(decrement > decrement_tol)) return;
      if (decrement < quadratic_region && decrement > 0.25 * previous) return;
      previous = decrement;
      double alpha = 1.0;
      while (!(objective_change(z, alpha, t) <= armijo * alpha * slope)) {
        alpha *= 0.5;
        if (alpha < min_step) return;  // rounding-limited: as centred as it gets
      }
      z += alpha * step_;
      ++iterations;
      if (done_early(z)) return;
    }
  }

 private:
  /// Fills s_ and h_; false unless every S_g is positive definite and every h_i > 0.
  bool evaluate_constraints(const Eigen::VectorXd& z) {
    s_.noalias() = p_.lmi * z;
    s_ += p_.lmi_offset;
    for (Eigen::Index g = 0; g < s_.size() / 3; ++g) {
      const double a = s_(3 * g), b = s_(3 * g + 1), d = s_(3 * g + 2);
      if (!(a > 0.0) || !(d > 0.0) || !(a * d - b * b > 0.0)) return false;
    }
    h_.noalias() = p_.lin * z;
    h_ += p_.lin_offset;
    for (Eigen::Index i = 0; i < h_.size(); ++i)
      if (!(h_(i) > 0.0)) return false;
    return true;
  }

  /// Gradient and Hessian of the barrier objective at z, step_ = -H^-1 grad, and the
  /// coefficients objective_change needs. For S = S_g and P = S^-1 (symmetric 2 x 2 written as
  /// vectors (11, 12, 22)):
  ///   d/dz_k (-log det S) = -tr(P A_k) = -v' a_k,     v = (P11, 2 P12, P22),
  ///   d2/dz_k dz_l        =  tr(P A_k P A_l) = a_k' M a_l,
  /// with M the symmetric 3 x 3 below (from the entries of P A P). False if H is not positive
  /// definite (cannot happen with a full-rank w or bounded variables; a guard, not a branch).
  bool newton_direction(const Eigen::VectorXd& z, double t) {
    evaluate_constraints(z);
    diff_ = z - p_.z0;
    grad_.noalias() = t * (wtw2_ * diff_);
    grad_ += t * p_.c;
    hess_ = t * wtw2_;
    for (Eigen::Index g = 0; g < s_.size() / 3; ++g) {
      const double a = s_(3 * g), b = s_(3 * g + 1), d = s_(3 * g + 2);
      det_(g) = a * d - b * b;
      const double inv_det = 1.0 / det_(g);
      const double p11 = d * inv_det, p12 = -b * inv_det, p22 = a * inv_det;
      v_(3 * g) = p11;
      v_(3 * g + 1) = 2.0 * p12;
      v_(3 * g + 2) = p22;
      Eigen::Matrix3d m;
      m << p11 * p11, 2.0 * p11 * p12, p12 * p12,                           //
          2.0 * p11 * p12, 2.0 * (p11 * p22 + p12 * p12), 2.0 * p12 * p22,  //
          p12 * p12, 2.0 * p12 * p22, p22 * p22;
      y_.middleRows<3>(3 * g).noalias() = m * lmi_j_.middleRows<3>(3 * g);
    }
    grad_j_.noalias() = lmi_j_.transpose() * v_;
    hess_j_.noalias() = lmi_j_.transpose() * y_;
    const Eigen::Index nj = static_cast<Eigen::Index>(columns_.size());
    for (Eigen::Index i = 0; i < nj; ++i) {
      grad_(columns_[i]) -= grad_j_(i);
      for (Eigen::Index j = 0; j < nj; ++j) hess_(columns_[i], columns_[j]) += hess_j_(i, j);
    }
    r_ = h_.cwiseInverse();
    grad_.noalias() -= p_.lin.transpose() * r_;
    for (Eigen::Index i = 0; i < h_.size(); ++i)
      hess_.noalias() += (r_(i) * r_(i)) * p_.lin.row(i).transpose() * p_.lin.row(i);
    llt_.compute(hess_);
    if (llt_.info() != Eigen::Success) return false;
    step_ = llt_.solve(grad_);
    step_ = -step_;

    e_.noalias() = p_.lmi * step_;
    for (Eigen::Index g = 0; g < det_.size(); ++g) {
      const auto eg = e_.segment<3>(3 * g);
      det_linear_(g) = v_.segment<3>(3 * g).dot(eg);  // tr(P E)
      det_quadratic_(g) = (eg(0) * eg(2) - eg(1) * eg(1)) / det_(g);
    }
    h_linear_.noalias() = p_.lin * step_;
    h_linear_.array() *= r_.array();
    wdiff_.noalias() = p_.w * diff_;
    wstep_.noalias() = p_.w * step_;
    cost_linear_ = 2.0 * wdiff_.dot(wstep_) + p_.c.dot(step_);
    cost_quadratic_ = wstep_.squaredNorm();
    return true;
  }

  /// F(z + alpha step) - F(z) at t, +infinity outside the strict interior; after
  /// newton_direction(z, t).
  double objective_change(const Eigen::VectorXd& z, double alpha, double t) {
    trial_ = z + alpha * step_;
    if (!evaluate_constraints(trial_)) return std::numeric_limits<double>::infinity();
    double change = t * alpha * (cost_linear_ + alpha * cost_quadratic_);
    for (Eigen::Index g = 0; g < det_.size(); ++g) {
      const double ratio_minus_one = alpha * (det_linear_(g) + alpha * det_quadratic_(g));
      if (!(ratio_minus_one > -1.0)) return std::numeric_limits<double>::infinity();
      change -= std::log1p(ratio_minus_one);
    }
    for (Eigen::Index i = 0; i < h_linear_.size(); ++i) change -= std::log1p(alpha * h_linear_(i));
    return change;
  }

  const BarrierProblem& p_;
  std::vector<Eigen::Index> columns_;
  Eigen::MatrixXd lmi_j_, y_, wtw2_, hess_, hess_j_;
  Eigen::VectorXd s_, v_, e_, det_, det_linear_, det_quadratic_, h_, r_, h_linear_, grad_, grad_j_,
      step_, trial_, diff_, wdiff_, wstep_;
  double cost_linear_ = 0.0, cost_quadratic_ = 0.0;
  Eigen::LLT<Eigen::MatrixXd> llt_;
};

SID_INLINE Eigen::MatrixXd mass_matrix_basis(const Model<double>& model, Eigen::Index grid_size) {
  const Vector2<double> zero = Vector2<double>::Zero();
  Eigen::MatrixXd basis(3 * grid_size, model.num_parameters());
  for (Eigen::Index g = 0; g < grid_size; ++g) {
    const Vector2<double> q(0.0, physical_grid_q2(g, grid_size));
    const ModelRegressor<double> z0 = model.regressor(q, zero, zero);
    const ModelRegressor<double> z1 = model.regressor(q, zero, Vector2<double>::UnitX());
    const ModelRegressor<double> z2 = model.regressor(q, zero, Vector2<double>::UnitY());
    basis.row(3 * g) = z1.row(0) - z0.row(0);
    basis.row(3 * g + 1) = 0.5 * ((z2.row(0) - z0.row(0)) + (z1.row(1) - z0.row(1)));
    basis.row(3 * g + 2) = z2.row(1) - z0.row(1);
  }
  return basis;
}

SID_INLINE GridMinimum grid_min_eigenvalue(const Eigen::Ref<const Eigen::VectorXd>& d) {
  GridMinimum m;
  for (Eigen::Index g = 0; g < d.size() / 3; ++g) {
    const double v = min_eigenvalue_2x2(d(3 * g), d(3 * g + 1), d(3 * g + 2));
    if (v < m.value || g == 0) m = {v, g};
  }
  return m;
}

SID_INLINE std::vector<Eigen::Index> bounded_indices(const Model<double>& model,
                                                     const PhysicalConstraints& c) {
  const std::vector<std::string> names = model.parameter_names();
  const std::vector<std::string> wanted =
      c.nonnegative ? *c.nonnegative : *default_physical_constraints(model).nonnegative;
  std::vector<Eigen::Index> indices;
  for (std::size_t k = 0; k < names.size(); ++k)
    if (std::find(wanted.begin(), wanted.end(), names[k]) != wanted.end())
      indices.push_back(static_cast<Eigen::Index>(k));
  return indices;
}

SID_INLINE void check_grid_size(const char* who, const PhysicalConstraints& c) {
  if (c.grid_size < 1)
    throw std::invalid_argument(std::string(who) + ": c.grid_size must be >= 1, got " +
                                std::to_string(c.grid_size));
}

SID_INLINE Eigen::VectorXd physical_interior_point(const Eigen::MatrixXd& basis,
                                                   const std::vector<Eigen::Index>& bounded,
                                                   int& iterations, int max_iterations) {
  constexpr const char* who = "sid::nearest_physical";
  constexpr double delta = 1e-9;
  const Eigen::Index p = basis.cols(), rows = basis.rows();
  const Eigen::Index nb = static_cast<Eigen::Index>(bounded.size());
  const double a_max = basis.cwiseAbs().maxCoeff();
  if (!(a_max > 0.0))
    throw std::invalid_argument(std::string(who) +
                                ": no parameter values make the mass matrix positive definite "
                                "(the model's D is identically zero): no strictly feasible point");
  BarrierProblem phase1;
  phase1.lmi.resize(rows, p + 1);
  phase1.lmi.leftCols(p) = basis / a_max;
  for (Eigen::Index g = 0; g < rows / 3; ++g) phase1.lmi.col(p).segment<3>(3 * g) << 1.0, 0.0, 1.0;
  phase1.lmi_offset = Eigen::VectorXd::Zero(rows);
  phase1.lin = Eigen::MatrixXd::Zero(nb + 2 * p, p + 1);
  phase1.lin_offset = Eigen::VectorXd::Zero(nb + 2 * p);
  for (Eigen::Index i = 0; i < nb; ++i) {
    phase1.lin(i, bounded[static_cast<std::size_t>(i)]) = 1.0;
    phase1.lin(i, p) = 1.0;
  }
  for (Eigen::Index j = 0; j < p; ++j) {
    phase1.lin(nb + 2 * j, j) = 1.0;
    phase1.lin(nb + 2 * j + 1, j) = -1.0;
    phase1.lin_offset.segment<2>(nb + 2 * j).setOnes();
  }
  phase1.w.resize(0, p + 1);
  phase1.z0 = Eigen::VectorXd::Zero(p + 1);
  phase1.c = Eigen::VectorXd::Unit(p + 1, p);

  BarrierSolver solver(phase1);
  Eigen::VectorXd z = Eigen::VectorXd::Zero(p + 1);
  z(p) = 1.0;
  const auto found = [p](const Eigen::VectorXd& zz) { return zz(p) < -delta; };
  double t = 1.0;
  for (int stage = 0;; ++stage, t *= 10.0) {
    solver.centre(z, t, iterations, max_iterations, found);
    if (found(z)) return z.head(p);
    if (z(p) - phase1.nu() / t > -2.0 * delta)
      throw std::invalid_argument(
          std::string(who) +
          ": no strictly feasible point: no parameter values make the mass matrix positive "
          "definite at every q2 with the bounded parameters positive (for example D is singular "
          "for all parameters, or a bound contradicts it)");
    if (iterations >= max_iterations || stage == kMaxBarrierStages)
      throw std::runtime_error(std::string(who) +
                               ": finding a strictly feasible start took more than "
                               "options.max_iterations Newton steps");
  }
}

SID_INLINE void check_nearest_physical_input(const char* who, const std::string& prefix,
                                             const Model<double>& model,
                                             const Eigen::Ref<const Eigen::MatrixXd>& X,
                                             const Eigen::Ref<const Eigen::VectorXd>& y,
                                             const PhysicalConstraints& c,
                                             const NearestPhysicalOptions& options) {
  const Eigen::Index m = X.rows(), p = X.cols();
  if (p != model.num_parameters())
    throw std::invalid_argument(prefix + "X has " + std::to_string(p) +
                                " columns but the model has " +
                                std::to_string(model.num_parameters()) + " parameters");
  if (p < 1) throw std::invalid_argument(prefix + "the model has no parameters");
  if (m <= p)
    throw std::invalid_argument(prefix + "X must have more rows than columns, got " +
                                std::to_string(m) + " x " + std::to_string(p));
  if (y.size() != m)
    throw std::invalid_argument(prefix + "y must have as many entries as X has rows (" +
                                std::to_string(m) + "), got " + std::to_string(y.size()));
  if (!X.allFinite()) throw std::invalid_argument(prefix + "X must be finite");
  if (!y.allFinite()) throw std::invalid_argument(prefix + "y must be finite");
  check_grid_size(who, c);
  if (!(options.margin >= 0.0) || !std::isfinite(options.margin))
    throw std::invalid_argument(prefix + "options.margin must be finite and >= 0");
  if (!(options.tolerance > 0.0) || !std::isfinite(options.tolerance))
    throw std::invalid_argument(prefix + "options.tolerance must be finite and > 0");
  if (options.max_iterations < 1)
    throw std::invalid_argument(prefix + "options.max_iterations must be >= 1");
}

/// The least-squares cost in scaled coordinates phi = scale .* theta:
/// ||X theta - y||^2 = ||r (phi - phi_hat)||^2 + rss.
struct WhitenedLeastSquares {
  Eigen::VectorXd scale;    ///< column norms of X, 1 for a zero column
  Eigen::MatrixXd r;        ///< R of the QR of X with unit-norm columns
  Eigen::VectorXd phi_hat;  ///< the unconstrained minimiser
  double rss = 0.0;         ///< the cost at phi_hat
};

SID_INLINE WhitenedLeastSquares whiten_least_squares(const std::string& prefix,
                                                     const Eigen::Ref<const Eigen::MatrixXd>& X,
                                                     const Eigen::Ref<const Eigen::VectorXd>& y) {
  const LeastSquaresResult<double> ls = least_squares(X, y);
  if (!ls.ok())
    throw std::invalid_argument(prefix +
                                "X is rank deficient (after scaling its columns to unit norm): "
                                "the constrained fit needs every parameter identifiable");
  WhitenedLeastSquares w;
  w.scale = ls.column_scale;
  w.r = ls.r;
  w.phi_hat = ls.theta.cwiseProduct(ls.column_scale);
  w.rss = ls.residual.squaredNorm();
  return w;
}

/// s_D: the largest |eigenvalue| of the stacked matrices d over the grid, the unit of the margin.
SID_INLINE double max_abs_eigenvalue_on_grid(const Eigen::VectorXd& d, Eigen::Index grid_size) {
  double s_d = 0.0;
  for (Eigen::Index g = 0; g < grid_size; ++g)
    s_d = std::max(s_d, max_abs_eigenvalue_2x2(d(3 * g), d(3 * g + 1), d(3 * g + 2)));
  return s_d;
}

SID_INLINE bool meets_constraints(const Eigen::VectorXd& d_hat, const Eigen::VectorXd& phi_hat,
                                  const std::vector<Eigen::Index>& bounded, double eps) {
  const GridMinimum worst_hat = grid_min_eigenvalue(d_hat);
  bool bounds_hold = true;
  for (const Eigen::Index k : bounded) bounds_hold = bounds_hold && phi_hat(k) >= 0.0;
  return worst_hat.value > 0.0 && worst_hat.value >= eps && bounds_hold;
}

/// Sets theta and where the smallest eigenvalue of D(theta) lies on the grid.
SID_INLINE void record_estimate(ConsistentEstimate& result, const Eigen::VectorXd& theta,
                                const Eigen::MatrixXd& basis, Eigen::Index grid_size) {
  result.theta = theta;
  const GridMinimum worst = grid_min_eigenvalue(basis * theta);
  result.min_eigenvalue = worst.value;
  result.min_eigenvalue_q2 = physical_grid_q2(worst.index, grid_size);
}

/// The c for which phi_hat + c phi_f meets every constraint, from Weyl's inequality
/// lambda_min(D(phi_hat + c phi_f)) >= lambda_min(D(phi_hat)) + c lambda_min(D(phi_f)).
SID_INLINE double weyl_step_to_feasible(const Eigen::VectorXd& d_hat,
                                        const Eigen::MatrixXd& basis_phi,
                                        const Eigen::VectorXd& phi_hat,
                                        const Eigen::VectorXd& phi_f,
                                        const std::vector<Eigen::Index>& bounded, double eps,
                                        Eigen::Index grid_size) {
  const Eigen::VectorXd d_f = basis_phi * phi_f;
  double c_needed = 0.0;
  for (Eigen::Index g = 0; g < grid_size; ++g) {
    const double lam_hat = min_eigenvalue_2x2(d_hat(3 * g), d_hat(3 * g + 1), d_hat(3 * g + 2));
    const double lam_f = min_eigenvalue_2x2(d_f(3 * g), d_f(3 * g + 1), d_f(3 * g + 2));
    c_needed = std::max(c_needed, (eps - lam_hat) / lam_f);
  }
  for (const Eigen::Index k : bounded) c_needed = std::max(c_needed, -phi_hat(k) / phi_f(k));
  return c_needed;
}

/// The fit in phi units: ||r (phi - phi_hat)||^2 subject to D(phi) >= eps I on the grid and
/// phi_k >= 0 on the bounded indices.
SID_INLINE BarrierProblem margin_fit_problem(const Eigen::MatrixXd& basis_phi,
                                             const std::vector<Eigen::Index>& bounded, double eps,
                                             const WhitenedLeastSquares& ls,
                                             Eigen::Index grid_size) {
  const Eigen::Index p = ls.phi_hat.size();
  BarrierProblem fit;
  fit.lmi = basis_phi;
  fit.lmi_offset = Eigen::VectorXd::Zero(3 * grid_size);
  for (Eigen::Index g = 0; g < grid_size; ++g) {
    fit.lmi_offset(3 * g) = -eps;
    fit.lmi_offset(3 * g + 2) = -eps;
  }
  const Eigen::Index nb = static_cast<Eigen::Index>(bounded.size());
  fit.lin = Eigen::MatrixXd::Zero(nb, p);
  for (Eigen::Index i = 0; i < nb; ++i) fit.lin(i, bounded[static_cast<std::size_t>(i)]) = 1.0;
  fit.lin_offset = Eigen::VectorXd::Zero(nb);
  fit.w = ls.r;
  fit.z0 = ls.phi_hat;
  fit.c = Eigen::VectorXd::Zero(p);
  return fit;
}

/// phi_hat + step phi_f, doubling step from 2 c_needed until the solver's constraints hold
/// strictly (c_needed may fall short through rounding).
SID_INLINE Eigen::VectorXd strictly_feasible_start(BarrierSolver& solver,
                                                   const Eigen::VectorXd& phi_hat,
                                                   const Eigen::VectorXd& phi_f, double c_needed,
                                                   const std::string& prefix) {
  double step = c_needed > 0.0 ? 2.0 * c_needed : 1e-3;
  Eigen::VectorXd phi = phi_hat + step * phi_f;
  for (int doubling = 0; !solver.strictly_feasible(phi); ++doubling) {
    if (doubling == 60)
      throw std::runtime_error(prefix + "could not place a strictly feasible start");
    step *= 2.0;
    phi = phi_hat + step * phi_f;
  }
  return phi;
}

struct CentralPathEnd {
  double t = 0.0;          ///< the barrier weight of the last centring
  bool converged = false;  ///< the duality-gap bound met the tolerance
};

/// Centres phi at barrier weights rising tenfold from nu / cost until the duality-gap bound
/// nu / t meets tolerance * (rss + cost), or the iterations or stages run out.
SID_INLINE CentralPathEnd follow_central_path(BarrierSolver& solver, Eigen::VectorXd& phi,
                                              double nu, double rss,
                                              const NearestPhysicalOptions& options,
                                              int& iterations) {
  CentralPathEnd end;
  double t = nu / std::max(solver.cost(phi), std::numeric_limits<double>::min());
  const auto never = [](const Eigen::VectorXd&) { return false; };
  for (int stage = 0;; ++stage, t *= 10.0) {
    solver.centre(phi, t, iterations, options.max_iterations, never);
    if (nu / t <= options.tolerance * (rss + solver.cost(phi))) {
      end.converged = true;
      break;
    }
    if (iterations >= options.max_iterations || stage == kMaxBarrierStages) break;
  }
  end.t = t;
  return end;
}

/// The bounds active at barrier weight t; sets them to zero in phi where that keeps D's margin.
SID_INLINE std::vector<Eigen::Index> snap_active_bounds(Eigen::VectorXd& phi,
                                                        const std::vector<Eigen::Index>& bounded,
                                                        const Eigen::MatrixXd& basis,
                                                        const Eigen::MatrixXd& basis_phi, double t,
                                                        double eps) {
  // Active bounds: on the central path phi_k * lambda_k = 1 / t (lambda_k the bound's
  // multiplier, same units as phi_k), so phi_k < 1 / sqrt(t) means lambda_k > phi_k: the
  // strict-complementarity split between "held at zero" and "free".
  const double zero_below = 1.0 / std::sqrt(t);
  std::vector<Eigen::Index> active;
  for (const Eigen::Index k : bounded)
    if (phi(k) < zero_below) active.push_back(k);
  Eigen::VectorXd snapped = phi;
  for (const Eigen::Index k : active)
    if (basis.col(k).isZero(0.0)) snapped(k) = 0.0;  // no effect on D
  Eigen::VectorXd all_snapped = snapped;
  for (const Eigen::Index k : active) all_snapped(k) = 0.0;
  const double snapped_min = grid_min_eigenvalue(basis_phi * all_snapped).value;
  if (snapped_min > 0.0 && snapped_min >= eps) snapped = all_snapped;
  phi = snapped;
  return active;
}
}  // namespace detail

SID_INLINE PhysicalCheck check_physical(const Model<double>& model,
                                        const Eigen::Ref<const Eigen::VectorXd>& theta,
                                        const PhysicalConstraints& c) {
  constexpr const char* who = "sid::check_physical";
  if (theta.size() != model.num_parameters())
    throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                " entries but the model has " +
                                std::to_string(model.num_parameters()) + " parameters");
  if (!theta.allFinite()) throw std::invalid_argument(std::string(who) + ": theta must be finite");
  detail::check_grid_size(who, c);

  PhysicalCheck check;
  const Eigen::VectorXd d = detail::mass_matrix_basis(model, c.grid_size) * theta;
  const detail::GridMinimum worst = detail::grid_min_eigenvalue(d);
  check.min_eigenvalue = worst.value;
  check.min_eigenvalue_q2 = detail::physical_grid_q2(worst.index, c.grid_size);
  check.mass_matrix_positive_definite = worst.value > 0.0;
  const std::vector<std::string> names = model.parameter_names();
  for (const Eigen::Index k : detail::bounded_indices(model, c))
    if (theta(k) < 0.0) {
      check.negative_parameters.push_back(names[static_cast<std::size_t>(k)]);
      check.negative_values.push_back(theta(k));
    }
  return check;
}

SID_INLINE ConsistentEstimate nearest_physical(const Model<double>& model,
                                               const Eigen::Ref<const Eigen::MatrixXd>& X,
                                               const Eigen::Ref<const Eigen::VectorXd>& y,
                                               const PhysicalConstraints& c,
                                               const NearestPhysicalOptions& options) {
  constexpr const char* who = "sid::nearest_physical";
  const std::string prefix = std::string(who) + ": ";
  detail::check_nearest_physical_input(who, prefix, model, X, y, c, options);
  const detail::WhitenedLeastSquares ls = detail::whiten_least_squares(prefix, X, y);

  const Eigen::MatrixXd basis = detail::mass_matrix_basis(model, c.grid_size);     // theta units
  const Eigen::MatrixXd basis_phi = basis * ls.scale.cwiseInverse().asDiagonal();  // phi units
  const std::vector<Eigen::Index> bounded = detail::bounded_indices(model, c);
  const std::vector<std::string> names = model.parameter_names();

  ConsistentEstimate result;
  result.theta_unconstrained = ls.phi_hat.cwiseQuotient(ls.scale);
  const Eigen::VectorXd d_hat = basis * result.theta_unconstrained;
  const double s_d = detail::max_abs_eigenvalue_on_grid(d_hat, c.grid_size);
  const double eps = options.margin * s_d;
  result.margin_absolute = eps;

  if (detail::meets_constraints(d_hat, ls.phi_hat, bounded, eps)) {
    detail::record_estimate(result, result.theta_unconstrained, basis, c.grid_size);
    result.converged = true;
    return result;
  }

  // Phase 1, then a strictly feasible start on the ray from phi_hat toward the interior point.
  int iterations = 0;
  const Eigen::VectorXd phi_f =
      detail::physical_interior_point(basis_phi, bounded, iterations, options.max_iterations);
  const double c_needed =
      detail::weyl_step_to_feasible(d_hat, basis_phi, ls.phi_hat, phi_f, bounded, eps, c.grid_size);

  const detail::BarrierProblem fit =
      detail::margin_fit_problem(basis_phi, bounded, eps, ls, c.grid_size);
  detail::BarrierSolver solver(fit);
  Eigen::VectorXd phi =
      detail::strictly_feasible_start(solver, ls.phi_hat, phi_f, c_needed, prefix);
  const detail::CentralPathEnd end =
      detail::follow_central_path(solver, phi, fit.nu(), ls.rss, options, iterations);
  if (end.converged) result.converged = true;

  const std::vector<Eigen::Index> active =
      detail::snap_active_bounds(phi, bounded, basis, basis_phi, end.t, eps);
  for (const Eigen::Index k : active)
    result.active_bounds.push_back(names[static_cast<std::size_t>(k)]);
  detail::record_estimate(result, phi.cwiseQuotient(ls.scale), basis, c.grid_size);
  result.changed = true;
  result.cost_increase = solver.cost(phi);
  result.mass_matrix_active = result.min_eigenvalue <= eps + 1e-6 * s_d;
  result.iterations = iterations;
  return result;
}

}  // namespace sid
