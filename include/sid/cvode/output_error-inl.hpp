#pragma once
// Definitions of sid/cvode/output_error.hpp (see sid/config.hpp).

#include <sid/cvode/output_error.hpp>

namespace sid {

namespace detail {

SID_INLINE double window_middle(const Eigen::VectorXd& t, const OutputErrorWindow& w) {
  return 0.5 * (t[w.begin] + t[w.end - 1]);
}

SID_INLINE auto window_rhs(const Model<double>& model, const Eigen::VectorXd& theta,
                           const TorqueInterpolator& torque, double middle,
                           const Vector2<double>& torque_offset,
                           const Vector2<double>& torque_slope) {
  return [&model, &theta, &torque, middle, &torque_offset, &torque_slope](
             double time, const Eigen::Map<const Eigen::VectorXd>& x,
             Eigen::Map<Eigen::VectorXd>& xdot) {
    if (!x.allFinite() || x.cwiseAbs().maxCoeff() > 1e4) throw std::runtime_error("blow-up");
    const Vector2<double> q = x.head<2>(), qd = x.tail<2>();
    xdot.head<2>() = qd;
    xdot.tail<2>() = model.forward_dynamics(
        theta, q, qd, torque(time) + torque_offset + (time - middle) * torque_slope);
  };
}

SID_INLINE bool simulate_window(const Model<double>& model, const Eigen::VectorXd& theta,
                                const TorqueInterpolator& torque, const Eigen::VectorXd& t,
                                const OutputErrorWindow& w, const Vector2<double>& q0,
                                const Vector2<double>& qd0, const Vector2<double>& torque_offset,
                                const Vector2<double>& torque_slope,
                                const SimulatorOptions& options, Eigen::MatrixXd& q_out) {
  const auto rhs =
      window_rhs(model, theta, torque, window_middle(t, w), torque_offset, torque_slope);
  Eigen::VectorXd x0(4);
  x0 << q0, qd0;
  const SimulationResult sim = simulate(rhs, x0, t.segment(w.begin, w.end - w.begin), options);
  if (!sim.ok()) return false;
  q_out = sim.states.leftCols(2);
  return true;
}

SID_INLINE bool window_jacobian(const Model<double>& model, const Eigen::VectorXd& theta,
                                const WindowParameters& parameters,
                                const TorqueInterpolator& torque, const Eigen::VectorXd& t,
                                const OutputErrorWindow& w, const Vector2<double>& q0,
                                const Vector2<double>& qd0, const Vector2<double>& torque_offset,
                                const Vector2<double>& torque_slope, const Vector2<double>& sigma_q,
                                const SimulatorOptions& options, Eigen::MatrixXd& jacobian) {
  const double middle = window_middle(t, w);
  const auto thetas = static_cast<Eigen::Index>(parameters.theta.size());
  const Eigen::Index globals = thetas + (parameters.model_at_larger_s ? 1 : 0);
  const Eigen::Index columns = globals + kWindowUnknowns;
  const auto rhs = window_rhs(model, theta, torque, middle, torque_offset, torque_slope);
  Eigen::Matrix<double, 2, Eigen::Dynamic> forcing(2, columns);
  auto sensitivity_rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                             const Eigen::Map<const Eigen::VectorXd>& xdot,
                             const Eigen::MatrixXd& s, Eigen::MatrixXd& sdot) {
    constexpr double kStep = 1e-7;
    const Vector2<double> q = x.head<2>(), qd = x.tail<2>(), qdd = xdot.tail<2>();
    const ModelRegressor<double> z = model.regressor(q, qd, qdd);
    const Vector2<double> id = z * theta;
    Matrix2<double> mass, by_q, by_qd;
    for (int j = 0; j < 2; ++j) {
      const Vector2<double> e = Vector2<double>::Unit(j);
      mass.col(j) = model.inverse_dynamics(theta, q, qd, qdd + e) - id;  // exact: ID is linear in q̈
      by_q.col(j) = (model.inverse_dynamics(theta, q + kStep * e, qd, qdd) - id) / kStep;
      by_qd.col(j) = (model.inverse_dynamics(theta, q, qd + kStep * e, qdd) - id) / kStep;
    }
    forcing.setZero();
    for (Eigen::Index c = 0; c < thetas; ++c)
      forcing.col(c) = -z.col(parameters.theta[static_cast<std::size_t>(c)]);
    if (parameters.model_at_larger_s)
      forcing.col(thetas) =
          -(parameters.model_at_larger_s->inverse_dynamics(theta, q, qd, qdd) - id) /
          parameters.log_step;
    forcing.block<2, 2>(0, globals + 4).setIdentity();
    forcing.block<2, 2>(0, globals + 6) = (time - middle) * Matrix2<double>::Identity();
    sdot.topRows(2) = s.bottomRows(2);
    sdot.bottomRows(2) = mass.inverse() * (forcing - by_q * s.topRows(2) - by_qd * s.bottomRows(2));
  };
  Eigen::VectorXd x0(4);
  x0 << q0, qd0;
  Eigen::MatrixXd s0 = Eigen::MatrixXd::Zero(4, columns);
  s0.block<4, 4>(0, globals).setIdentity();
  const SensitivityResult sim = simulate_with_sensitivities(
      rhs, sensitivity_rhs, x0, s0, t.segment(w.begin, w.end - w.begin), options);
  if (!sim.ok()) return false;
  const Eigen::Index m = w.end - w.begin;
  jacobian.resize(2 * m, columns);
  for (Eigen::Index k = 0; k < m; ++k)
    for (Eigen::Index c = 0; c < columns; ++c)
      for (int j = 0; j < 2; ++j)
        jacobian(j * m + k, c) = sim.sensitivities(k, 4 * c + j) / sigma_q[j];
  return true;
}

SID_INLINE Eigen::VectorXd normalised_residual(const OutputErrorProblem& problem,
                                               const OutputErrorWindow& w,
                                               const Eigen::MatrixXd& q_simulated) {
  const Eigen::Index m = w.end - w.begin;
  Eigen::VectorXd r(2 * m);
  for (int j = 0; j < 2; ++j)
    r.segment(j * m, m) =
        (problem.q_measured.col(j).segment(w.begin, m) - q_simulated.col(j)) / problem.sigma_q[j];
  return r;
}

SID_INLINE int output_error_threads(const OutputErrorOptions& options, Eigen::Index windows) {
  return static_cast<int>(std::min<Eigen::Index>(
      windows,
      options.threads > 0 ? options.threads : std::max(1u, std::thread::hardware_concurrency())));
}

}  // namespace detail

