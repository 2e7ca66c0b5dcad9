#pragma once
// The definitions of <sid/external_torque.hpp>: included by it in header-only mode, compiled once
// into sid::compiled otherwise.

#include <sid/external_torque.hpp>

#include <sid/arm_dynamics.hpp>
#include <sid/identify_chain.hpp>
#include <sid/identify_runs.hpp>
#include <sid/momentum_observer.hpp>
#include <sid/quantisation.hpp>
#include <sid/smoothing_spline.hpp>

#include <sid/detail/format.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace sid {

namespace detail {

/// Runs of samples above threshold, merged across short gaps, short ones dropped.
inline std::vector<std::pair<Eigen::Index, Eigen::Index>> contact_spans(
    const Eigen::VectorXd& t, const Eigen::MatrixXd& external, const Eigen::VectorXd& threshold,
    const ExternalTorqueOptions& o) {
  std::vector<std::pair<Eigen::Index, Eigen::Index>> spans;
  for (Eigen::Index k = 0; k < t.size(); ++k) {
    if (t[k] < t[0] + o.skip || t[k] > t[t.size() - 1] - o.skip) continue;
    if (!(external.row(k).cwiseAbs().transpose().array() > threshold.array()).any()) continue;
    if (!spans.empty() && t[k] - t[spans.back().second] <= o.merge_gap)
      spans.back().second = k;
    else
      spans.push_back({k, k});
  }
  spans.erase(
      std::remove_if(spans.begin(), spans.end(),
                     [&](const auto& s) { return t[s.second] - t[s.first] < o.min_duration; }),
      spans.end());
  return spans;
}

/// Per joint, 1.4826 times the median absolute deviation of the estimate from its median, over
/// the samples where contacts are looked for: its standard deviation where it is noise.
inline Eigen::VectorXd robust_spread(const Eigen::VectorXd& t, const Eigen::MatrixXd& external,
                                     double skip) {
  std::vector<double> values;
  Eigen::VectorXd spread(external.cols());
  for (Eigen::Index j = 0; j < external.cols(); ++j) {
    values.clear();
    for (Eigen::Index i = 0; i < t.size(); ++i)
      if (t[i] >= t[0] + skip && t[i] <= t[t.size() - 1] - skip) values.push_back(external(i, j));
    const auto median = [](std::vector<double>& v) {
      const auto middle = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
      std::nth_element(v.begin(), middle, v.end());
      return *middle;
    };
    const double centre = median(values);
    for (double& v : values) v = std::abs(v - centre);
    spread[j] = 1.4826 * median(values);
  }
  return spread;
}

/// The log's mean sampling step [s].
inline double mean_step(const ChainTrajectory<double>& log) {
  return (log.t[log.size() - 1] - log.t[0]) / static_cast<double>(log.size() - 1);
}

/// Per joint, the cutoff [Hz] of the GCV smoothing spline of the log's angles.
inline Eigen::VectorXd gcv_rate_cutoff(const ChainTrajectory<double>& run) {
  const Eigen::Index n = run.q.cols();
  const double h = mean_step(run);
  const SmoothingSpline<double> spline(run.t);
  Eigen::VectorXd cutoff(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    const double lambda = spline.fit_cross_validated(run.q.col(j)).lambda;
    cutoff[j] = std::min(smoothing_cutoff_for_lambda(lambda, h), 0.25 / h);
  }
  return cutoff;
}

/// Why GCV cannot choose the rates of a log, or "" when it can: GCV assumes white angle noise,
/// and takes a real log's quantised angles (encoder counts, a fixed number of logged decimals)
/// for motion; rates it leaves unsmoothed carry that error into the momentum, and on a real
/// arm's free motion they made contacts of the model's error.
inline std::string measured_log(const ChainModel& model, const ChainTrajectory<double>& run,
                                const Eigen::VectorXd& gcv, double h) {
  for (int j = 0; j < model.joints(); ++j)
    if (const double step = quantisation_step(run.q.col(j)); step > 0.0)
      return "the angles of " + model.joint_names()[std::size_t(j)] + " lie on a grid (a step of " +
             format_number("%.2g", step) + "): a measured log";
  for (int j = 0; j < model.joints(); ++j)
    if (gcv[j] >= 0.25 / h * (1.0 - 1e-9))
      return "GCV leaves the angles of " + model.joint_names()[std::size_t(j)] +
             " unsmoothed: a measured log";
  return "";
}

/// τ_ext = ID(q, q̇, q̈) − τ on the smoothed motion.
inline Eigen::MatrixXd inverse_dynamics_residual(const ArmDynamics& dynamics,
                                                 const ChainKinematics<double>& k,
                                                 const ChainTrajectory<double>& log) {
  const Eigen::Index samples = log.size(), n = log.joints();
  Eigen::MatrixXd external(samples, n);
  ArmDynamics::Vector q(n), qd(n), qdd(n), id(n);
  for (Eigen::Index i = 0; i < samples; ++i) {
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    dynamics.inverse_dynamics(q, qd, qdd, id);
    external.row(i) = (id - log.tau.row(i).transpose()).transpose();
  }
  return external;
}

inline void check_external_torque_input(const ChainModel& model, const Eigen::VectorXd& theta,
                                        const Eigen::VectorXd& fit_cutoff_hz,
                                        const Eigen::VectorXd& fit_residual_rms,
                                        const ChainTrajectory<double>& run,
                                        const ExternalTorqueOptions& o) {
  const std::string who = "sid::estimate_external_torque: ";
  const int n = model.joints();
  if (theta.size() != model.parameters() || fit_cutoff_hz.size() != n ||
      fit_residual_rms.size() != n)
    throw std::invalid_argument(
        who + "theta needs the model's " + std::to_string(model.parameters()) +
        " parameters and the fit's cutoffs and residual one per joint (" + std::to_string(n) + ")");
  if (run.joints() != n)
    throw std::invalid_argument(who + "the run has " + std::to_string(run.joints()) +
                                " joints, the model " + std::to_string(n));
  run.validate("sid::estimate_external_torque");
  if (run.size() < 4) throw std::invalid_argument(who + "the run needs at least 4 samples");
  if (!(o.threshold_factor > 0.0 && std::isfinite(o.threshold_factor)))
    throw std::invalid_argument(who + "threshold_factor must be > 0");
  if (!(o.min_duration >= 0.0 && o.merge_gap >= 0.0 && o.skip >= 0.0))
    throw std::invalid_argument(who + "min_duration, merge_gap and skip must be >= 0 s");
  if (!(std::isfinite(o.torque_delay) && std::abs(o.torque_delay) <= o.skip + 1e-12))
    throw std::invalid_argument(who + "the torque delay must be finite and within the skip (" +
                                format_number("%.3g", o.skip) + " s)");
  // Contacts are looked for |torque_delay| further from the ends (estimate_external_torque).
  const double ends = o.skip + std::abs(o.torque_delay);
  if (!(2.0 * ends < run.t[run.size() - 1] - run.t[0]))
    throw std::invalid_argument(who + "a skip of " + format_number("%.3g", ends) +
                                " s at each end leaves nothing of the run");
  if (!(o.gain >= 0.0 && std::isfinite(o.gain)))
    throw std::invalid_argument(who + "the gain must be > 0 [1/s] (0: the default)");
  if (!o.cutoff_hz.empty() && o.cutoff_hz.size() != 1 && o.cutoff_hz.size() != std::size_t(n))
    throw std::invalid_argument(who + "cutoff_hz takes one value or one per joint (" +
                                std::to_string(n) + ")");
  for (const double c : o.cutoff_hz)
    if (!(c > 0.0 && std::isfinite(c)))
      throw std::invalid_argument(who + "cutoff_hz values must be > 0 Hz");
  if (o.effort_limit.size() != 0 && o.effort_limit.size() != n)
    throw std::invalid_argument(who + "effort_limit takes one value per joint (" +
                                std::to_string(n) + ") or none");
  for (const double limit : o.effort_limit)
    if (!(limit > 0.0 || std::isnan(limit)))
      throw std::invalid_argument(who + "effort limits must be > 0 (NaN: not known)");
}

/// The momentum observer of rate gain run forwards, then the same first-order lag backwards.
inline Eigen::MatrixXd observed_external_torque(const ArmDynamics& dynamics,
                                                const ChainKinematics<double>& k,
                                                const ChainTrajectory<double>& log, double gain) {
  const Eigen::Index samples = log.size(), n = log.joints();
  Eigen::MatrixXd external(samples, n);
  ArmDynamics::Vector q(n), qd(n), tau(n);
  MomentumObserver observer(dynamics, Eigen::VectorXd::Constant(n, gain));
  for (Eigen::Index i = 0; i < samples; ++i) {
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    tau = log.tau.row(i).transpose();
    const double step = i > 0 ? log.t[i] - log.t[i - 1] : 0.0;
    external.row(i) = observer.update(q, qd, tau, step).transpose();
  }
  // The observer lags the external torque by 1 / K; with the whole log at hand, the same
  // first-order lag run backwards in time cancels that phase (a ramp comes out where it was),
  // and halves the noise's bandwidth again.
  for (Eigen::Index i = samples - 2; i >= 0; --i) {
    const double decay = std::exp(-gain * (log.t[i + 1] - log.t[i]));
    external.row(i) += decay * (external.row(i + 1) - external.row(i));
  }
  return external;
}

/// The observer's rate: the one given, else min(300, 1 / (2 dt), 2 pi x the slowest rate cutoff).
/// No faster than the rates: above their cutoff the momentum's derivative has lost what the
/// torque still carries, and a faster observer passes that difference as external torque.
inline double observer_gain(const ExternalTorqueOptions& o, const ChainTrajectory<double>& log,
                            const Eigen::VectorXd& rate_cutoff_hz) {
  if (o.gain > 0.0) return o.gain;
  constexpr double kPi = 3.14159265358979323846;
  return std::min({300.0, 0.5 / mean_step(log), 2.0 * kPi * rate_cutoff_hz.minCoeff()});
}

/// How the rates are taken from the angles: the torque left as logged, paired with the motion
/// torque_delay earlier.
inline ChainIdentifyOptions rate_smoothing(const ExternalTorqueOptions& o) {
  ChainIdentifyOptions smoothing;
  smoothing.filter_torque = false;
  smoothing.torque_delay = o.torque_delay;
  return smoothing;
}

/// The smoothing of a measured log's angles: the fit's cutoffs scaled by the half octave (from
/// 1/2 to 4) at which the observer's estimate on this log is least, measured in the fit's own
/// residual per joint (its mean square away from the ends, each sample's capped at the contact
/// threshold's). On free motion the estimate is the model's error plus what the smoothing adds:
/// the rates' noise when too little, the motion it removes when too much. The fit's cutoffs
/// were chosen for accelerations on its own logs: on the double pendulum's swing-up, faster
/// than the fitted runs, they smoothed away a reversal, which the observer then took for a
/// push. The cap makes a contact count by its length alone, which a slower observer stretches.
inline std::pair<Eigen::VectorXd, double> measured_log_cutoff(
    const ExternalTorqueOptions& o, const ArmDynamics& dynamics,
    const Eigen::VectorXd& fit_cutoff_hz, const Eigen::VectorXd& fit_residual_rms,
    const ChainTrajectory<double>& log) {
  const double h = mean_step(log);
  const ChainIdentifyOptions smoothing = rate_smoothing(o);
  const double cap = o.threshold_factor * o.threshold_factor;
  std::pair<Eigen::VectorXd, double> best{fit_cutoff_hz, 1.0};
  double least = std::numeric_limits<double>::infinity();
  for (int step = -2; step <= 4; ++step) {
    const double scale = std::pow(2.0, 0.5 * step);
    const Eigen::VectorXd cutoff = (scale * fit_cutoff_hz).cwiseMin(0.25 / h);
    const Eigen::MatrixXd external = observed_external_torque(
        dynamics, smooth_chain_run(log, cutoff, smoothing), log, observer_gain(o, log, cutoff));
    double size = 0.0;
    for (Eigen::Index i = 0; i < log.size(); ++i)
      if (log.t[i] >= log.t[0] + o.skip && log.t[i] <= log.t[log.size() - 1] - o.skip)
        size += external.row(i)
                    .cwiseQuotient(fit_residual_rms.transpose())
                    .array()
                    .square()
                    .min(cap)
                    .sum();
    if (size < least) {
      least = size;
      best = {cutoff, scale};
    }
  }
  return best;
}

/// The rates' cutoffs and, in words, how they were chosen.
inline std::pair<Eigen::VectorXd, std::string> rate_cutoff(const ExternalTorqueOptions& o,
                                                           const ChainModel& model,
                                                           const ArmDynamics& dynamics,
                                                           const Eigen::VectorXd& fit_cutoff_hz,
                                                           const Eigen::VectorXd& fit_residual_rms,
                                                           const ChainTrajectory<double>& run) {
  const int n = model.joints();
  if (o.fit_cutoffs) return {fit_cutoff_hz, "the fit's"};
  if (o.cutoff_hz.empty() && o.method == ExternalTorqueMethod::InverseDynamicsResidual)
    return {fit_cutoff_hz, "the fit's"};
  if (o.cutoff_hz.empty()) {
    const double h = mean_step(run);
    const Eigen::VectorXd gcv = gcv_rate_cutoff(run);
    const std::string measured = measured_log(model, run, gcv, h);
    if (measured.empty()) return {gcv, "GCV"};
    const auto [cutoff, scale] =
        measured_log_cutoff(o, dynamics, fit_cutoff_hz, fit_residual_rms, run);
    return {cutoff, "the fit's x " + format_number("%.3g", scale) +
                        ", where the estimate on this log is least: " + measured};
  }
  Eigen::VectorXd cutoff(n);
  for (int j = 0; j < n; ++j) cutoff[j] = o.cutoff_hz[o.cutoff_hz.size() == 1 ? 0 : std::size_t(j)];
  return {cutoff, "given"};
}

/// The excursion from sample first to last, with each joint's signed peak and the joints above
/// their threshold.
inline ExternalContact excursion(const ExternalTorque& r, Eigen::Index first, Eigen::Index last) {
  ExternalContact c;
  c.start = r.t[first];
  c.end = r.t[last];
  const Eigen::Index n = r.external.cols();
  c.peak = Eigen::VectorXd::Zero(n);
  for (Eigen::Index j = 0; j < n; ++j) {
    for (Eigen::Index i = first; i <= last; ++i)
      if (std::abs(r.external(i, j)) > std::abs(c.peak[j])) c.peak[j] = r.external(i, j);
    if (std::abs(c.peak[j]) > r.thresholds[j]) c.joints.push_back(static_cast<int>(j));
  }
  return c;
}

/// The joint whose effort limit the excursion's peak exceeds, or -1.
inline int beyond_effort_limit(const ExternalContact& c, const Eigen::VectorXd& effort_limit) {
  for (Eigen::Index j = 0; j < effort_limit.size(); ++j)
    if (std::abs(c.peak[j]) > effort_limit[j]) return static_cast<int>(j);
  return -1;
}

/// The contacts above r.thresholds, less the excursions beyond a joint's effort limit, which
/// are the model's failure: a drive cannot hold against more than it can give.
inline void find_contacts(const ChainModel& model, const ExternalTorqueOptions& o,
                          ExternalTorque& r) {
  r.contact = Eigen::VectorXi::Zero(r.t.size());
  for (const auto& [first, last] : contact_spans(r.t, r.external, r.thresholds, o)) {
    ExternalContact c = excursion(r, first, last);
    if (const int joint = beyond_effort_limit(c, o.effort_limit); joint >= 0) {
      r.warnings.push_back(
          "from " + format_number("%.3f", c.start) + " s to " + format_number("%.3f", c.end) +
          " s the estimate on " + model.joint_names()[std::size_t(joint)] + " reaches " +
          format_number("%.3g", c.peak[joint]) + ", beyond its effort limit " +
          format_number("%.3g", o.effort_limit[joint]) +
          ": the model's failure (an effect it lacks, a wrong transmission or unit), not a "
          "contact");
      r.beyond_effort.push_back(std::move(c));
      continue;
    }
    r.contact.segment(first, last - first + 1).setOnes();
    r.contacts.push_back(std::move(c));
  }
}

/// Twice the model's own error: the estimate's noise, not the model, sets the thresholds.
inline void warn_of_noise(const ChainModel& model, const Eigen::VectorXd& fit_residual_rms,
                          ExternalTorque& r) {
  for (int joint = 0; joint < model.joints(); ++joint)
    if (r.noise[joint] > 2.0 * fit_residual_rms[joint]) {
      r.warnings.push_back(
          "the estimate's spread on " + model.joint_names()[static_cast<std::size_t>(joint)] +
          " (" + format_number("%.3g", r.noise[joint]) +
          " N m) is more than twice the fit's residual (" +
          format_number("%.3g", fit_residual_rms[joint]) +
          "): the rates are noisy (coarse encoders?), so only contacts above its threshold are "
          "seen; lower rate cutoffs (the fit's, for one) and a lower gain quiet it");
      return;
    }
}

}  // namespace detail

