#pragma once
/// @file
/// @brief Output-error estimation: the parameters of a model chosen so that its simulations,
/// driven by the applied torque, reproduce the measured angles over a set of time windows, each
/// with its own free initial state (multiple shooting).
///
/// Why, next to the torque-domain least squares: a regression on smoothed q̂̈ sees only what
/// survives the smoothing spline's bandwidth. Effects that act in tens of milliseconds (the
/// Stribeck bump at a velocity reversal) are smeared there, so the regression fixes only their
/// area. The measured angles keep the full bandwidth: a Cramér–Rao computation on the paper's
/// excitation (σq = 1e-3 rad, 1 s windows) bounds Fs's standard deviation at 3 % on joint 1 and
/// 0.3 % on joint 2, where the torque-domain fit leaves it 20–40 % low.

#include <sid/cvode/free_simulation.hpp>
#include <sid/cvode/simulator.hpp>
#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <functional>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace sid {

/// @brief Settings of fit_output_error().
struct OutputErrorOptions {
  int max_iterations = 15;  ///< Levenberg–Marquardt iterations, >= 1
  /// Stop when an accepted step lowers the cost by less than this fraction of it, > 0.
  double relative_tolerance = 1e-7;
  /// ... or by less than this [χ² units]: a change that no test or standard deviation notices.
  double absolute_tolerance = 0.1;
  /// CVODE settings of the simulations. BDF: a friction term Fc tanh(q̇/ε) is stiff near a
  /// reversal. 1e-9 keeps the finite-difference Jacobian (steps of 1e-4 relative) accurate to
  /// about 1e-5.
  /// Threads over the windows (each window's simulations are independent); 0: the hardware's.
  /// The result does not depend on it.
  int threads = 0;
  SimulatorOptions simulator = [] {
    SimulatorOptions s;
    s.method = IntegrationMethod::Bdf;
    s.rtol = 1e-8;
    s.atol = 1e-9;
    s.max_steps = 20000;
    return s;
  }();
};

/// @brief One multiple-shooting window: rows [begin, end) of the data, simulated from a free
/// initial state (q, q̇) that starts at the given guess.
struct OutputErrorWindow {
  Eigen::Index begin = 0, end = 0;
  Vector2<double> q0 = Vector2<double>::Zero(), qd0 = Vector2<double>::Zero();
  /// A constant torque added to the input over the window [N m], estimated (starts at 0).
  Vector2<double> torque_offset = Vector2<double>::Zero();
  /// Its rate of change over the window [N m/s] (about the window's middle), estimated.
  Vector2<double> torque_slope = Vector2<double>::Zero();
};

/// @brief An output-error problem. The model may depend on one nonlinear scalar s > 0 (a
/// Stribeck velocity): model_at(s) builds it; s is estimated in log s. Without it
/// (estimate_nonlinear false) model_at is called with s0 only.
struct OutputErrorProblem {
  std::function<Model<double>(double)> model_at;
  Eigen::VectorXd theta0;  ///< start of the model's parameters
  /// Indices into theta0 of parameters held at their start values (each costs one simulation
  /// per window and iteration when free).
  std::vector<Eigen::Index> fixed_parameters;
  double s0 = 1.0;         ///< start of the nonlinear scalar (> 0)
  /// Bounds the estimate of s is kept within (where its bump vanishes, s has no gradient and
  /// would otherwise wander off).
  double s_min = 1e-6, s_max = 1e6;
  bool estimate_nonlinear = false;
  /// Independent Gaussian priors on the parameters (empty, or theta0.size() entries; an
  /// infinite std is no prior): what another estimate (the torque-domain fit) already says.
  Eigen::VectorXd prior_mean, prior_std;
  Eigen::VectorXd t;               ///< sample times [s], strictly increasing
  MatrixX2<double> q_measured;     ///< measured angles [rad]
  MatrixX2<double> tau;            ///< the applied torque at t [N m] (smooth: see the caller)
  Vector2<double> sigma_q = Vector2<double>::Ones();  ///< angle noise per joint [rad]
  std::vector<OutputErrorWindow> windows;
};