SID_INLINE OutputErrorFit fit_output_error(const OutputErrorProblem& problem,
                                           const OutputErrorOptions& options) {
  const std::string who = "sid::fit_output_error: ";
  const Eigen::Index n = problem.t.size();
  if (problem.q_measured.rows() != n || problem.tau.rows() != n)
    throw std::invalid_argument(who + "t, q_measured and tau must have the same number of rows");
  if (!problem.model_at) throw std::invalid_argument(who + "model_at is empty");
  if (!(problem.s_min > 0.0) || !(problem.s_max >= problem.s_min) || !std::isfinite(problem.s_max))
    throw std::invalid_argument(who + "need 0 < s_min <= s_max < inf");
  if (!(problem.s0 >= problem.s_min) || !(problem.s0 <= problem.s_max))
    throw std::invalid_argument(who + "s0 must lie in [s_min, s_max]");
  if (!(problem.sigma_q.array() > 0.0).all())
    throw std::invalid_argument(who + "sigma_q must be > 0");
  if (problem.windows.empty()) throw std::invalid_argument(who + "no windows");
  for (const auto& w : problem.windows)
    if (!(w.begin >= 0 && w.end <= n && w.end - w.begin >= 2))
      throw std::invalid_argument(who + "a window lies outside the data or has < 2 samples");
  const bool has_prior = problem.prior_mean.size() > 0;
  if (has_prior && (problem.prior_mean.size() != problem.theta0.size() ||
                    problem.prior_std.size() != problem.theta0.size() ||
                    !(problem.prior_std.array() > 0.0).all() || !problem.prior_mean.allFinite()))
    throw std::invalid_argument(who +
                                "prior_mean and prior_std need one entry per parameter, "
                                "finite means and stds > 0");
  if (options.max_iterations < 1) throw std::invalid_argument(who + "max_iterations must be >= 1");
  if (!(options.sensitivity_rtol > 0.0) || !std::isfinite(options.sensitivity_rtol))
    throw std::invalid_argument(who + "sensitivity_rtol must be finite and > 0");
  if (!(options.comparison_tolerance >= 0.0) || !(options.comparison_tolerance < 1.0) ||
      std::isnan(options.comparison_cost) ||
      options.comparison_cost == std::numeric_limits<double>::infinity())
    throw std::invalid_argument(
        who + "need 0 <= comparison_tolerance < 1 and comparison_cost < inf (or -inf: none)");

  const Eigen::Index p = problem.theta0.size();
  std::vector<bool> is_fixed(static_cast<std::size_t>(p + 1), false);
  for (Eigen::Index u : problem.fixed_parameters) {
    if (u < 0 || u >= p)
      throw std::invalid_argument(who + "a fixed parameter index is out of range");
    is_fixed[static_cast<std::size_t>(u)] = true;
  }
  const Eigen::Index g = p + (problem.estimate_nonlinear ? 1 : 0);  // global unknowns
  const auto nw = static_cast<Eigen::Index>(problem.windows.size());
  const Eigen::Index local = detail::kWindowUnknowns;
  const Eigen::Index unknowns = g + local * nw;
  const int threads = detail::output_error_threads(options, nw);
  // One interpolator per thread: it caches the interval of its last call.
  const std::vector<detail::TorqueInterpolator> torques(
      static_cast<std::size_t>(threads), detail::TorqueInterpolator(problem.t, problem.tau));
  const Eigen::VectorXd prior_weight =
      has_prior ? Eigen::VectorXd(problem.prior_std.cwiseInverse()) : Eigen::VectorXd();

  // x = (theta, log s, per window q0, qd0, torque offset, torque slope)
  Eigen::VectorXd x(unknowns);
  x.head(p) = problem.theta0;
  if (problem.estimate_nonlinear) x[p] = std::log(problem.s0);
  for (Eigen::Index w = 0; w < nw; ++w) {
    const auto& win = problem.windows[static_cast<std::size_t>(w)];
    x.segment<detail::kWindowUnknowns>(g + local * w) = detail::window_unknowns(win);
  }
  Eigen::Index residual_count = 0;
  for (const auto& w : problem.windows) residual_count += 2 * (w.end - w.begin);

  const auto model_for = [&](const Eigen::VectorXd& v) {
    return problem.model_at(problem.estimate_nonlinear ? std::exp(v[p]) : problem.s0);
  };
  // Normalised residuals of window w (2 m entries, joint 1 then joint 2) for unknowns v.
  const auto window_residual = [&](const Model<double>& model, const Eigen::VectorXd& v,
                                   Eigen::Index w, int thread, Eigen::VectorXd& r) {
    const detail::TorqueInterpolator& torque = torques[static_cast<std::size_t>(thread)];
    const auto& win = problem.windows[static_cast<std::size_t>(w)];
    Eigen::MatrixXd q;
    const Eigen::Index o = g + local * w;
    const Vector2<double> q0 = v.segment<2>(o), qd0 = v.segment<2>(o + 2);
    const Vector2<double> offset = v.segment<2>(o + 4), slope = v.segment<2>(o + 6);
    if (!detail::simulate_window(model, v.head(p), torque, problem.t, win, q0, qd0, offset, slope,
                                 options.simulator, q))
      return false;
    r = detail::normalised_residual(problem, win, q);
    return true;
  };
  const auto prior_residual = [&](const Eigen::VectorXd& v) {
    if (!has_prior) return Eigen::VectorXd(Eigen::VectorXd::Zero(0));
    return Eigen::VectorXd((v.head(p) - problem.prior_mean).cwiseProduct(prior_weight));
  };
  // Residuals of every window at v (empty where a simulation failed) and their total cost.
  const auto evaluate = [&](const Eigen::VectorXd& v, std::vector<Eigen::VectorXd>& r,
                            double* data_part) {
    const Model<double> model = model_for(v);
    r.assign(static_cast<std::size_t>(nw), Eigen::VectorXd());
    detail::for_each_index(nw, threads, [&](Eigen::Index w, int thread) {
      Eigen::VectorXd& rw = r[static_cast<std::size_t>(w)];
      if (!window_residual(model, v, w, thread, rw)) rw.resize(0);
    });
    double c = 0;
    for (const auto& rw : r) {  // in window order: the same sum for any threads
      if (rw.size() == 0) return std::numeric_limits<double>::infinity();
      c += rw.squaredNorm();
    }
    if (data_part) *data_part = c;
    return c + prior_residual(v).squaredNorm();
  };

  OutputErrorFit fit;
  fit.residuals = residual_count;
  fit.free_unknowns = unknowns - static_cast<Eigen::Index>(problem.fixed_parameters.size());
  double data_cost = 0;
  std::vector<Eigen::VectorXd> residual;  // per window, at x
  double cost = evaluate(x, residual, &data_cost);
  fit.initial_cost = cost;
  if (!std::isfinite(cost)) {
    fit.ok = false;
    fit.message = "the simulation from the starting values failed";
    fit.theta = problem.theta0;
    return fit;
  }

  // Per window: the columns it touches (the free globals and its own unknowns) and d(q_sim)/du
  // over them, normalised.
  std::vector<Eigen::Index> free_globals;
  for (Eigen::Index c = 0; c < g; ++c)
    if (!is_fixed[static_cast<std::size_t>(c)]) free_globals.push_back(c);
  const auto columns = static_cast<Eigen::Index>(free_globals.size()) + local;
  const auto column_unknown = [&](Eigen::Index w, Eigen::Index c) {
    return c < static_cast<Eigen::Index>(free_globals.size())
               ? free_globals[static_cast<std::size_t>(c)]
               : g + local * w + (c - static_cast<Eigen::Index>(free_globals.size()));
  };
  std::vector<Eigen::MatrixXd> jacobian(static_cast<std::size_t>(nw));
  // Forward sensitivities at x, one task per window; log s's column from the model at a
  // slightly larger s.
  constexpr double kLogStep = 1e-6;
  const auto sensitivity_jacobian = [&]() {
    const Model<double> model = model_for(x);
    detail::WindowParameters parameters;
    for (Eigen::Index u : free_globals)
      if (u < p) parameters.theta.push_back(u);
    Model<double> larger_s;
    if (problem.estimate_nonlinear && !is_fixed[static_cast<std::size_t>(p)]) {
      larger_s = problem.model_at(std::exp(x[p] + kLogStep));
      parameters.model_at_larger_s = &larger_s;
      parameters.log_step = kLogStep;
    }
    SimulatorOptions loose = options.simulator;
    loose.rtol = options.sensitivity_rtol;
    loose.atol = 0.1 * options.sensitivity_rtol;
    std::vector<char> ok(static_cast<std::size_t>(nw), 1);
    detail::for_each_index(nw, threads, [&](Eigen::Index w, int thread) {
      const auto& win = problem.windows[static_cast<std::size_t>(w)];
      const Eigen::Index o = g + local * w;
      ok[static_cast<std::size_t>(w)] = detail::window_jacobian(
          model, x.head(p), parameters, torques[static_cast<std::size_t>(thread)], problem.t, win,
          x.segment<2>(o), x.segment<2>(o + 2), x.segment<2>(o + 4), x.segment<2>(o + 6),
          problem.sigma_q, loose, jacobian[static_cast<std::size_t>(w)]);
    });
    return std::all_of(ok.begin(), ok.end(), [](char o) { return o != 0; });
  };
  Eigen::MatrixXd normal(unknowns, unknowns);
  Eigen::VectorXd gradient(unknowns);
  // Gauss–Newton normal equations from the window blocks, the prior and the fixed parameters.
  const auto assemble = [&]() {
    normal.setZero();
    gradient.setZero();
    for (Eigen::Index w = 0; w < nw; ++w) {
      const Eigen::MatrixXd& jac = jacobian[static_cast<std::size_t>(w)];
      const Eigen::MatrixXd jtj = jac.transpose() * jac;
      const Eigen::VectorXd jtr = jac.transpose() * residual[static_cast<std::size_t>(w)];
      for (Eigen::Index a = 0; a < columns; ++a) {
        gradient[column_unknown(w, a)] += jtr[a];
        for (Eigen::Index b = 0; b < columns; ++b)
          normal(column_unknown(w, a), column_unknown(w, b)) += jtj(a, b);
      }
    }
    if (has_prior) {
      // The prior's residual (θ − μ)/σ adds 1/σ² to the normal matrix's diagonal.
      const Eigen::VectorXd information = prior_weight.cwiseAbs2();
      normal.diagonal().head(p) += information;
      gradient.head(p) -= information.cwiseProduct(x.head(p) - problem.prior_mean);
    }
    for (Eigen::Index u : problem.fixed_parameters) {
      normal.row(u).setZero();
      normal.col(u).setZero();
      normal(u, u) = 1.0;
      gradient[u] = 0.0;
    }
  };

  // Levenberg–Marquardt. The sensitivity Jacobian costs several simulations' time per window
  // (a dozen unknowns ride along); between them a Broyden update from each accepted step's
  // residuals keeps it current (the windows are nearly linear in their own unknowns), so most
  // iterations cost one
  // simulation per window. Convergence is only declared on a fresh Jacobian, so the minimum
  // and the covariance are those of the full Gauss–Newton method (a compared fit, see
  // OutputErrorOptions::comparison_cost, excepted).
  const bool compared = std::isfinite(options.comparison_cost);
  const auto below_tolerances = [&](double drop, double at_cost) {
    return drop < options.relative_tolerance * at_cost || drop < options.absolute_tolerance;
  };
  const auto negligible = [&](double drop, double at_cost) {
    return below_tolerances(drop, at_cost) ||
           (compared && drop < options.comparison_tolerance * (at_cost - options.comparison_cost));
  };
  // The cost drop the Gauss–Newton model predicts for a step.
  const auto predicted_drop = [&](const Eigen::VectorXd& step) {
    return step.dot(2.0 * gradient - normal * step);
  };
  double mu = 1e-3;
  bool confirming = false;
  bool fresh = sensitivity_jacobian();
  bool failed = !fresh;
  if (failed) fit.message = "a simulation failed while forming the Jacobian at the start";
  std::vector<Eigen::VectorXd> trial;
  for (int it = 0; !failed && it < options.max_iterations; ++it) {
    fit.iterations = it + 1;
    assemble();
    bool accepted = false, small = false, poor = false;
    // After a negligible step the fresh Jacobian only confirms the minimum: where the cost is
    // flat to within the simulations' accuracy its step can fail however it is damped (12
    // trials, each one simulation per window, on Stribeck data), so fewer trials are spent.
    for (int tries = 0; tries < (confirming ? 4 : 12); ++tries) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += mu * normal.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = damped.ldlt().solve(gradient);
      // Damped until the Gauss–Newton model predicts a drop below the tolerances, no step can
      // lower the cost by more: more damping would only spend simulations where the cost is
      // flat to within their accuracy (24 of the 37 evaluations of seed 11's Stribeck fit, joint
      // 2 of the multisine excitation, ramped the damping to 1e22 without a gain). Not the
      // compared fit's looser stop: a step it calls negligible may still settle its test.
      if (below_tolerances(predicted_drop(step), cost)) break;
      Eigen::VectorXd candidate = x + step;
      if (problem.estimate_nonlinear)
        candidate[p] = std::clamp(candidate[p], std::log(problem.s_min), std::log(problem.s_max));
      double candidate_data = 0;
      const double c = evaluate(candidate, trial, &candidate_data);
      if (std::isfinite(c) && c < cost) {
        // Broyden: make each window's Jacobian reproduce the change the step caused.
        for (Eigen::Index w = 0; w < nw; ++w) {
          Eigen::VectorXd d(columns);
          for (Eigen::Index a = 0; a < columns; ++a)
            d[a] = candidate[column_unknown(w, a)] - x[column_unknown(w, a)];
          const double dd = d.squaredNorm();
          if (!(dd > 0.0)) continue;
          Eigen::MatrixXd& jac = jacobian[static_cast<std::size_t>(w)];
          const Eigen::VectorXd change =
              residual[static_cast<std::size_t>(w)] - trial[static_cast<std::size_t>(w)];
          jac += (change - jac * d) * (d.transpose() / dd);
        }
        const double cost_drop = cost - c;
        poor =
            cost_drop < 0.25 * predicted_drop(candidate - x);  // not step: s may have hit a bound
        mu = std::max(mu / 10.0, 1e-9);
        small = negligible(cost_drop, cost);
        x = candidate;
        residual.swap(trial);
        cost = c;
        data_cost = candidate_data;
        accepted = true;
        break;
      }
      mu *= 10.0;
    }
    const bool stale = !fresh;
    confirming = false;
    if (accepted && !small && !(poor && stale)) {
      fresh = false;
      continue;
    }
    // With a fresh Jacobian no step (or only a negligible one) lowers the cost; a compared fit
    // needs no more than a negligible step that went as predicted.
    if (fresh || (compared && accepted && small && !poor)) {
      fit.converged = true;
      break;
    }
    // The updated Jacobian may have misled the step or made it poor: go on with a fresh one.
    confirming = accepted && small;
    fresh = sensitivity_jacobian();
    failed = !fresh;
    if (failed)
      fit.message =
          "a simulation failed while forming the Jacobian at iteration " + std::to_string(it + 1);
  }
  if (!failed && !fresh && !(compared && fit.converged))
    failed = !sensitivity_jacobian();  // for the covariance
  if (!fit.converged && fit.message.empty())
    fit.message =
        failed ? "a simulation failed while forming the final Jacobian"
               : "not converged in " + std::to_string(options.max_iterations) + " iterations";

  fit.theta = x.head(p);
  fit.cost = cost;
  fit.data_cost = data_cost;
  if (problem.estimate_nonlinear) fit.s = std::exp(x[p]);
  fit.windows = problem.windows;
  for (Eigen::Index w = 0; w < nw; ++w) {
    detail::set_window_unknowns(fit.windows[static_cast<std::size_t>(w)],
                                x.segment<detail::kWindowUnknowns>(g + local * w));
  }
  // Covariance of the globals: the inverse normal matrix's global block, scaled by the mean
  // square residual; s by the delta method from log s.
  const double dof = std::max<double>(1.0, static_cast<double>(residual_count - unknowns));
  const double scale = std::max(1.0, data_cost / dof);
  if (failed) {
    fit.covariance = Eigen::MatrixXd::Constant(g, g, std::numeric_limits<double>::quiet_NaN());
    return fit;
  }
  assemble();
  const Eigen::MatrixXd inverse =
      normal.ldlt().solve(Eigen::MatrixXd::Identity(unknowns, unknowns));
  fit.covariance = scale * inverse.topLeftCorner(g, g);
  for (Eigen::Index u : problem.fixed_parameters) {
    fit.covariance.row(u).setZero();
    fit.covariance.col(u).setZero();
  }
  if (problem.estimate_nonlinear) {
    fit.covariance.row(p) *= fit.s;
    fit.covariance.col(p) *= fit.s;
  }
  fit.window_residuals = std::move(residual);
  fit.window_jacobians = std::move(jacobian);
  for (Eigen::Index w = 0; w < nw; ++w) {
    std::vector<Eigen::Index> cols;
    for (Eigen::Index c = 0; c < columns; ++c) cols.push_back(column_unknown(w, c));
    fit.window_columns.push_back(std::move(cols));
  }
  fit.normal = normal;
  fit.gradient = gradient;
  return fit;
}

