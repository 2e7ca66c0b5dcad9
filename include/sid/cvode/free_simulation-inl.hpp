#pragma once
// Definitions of sid/cvode/free_simulation.hpp (see sid/config.hpp).

#include <sid/cvode/free_simulation.hpp>

namespace sid {

namespace detail {

SID_INLINE SimulatorOptions free_simulation_simulator_defaults() {
  SimulatorOptions options;
  options.rtol = 1e-9;
  options.atol = 1e-9;
  options.method = IntegrationMethod::Bdf;
  // Between two samples (2.5 ms in the paper's data) 20000 steps is a failure, not work:
  // stop there instead of appearing to hang on a model that blows up.
  options.max_steps = 20000;
  return options;
}

SID_INLINE void validate_free_simulation(const Model<double>& model,
                                         const Eigen::Ref<const Eigen::VectorXd>& theta,
                                         const Kinematics<double>& k,
                                         const FreeSimulationOptions& options) {
  const std::string who = "sid::free_simulation: ";
  if (theta.size() != model.num_parameters())
    throw std::invalid_argument(who + "theta has " + std::to_string(theta.size()) +
                                " entries but the model has " +
                                std::to_string(model.num_parameters()) + " parameters");
  if (!theta.allFinite()) throw std::invalid_argument(who + "theta must be finite");
  const Eigen::Index n = k.size();
  if (n < 2)
    throw std::invalid_argument(who + "the kinematics need at least 2 samples, got " +
                                std::to_string(n));
  if (k.q.rows() != n || k.qd.rows() != n || k.tau.rows() != n)
    throw std::invalid_argument(
        who + "k.t, k.q, k.qd and k.tau must have the same number of rows (t: " +
        std::to_string(n) + ", q: " + std::to_string(k.q.rows()) +
        ", qd: " + std::to_string(k.qd.rows()) + ", tau: " + std::to_string(k.tau.rows()) + ")");
  for (Eigen::Index i = 0; i < n; ++i) {
    if (!std::isfinite(k.t[i]))
      throw std::invalid_argument(who + "k.t[" + std::to_string(i) + "] is not finite");
    if (i > 0 && !(k.t[i] > k.t[i - 1]))
      throw std::invalid_argument(who + "k.t must be strictly increasing (k.t[" +
                                  std::to_string(i) + "] <= k.t[" + std::to_string(i - 1) + "])");
  }
  if (!k.q.allFinite()) throw std::invalid_argument(who + "k.q must be finite");
  if (!k.qd.allFinite()) throw std::invalid_argument(who + "k.qd must be finite");
  if (!k.tau.allFinite()) throw std::invalid_argument(who + "k.tau must be finite");
  if (std::isnan(options.segment)) throw std::invalid_argument(who + "options.segment is NaN");
  if (!(options.blow_up > 0.0)) throw std::invalid_argument(who + "options.blow_up must be > 0");
  if (std::isnan(options.torque_bandwidth))
    throw std::invalid_argument(who + "options.torque_bandwidth is NaN");
}

SID_INLINE MatrixX2<double> driving_torque(const Kinematics<double>& k, double bandwidth,
                                           bool& filtered) {
  filtered = false;
  constexpr int kOrder = 2;
  const Eigen::Index n = k.size();
  if (!(bandwidth > 0.0) || !std::isfinite(bandwidth) || n <= 3 * (kOrder + 1)) return k.tau;
  const double ts = (k.t[n - 1] - k.t[0]) / static_cast<double>(n - 1);
  constexpr double kUniformTolerance = 1e-6;  // relative jitter of logged time stamps
  for (Eigen::Index i = 1; i < n; ++i)
    if (std::abs((k.t[i] - k.t[i - 1]) - ts) > kUniformTolerance * ts) return k.tau;
  const double cutoff = bandwidth * 2.0 * ts;  // relative to the Nyquist frequency 1 / (2 ts)
  if (!(cutoff < 1.0)) return k.tau;
  filtered = true;
  // filtfilt's own odd extension (6 samples at order 2) is shorter than the filter's memory
  // (~1 / bandwidth), and a point reflection flips the curvature at the end sample, so its
  // transient would reach the data (3e-5 rad on the exact experiment). Extend further first by
  // x(-i) = 3 x(0) - 3 x(i) + x(2i), exact for quadratics: value, slope and curvature continue.
  const auto pad = std::min<Eigen::Index>(
      (n - 1) / 2, static_cast<Eigen::Index>(std::ceil(10.0 / (bandwidth * ts))));
  MatrixX2<double> extended(n + 2 * pad, 2);
  for (Eigen::Index i = 1; i <= pad; ++i) {
    extended.row(pad - i) = 3.0 * k.tau.row(0) - 3.0 * k.tau.row(i) + k.tau.row(2 * i);
    extended.row(pad + n - 1 + i) =
        3.0 * k.tau.row(n - 1) - 3.0 * k.tau.row(n - 1 - i) + k.tau.row(n - 1 - 2 * i);
  }
  extended.middleRows(pad, n) = k.tau;
  return filtfilt(butterworth_lowpass(kOrder, cutoff), extended).middleRows(pad, n);
}

SID_INLINE std::vector<Eigen::Index> segment_starts(const Eigen::Ref<const Eigen::VectorXd>& t,
                                                    double segment) {
  std::vector<Eigen::Index> starts{0};
  if (!(segment > 0.0) || !std::isfinite(segment)) return starts;
  const double t0 = t[0];
  const double tolerance = 1e-9 * segment;  // a sample on a boundary despite rounding
  double boundary = t0 + segment;
  for (Eigen::Index i = 1; i + 1 < t.size(); ++i) {
    if (t[i] < boundary - tolerance) continue;
    starts.push_back(i);
    // Skip boundaries that fall into a gap of the data (no samples there).
    while (boundary <= t[i] + tolerance) boundary += segment;
  }
  return starts;
}

}  // namespace detail

SID_INLINE FreeSimulation free_simulation(const Model<double>& model,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta,
                                          const Kinematics<double>& k,
                                          const FreeSimulationOptions& options) {
  detail::validate_free_simulation(model, theta, k, options);
  const Eigen::Index n = k.size();
  FreeSimulation result;
  result.t = k.t;
  result.q.setConstant(n, 2, std::numeric_limits<double>::quiet_NaN());
  result.segment_starts = detail::segment_starts(k.t, options.segment);

  const Eigen::VectorXd parameters = theta;
  const detail::TorqueInterpolator torque(
      k.t, detail::driving_torque(k, options.torque_bandwidth, result.torque_filtered),
      detail::TorqueJoins::C2);
  const double limit = options.blow_up;
  auto rhs = [&](double time, const Eigen::Map<const Eigen::VectorXd>& x,
                 Eigen::Map<Eigen::VectorXd>& xdot) {
    if (!x.allFinite() || x.cwiseAbs().maxCoeff() > limit)
      throw std::runtime_error("the state left |x| <= " + detail::format_time(limit) +
                               " (blow-up) at t = " + detail::format_time(time));
    const Vector2<double> q = x.head<2>();
    const Vector2<double> qd = x.tail<2>();
    xdot.head<2>() = qd;
    xdot.tail<2>() = model.forward_dynamics(parameters, q, qd, torque(time));
  };

  const auto segments = static_cast<Eigen::Index>(result.segment_starts.size());
  Eigen::VectorXd x0(4);
  for (Eigen::Index s = 0; s < segments; ++s) {
    const Eigen::Index begin = result.segment_starts[static_cast<std::size_t>(s)];
    const Eigen::Index end =
        s + 1 < segments ? result.segment_starts[static_cast<std::size_t>(s + 1)] : n;
    x0 << k.q.row(begin).transpose(), k.qd.row(begin).transpose();
    const SimulationResult sim =
        simulate(rhs, x0, k.t.segment(begin, end - begin), options.simulator);
    result.q.middleRows(begin, sim.completed) = sim.states.topLeftCorner(sim.completed, 2);
    const SimulationStatistics& st = sim.statistics;
    result.statistics.steps += st.steps;
    result.statistics.rhs_evaluations += st.rhs_evaluations;
    result.statistics.error_test_failures += st.error_test_failures;
    result.statistics.nonlinear_iterations += st.nonlinear_iterations;
    result.statistics.nonlinear_convergence_failures += st.nonlinear_convergence_failures;
    result.statistics.jacobian_evaluations += st.jacobian_evaluations;
    if (!sim.ok()) {
      ++result.failed_segments;
      if (!result.message.empty()) result.message += "; ";
      result.message += "segment " + std::to_string(s + 1) + " of " + std::to_string(segments) +
                        " (t = " + detail::format_time(k.t[begin]) +
                        " s) stopped at t = " + detail::format_time(sim.t_reached) +
                        " s: " + to_string(sim.status) +
                        (sim.message.empty() ? "" : " (" + sim.message + ")");
    }
  }

  result.error = k.q - result.q;
  for (int j = 0; j < 2; ++j) {
    double sum = 0.0;
    Eigen::Index count = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      const double e = result.error(i, j);
      if (std::isfinite(e)) {
        sum += e * e;
        ++count;
      }
    }
    if (count > 0) result.error_rms[j] = std::sqrt(sum / static_cast<double>(count));
  }
  return result;
}

}  // namespace sid
