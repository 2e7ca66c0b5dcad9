#pragma once
// Definitions of <sid/chain_consistency.hpp>: inline in header-only mode, compiled once in the
// compiled library (see sid/config.hpp).

#include <sid/chain_consistency.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {
namespace detail {

inline Eigen::Matrix4d pseudo_inertia(const LinkParameters<double>& phi) {
  Eigen::Matrix3d i;
  i << phi[4], phi[5], phi[7], phi[5], phi[6], phi[8], phi[7], phi[8], phi[9];
  Eigen::Matrix4d j;
  j.topLeftCorner<3, 3>() = 0.5 * i.trace() * Eigen::Matrix3d::Identity() - i;
  j.topRightCorner<3, 1>() = phi.segment<3>(1);
  j.bottomLeftCorner<1, 3>() = phi.segment<3>(1).transpose();
  j(3, 3) = phi[0];
  return j;
}

}  // namespace detail

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
  Eigen::Matrix4d j = detail::pseudo_inertia(phi);
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

SID_INLINE ChainConsistentFit consistent_chain_parameters(const ChainModel& model,
                                                          const ChainIdentification& id,
                                                          const Eigen::VectorXd& prior_in,
                                                          const ChainConsistencyOptions& options) {
  const std::string who = "sid::consistent_chain_parameters: ";
  const int n = model.joints();
  const Eigen::Index p = model.parameters(), links = 10 * n, drives = p - links;
  if (!id.fit.ok() || id.fit.theta.size() != id.base.rank() ||
      static_cast<Eigen::Index>(id.base.independent.size() + id.base.dependent.size()) != p)
    throw std::invalid_argument(who + "the identification failed or is not of this model");
  if (!(options.prior_weight > 0.0) || !std::isfinite(options.prior_weight) ||
      options.max_iterations < 1 || !(options.tolerance > 0.0))
    throw std::invalid_argument(who +
                                "prior_weight and tolerance must be > 0, max_iterations >= 1");
  Eigen::VectorXd prior = prior_in;
  if (prior.size() == 0) {
    prior = Eigen::VectorXd::Zero(p);
    for (int i = 0; i < n; ++i) {
      LinkInertia<double> body;
      body.mass = 1.0;
      body.inertia_com = 0.01 * Eigen::Matrix3d::Identity();
      prior.segment<10>(10 * i) = standard_parameters(body);
    }
  }
  if (prior.size() != p || !prior.allFinite())
    throw std::invalid_argument(who + "the prior has " + std::to_string(prior.size()) +
                                " entries or a value that is not finite; the model has " +
                                std::to_string(p) + " parameters");

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
  // The prior's distance in each link's own scale: its mass m0 and radius of gyration r0
  // about its origin, so that a change of mass, of first moment (m0 r0) and of inertia
  // (m0 r0²) by the same fraction cost the same, whatever the link's size.
  Eigen::VectorXd scale(p);
  for (int i = 0; i < n; ++i) {
    const LinkParameters<double> phi = prior.segment<10>(10 * i);
    const double m0 = std::max(phi[0], 1e-3);
    const double r2 = std::max((phi[4] + phi[6] + phi[9]) / (2.0 * m0), 1e-4);
    scale.segment<10>(10 * i) << m0, Eigen::Vector3d::Constant(m0 * std::sqrt(r2)),
        Eigen::Matrix<double, 6, 1>::Constant(m0 * r2);
  }
  scale.tail(drives) = prior.tail(drives).cwiseAbs().array() + 1.0;
  // γ in units of the fit's residual sum of squares: a unit relative change of a parameter the
  // data do not see costs prior_weight of it, whatever the log's length and units.
  const double least_squares_rss = id.fit.residual.squaredNorm();
  const Eigen::VectorXd w2 = (options.prior_weight * std::max(least_squares_rss, 1e-300)) *
                             scale.cwiseAbs2().cwiseInverse();

  // F(θ) = ‖A (P θ − β̂)‖² + Σ w2 (θ − θ₀)², with β = P θ the base parameters: a quadratic.
  const Eigen::Index r = id.base.rank();
  Eigen::MatrixXd pm = Eigen::MatrixXd::Zero(r, p);
  for (Eigen::Index c = 0; c < r; ++c)
    pm(c, id.base.independent[static_cast<std::size_t>(c)]) = 1.0;
  for (Eigen::Index c = 0; c < id.base.K.cols(); ++c)
    pm.col(id.base.dependent[static_cast<std::size_t>(c)]) = id.base.K.col(c);
  const Eigen::MatrixXd ap = a * pm;
  const Eigen::VectorXd ab = a * id.fit.theta;
  Eigen::MatrixXd hessian_f = 2.0 * ap.transpose() * ap;
  hessian_f.diagonal() += 2.0 * w2;
  const auto cost_f = [&](const Eigen::VectorXd& t) {
    return (ap * t - ab).squaredNorm() + w2.dot((t - prior).cwiseAbs2());
  };
  const auto gradient_f = [&](const Eigen::VectorXd& t) {
    return Eigen::VectorXd(2.0 * ap.transpose() * (ap * t - ab) + 2.0 * w2.cwiseProduct(t - prior));
  };
  // The pseudo-inertia is linear in a link's ten parameters: J = Σ_k φ_k E_k.
  std::array<Eigen::Matrix4d, 10> basis;
  for (int c = 0; c < 10; ++c)
    basis[static_cast<std::size_t>(c)] = detail::pseudo_inertia(LinkParameters<double>::Unit(c));
  // The barrier −Σ log det J_i, its gradient and Hessian; +∞ outside the real bodies.
  const auto barrier = [&](const Eigen::VectorXd& t, Eigen::VectorXd* g, Eigen::MatrixXd* h) {
    double value = 0.0;
    for (int i = 0; i < n; ++i) {
      const Eigen::Matrix4d j = detail::pseudo_inertia(t.segment<10>(10 * i));
      const Eigen::LLT<Eigen::Matrix4d> llt(j);
      if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0.0))
        return std::numeric_limits<double>::infinity();
      value -= 2.0 * llt.matrixLLT().diagonal().array().log().sum();
      if (!g) continue;
      const Eigen::Matrix4d inverse = llt.solve(Eigen::Matrix4d::Identity());
      std::array<Eigen::Matrix4d, 10> ie;
      for (std::size_t c = 0; c < 10; ++c) ie[c] = inverse * basis[c];
      for (int c = 0; c < 10; ++c) {
        (*g)[10 * i + c] -= ie[static_cast<std::size_t>(c)].trace();
        for (int e = 0; e < 10; ++e)
          (*h)(10 * i + c, 10 * i + e) +=
              (ie[static_cast<std::size_t>(c)] * ie[static_cast<std::size_t>(e)]).trace();
      }
    }
    return value;
  };

  // Interior point: Newton's method on t F − Σ log det J_i for growing t; the answer is within
  // 4n / t of the optimum of F over the real bodies.
  const double barrier_size = 4.0 * n;
  const double target_gap = options.tolerance * std::max(least_squares_rss, 1e-300);
  double weight_t = barrier_size / std::max(cost_f(theta), 1e-300);
  out.iterations = 0;
  while (out.iterations < options.max_iterations) {
    for (; out.iterations < options.max_iterations; ++out.iterations) {
      Eigen::VectorXd g = weight_t * gradient_f(theta);
      Eigen::MatrixXd h = weight_t * hessian_f;
      const double value = weight_t * cost_f(theta) + barrier(theta, &g, &h);
      const Eigen::VectorXd step = h.ldlt().solve(-g);
      const double decrement = -g.dot(step);
      if (!(decrement > 2e-10)) break;
      double length = 1.0;
      bool descended = false;
      for (int halving = 0; halving < 60 && !descended; ++halving) {
        const Eigen::VectorXd trial = theta + length * step;
        const double b = barrier(trial, nullptr, nullptr);
        descended =
            std::isfinite(b) && weight_t * cost_f(trial) + b <= value - 0.25 * length * decrement;
        if (!descended) length *= 0.5;
      }
      if (!descended) break;  // round-off: Newton's step no longer descends, t's centre is here
      theta += length * step;
    }
    if (barrier_size / weight_t <= target_gap) {
      out.converged = true;
      break;
    }
    weight_t *= 10.0;
  }
  out.theta = theta;
  out.beta = id.base.beta(out.theta);
  const double rss = least_squares_rss;
  out.least_squares_relative_residual = id.fitted.relative_residual;
  const double yy =
      rss / std::max(id.fitted.relative_residual * id.fitted.relative_residual, 1e-300);
  const double growth = (a * (out.beta - id.fit.theta)).squaredNorm();
  out.relative_residual = std::sqrt((rss + growth) / yy);
  return out;
}

}  // namespace sid