SID_INLINE OutputErrorStart nested_start(const OutputErrorFit& fit,
                                         const std::vector<Eigen::Index>& held,
                                         const Eigen::Ref<const Eigen::VectorXd>& values) {
  const std::string who = "sid::nested_start: ";
  const Eigen::Index p = fit.theta.size(), g = p + (std::isnan(fit.s) ? 0 : 1);
  const auto nw = static_cast<Eigen::Index>(fit.windows.size());
  constexpr Eigen::Index kLocal = detail::kWindowUnknowns;
  const Eigen::Index unknowns = g + kLocal * nw;
  if (nw == 0 || fit.normal.rows() != unknowns || fit.normal.cols() != unknowns ||
      fit.gradient.size() != unknowns)
    throw std::invalid_argument(
        who + "the fit holds no normal matrix and gradient over its unknowns (did it fail?)");
  if (static_cast<Eigen::Index>(held.size()) != values.size())
    throw std::invalid_argument(who + "held and values differ in size");
  Eigen::VectorXd delta = Eigen::VectorXd::Zero(unknowns);
  std::vector<char> is_held(static_cast<std::size_t>(unknowns), 0);
  for (std::size_t k = 0; k < held.size(); ++k) {
    const Eigen::Index u = held[k];
    if (u < 0 || u >= p)
      throw std::invalid_argument(who + "a held index is not one of the fit's parameters");
    is_held[static_cast<std::size_t>(u)] = 1;
    delta[u] = values[static_cast<Eigen::Index>(k)] - fit.theta[u];
  }
  if (g > p) is_held[static_cast<std::size_t>(p)] = 1;
  std::vector<Eigen::Index> free;
  for (Eigen::Index u = 0; u < unknowns; ++u)
    if (!is_held[static_cast<std::size_t>(u)]) free.push_back(u);
  // N_FF δ_F = g_F − N_FH δ_H: the fit's own step equation with the held entries moved to the
  // right. A parameter the fit held has an identity row and a zero gradient, so it stays.
  const Eigen::VectorXd pulled = fit.normal * delta;
  const auto nf = static_cast<Eigen::Index>(free.size());
  Eigen::MatrixXd normal_free(nf, nf);
  Eigen::VectorXd rhs(nf);
  for (Eigen::Index a = 0; a < nf; ++a) {
    rhs[a] =
        fit.gradient[free[static_cast<std::size_t>(a)]] - pulled[free[static_cast<std::size_t>(a)]];
    for (Eigen::Index b = 0; b < nf; ++b)
      normal_free(a, b) =
          fit.normal(free[static_cast<std::size_t>(a)], free[static_cast<std::size_t>(b)]);
  }
  const Eigen::VectorXd step = normal_free.ldlt().solve(rhs);
  for (Eigen::Index a = 0; a < nf; ++a) delta[free[static_cast<std::size_t>(a)]] = step[a];
  OutputErrorStart start;
  start.theta = fit.theta + delta.head(p);
  start.windows = fit.windows;
  for (Eigen::Index w = 0; w < nw; ++w) {
    OutputErrorWindow& win = start.windows[static_cast<std::size_t>(w)];
    detail::set_window_unknowns(
        win, detail::window_unknowns(win) + delta.segment<kLocal>(g + kLocal * w));
  }
  return start;
}

