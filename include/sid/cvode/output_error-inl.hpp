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
  return static_cast<int>(std::min<Eigen::Index>(windows, thread_count(options.threads)));
}

SID_INLINE void check_output_error_problem(const OutputErrorProblem& problem,
                                           const OutputErrorOptions& options,
                                           const std::string& who) {
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
}

/// Per global unknown (the parameters, then log s): whether problem.fixed_parameters holds it.
SID_INLINE std::vector<bool> output_error_fixed_flags(const OutputErrorProblem& problem,
                                                      const std::string& who) {
  const Eigen::Index p = problem.theta0.size();
  std::vector<bool> is_fixed(static_cast<std::size_t>(p + 1), false);
  for (Eigen::Index u : problem.fixed_parameters) {
    if (u < 0 || u >= p)
      throw std::invalid_argument(who + "a fixed parameter index is out of range");
    is_fixed[static_cast<std::size_t>(u)] = true;
  }
  return is_fixed;
}

SID_INLINE std::vector<Eigen::Index> output_error_free_globals(const std::vector<bool>& is_fixed,
                                                               Eigen::Index globals) {
  std::vector<Eigen::Index> free_globals;
  for (Eigen::Index c = 0; c < globals; ++c)
    if (!is_fixed[static_cast<std::size_t>(c)]) free_globals.push_back(c);
  return free_globals;
}

/// What every stage of fit_output_error() reads: the problem, the layout of its unknowns
/// x = (theta, log s, per window q0, qd0, torque offset, torque slope) and the threads' tools.
struct OutputErrorContext {
  /// @throws std::invalid_argument if a fixed parameter index is out of range.
  OutputErrorContext(const OutputErrorProblem& problem, const OutputErrorOptions& options,
                     const std::string& who);

  const OutputErrorProblem& problem;
  const OutputErrorOptions& options;
  std::vector<bool> is_fixed;  ///< per global unknown
  Eigen::Index p;              ///< the model's parameters
  Eigen::Index g;              ///< global unknowns
  Eigen::Index nw;             ///< windows
  Eigen::Index unknowns;
  bool has_prior;
  bool compared;  ///< a compared fit (see OutputErrorOptions::comparison_cost)
  int threads;
  /// One interpolator per thread: it caches the interval of its last call.
  std::vector<TorqueInterpolator> torques;
  Eigen::VectorXd prior_weight;  ///< 1/prior_std, empty without a prior
  /// The globals not held: with a window's own unknowns, the unknowns that window touches, the
  /// columns of its Jacobian.
  std::vector<Eigen::Index> free_globals;
  Eigen::Index columns;  ///< of each window's Jacobian

  /// Index into x of window w's first own unknown.
  Eigen::Index window_offset(Eigen::Index w) const { return g + kWindowUnknowns * w; }
  /// Index into x of column c of window w's Jacobian.
  Eigen::Index column_unknown(Eigen::Index w, Eigen::Index c) const {
    return c < static_cast<Eigen::Index>(free_globals.size())
               ? free_globals[static_cast<std::size_t>(c)]
               : window_offset(w) + (c - static_cast<Eigen::Index>(free_globals.size()));
  }
};

SID_INLINE OutputErrorContext::OutputErrorContext(const OutputErrorProblem& problem,
                                                  const OutputErrorOptions& options,
                                                  const std::string& who)
    : problem(problem),
      options(options),
      is_fixed(output_error_fixed_flags(problem, who)),
      p(problem.theta0.size()),
      g(p + (problem.estimate_nonlinear ? 1 : 0)),
      nw(static_cast<Eigen::Index>(problem.windows.size())),
      unknowns(g + kWindowUnknowns * nw),
      has_prior(problem.prior_mean.size() > 0),
      compared(std::isfinite(options.comparison_cost)),
      threads(output_error_threads(options, nw)),
      torques(static_cast<std::size_t>(threads), TorqueInterpolator(problem.t, problem.tau)),
      prior_weight(has_prior ? Eigen::VectorXd(problem.prior_std.cwiseInverse())
                             : Eigen::VectorXd()),
      free_globals(output_error_free_globals(is_fixed, g)),
      columns(static_cast<Eigen::Index>(free_globals.size()) + kWindowUnknowns) {}

