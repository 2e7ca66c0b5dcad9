#pragma once
/// @file
/// @brief Coulomb or Stribeck? The output-error test of a joint's friction curve, and the
/// Stribeck values (Fc, Fs, vs) it estimates, for diagnose_with_simulation.
///
/// The torque-domain regression of sid/diagnose.hpp works on q̂̈ from a smoothing spline whose
/// bandwidth (tens of milliseconds) is about the time a joint takes to cross |q̇| < vs at a
/// reversal. It fixes the Stribeck bump's area, (Fs − Fc) vs, not its height: on the paper's
/// excitation Fs came out 20–40 % low and joint 1's bump was named as Coulomb friction in half
/// the seeds. The measured angles keep the full bandwidth. Here the final model is simulated
/// over a window around each reversal of the joint, driven by the applied torque, and its
/// friction parameters are fitted to the measured angles (sid/cvode/output_error.hpp) with the
/// Coulomb and the Stribeck curve; a likelihood-ratio test chooses. Where the torque-domain
/// tests named Coulomb friction, the Stribeck fit runs only if a score test at the Coulomb fit
/// hints at a bump; where they named Stribeck friction, it runs first, and the Coulomb fit,
/// which then misfits, is taken only as far as the likelihood ratio needs.
///
/// The applied torque is the measured one smoothed by a GCV spline (the sensor noise would
/// otherwise drive the simulation like a random walk). What the spline leaves of the noise
/// varies over a few tenths of a second, so each window also gets its own torque offset and
/// slope: without them the smoothed torque alone raised the cost at the true parameters
/// ninefold, and a spurious bump passed the test on Coulomb data.

#include <sid/config.hpp>
#include <sid/cvode/output_error.hpp>
#include <sid/diagnose.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/diagnosis/noise_floor.hpp>
#include <sid/model/effects.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief Settings of refine_friction().
struct FrictionRefinementOptions {
  double before = 0.15;  ///< [s] a window starts this long before a reversal of the joint
  double after = 0.25;   ///< [s] and ends this long after it
  /// [s] a window that the previous one cuts shorter than this is not used.
  double min_window = 0.2;
  /// At most this many windows, spread evenly over the reversals (each costs a sensitivity
  /// simulation per Jacobian and one simulation per Levenberg–Marquardt step).
  int max_windows = 8;
  /// Level of the likelihood-ratio test (Stribeck against Coulomb). Not 0.01: the angle
  /// residuals are not independent (what the smoothed torque leaves varies smoothly), so the
  /// statistic runs above χ²(2) on Coulomb data: over 32 effect-free-curve data sets (Coulomb on
  /// either joint, both excitations, seeds 1-6, 11, 12) it passed the 1 % point (9.2) four times,
  /// all on joint 1 of the multisine excitation, at most 13.9; 1e-4 (18.4) keeps a margin, and
  /// Stribeck data (16 sets) gave 85 and more.
  double alpha = 1e-4;
  /// [rad/s] a Stribeck velocity outside this range is not admissible (the bump is then a
  /// step, or wider than the motion).
  double min_velocity = 0.01, max_velocity = 2.0;
  /// Start of vs when the torque-domain selection named Coulomb friction and the screen found no
  /// better one [rad/s].
  double start_velocity = 0.5;
  double gravity = kPaperGravity;  ///< g of the model [m/s²]: the diagnosis's identify.gravity
  /// Hold Fc near the torque-domain estimate (a prior with its standard deviation): the
  /// sliding away from the reversals fixes Fc better than the windows do. Without it Fc
  /// scattered by up to 18 % over the Stribeck test cases, with it by up to 14 %; Fs is fixed
  /// by the windows either way.
  bool prior_on_coulomb_level = true;
  /// The screen, where the torque-domain tests named Coulomb friction: at the Coulomb fit, the
  /// score test of a Stribeck bump at each of these vs [rad/s] (one simulation per window
  /// each). The Stribeck fit, several times the cost of the Coulomb one, runs only if the
  /// largest statistic with a positive bump reaches screen_level; otherwise Coulomb is kept.
  /// Why the level is far below the test's χ²(2) critical value: see the README's calibration
  /// ("Stribeck friction"). An empty grid: always fit.
  std::vector<double> screen_velocities = {0.03, 0.06, 0.12, 0.25, 0.5, 1.0};
  double screen_level = 4.0;
  OutputErrorOptions fit;
};