SID_INLINE OutputErrorScore output_error_score_test(const OutputErrorProblem& problem,
                                                    const OutputErrorFit& fit,
                                                    const Model<double>& extended,
                                                    const Eigen::VectorXd& theta_extended,
                                                    Eigen::Index added, double step,
                                                    const OutputErrorOptions& options) {
  const std::string who = "sid::output_error_score_test: ";
  const auto nw = static_cast<Eigen::Index>(fit.windows.size());
  if (theta_extended.size() != fit.theta.size() + 1 || added < 0 || added >= theta_extended.size())
    throw std::invalid_argument(who + "theta_extended must be the fit's parameters plus one");
  if (problem.windows.size() != fit.windows.size())
    throw std::invalid_argument(who + "the fit is not one of this problem (its windows differ)");
  OutputErrorScore out;
  if (static_cast<Eigen::Index>(fit.window_jacobians.size()) != nw || nw == 0 ||
      fit.normal.rows() == 0 || fit.gradient.size() != fit.normal.rows())
    return out;  // the fit failed: nothing to test at
  if (!(step != 0.0) || !std::isfinite(step))
    throw std::invalid_argument(who + "step must be finite and != 0");
  const int threads = detail::output_error_threads(options, nw);
  const std::vector<detail::TorqueInterpolator> torques(
      static_cast<std::size_t>(threads), detail::TorqueInterpolator(problem.t, problem.tau));
  Eigen::VectorXd moved = theta_extended;
  moved[added] += step;
  std::vector<Eigen::VectorXd> derivative(static_cast<std::size_t>(nw));
  std::vector<char> ok(static_cast<std::size_t>(nw), 0);
  detail::for_each_index(nw, threads, [&](Eigen::Index w, int thread) {
    const OutputErrorWindow& win = fit.windows[static_cast<std::size_t>(w)];
    Eigen::MatrixXd q;
    if (!detail::simulate_window(extended, moved, torques[static_cast<std::size_t>(thread)],
                                 problem.t, win, win.q0, win.qd0, win.torque_offset,
                                 win.torque_slope, options.simulator, q))
      return;
    derivative[static_cast<std::size_t>(w)] = (fit.window_residuals[static_cast<std::size_t>(w)] -
                                               detail::normalised_residual(problem, win, q)) /
                                              step;
    ok[static_cast<std::size_t>(w)] = 1;
  });
  if (!std::all_of(ok.begin(), ok.end(), [](char o) { return o != 0; })) return out;
  // Efficient score s = jᵀr − cᵀ N⁻¹ g with c = Jᵀj and g the gradient the fit left, and its
  // information d − cᵀ N⁻¹ c (the other unknowns re-adjusting).
  // Without −cᵀ N⁻¹ g the score depends on how close to its minimum the fit stopped: on Coulomb
  // data (joint 2, multisine, seed 12) that term was a quarter to a half of jᵀr, and a fit that
  // stopped within 0.1 of the same cost moved the statistic from 2.1 to 5.0, across the screen.
  double score = 0, information = 0;
  Eigen::VectorXd cross = Eigen::VectorXd::Zero(fit.normal.rows());
  for (Eigen::Index w = 0; w < nw; ++w) {
    const Eigen::VectorXd& j = derivative[static_cast<std::size_t>(w)];
    const Eigen::VectorXd& r = fit.window_residuals[static_cast<std::size_t>(w)];
    const Eigen::MatrixXd& jacobian = fit.window_jacobians[static_cast<std::size_t>(w)];
    score += j.dot(r);
    information += j.squaredNorm();
    const Eigen::VectorXd c = jacobian.transpose() * j;
    const auto& cols = fit.window_columns[static_cast<std::size_t>(w)];
    for (std::size_t a = 0; a < cols.size(); ++a) cross[cols[a]] += c[static_cast<Eigen::Index>(a)];
  }
  for (Eigen::Index u : problem.fixed_parameters) cross[u] = 0.0;
  const Eigen::LDLT<Eigen::MatrixXd> normal(fit.normal);
  score -= cross.dot(normal.solve(fit.gradient));
  information -= cross.dot(normal.solve(cross));
  const double dof = std::max<double>(1.0, static_cast<double>(fit.residuals - fit.free_unknowns));
  const double scale = std::max(1.0, fit.data_cost / dof);
  out.ok = true;
  out.direction = score;
  out.statistic = information > 0.0 ? score * score / information / scale : 0.0;
  return out;
}

}  // namespace sid
