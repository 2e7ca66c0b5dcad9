#pragma once
// Definitions of <sid/chain_consistency.hpp>: inline in header-only mode, compiled once in the
// compiled library (see sid/config.hpp).

#include <sid/chain_consistency.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <cmath>
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
  Eigen::VectorXd z(links + drives);
  for (int i = 0; i < n; ++i) {
    const LinkParameters<double> phi = prior.segment<10>(10 * i);
    out.prior_inconsistency.push_back(link_inconsistency(phi));
    z.segment<10>(10 * i) = log_cholesky_from_link_parameters(phi);
  }
  z.tail(drives) = prior.tail(drives);

  // r is upper triangular (the QR's factor): below its diagonal it holds zeros.
  const Eigen::MatrixXd a = id.fit.r * id.fit.column_scale.asDiagonal();
  const Eigen::VectorXd weight =
      std::sqrt(options.prior_weight) * (prior.cwiseAbs().array() + 0.01).inverse().matrix();
  const auto theta_of = [&](const Eigen::VectorXd& zz) {
    Eigen::VectorXd theta(p);
    for (int i = 0; i < n; ++i)
      theta.segment<10>(10 * i) = link_parameters_from_log_cholesky(zz.segment<10>(10 * i));
    theta.tail(drives) = zz.tail(drives);
    return theta;
  };
  const Eigen::Index r = id.base.rank();
  const auto residual = [&](const Eigen::VectorXd& zz) {
    const Eigen::VectorXd theta = theta_of(zz);
    Eigen::VectorXd res(r + p);
    res.head(r) = a * (id.base.beta(theta) - id.fit.theta);
    res.tail(p) = weight.cwiseProduct(theta - prior);
    return res;
  };

  Eigen::VectorXd res = residual(z);
  double cost = res.squaredNorm(), mu = 1e-3;
  Eigen::MatrixXd jac(r + p, z.size());
  std::vector<double> history;
  const double least_squares_rss = id.fit.residual.squaredNorm();
  for (out.iterations = 0; out.iterations < options.max_iterations; ++out.iterations) {
    for (Eigen::Index k = 0; k < z.size(); ++k) {  // central differences
      const double h = 1e-6 * (1.0 + std::abs(z[k]));
      Eigen::VectorXd up = z, down = z;
      up[k] += h;
      down[k] -= h;
      jac.col(k) = (residual(up) - residual(down)) / (2.0 * h);
    }
    const Eigen::MatrixXd normal = jac.transpose() * jac;
    const Eigen::VectorXd gradient = jac.transpose() * res;
    bool improved = false;
    for (int attempt = 0; attempt < 30 && !improved; ++attempt) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += mu * normal.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = damped.ldlt().solve(-gradient);
      const Eigen::VectorXd trial = z + step;
      const Eigen::VectorXd trial_res = residual(trial);
      const double trial_cost = trial_res.squaredNorm();
      if (std::isfinite(trial_cost) && trial_cost < cost) {
        z = trial;
        res = trial_res;
        cost = trial_cost;
        mu = std::max(mu / 3.0, 1e-12);
        improved = true;
      } else {
        mu *= 4.0;
      }
    }
    // The best real body often lies on the boundary (a link flat along an axis), which the
    // log-Cholesky numbers reach only asymptotically: the cost then keeps falling, ever more
    // slowly. Stop once ten steps together gain less than the tolerance of the residual sum of
    // squares (nothing a user would see) or 1e-4 of the cost itself.
    history.push_back(cost);
    if (history.size() > 10) {
      const double gain = history[history.size() - 11] - cost;
      if (gain <= options.tolerance * (least_squares_rss + cost) || gain <= 1e-4 * cost)
        out.converged = true;
    }
    if (!improved) out.converged = true;  // no step lowers the cost: a minimum to round-off
    if (out.converged) break;
  }
  out.theta = theta_of(z);
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
