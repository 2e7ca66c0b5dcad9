#pragma once
// Definitions of <sid/chain_consistency.hpp>: inline in header-only mode, compiled once in the
// compiled library (see sid/config.hpp).

#include <sid/chain_consistency.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

SID_INLINE LinkParameters<double> link_parameters_from_log_cholesky(
    const Eigen::Ref<const Eigen::Matrix<double, 10, 1>>& xi) {
  Eigen::Matrix4d u = Eigen::Matrix4d::Zero();
  u(0, 0) = std::exp(xi[1]);
  u(1, 1) = std::exp(xi[2]);
  u(2, 2) = std::exp(xi[3]);
  u(3, 3) = 1.0;
  u(0, 1) = xi[4];
  u(1, 2) = xi[5];
  u(0, 2) = xi[6];
  u(0, 3) = xi[7];
  u(1, 3) = xi[8];
  u(2, 3) = xi[9];
  u *= std::exp(xi[0]);
  const Eigen::Matrix4d j = u * u.transpose();
  const Eigen::Matrix3d sigma = j.topLeftCorner<3, 3>();
  const Eigen::Matrix3d i = sigma.trace() * Eigen::Matrix3d::Identity() - sigma;
  LinkParameters<double> phi;
  phi << j(3, 3), j(0, 3), j(1, 3), j(2, 3), i(0, 0), i(0, 1), i(1, 1), i(0, 2), i(1, 2), i(2, 2);
  return phi;
}

SID_INLINE Eigen::Matrix<double, 10, 1> log_cholesky_from_link_parameters(
    const LinkParameters<double>& phi) {
  Eigen::Matrix4d j = pseudo_inertia(phi);
  const double smallest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d>(j).eigenvalues()[0];
  const double inside = std::max(1e-6 * std::abs(j.trace()), 1e-9);
  if (!(smallest >= inside)) j.diagonal().array() += inside - std::min(smallest, 0.0);
  // J = U Uᵀ with U upper triangular: the lower Cholesky factor of J with rows and columns
  // reversed, reversed back.
  const Eigen::Matrix4d reversed = j.reverse();
  const Eigen::Matrix4d l = Eigen::LLT<Eigen::Matrix4d>(reversed).matrixL();
  const Eigen::Matrix4d u = l.reverse();
  const double scale = u(3, 3);
  Eigen::Matrix<double, 10, 1> xi;
  xi << std::log(scale), std::log(u(0, 0) / scale), std::log(u(1, 1) / scale),
      std::log(u(2, 2) / scale), u(0, 1) / scale, u(1, 2) / scale, u(0, 2) / scale, u(0, 3) / scale,
      u(1, 3) / scale, u(2, 3) / scale;
  return xi;
}

namespace detail {

/// The prior to stay near: the one given, or every link 1 kg at its origin with 0.01 kg m²
/// about each axis and the drive terms 0.
inline Eigen::VectorXd consistency_prior(const ChainModel& model, const Eigen::VectorXd& given,
                                         const std::string& who) {
  const Eigen::Index p = model.parameters();
  Eigen::VectorXd prior = given;
  if (prior.size() == 0) {
    prior = Eigen::VectorXd::Zero(p);
    LinkInertia<double> body;
    body.mass = 1.0;
    body.inertia_com = 0.01 * Eigen::Matrix3d::Identity();
    for (int i = 0; i < model.joints(); ++i) prior.segment<10>(10 * i) = standard_parameters(body);
  }
  if (prior.size() != p || !prior.allFinite())
    throw std::invalid_argument(who + "the prior has " + std::to_string(prior.size()) +
                                " entries or a value that is not finite; the model has " +
                                std::to_string(p) + " parameters");
  return prior;
}

/// κ of the file comment: the mean over the base parameters of their HAC variance over the
/// variance the fit gives for uncorrelated residuals, at least 1; 1 when the identification has
/// no HAC standard deviations (e.g. an instrumental-variable estimate).
inline double correlation_inflation(const ChainIdentification& id) {
  const Eigen::VectorXd& hac = id.std_dev;
  const Eigen::VectorXd& plain = id.fit.std_dev;
  if (hac.size() != plain.size() || hac.size() == 0) return 1.0;
  double sum = 0.0;
  int count = 0;
  for (Eigen::Index k = 0; k < hac.size(); ++k) {
    if (!(plain[k] > 0.0) || !std::isfinite(hac[k]) || !std::isfinite(plain[k])) continue;
    sum += (hac[k] * hac[k]) / (plain[k] * plain[k]);
    ++count;
  }
  return count ? std::max(sum / count, 1.0) : 1.0;
}

/// The convex problem of the file comment: F(θ) = ‖A (P θ − β̂)‖² + Σ w2 (θ − θ₀)² (β = P θ
/// the base parameters) and the barrier −Σ log det J_i of the real bodies, − Σ log θ_k of the
/// drive terms that are real only when positive.
struct ConsistencyProblem {
  int links = 0;
  std::vector<Eigen::Index> positive;  ///< rotor inertias and friction levels
  Eigen::MatrixXd ap;                  ///< A P
  Eigen::VectorXd ab;                  ///< A β̂
  Eigen::VectorXd w2, prior;
  Eigen::MatrixXd hessian;                ///< of F
  std::array<Eigen::Matrix4d, 10> basis;  ///< J = Σ_k φ_k E_k, linear in a link's ten