/// Where the Levenberg–Marquardt iteration stands.
struct OutputErrorState {
  Eigen::VectorXd x;                      ///< the unknowns
  std::vector<Eigen::VectorXd> residual;  ///< per window, at x
  double cost = 0;                        ///< at x
  double data_cost = 0;                   ///< the same without the prior term
  /// Per window: d(q_sim)/du over the unknowns it touches (see OutputErrorContext), normalised.
  std::vector<Eigen::MatrixXd> jacobian;
  /// Gauss–Newton normal matrix and gradient over all unknowns.
  Eigen::MatrixXd normal;
  Eigen::VectorXd gradient;
};

SID_INLINE Eigen::VectorXd output_error_initial_unknowns(const OutputErrorContext& ctx) {
  const OutputErrorProblem& problem = ctx.problem;
  Eigen::VectorXd x(ctx.unknowns);
  x.head(ctx.p) = problem.theta0;
  if (problem.estimate_nonlinear) x[ctx.p] = std::log(problem.s0);
  for (Eigen::Index w = 0; w < ctx.nw; ++w) {
    const auto& win = problem.windows[static_cast<std::size_t>(w)];
    x.segment<kWindowUnknowns>(ctx.window_offset(w)) = window_unknowns(win);
  }
  return x;
}

SID_INLINE Eigen::Index output_error_residual_count(const OutputErrorProblem& problem) {
  Eigen::Index residual_count = 0;
  for (const auto& w : problem.windows) residual_count += 2 * (w.end - w.begin);
  return residual_count;
}

/// The model at the nonlinear scalar of unknowns v.
SID_INLINE Model<double> output_error_model(const OutputErrorContext& ctx,
                                            const Eigen::VectorXd& v) {
  return ctx.problem.model_at(ctx.problem.estimate_nonlinear ? std::exp(v[ctx.p]) : ctx.problem.s0);
}

/// Normalised residuals of window w (2 m entries, joint 1 then joint 2) for unknowns v.
SID_INLINE bool output_error_window_residual(const OutputErrorContext& ctx,
                                             const Model<double>& model, const Eigen::VectorXd& v,
                                             Eigen::Index w, int thread, Eigen::VectorXd& r) {
  const TorqueInterpolator& torque = ctx.torques[static_cast<std::size_t>(thread)];
  const auto& win = ctx.problem.windows[static_cast<std::size_t>(w)];
  Eigen::MatrixXd q;
  const Eigen::Index o = ctx.window_offset(w);
  const Vector2<double> q0 = v.segment<2>(o), qd0 = v.segment<2>(o + 2);
  const Vector2<double> offset = v.segment<2>(o + 4), slope = v.segment<2>(o + 6);
  if (!simulate_window(model, v.head(ctx.p), torque, ctx.problem.t, win, q0, qd0, offset, slope,
                       ctx.options.simulator, q))
    return false;
  r = normalised_residual(ctx.problem, win, q);
  return true;
}

SID_INLINE Eigen::VectorXd output_error_prior_residual(const OutputErrorContext& ctx,
                                                       const Eigen::VectorXd& v) {
  if (!ctx.has_prior) return Eigen::VectorXd(Eigen::VectorXd::Zero(0));
  return Eigen::VectorXd((v.head(ctx.p) - ctx.problem.prior_mean).cwiseProduct(ctx.prior_weight));
}

