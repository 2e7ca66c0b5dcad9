#pragma once
/// @file
/// @brief Free (open-loop) simulation of an identified model driven by the measured torque,
/// compared with the measured angles: where a model that fits the torques well still drifts
/// away from the data, something physical is missing (sid_diagnose).

#include <sid/butterworth.hpp>
#include <sid/config.hpp>
#include <sid/cvode/simulator.hpp>
#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

namespace detail {

/// Tolerances of the free simulation. The reference it is compared with is a smoothed angle
/// (errors ~1e-4 rad) and the torque that drives it is noisy, so the simulator's default 1e-10
/// buys nothing; 1e-9 keeps the error of the exact model on the exact experiment below 2e-7 rad
/// (1e-8 gives 8e-7, too close to the 1e-6 of tests/free_simulation_test.cpp). BDF because a fitted
/// Coulomb term Fc tanh(qd/eps) adds a damping Fc/eps (20 N m s/rad at Fc = 0.2, eps = 0.01) over
/// the small link-2 inertia near every velocity reversal, and Adams methods would crawl there.
SID_INLINE SimulatorOptions free_simulation_simulator_defaults();

}  // namespace detail

/// @brief Settings of free_simulation().
struct FreeSimulationOptions {
  /// Length of a segment [s]: the simulation restarts from the smoothed state (k.q, k.qd) at the
  /// first sample of every segment, because the arm is a double pendulum whose open-loop
  /// trajectories diverge from each other however good the model is. <= 0 or infinite: one run
  /// over the whole record.
  double segment = 1.0;
  /// A state with |q| [rad] or |qd| [rad/s] above this is a blow-up: the segment stops there
  /// (reported in FreeSimulation::message) instead of integrating to overflow. > 0.
  double blow_up = 1e4;
  /// Cut-off [Hz] of a zero-phase low-pass (Butterworth order 2, forward-backward) applied to
  /// the measured torque before it drives the simulation; <= 0, infinite or at/above the
  /// Nyquist frequency: none. Applied only on a uniform grid. Why: white torque noise makes the
  /// interpolated input rough at every sample, and CVODE then resolves every sample with ~35
  /// steps (136000 steps, 0.2 s for the paper's record at sigma_tau = 0.1 N m); at 20 Hz it
  /// needs 51000 steps, 0.075 s. The angles barely notice: the noise acts on q through its
  /// low-frequency content (a random walk through the viscous friction), which the filter
  /// keeps; the content it removes (joint 2's small inertia follows the noise up to ~30 Hz)
  /// changes q by 8e-4 rad RMS against the 5.7e-3 rad RMS random walk of joint 2. The motion's
  /// torque (< 1 Hz in the paper's experiment) passes unchanged (exact experiment: < 1e-6 rad,
  /// tests/free_simulation_test.cpp).
  double torque_bandwidth = 20.0;
  SimulatorOptions simulator = detail::free_simulation_simulator_defaults();
};

/// @brief A free simulation and its disagreement with the (smoothed) measured angles.
/// Class invariant: t, q and error have the same number of rows; the rows of a failed segment
/// after its failure time are NaN in q and error.
struct [[nodiscard]] FreeSimulation {
  Eigen::VectorXd t;       ///< the sample times of the kinematics [s]
  MatrixX2<double> q;      ///< simulated angles [rad]
  MatrixX2<double> error;  ///< k.q - simulated q [rad]
  /// RMS of error per joint over the samples that were simulated [rad] (NaN if none).
  Vector2<double> error_rms = Vector2<double>::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<Eigen::Index> segment_starts;  ///< row index of each restart (first is 0)
  Eigen::Index failed_segments = 0;
  SimulationStatistics statistics;  ///< summed over the segments
  std::string message;              ///< empty when ok; otherwise what failed, segment by segment
  bool torque_filtered =
      false;  ///< the torque was low-passed (FreeSimulationOptions::torque_bandwidth)

  /// Every segment was simulated to its end.
  bool ok() const noexcept { return failed_segments == 0; }
};