  ConsistencyProblem(const ChainIdentification& id, const Eigen::MatrixXd& a,
                     const Eigen::VectorXd& prior_in, int link_count, double gamma_rss,
                     std::vector<Eigen::Index> positive_terms)
      : links(link_count), positive(std::move(positive_terms)), prior(prior_in) {
    const Eigen::Index r = id.base.rank(), p = prior.size();
    Eigen::MatrixXd pm = Eigen::MatrixXd::Zero(r, p);
    for (Eigen::Index c = 0; c < r; ++c)
      pm(c, id.base.independent[static_cast<std::size_t>(c)]) = 1.0;
    for (Eigen::Index c = 0; c < id.base.K.cols(); ++c)
      pm.col(id.base.dependent[static_cast<std::size_t>(c)]) = id.base.K.col(c);
    ap = a * pm;
    ab = a * id.fit.theta;
    // The prior's distance in each link's own scale: its mass m0 and radius of gyration r0
    // about its origin, so that a change of mass, of first moment (m0 r0) and of inertia
    // (m0 r0²) by the same fraction cost the same, whatever the link's size.
    // A link the prior gives no mass (a URDF link without <inertial>) is unknown rather than
    // massless: it takes the scale of a typical link of the arm, else the prior would pin it
    // at zero mass whatever the data say.
    double typical_mass = 0.0, typical_r2 = 0.0;
    int massive = 0;
    for (int i = 0; i < links; ++i) {
      const LinkParameters<double> phi = prior.segment<10>(10 * i);
      if (!(phi[0] > 0.0)) continue;
      typical_mass += phi[0];
      typical_r2 += std::max((phi[4] + phi[6] + phi[9]) / (2.0 * phi[0]), 1e-4);
      ++massive;
    }
    typical_mass = massive ? typical_mass / massive : 1.0;
    typical_r2 = massive ? typical_r2 / massive : 1e-2;
    Eigen::VectorXd scale(p);
    for (int i = 0; i < links; ++i) {
      const LinkParameters<double> phi = prior.segment<10>(10 * i);
      const bool unknown = !(phi[0] > 0.0);
      const double m0 = unknown ? typical_mass : std::max(phi[0], 1e-3);
      const double r2 =
          unknown ? typical_r2 : std::max((phi[4] + phi[6] + phi[9]) / (2.0 * m0), 1e-4);
      scale.segment<10>(10 * i) << m0, Eigen::Vector3d::Constant(m0 * std::sqrt(r2)),
          Eigen::Matrix<double, 6, 1>::Constant(m0 * r2);
    }
    scale.tail(p - 10 * links) = prior.tail(p - 10 * links).cwiseAbs().array() + 1.0;
    w2 = gamma_rss * scale.cwiseAbs2().cwiseInverse();
    hessian = 2.0 * ap.transpose() * ap;
    hessian.diagonal() += 2.0 * w2;
    for (int c = 0; c < 10; ++c)
      basis[static_cast<std::size_t>(c)] =
          pseudo_inertia(LinkParameters<double>(LinkParameters<double>::Unit(c)));
  }