/// Residuals of every window at v (empty where a simulation failed) and their total cost.
SID_INLINE double output_error_cost(const OutputErrorContext& ctx, const Eigen::VectorXd& v,
                                    std::vector<Eigen::VectorXd>& r, double* data_part) {
  const Model<double> model = output_error_model(ctx, v);
  r.assign(static_cast<std::size_t>(ctx.nw), Eigen::VectorXd());
  for_each_index(ctx.nw, ctx.threads, [&](Eigen::Index w, int thread) {
    Eigen::VectorXd& rw = r[static_cast<std::size_t>(w)];
    if (!output_error_window_residual(ctx, model, v, w, thread, rw)) rw.resize(0);
  });
  double cost = 0;
  for (const auto& rw : r) {  // in window order: the same sum for any threads
    if (rw.size() == 0) return std::numeric_limits<double>::infinity();
    cost += rw.squaredNorm();
  }
  if (data_part) *data_part = cost;
  return cost + output_error_prior_residual(ctx, v).squaredNorm();
}

/// Forward sensitivities at x, one task per window; log s's column from the model at a
/// slightly larger s. false if a simulation failed.
SID_INLINE bool output_error_jacobians(const OutputErrorContext& ctx, const Eigen::VectorXd& x,
                                       std::vector<Eigen::MatrixXd>& jacobian) {
  constexpr double kLogStep = 1e-6;
  const OutputErrorProblem& problem = ctx.problem;
  const Model<double> model = output_error_model(ctx, x);
  WindowParameters parameters;
  for (Eigen::Index u : ctx.free_globals)
    if (u < ctx.p) parameters.theta.push_back(u);
  Model<double> larger_s;
  if (problem.estimate_nonlinear && !ctx.is_fixed[static_cast<std::size_t>(ctx.p)]) {
    larger_s = problem.model_at(std::exp(x[ctx.p] + kLogStep));
    parameters.model_at_larger_s = &larger_s;
    parameters.log_step = kLogStep;
  }
  SimulatorOptions loose = ctx.options.simulator;
  loose.rtol = ctx.options.sensitivity_rtol;
  loose.atol = 0.1 * ctx.options.sensitivity_rtol;
  std::vector<char> ok(static_cast<std::size_t>(ctx.nw), 1);
  for_each_index(ctx.nw, ctx.threads, [&](Eigen::Index w, int thread) {
    const auto& win = problem.windows[static_cast<std::size_t>(w)];
    const Eigen::Index o = ctx.window_offset(w);
    ok[static_cast<std::size_t>(w)] = window_jacobian(
        model, x.head(ctx.p), parameters, ctx.torques[static_cast<std::size_t>(thread)], problem.t,
        win, x.segment<2>(o), x.segment<2>(o + 2), x.segment<2>(o + 4), x.segment<2>(o + 6),
        problem.sigma_q, loose, jacobian[static_cast<std::size_t>(w)]);
  });
  return std::all_of(ok.begin(), ok.end(), [](char o) { return o != 0; });
}

/// Gauss–Newton normal equations from the window blocks, the prior and the fixed parameters.
SID_INLINE void output_error_normal_equations(const OutputErrorContext& ctx,
                                              OutputErrorState& state) {
  Eigen::MatrixXd& normal = state.normal;
  Eigen::VectorXd& gradient = state.gradient;
  normal.setZero();
  gradient.setZero();
  for (Eigen::Index w = 0; w < ctx.nw; ++w) {
    const Eigen::MatrixXd& jac = state.jacobian[static_cast<std::size_t>(w)];
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const Eigen::VectorXd jtr = jac.transpose() * state.residual[static_cast<std::size_t>(w)];
    for (Eigen::Index a = 0; a < ctx.columns; ++a) {
      gradient[ctx.column_unknown(w, a)] += jtr[a];
      for (Eigen::Index b = 0; b < ctx.columns; ++b)
        normal(ctx.column_unknown(w, a), ctx.column_unknown(w, b)) += jtj(a, b);
    }
  }
  if (ctx.has_prior) {
    // The prior's residual (θ − μ)/σ adds 1/σ² to the normal matrix's diagonal.
    const Eigen::VectorXd information = ctx.prior_weight.cwiseAbs2();
    normal.diagonal().head(ctx.p) += information;
    gradient.head(ctx.p) -= information.cwiseProduct(state.x.head(ctx.p) - ctx.problem.prior_mean);
  }
  for (Eigen::Index u : ctx.problem.fixed_parameters) {
    normal.row(u).setZero();
    normal.col(u).setZero();
    normal(u, u) = 1.0;
    gradient[u] = 0.0;
  }
}