namespace detail {

/// How an interpolated torque joins at the samples.
enum class TorqueJoins {
  /// Cubic Hermite with slopes from the neighbouring samples (central differences: Catmull-Rom
  /// on a uniform grid), one-sided at the ends: local, its second derivative jumps at samples.
  C1,
  /// The natural interpolating cubic spline: second derivative continuous. A multistep method of
  /// order q > 2 sees a C1 curve's jumps at every sample: the free simulation of a noisy 10 s
  /// record (4001 samples) took 16,800 CVODE steps at rtol 1e-7 with C1 joins, 9,200 with C2,
  /// in half the time. (The output-error windows, whose steps the friction term sets, took 630
  /// steps per window either way.)
  C2,
};

/// Cubic interpolation of tau on the sample grid t (TorqueJoins).
/// Not linear interpolation: a chord of a smooth torque is biased by ~h^2 tau''/12 over every
/// interval, which the integration accumulates (5e-6 rad on the exact paper experiment after
/// 1 s, tests/free_simulation_test.cpp); the cubics' O(h^3) errors do not show. On noisy torque
/// all interpolants carry the same noise. The hint follows CVODE's mostly increasing times, so
/// the interval of the last call is almost always the right one.
class TorqueInterpolator {
 public:
  TorqueInterpolator(const Eigen::Ref<const Eigen::VectorXd>& t,
                     const Eigen::Ref<const MatrixX2<double>>& tau,
                     TorqueJoins joins = TorqueJoins::C1)
      : t_(t), tau_(tau), joins_(joins), derivative_(MatrixX2<double>::Zero(t.size(), 2)) {
    const Eigen::Index n = t.size();
    if (joins == TorqueJoins::C1) {
      for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::Index a = i > 0 ? i - 1 : 0, b = i + 1 < n ? i + 1 : n - 1;
        derivative_.row(i) = (tau.row(b) - tau.row(a)) / (t[b] - t[a]);
      }
      return;
    }
    // C2: second derivatives m (in derivative_), m = 0 at the ends, from the tridiagonal system
    // h[i-1] m[i-1] + 2 (h[i-1] + h[i]) m[i] + h[i] m[i+1] = 6 (d[i] - d[i-1]), d the chord
    // slopes; forward elimination, then back substitution (diagonally dominant: no pivoting).
    // Row 0 of the elimination and m[n-1] are zero, so neither sweep needs a special case.
    if (n < 3) return;
    Eigen::VectorXd upper = Eigen::VectorXd::Zero(n);
    MatrixX2<double> rhs = MatrixX2<double>::Zero(n, 2);
    for (Eigen::Index i = 1; i + 1 < n; ++i) {
      const double h0 = t[i] - t[i - 1], h1 = t[i + 1] - t[i];
      const double pivot = 2.0 * (h0 + h1) - h0 * upper[i - 1];
      upper[i] = h1 / pivot;
      rhs.row(i) =
          (6.0 * ((tau.row(i + 1) - tau.row(i)) / h1 - (tau.row(i) - tau.row(i - 1)) / h0) -
           h0 * rhs.row(i - 1)) /
          pivot;
    }
    for (Eigen::Index i = n - 2; i >= 1; --i)
      derivative_.row(i) = rhs.row(i) - upper[i] * derivative_.row(i + 1);
  }