  double cost(const Eigen::VectorXd& t) const {
    return (ap * t - ab).squaredNorm() + w2.dot((t - prior).cwiseAbs2());
  }
  Eigen::VectorXd gradient(const Eigen::VectorXd& t) const {
    return 2.0 * ap.transpose() * (ap * t - ab) + 2.0 * w2.cwiseProduct(t - prior);
  }

  /// The number of scalar constraints the barrier stands for (4 per link).
  double size() const { return 4.0 * links + static_cast<double>(positive.size()); }

  /// −Σ log det J_i − Σ log θ_k, adding its gradient and Hessian to g and h when given; +∞
  /// outside.
  double barrier(const Eigen::VectorXd& t, Eigen::VectorXd* g, Eigen::MatrixXd* h) const {
    double value = 0.0;
    for (const Eigen::Index k : positive) {
      if (!(t[k] > 0.0)) return std::numeric_limits<double>::infinity();
      value -= std::log(t[k]);
      if (!g) continue;
      (*g)[k] -= 1.0 / t[k];
      (*h)(k, k) += 1.0 / (t[k] * t[k]);
    }
    for (int i = 0; i < links; ++i) {
      const Eigen::LLT<Eigen::Matrix4d> llt(
          pseudo_inertia(LinkParameters<double>(t.segment<10>(10 * i))));
      if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0.0))
        return std::numeric_limits<double>::infinity();
      value -= 2.0 * llt.matrixLLT().diagonal().array().log().sum();
      if (!g) continue;
      const Eigen::Matrix4d inverse = llt.solve(Eigen::Matrix4d::Identity());
      std::array<Eigen::Matrix4d, 10> ie;
      for (std::size_t c = 0; c < 10; ++c) ie[c] = inverse * basis[c];
      for (std::size_t c = 0; c < 10; ++c) {
        (*g)[10 * i + static_cast<int>(c)] -= ie[c].trace();
        for (std::size_t e = 0; e < 10; ++e)
          (*h)(10 * i + static_cast<int>(c), 10 * i + static_cast<int>(e)) +=
              (ie[c] * ie[e]).trace();
      }
    }
    return value;
  }

  /// Newton's method on t F + barrier from theta (strictly inside) to t's centre; returns false
  /// when the step budget ran out.
  bool centre(double t, Eigen::VectorXd& theta, int& steps, int max_steps) const {
    for (; steps < max_steps; ++steps) {
      Eigen::VectorXd g = t * gradient(theta);
      Eigen::MatrixXd h = t * hessian;
      const double value = t * cost(theta) + barrier(theta, &g, &h);
      const Eigen::VectorXd step = h.ldlt().solve(-g);
      const double decrement = -g.dot(step);
      // Close enough to t's centre: half the squared decrement bounds the distance from it, and
      // 1e-6 of the barrier's size is far below the gap size / t that the centre stands for.
      // At large t the barrier's value carries round-off of its own: a decrement below it
      // cannot be resolved by the line search, which would then wander on noise until the
      // budget ran out.
      if (!(decrement > 1e-6 * size()) ||
          !(decrement > 64.0 * std::numeric_limits<double>::epsilon() * std::abs(value)))
        return true;
      double length = 1.0;
      bool descended = false;
      for (int halving = 0; halving < 60 && !descended; ++halving) {
        const Eigen::VectorXd trial = theta + length * step;
        const double b = barrier(trial, nullptr, nullptr);
        descended = std::isfinite(b) && t * cost(trial) + b <= value - 0.25 * length * decrement;
        if (!descended) length *= 0.5;
      }
      if (!descended) return true;  // round-off: the step no longer descends, t's centre is here
      theta += length * step;
    }
    return false;
  }
};

}  // namespace detail