SID_INLINE bool output_error_below_tolerances(const OutputErrorOptions& options, double drop,
                                              double at_cost) {
  return drop < options.relative_tolerance * at_cost || drop < options.absolute_tolerance;
}

SID_INLINE bool output_error_negligible_drop(const OutputErrorContext& ctx, double drop,
                                             double at_cost) {
  const OutputErrorOptions& options = ctx.options;
  return output_error_below_tolerances(options, drop, at_cost) ||
         (ctx.compared &&
          drop < options.comparison_tolerance * (at_cost - options.comparison_cost));
}

/// The cost drop the Gauss–Newton model predicts for a step.
SID_INLINE double output_error_predicted_drop(const OutputErrorState& state,
                                              const Eigen::VectorXd& step) {
  return step.dot(2.0 * state.gradient - state.normal * step);
}

/// Broyden: make each window's Jacobian reproduce the change the step from state.x to
/// `candidate` caused (`trial`: the residuals at candidate).
SID_INLINE void output_error_broyden_update(const OutputErrorContext& ctx,
                                            const Eigen::VectorXd& candidate,
                                            const std::vector<Eigen::VectorXd>& trial,
                                            OutputErrorState& state) {
  for (Eigen::Index w = 0; w < ctx.nw; ++w) {
    Eigen::VectorXd d(ctx.columns);
    for (Eigen::Index a = 0; a < ctx.columns; ++a)
      d[a] = candidate[ctx.column_unknown(w, a)] - state.x[ctx.column_unknown(w, a)];
    const double dd = d.squaredNorm();
    if (!(dd > 0.0)) continue;
    Eigen::MatrixXd& jac = state.jacobian[static_cast<std::size_t>(w)];
    const Eigen::VectorXd change =
        state.residual[static_cast<std::size_t>(w)] - trial[static_cast<std::size_t>(w)];
    jac += (change - jac * d) * (d.transpose() / dd);
  }
}

/// How one iteration's damped steps went.
struct OutputErrorStepOutcome {
  bool accepted = false;  ///< a step lowered the cost: the state moved there
  bool small = false;     ///< ... by a negligible amount
  bool poor = false;      ///< ... by less than a quarter of the predicted drop
};

/// Levenberg–Marquardt steps from state.x, the damping mu growing until one lowers the cost
/// (then the state moves there, its Jacobians Broyden-updated) or the trials run out. `trial`
/// is a buffer for the trial residuals.
SID_INLINE OutputErrorStepOutcome output_error_damped_step(const OutputErrorContext& ctx,
                                                           bool confirming, double& mu,
                                                           std::vector<Eigen::VectorXd>& trial,
                                                           OutputErrorState& state) {
  const OutputErrorProblem& problem = ctx.problem;
  OutputErrorStepOutcome outcome;
  // After a negligible step the fresh Jacobian only confirms the minimum: where the cost is
  // flat to within the simulations' accuracy its step can fail however it is damped (12
  // trials, each one simulation per window, on Stribeck data), so fewer trials are spent.
  for (int tries = 0; tries < (confirming ? 4 : 12); ++tries) {
    Eigen::MatrixXd damped = state.normal;
    damped.diagonal() += mu * state.normal.diagonal().cwiseMax(1e-12);
    const Eigen::VectorXd step = damped.ldlt().solve(state.gradient);
    // Damped until the Gauss–Newton model predicts a drop below the tolerances, no step can
    // lower the cost by more: more damping would only spend simulations where the cost is
    // flat to within their accuracy (24 of the 37 evaluations of seed 11's Stribeck fit, joint
    // 2 of the multisine excitation, ramped the damping to 1e22 without a gain). Not the
    // compared fit's looser stop: a step it calls negligible may still settle its test.
    if (output_error_below_tolerances(ctx.options, output_error_predicted_drop(state, step),
                                      state.cost))
      break;
    Eigen::VectorXd candidate = state.x + step;
    if (problem.estimate_nonlinear)
      candidate[ctx.p] =
          std::clamp(candidate[ctx.p], std::log(problem.s_min), std::log(problem.s_max));
    double candidate_data = 0;
    const double c = output_error_cost(ctx, candidate, trial, &candidate_data);
    if (std::isfinite(c) && c < state.cost) {
      output_error_broyden_update(ctx, candidate, trial, state);
      const double cost_drop = state.cost - c;
      // From candidate − x, not step: s may have hit a bound.
      outcome.poor = cost_drop < 0.25 * output_error_predicted_drop(state, candidate - state.x);
      mu = std::max(mu / 10.0, 1e-9);
      outcome.small = output_error_negligible_drop(ctx, cost_drop, state.cost);
      state.x = candidate;
      state.residual.swap(trial);
      state.cost = c;
      state.data_cost = candidate_data;
      outcome.accepted = true;
      break;
    }
    mu *= 10.0;
  }
  return outcome;
}