/// @brief The result of fit_output_error().
struct OutputErrorFit {
  Eigen::VectorXd theta;   ///< the model's parameters
  double s = std::numeric_limits<double>::quiet_NaN();  ///< the nonlinear scalar (if estimated)
  /// Covariance of (theta, s) from the Gauss–Newton information, scaled by the fit's mean
  /// square normalised residual (1 when sigma_q is right and the model fits).
  Eigen::MatrixXd covariance;
  double initial_cost = 0, cost = 0;  ///< Σ ((q − q_sim)/σq)² over the windows (+ prior term)
  double data_cost = 0;               ///< the same without the prior term
  Eigen::Index residuals = 0;         ///< number of angle residuals
  /// Unknowns the fit moved: the free parameters, log s if estimated, and the windows' own.
  Eigen::Index free_unknowns = 0;
  int iterations = 0;
  bool converged = false;
  bool ok = true;           ///< false if a simulation failed at the start
  std::string message;      ///< why not ok / not converged
  std::vector<OutputErrorWindow> windows;  ///< with the estimated initial states
};

namespace detail {

/// Simulated angles of one window with parameters theta, or false if CVODE failed.
inline bool simulate_window(const Model<double>& model, const Eigen::VectorXd& theta,
                            const TorqueInterpolator& torque, const Eigen::VectorXd& t,
                            const OutputErrorWindow& w, const Vector2<double>& q0,
                            const Vector2<double>& qd0, const Vector2<double>& torque_offset,
                            const Vector2<double>& torque_slope,
                            const SimulatorOptions& options,
                            Eigen::MatrixXd& q_out) {
  const double middle = 0.5 * (t[w.begin] + t[w.end - 1]);
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    if (!x.allFinite() || x.cwiseAbs().maxCoeff() > 1e4)
      throw std::runtime_error("blow-up");
    const Vector2<double> q = x.head<2>();
    const Vector2<double> qd = x.tail<2>();
    xdot.head<2>() = qd;
    xdot.tail<2>() = model.forward_dynamics(theta, q, qd, torque(time) + torque_offset +
                                                          (time - middle) * torque_slope);
  };
  Eigen::VectorXd x0(4);
  x0 << q0, qd0;
  const SimulationResult sim = simulate(rhs, x0, t.segment(w.begin, w.end - w.begin), options);
  if (!sim.ok()) return false;
  q_out = sim.states.leftCols(2);
  return true;
}