/// @brief What refine_friction() found for one joint.
struct [[nodiscard]] FrictionRefinement {
  FrictionCheck check;
  /// The chosen effect's values with standard deviations from the output-error fit: Fc for
  /// Coulomb; Fc, Fs, vs for Stribeck.
  Eigen::VectorXd estimate, std;
  OutputErrorFit coulomb, stribeck;
  bool completed = false;  ///< false: check.message says why; the diagnosis is to be left as it is

  bool ok() const noexcept { return completed; }
};

namespace detail {

/// Windows of [t_r − before, t_r + after] around the velocity reversals t_r of `joint` (0-based,
/// sign changes of the smoothed q̇). Sign changes closer than `before` to the previous one are
/// one event (a joint that sticks chatters around q̇ = 0): its window runs from before the first
/// to after the last. Windows do not overlap: one starts where the previous ends at the
/// earliest and is dropped if that leaves less than min_window. At most max_windows, evenly
/// spread over the events.
SID_INLINE std::vector<OutputErrorWindow> reversal_windows(const Kinematics<double>& k, int joint,
                                                           const FrictionRefinementOptions& o);

/// Whether the diagnosis names Coulomb or Stribeck friction of `joint` (1 or 2): what
/// refine_named_friction tests.
SID_INLINE bool names_friction_of(const DiagnosisResult& result, int joint);

}  // namespace detail

/// @brief The output-error test of joint `joint`'s friction in a diagnosis that named Coulomb
/// or Stribeck friction there: fits the Coulomb curve (viscous and Fc free) and the Stribeck
/// curve (viscous, Fc, Fs − Fc and vs free) to the measured angles over windows around the
/// joint's reversals, every other parameter held at the diagnosis's final fit, and prefers
/// Stribeck when the likelihood ratio passes the χ²(2) test at options.alpha with Fs > Fc and vs
/// within [min_velocity, max_velocity]. Named Coulomb: the Stribeck fit runs only if the score
/// test of a bump at the Coulomb fit (options.screen_velocities) reaches options.screen_level;
/// otherwise Coulomb is kept without it (check.stribeck_fitted false, no likelihood ratio).
/// Named Stribeck: the Stribeck fit runs first (no screen, check.score NaN) and the Coulomb fit
/// stops once the ratio is known to 1 % (OutputErrorOptions::comparison_cost); if Coulomb is
/// chosen all the same, its fit is taken on to its minimum.
/// @param result a diagnosis of `data` (diagnose()), naming coulomb_jX or stribeck_jX.
/// @param data the measured data the diagnosis ran on.
/// @param joint 1 or 2.
/// @throws std::invalid_argument if joint is not 1 or 2, no friction of that joint is named, or
///   data does not hold the diagnosis's samples.
SID_INLINE FrictionRefinement refine_friction(const DiagnosisResult& result,
                                              const Trajectory<double>& data, int joint,
                                              const FrictionRefinementOptions& options = {});

/// @brief The diagnosis after refine_friction() on every joint whose friction it named: where
/// the test changes the curve or estimates a Stribeck one, its choice and values replace the
/// diagnosis's (the effect, its values from the output-error fit and its note), every test is
/// listed in friction_checks, and the torque-domain final fit is redone at the chosen curve
/// (refit_final_model). `options` are the diagnosis's. A joint whose fits fail keeps what the
/// diagnosis named (its check says why).
/// @throws std::invalid_argument as refine_friction() does.
[[nodiscard]] SID_INLINE DiagnosisResult
refine_named_friction(DiagnosisResult result, const Trajectory<double>& data,
                      const DiagnoseOptions& options, FrictionRefinementOptions friction = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/friction_refinement-inl.hpp>
#endif