/// Levenberg–Marquardt from the state's start (its residuals and cost evaluated). The
/// sensitivity Jacobian costs several simulations' time per window (a dozen unknowns ride
/// along); between them a Broyden update from each accepted step's residuals keeps it current
/// (the windows are nearly linear in their own unknowns), so most iterations cost one
/// simulation per window. Convergence is only declared on a fresh Jacobian, so the minimum
/// and the covariance are those of the full Gauss–Newton method (a compared fit, see
/// OutputErrorOptions::comparison_cost, excepted).
/// Sets fit's iterations, converged and message; returns whether a simulation failed while
/// forming a Jacobian (else the state's Jacobian is the one the covariance needs).
SID_INLINE bool output_error_levenberg_marquardt(const OutputErrorContext& ctx,
                                                 OutputErrorState& state, OutputErrorFit& fit) {
  double mu = 1e-3;
  bool confirming = false;
  bool fresh = output_error_jacobians(ctx, state.x, state.jacobian);
  bool failed = !fresh;
  if (failed) fit.message = "a simulation failed while forming the Jacobian at the start";
  std::vector<Eigen::VectorXd> trial;
  for (int it = 0; !failed && it < ctx.options.max_iterations; ++it) {
    fit.iterations = it + 1;
    output_error_normal_equations(ctx, state);
    const OutputErrorStepOutcome step = output_error_damped_step(ctx, confirming, mu, trial, state);
    const bool stale = !fresh;
    confirming = false;
    if (step.accepted && !step.small && !(step.poor && stale)) {
      fresh = false;
      continue;
    }
    // With a fresh Jacobian no step (or only a negligible one) lowers the cost; a compared fit
    // needs no more than a negligible step that went as predicted.
    if (fresh || (ctx.compared && step.accepted && step.small && !step.poor)) {
      fit.converged = true;
      break;
    }
    // The updated Jacobian may have misled the step or made it poor: go on with a fresh one.
    confirming = step.accepted && step.small;
    fresh = output_error_jacobians(ctx, state.x, state.jacobian);
    failed = !fresh;
    if (failed)
      fit.message =
          "a simulation failed while forming the Jacobian at iteration " + std::to_string(it + 1);
  }
  if (!failed && !fresh && !(ctx.compared && fit.converged))
    failed = !output_error_jacobians(ctx, state.x, state.jacobian);  // for the covariance
  if (!fit.converged && fit.message.empty())
    fit.message =
        failed ? "a simulation failed while forming the final Jacobian"
               : "not converged in " + std::to_string(ctx.options.max_iterations) + " iterations";
  return failed;
}

/// The estimates at state.x: parameters, s, windows and costs.
SID_INLINE void store_output_error_estimates(const OutputErrorContext& ctx,
                                             const OutputErrorState& state, OutputErrorFit& fit) {
  fit.theta = state.x.head(ctx.p);
  fit.cost = state.cost;
  fit.data_cost = state.data_cost;
  if (ctx.problem.estimate_nonlinear) fit.s = std::exp(state.x[ctx.p]);
  fit.windows = ctx.problem.windows;
  for (Eigen::Index w = 0; w < ctx.nw; ++w) {
    set_window_unknowns(fit.windows[static_cast<std::size_t>(w)],
                        state.x.segment<kWindowUnknowns>(ctx.window_offset(w)));
  }
}