SID_INLINE ChainConsistentFit consistent_chain_parameters(const ChainModel& model,
                                                          const ChainIdentification& id,
                                                          const Eigen::VectorXd& prior_in,
                                                          const ChainConsistencyOptions& options) {
  const std::string who = "sid::consistent_chain_parameters: ";
  const int n = model.joints();
  if (!id.fit.ok() || id.fit.theta.size() != id.base.rank() ||
      static_cast<Eigen::Index>(id.base.independent.size() + id.base.dependent.size()) !=
          model.parameters())
    throw std::invalid_argument(who + "the identification failed or is not of this model");
  if (!(options.prior_std > 0.0) || !std::isfinite(options.prior_std) ||
      !(options.prior_weight >= 0.0) || !std::isfinite(options.prior_weight) ||
      options.max_iterations < 1 || !(options.tolerance > 0.0))
    throw std::invalid_argument(
        who + "prior_std and tolerance must be > 0, prior_weight >= 0, max_iterations >= 1");
  const Eigen::VectorXd prior = detail::consistency_prior(model, prior_in, who);

  ChainConsistentFit out;
  // A strictly feasible start: the prior, each link moved just inside the set of real bodies.
  Eigen::VectorXd theta = prior;
  for (int i = 0; i < n; ++i) {
    const LinkParameters<double> phi = prior.segment<10>(10 * i);
    out.prior_inconsistency.push_back(link_inconsistency(phi));
    theta.segment<10>(10 * i) =
        link_parameters_from_log_cholesky(log_cholesky_from_link_parameters(phi));
  }
  // r is upper triangular (the QR's factor): below its diagonal it holds zeros.
  const Eigen::MatrixXd a = id.fit.r * id.fit.column_scale.asDiagonal();
  // γ in units of the fit's residual sum of squares, so that it does not depend on the log's
  // length and units: the prior's variance against the estimate's (see the file comment).
  const double rss = std::max(id.fit.residual.squaredNorm(), 1e-300);
  const double dof = std::max(static_cast<double>(id.fit.residual.size() - id.base.rank()), 1.0);
  out.correlation_inflation = detail::correlation_inflation(id);
  out.prior_weight = options.prior_weight > 0.0 ? options.prior_weight
                                                : out.correlation_inflation /
                                                      (dof * options.prior_std * options.prior_std);
  // A rotor's inertia and a friction level are real only when positive (a negative rotor makes
  // the mass matrix indefinite, negative friction feeds energy in): the drive of a real arm.
  std::vector<Eigen::Index> positive;
  Eigen::Index column = model.rigid_body_parameters();
  for (const DriveTerm& term : model.terms()) {
    if (term.kind == DriveTermKind::Armature || term.kind == DriveTermKind::Viscous ||
        term.kind == DriveTermKind::Coulomb) {
      positive.push_back(column);
      theta[column] = std::max(theta[column], 1e-3 * (1.0 + std::abs(prior[column])));
    }
    ++column;
  }
  const detail::ConsistencyProblem problem(id, a, prior, n, out.prior_weight * rss, positive);

  // Interior point: the centre at t is within size / t of the optimum of F over the real bodies.
  const double barrier_size = problem.size();
  double t = barrier_size / std::max(problem.cost(theta), 1e-300);
  out.iterations = 0;
  while (problem.centre(t, theta, out.iterations, options.max_iterations)) {
    if (barrier_size / t <= options.tolerance * rss) {
      out.converged = true;
      break;
    }
    t *= 10.0;
  }
  out.theta = theta;
  out.beta = id.base.beta(out.theta);
  out.least_squares_relative_residual = id.fitted.relative_residual;
  const double yy =
      rss / std::max(id.fitted.relative_residual * id.fitted.relative_residual, 1e-300);
  const double growth = (a * (out.beta - id.fit.theta)).squaredNorm();
  out.relative_residual = std::sqrt((rss + growth) / yy);
  const auto r = static_cast<double>(id.base.rank());
  out.misfit = growth * dof / (out.correlation_inflation * rss);
  out.misfit_limit = r + 3.0 * std::sqrt(2.0 * r);
  out.fits_estimate = out.misfit <= out.misfit_limit;
  return out;
}

}  // namespace sid