  Vector2<double> operator()(double time) const {
    const Eigen::Index n = t_.size();
    if (time <= t_[0]) return tau_.row(0).transpose();
    if (time >= t_[n - 1]) return tau_.row(n - 1).transpose();
    Eigen::Index i = std::min(hint_, n - 2);
    if (!(t_[i] <= time && time <= t_[i + 1])) {
      if (i + 2 < n && t_[i + 1] <= time && time <= t_[i + 2]) {
        ++i;
      } else {
        const double* begin = t_.data();
        i = static_cast<Eigen::Index>(std::upper_bound(begin, begin + n, time) - begin) - 1;
        i = std::clamp<Eigen::Index>(i, 0, n - 2);
      }
    }
    hint_ = i;
    const double h = t_[i + 1] - t_[i];
    if (joins_ == TorqueJoins::C2) {
      const double b = (time - t_[i]) / h, a = 1.0 - b;
      return (a * tau_.row(i) + b * tau_.row(i + 1) +
              ((a * a * a - a) * derivative_.row(i) + (b * b * b - b) * derivative_.row(i + 1)) *
                  (h * h / 6.0))
          .transpose();
    }
    const double s = (time - t_[i]) / h;
    const double s2 = s * s, s3 = s2 * s;
    const double h00 = 2.0 * s3 - 3.0 * s2 + 1.0, h10 = s3 - 2.0 * s2 + s;
    const double h01 = -2.0 * s3 + 3.0 * s2, h11 = s3 - s2;
    return (h00 * tau_.row(i) + h10 * h * derivative_.row(i) + h01 * tau_.row(i + 1) +
            h11 * h * derivative_.row(i + 1))
        .transpose();
  }

 private:
  // Copies (cheap next to the simulation), so the interpolator never outlives its data.
  Eigen::VectorXd t_;
  MatrixX2<double> tau_;
  TorqueJoins joins_;
  MatrixX2<double> derivative_;  // at the samples: C1 the first, C2 the second
  mutable Eigen::Index hint_ = 0;
};

SID_INLINE void validate_free_simulation(const Model<double>& model,
                                         const Eigen::Ref<const Eigen::VectorXd>& theta,
                                         const Kinematics<double>& k,
                                         const FreeSimulationOptions& options);

/// The torque that drives the simulation: k.tau low-passed when FreeSimulationOptions asks for
/// it and the grid is uniform (a Butterworth filter needs one), else k.tau itself.
SID_INLINE MatrixX2<double> driving_torque(const Kinematics<double>& k, double bandwidth,
                                           bool& filtered);

/// Row indices where the segments start: the first sample with t >= t0 + m * segment, but never
/// the last sample (a one-sample segment simulates nothing).
SID_INLINE std::vector<Eigen::Index> segment_starts(const Eigen::Ref<const Eigen::VectorXd>& t,
                                                    double segment);

}  // namespace detail

/// @brief Simulates `model` with parameters theta open loop, driven by the measured torque
/// k.tau, restarting from the smoothed state (k.q, k.qd) every options.segment seconds, and
/// compares the simulated angles with k.q.
///
/// The torque is the measured one with its noise. It is low-passed far above the motion's
/// bandwidth (FreeSimulationOptions::torque_bandwidth, 20 Hz by default) only so that CVODE can
/// take steps longer than a sample, and interpolated between samples by the natural cubic spline
/// (linear interpolation would bias the result by ~h^2 tau''/12, and a C1 cubic would cost
/// twice the steps: detail::TorqueJoins).
/// No filter can remove what matters of the noise: the angles integrate its low-frequency
/// content, so an exact model still drifts like a random walk of size ~ sigma_tau sqrt(Ts t) /
/// theta_friction within a segment (about 5e-3 rad on each joint after 1 s at sigma_tau =
/// 0.1 N m, Ts = 2.5 ms). Callers judge the error against that floor (diagnose_with_simulation
/// calibrates it by simulating the noise alone); the segments keep it bounded.
///
/// A numerical failure (CVODE gives up, the model blows up, a singular mass matrix) never
/// throws: the failed segment's remaining rows are NaN, ok is false and message says which
/// segment failed and why; the other segments are still simulated.
/// @param[in] model the model (any terms; its forward dynamics is used).
/// @param[in] theta its parameters, finite, model.num_parameters() entries.
/// @param[in] k kinematics: t strictly increasing, q [rad], qd [rad/s] (initial states of the
///   segments) and tau [N m] (the input); at least 2 samples; qdd is not used.
/// @param[in] options segment length, blow-up limit, CVODE settings.
/// @throws std::invalid_argument on wrongly sized or non-finite input or bad options.
SID_INLINE FreeSimulation free_simulation(const Model<double>& model,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta,
                                          const Kinematics<double>& k,
                                          const FreeSimulationOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/free_simulation-inl.hpp>
#endif