/// Covariance of the globals: the inverse normal matrix's global block, scaled by the mean
/// square residual; s by the delta method from log s. Reassembles the normal equations from
/// the state's Jacobians; needs fit's residuals and s.
SID_INLINE void store_output_error_covariance(const OutputErrorContext& ctx,
                                              OutputErrorState& state, OutputErrorFit& fit) {
  const double dof = std::max<double>(1.0, static_cast<double>(fit.residuals - ctx.unknowns));
  const double scale = std::max(1.0, state.data_cost / dof);
  output_error_normal_equations(ctx, state);
  const Eigen::MatrixXd inverse =
      state.normal.ldlt().solve(Eigen::MatrixXd::Identity(ctx.unknowns, ctx.unknowns));
  fit.covariance = scale * inverse.topLeftCorner(ctx.g, ctx.g);
  for (Eigen::Index u : ctx.problem.fixed_parameters) {
    fit.covariance.row(u).setZero();
    fit.covariance.col(u).setZero();
  }
  if (ctx.problem.estimate_nonlinear) {
    fit.covariance.row(ctx.p) *= fit.s;
    fit.covariance.col(ctx.p) *= fit.s;
  }
}

/// What output_error_score_test() needs, moved out of the state: the windows' residuals and
/// Jacobians with their columns, and the normal equations.
SID_INLINE void store_output_error_score_inputs(const OutputErrorContext& ctx,
                                                OutputErrorState& state, OutputErrorFit& fit) {
  fit.window_residuals = std::move(state.residual);
  fit.window_jacobians = std::move(state.jacobian);
  for (Eigen::Index w = 0; w < ctx.nw; ++w) {
    std::vector<Eigen::Index> cols;
    for (Eigen::Index c = 0; c < ctx.columns; ++c) cols.push_back(ctx.column_unknown(w, c));
    fit.window_columns.push_back(std::move(cols));
  }
  fit.normal = state.normal;
  fit.gradient = state.gradient;
}

}  // namespace detail

SID_INLINE OutputErrorFit fit_output_error(const OutputErrorProblem& problem,
                                           const OutputErrorOptions& options) {
  const std::string who = "sid::fit_output_error: ";
  detail::check_output_error_problem(problem, options, who);
  const detail::OutputErrorContext ctx(problem, options, who);

  OutputErrorFit fit;
  fit.residuals = detail::output_error_residual_count(problem);
  fit.free_unknowns = ctx.unknowns - static_cast<Eigen::Index>(problem.fixed_parameters.size());
  detail::OutputErrorState state;
  state.x = detail::output_error_initial_unknowns(ctx);
  state.cost = detail::output_error_cost(ctx, state.x, state.residual, &state.data_cost);
  fit.initial_cost = state.cost;
  if (!std::isfinite(state.cost)) {
    fit.start_failed = true;
    fit.message = "the simulation from the starting values failed";
    fit.theta = problem.theta0;
    return fit;
  }
  state.jacobian.resize(static_cast<std::size_t>(ctx.nw));
  state.normal.resize(ctx.unknowns, ctx.unknowns);
  state.gradient.resize(ctx.unknowns);

  const bool failed = detail::output_error_levenberg_marquardt(ctx, state, fit);
  detail::store_output_error_estimates(ctx, state, fit);
  if (failed) {
    fit.covariance =
        Eigen::MatrixXd::Constant(ctx.g, ctx.g, std::numeric_limits<double>::quiet_NaN());
    return fit;
  }
  detail::store_output_error_covariance(ctx, state, fit);
  detail::store_output_error_score_inputs(ctx, state, fit);
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
  out.completed = true;
  out.direction = score;
  out.statistic = information > 0.0 ? score * score / information / scale : 0.0;
  return out;
}

}  // namespace sid