SID_INLINE ExternalTorque estimate_external_torque(const ChainModel& model,
                                                   const Eigen::VectorXd& theta,
                                                   const Eigen::VectorXd& fit_cutoff_hz,
                                                   const Eigen::VectorXd& fit_residual_rms,
                                                   const ChainTrajectory<double>& log,
                                                   const ExternalTorqueOptions& options) {
  detail::check_external_torque_input(model, theta, fit_cutoff_hz, fit_residual_rms, log, options);
  // The rates at t are the spline's at t − delay: its ends, which the skip keeps out, reach
  // |delay| further into the log.
  ExternalTorqueOptions o = options;
  o.skip += std::abs(options.torque_delay);
  const ArmDynamics dynamics(model, theta);
  ExternalTorque r;
  std::tie(r.rate_cutoff_hz, r.rate_cutoff_choice) =
      detail::rate_cutoff(o, model, dynamics, fit_cutoff_hz, fit_residual_rms, log);
  const ChainIdentifyOptions smoothing = detail::rate_smoothing(o);
  const ChainKinematics<double> k = smooth_chain_run(log, r.rate_cutoff_hz, smoothing);
  r.t = log.t;
  if (o.method == ExternalTorqueMethod::InverseDynamicsResidual) {
    r.external = detail::inverse_dynamics_residual(dynamics, k, log);
  } else {
    r.gain = detail::observer_gain(o, log, r.rate_cutoff_hz);
    r.external = detail::observed_external_torque(dynamics, k, log, r.gain);
  }
  // The model's own error sets what counts as a contact; where this log's estimate is noisier
  // still (coarse encoders: the momentum's rate noise), its robust spread does, so that noise is
  // not called a contact. The median absolute deviation ignores the contacts themselves as long
  // as they cover less than half the log.
  r.noise = detail::robust_spread(r.t, r.external, o.skip);
  r.thresholds = o.threshold_factor * fit_residual_rms.cwiseMax(r.noise);
  detail::find_contacts(model, o, r);
  detail::warn_of_noise(model, fit_residual_rms, r);
  return r;
}

}  // namespace sid