/// Calls f(i, thread) for i in [0, count) on up to `threads` threads (thread 0 is the caller's).
/// An exception in f is rethrown after all threads finished.
template <typename F>
void for_each_index(Eigen::Index count, int threads, const F& f) {
  if (threads <= 1 || count <= 1) {
    for (Eigen::Index i = 0; i < count; ++i) f(i, 0);
    return;
  }
  std::atomic<Eigen::Index> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto work = [&](int thread) {
    for (Eigen::Index i = next++; i < count; i = next++) {
      try {
        f(i, thread);
      } catch (...) {
        const std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(work, t);
  work(0);
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace detail

/// @brief Levenberg–Marquardt on the normalised angle errors of every window, over the model's
/// parameters, log s (if estimated) and each window's initial state, with a forward-difference
/// Jacobian (one simulation per column and window).
/// @throws std::invalid_argument on inconsistent sizes or settings.
inline OutputErrorFit fit_output_error(const OutputErrorProblem& problem,
                                       const OutputErrorOptions& options = {}) {
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
    throw std::invalid_argument(who + "prior_mean and prior_std need one entry per parameter, "
                                      "finite means and stds > 0");
  if (options.max_iterations < 1) throw std::invalid_argument(who + "max_iterations must be >= 1");

  // Forward-difference steps: large enough that CVODE's error (rtol 1e-8) stays ~1e-4 of the
  // difference, small enough that q's response is linear (σq ~ 1e-3 rad).
  constexpr double kParameterStep = 1e-3;  // relative, at least 1e-5 absolute
  constexpr double kStateStep = 1e-4;      // [rad], [rad/s]
  constexpr double kTorqueStep = 1e-4;     // [N m]; the slope's step is 10x [N m/s]
  constexpr Eigen::Index kLocalUnknowns = 8;  // q0, qd0, torque offset and slope of a window
  const Eigen::Index p = problem.theta0.size();
  std::vector<bool> is_fixed(static_cast<std::size_t>(p + 1), false);
  for (Eigen::Index u : problem.fixed_parameters) {
    if (u < 0 || u >= p) throw std::invalid_argument(who + "a fixed parameter index is out of range");
    is_fixed[static_cast<std::size_t>(u)] = true;
  }
  const Eigen::Index g = p + (problem.estimate_nonlinear ? 1 : 0);  // global unknowns
  const auto nw = static_cast<Eigen::Index>(problem.windows.size());
  const Eigen::Index local = kLocalUnknowns;
  const Eigen::Index unknowns = g + local * nw;
  const int threads = static_cast<int>(std::min<Eigen::Index>(
      nw, options.threads > 0 ? options.threads
                              : std::max(1u, std::thread::hardware_concurrency())));
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
    x.segment(g + local * w, local).setZero();
    x.segment(g + local * w, 4) << win.q0, win.qd0;
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
    const Eigen::Index m = win.end - win.begin;
    Eigen::MatrixXd q;
    const Eigen::Index o = g + local * w;
    const Vector2<double> q0 = v.segment<2>(o), qd0 = v.segment<2>(o + 2);
    const Vector2<double> offset = v.segment<2>(o + 4), slope = v.segment<2>(o + 6);
    if (!detail::simulate_window(model, v.head(p), torque, problem.t, win, q0, qd0, offset, slope,
                                 options.simulator, q))
      return false;
    r.resize(2 * m);
    for (int j = 0; j < 2; ++j)
      r.segment(j * m, m) =
          (problem.q_measured.col(j).segment(win.begin, m) - q.col(j)) / problem.sigma_q[j];
    return true;
  };
  const auto prior_residual = [&](const Eigen::VectorXd& v) {
    if (!has_prior) return Eigen::VectorXd(Eigen::VectorXd::Zero(0));
    return Eigen::VectorXd((v.head(p) - problem.prior_mean).cwiseProduct(prior_weight));
  };
  const auto total_cost = [&](const Eigen::VectorXd& v, double* data_part) {
    const Model<double> model = model_for(v);
    std::vector<double> window_cost(static_cast<std::size_t>(nw));
    detail::for_each_index(nw, threads, [&](Eigen::Index w, int thread) {
      Eigen::VectorXd r;
      window_cost[static_cast<std::size_t>(w)] = window_residual(model, v, w, thread, r)
                                                     ? r.squaredNorm()
                                                     : std::numeric_limits<double>::infinity();
    });
    double c = 0;
    for (double wc : window_cost) c += wc;  // in window order: the same sum for any threads
    if (!std::isfinite(c)) return std::numeric_limits<double>::infinity();
    if (data_part) *data_part = c;
    return c + prior_residual(v).squaredNorm();
  };

  OutputErrorFit fit;
  fit.residuals = residual_count;
  fit.free_unknowns = unknowns - static_cast<Eigen::Index>(problem.fixed_parameters.size());
  double data_cost = 0;
  double cost = total_cost(x, &data_cost);
  fit.initial_cost = cost;
  if (!std::isfinite(cost)) {
    fit.ok = false;
    fit.message = "the simulation from the starting values failed";
    fit.theta = problem.theta0;
    return fit;
  }
  double mu = 1e-3;
  Eigen::MatrixXd normal(unknowns, unknowns);
  Eigen::VectorXd gradient(unknowns);
  for (int it = 0; it < options.max_iterations; ++it) {
    fit.iterations = it + 1;
    // Gauss–Newton normal equations, window by window (each touches the globals and its state).
    normal.setZero();
    gradient.setZero();
    const Model<double> model = model_for(x);
    struct Block {
      std::vector<Eigen::Index> columns;
      Eigen::MatrixXd jtj;
      Eigen::VectorXd jtr;
      bool ok = false;
    };
    std::vector<Block> blocks(static_cast<std::size_t>(nw));
    detail::for_each_index(nw, threads, [&](Eigen::Index w, int thread) {
      Block& block = blocks[static_cast<std::size_t>(w)];
      Eigen::VectorXd r0;
      if (!window_residual(model, x, w, thread, r0)) return;
      for (Eigen::Index c = 0; c < g; ++c)
        if (!is_fixed[static_cast<std::size_t>(c)]) block.columns.push_back(c);
      for (Eigen::Index c = 0; c < local; ++c) block.columns.push_back(g + local * w + c);
      Eigen::MatrixXd jac(r0.size(), static_cast<Eigen::Index>(block.columns.size()));
      for (std::size_t c = 0; c < block.columns.size(); ++c) {
        const Eigen::Index u = block.columns[c];
        const Eigen::Index role = (u - g) % local;  // for a window's own unknowns
        const double h = u >= g ? (role < 4 ? kStateStep : role < 6 ? kTorqueStep : 10 * kTorqueStep)
                                : kParameterStep * std::max(std::fabs(x[u]), 1e-2);
        Eigen::VectorXd v = x;
        v[u] += h;
        Eigen::VectorXd r1;
        const bool changes_model = problem.estimate_nonlinear && u == p;
        if (!(changes_model ? window_residual(model_for(v), v, w, thread, r1)
                            : window_residual(model, v, w, thread, r1)))
          return;
        jac.col(static_cast<Eigen::Index>(c)) = (r0 - r1) / h;  // d(q_sim)/du, normalised
      }
      block.jtj = jac.transpose() * jac;
      block.jtr = jac.transpose() * r0;
      block.ok = true;
    });
    bool failed = false;
    for (const Block& block : blocks) {
      if (!block.ok) {
        failed = true;
        break;
      }
      for (std::size_t a = 0; a < block.columns.size(); ++a) {
        gradient[block.columns[a]] += block.jtr[static_cast<Eigen::Index>(a)];
        for (std::size_t b = 0; b < block.columns.size(); ++b)
          normal(block.columns[a], block.columns[b]) +=
              block.jtj(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      }
    }
    if (failed) {
      fit.message = "a simulation failed while forming the Jacobian at iteration " +
                    std::to_string(it + 1);
      break;
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
    // Solve with damping; raise it until a step lowers the cost.
    bool accepted = false;
    for (int tries = 0; tries < 12; ++tries) {
      Eigen::MatrixXd damped = normal;
      damped.diagonal() += mu * normal.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = damped.ldlt().solve(gradient);
      Eigen::VectorXd candidate = x + step;
      if (problem.estimate_nonlinear)
        candidate[p] = std::clamp(candidate[p], std::log(problem.s_min), std::log(problem.s_max));
      double candidate_data = 0;
      const double c = total_cost(candidate, &candidate_data);
      if (std::isfinite(c) && c < cost) {
        const double drop = (cost - c) / cost, cost_drop = cost - c;
        x = candidate;
        cost = c;
        data_cost = candidate_data;
        mu = std::max(mu / 10.0, 1e-9);
        accepted = true;
        if (drop < options.relative_tolerance || cost_drop < options.absolute_tolerance) fit.converged = true;
        break;
      }
      mu *= 10.0;
    }
    if (!accepted) {
      fit.converged = true;  // no step lowers the cost: a minimum to within the damping
      break;
    }
    if (fit.converged) break;
  }
  if (!fit.converged && fit.message.empty())
    fit.message = "not converged in " + std::to_string(options.max_iterations) + " iterations";

  fit.theta = x.head(p);
  fit.cost = cost;
  fit.data_cost = data_cost;
  if (problem.estimate_nonlinear) fit.s = std::exp(x[p]);
  fit.windows = problem.windows;
  for (Eigen::Index w = 0; w < nw; ++w) {
    fit.windows[static_cast<std::size_t>(w)].q0 = x.segment<2>(g + local * w);
    fit.windows[static_cast<std::size_t>(w)].qd0 = x.segment<2>(g + local * w + 2);
    fit.windows[static_cast<std::size_t>(w)].torque_offset = x.segment<2>(g + local * w + 4);
    fit.windows[static_cast<std::size_t>(w)].torque_slope = x.segment<2>(g + local * w + 6);
  }
  // Covariance of the globals: the inverse normal matrix's global block, scaled by the mean
  // square residual; s by the delta method from log s.
  const double dof = std::max<double>(1.0, static_cast<double>(residual_count - unknowns));
  const double scale = std::max(1.0, data_cost / dof);
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
  return fit;
}

}  // namespace sid
