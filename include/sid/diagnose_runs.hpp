#pragma once
/// @file
/// @brief Model-discrepancy diagnosis on several measured runs of the same arm: which physical
/// effects of sid/model/effects.hpp the runs support, judged by how well a model with the effect
/// predicts torques of runs it was not fitted on.
///
/// Why prediction rather than significance: on measured logs the residuals are correlated over
/// many samples and differ from run to run, and a term that absorbs part of one run's model
/// error is "significant" even under a HAC covariance. On the six runs of a real two-link arm a
/// spring on joint 1 reaches z = 25 with a HAC standard deviation, yet the fit of five runs with
/// it predicts the sixth worse (0.208 against 0.182 N m on joint 1). A term is therefore named
/// only when it also lowers the torque error on held-out runs.

#include <sid/config.hpp>
#include <sid/diagnose.hpp>
#include <sid/identify_runs.hpp>
#include <sid/model/effects.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/smoothing_spline.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief Options of diagnose_runs.
struct RunsDiagnoseOptions {
  /// Smoothing (cutoff, chosen by torque cross-validation of the nominal model when empty),
  /// skips, folds per run, threads.
  RunsIdentifyOptions identify;
  EffectSettings effects;          ///< ε, g; the Stribeck vs is searched on a grid
  std::vector<Effect> candidates;  ///< effects to try; empty: all_effects()
  /// vs grid [rad/s] for stribeck candidates; empty: 0.05..1 rad/s, 9 points.
  std::vector<double> stribeck_velocities;
  /// A candidate is named only if its HAC Wald test (runs independent, prewhitened Newey–West
  /// within each run) rejects at this family-wise level (Holm over the round's candidates) ...
  double family_alpha = 0.01;
  /// ... and the held-out torque mean square drops by more than this fraction, averaged over
  /// the joints. Held out: each run in turn with three runs or more; otherwise each of the
  /// identify.folds_per_run contiguous blocks of every run. 0.5 %: the torque error of a
  /// held-out run moves by about that much between equally good models (the smoothing cutoff's
  /// neighbouring grid points), so smaller gains are not evidence.
  double min_prediction_gain = 0.005;
};

/// @brief One effect tested against the model of a selection round.
struct RunsEffectTest {
  Effect effect;
  EffectSettings settings;       ///< the settings its term was built with (Stribeck: the vs found)
  EffectEstimate estimate;       ///< physical values with HAC standard deviations
  double wald = 0, p_value = 1;  ///< HAC Wald statistic; p-value after Holm's correction
  /// Relative drop of the held-out torque mean square per joint when the effect is added
  /// (negative: the predictions got worse), and their mean, the selection's criterion.
  Vector2<double> prediction_gain = Vector2<double>::Zero();
  double gain = 0;
  std::string reason;  ///< why it was not named; empty for a named effect
};

/// @brief The shape of a named Coulomb friction, tested after the selection: the sign stand-in
/// atan instead of tanh (a slower approach to the level), then a level that differs by direction.
struct FrictionShapeTest {
  Effect coulomb;                           ///< the Coulomb friction tested
  CoulombShape shape = CoulombShape::Tanh;  ///< the one kept
  bool asymmetric = false;                  ///< kept: Fc + dFc forward, Fc − dFc backward
  /// Relative drops of the held-out torque mean square per joint when the variant replaces the
  /// current term (negative: worse), as the selection's criterion measures them.
  Vector2<double> atan_gain = Vector2<double>::Zero(), asymmetric_gain = Vector2<double>::Zero();
  double asymmetric_p_value = 1;  ///< HAC Wald test of dFc = 0
  /// The levels forward and backward [N m] with HAC std: of the final model when asymmetric, of
  /// the asymmetric trial otherwise.
  double forward = std::nan(""), backward = std::nan(""), forward_std = std::nan(""),
         backward_std = std::nan("");
};

/// @brief What diagnose_runs found.
struct RunsDiagnosis {
  double cutoff_hz = std::nan("");
  bool cutoff_chosen = false;
  Model<double> nominal_model, final_model;  ///< final: nominal plus the named effects' terms
  RunsIdentification nominal, final;         ///< fits of all runs, left-out predictions, HAC std
  Eigen::MatrixXd final_covariance;          ///< HAC covariance of final.fit.theta
  std::vector<RunsEffectTest> named;         ///< in selection order, estimates from the final fit
  std::vector<RunsEffectTest> not_named;     ///< the last round's candidates and the reasons
  /// The drive-2 rotor carried by link 1 (armature_j2) tested against the final model when it
  /// was not named; its estimate gives Ir = Ia / (gr² + gr) for a gear ratio gr.
  std::optional<RunsEffectTest> rotor_coupling;
  /// One per named Coulomb friction. A variant is kept when it lowers the held-out torque mean
  /// square by more than min_prediction_gain (the asymmetry also when its Wald test rejects at
  /// family_alpha and both levels are positive).
  std::vector<FrictionShapeTest> friction_shapes;
  /// Per run and joint: RMS of the measured torque's content above the cutoff [N m]. The
  /// kinematics carry nothing above the cutoff, so no model built on them can explain it: it is
  /// the floor the residual is compared with. A floor from the torque's own noise estimate (GCV)
  /// would not hold: drive torques are quantised and filtered, and GCV takes that for signal.
  std::vector<Vector2<double>> floor;
  /// What no named effect explains, per joint over all runs: √(max(0, RMS² − floor²)) of the
  /// final model's residual and of its held-out prediction error [N m].
  Vector2<double> excess_rms = Vector2<double>::Zero();
  Vector2<double> left_out_excess_rms = Vector2<double>::Zero();
  double seconds = 0;  ///< wall time
};

namespace detail {

/// The equations of one model on every run, with the per-group normal equations that make each
/// held-out prediction a p x p solve. Columns are scaled to unit norm over all runs.
struct RunsEquations {
  std::vector<StackedRegression<double>> runs;  ///< per run: joint 1's rows, then joint 2's
  Eigen::VectorXd scale;                        ///< column norms
  struct Group {
    std::size_t run = 0;
    Eigen::Index begin = 0, size = 0;  ///< sample range within the run
    Eigen::MatrixXd gram[2];
    Eigen::VectorXd cross[2];
    double yy[2] = {0.0, 0.0};
  };
  std::vector<Group> groups;
  Eigen::MatrixXd gram;  ///< the sums of the groups' (both joints)
  Eigen::VectorXd cross;
};

SID_INLINE RunsEquations runs_equations(const Model<double>& model,
                                        const std::vector<Kinematics<double>>& kinematics,
                                        int folds_per_run);

/// The held-out torque mean square per joint: each group predicted by the fit of the others.
/// Infinite when a fit without some group is singular.
SID_INLINE Vector2<double> left_out_mean_square(const RunsEquations& e);

/// θ of all runs together and its HAC covariance (runs independent), from the scaled normal
/// equations: accurate enough for the tests of a round; the reported fits are QR fits.
SID_INLINE std::pair<Eigen::VectorXd, Eigen::MatrixXd> fit_with_hac(const RunsEquations& e);

/// The nominal two-link model plus the terms of `named` (a Stribeck term replaces the Coulomb
/// term of its joint, which it contains).
SID_INLINE Model<double> model_with(double g,
                                    const std::vector<std::pair<Effect, EffectSettings>>& named);

SID_INLINE std::vector<std::pair<Effect, EffectSettings>> with_candidate(
    std::vector<std::pair<Effect, EffectSettings>> named, Effect effect,
    const EffectSettings& settings);

/// A candidate's test against the model of `named` (its held-out mean square `base_ms`).
SID_INLINE RunsEffectTest
test_candidate(Effect effect, const EffectSettings& settings,
               const std::vector<std::pair<Effect, EffectSettings>>& named,
               const std::vector<Kinematics<double>>& kinematics, const Vector2<double>& base_ms,
               const RunsDiagnoseOptions& options);

/// The Stribeck width whose model predicts held-out torques best.
SID_INLINE double best_stribeck_width(Effect stribeck,
                                      const std::vector<std::pair<Effect, EffectSettings>>& named,
                                      const std::vector<Kinematics<double>>& kinematics,
                                      const RunsDiagnoseOptions& options);

/// RMS per joint of a run's torque above cutoff_hz: τ minus its smoothing at the cutoff, at the
/// samples the fits use.
SID_INLINE Vector2<double> torque_above_cutoff(const Trajectory<double>& run, double cutoff_hz,
                                               const RunsIdentifyOptions& options);

SID_INLINE void check_runs_diagnose_options(const RunsDiagnoseOptions& o);

/// "+1.19 % / -0.17 %": the change of the held-out mean square per joint.
SID_INLINE std::string mean_square_change(const Vector2<double>& gain);

/// Why a tested candidate is not named (empty: it passes).
SID_INLINE std::string rejection(const RunsEffectTest& t, const RunsDiagnoseOptions& o);

/// One round of the forward selection: every remaining candidate tested against `named`.
SID_INLINE std::vector<RunsEffectTest> selection_round(
    const std::vector<std::string>& remaining,
    const std::vector<std::pair<Effect, EffectSettings>>& named,
    const std::vector<Kinematics<double>>& kinematics, const RunsDiagnoseOptions& options);

/// The passing candidate with the largest gain, except that a term containing another passing
/// one (Stribeck contains Coulomb) must beat it by min_gain: on data with plain Coulomb
/// friction a Stribeck term with Fs ≈ Fc predicts as well, and the simpler effect is the finding.
SID_INLINE const RunsEffectTest* best_candidate(const std::vector<RunsEffectTest>& tests,
                                                double min_gain);

/// The levels forward and backward of an asymmetric Coulomb term at `at` (Fc, dFc) of θ.
SID_INLINE void directional_levels(FrictionShapeTest& s, const Eigen::VectorXd& theta,
                                   const Eigen::MatrixXd& covariance, Eigen::Index at);

/// Tests the shapes of the named Coulomb terms, one joint after the other, and keeps those that
/// pass (see RunsDiagnosis::friction_shapes); updates `named` and `chosen`'s settings.
SID_INLINE std::vector<FrictionShapeTest> test_friction_shapes(
    std::vector<std::pair<Effect, EffectSettings>>& named, std::vector<RunsEffectTest>& chosen,
    const std::vector<Kinematics<double>>& kinematics, const RunsDiagnoseOptions& options);

}  // namespace detail

/// @brief Diagnoses several measured runs of the two-link arm together.
///
/// 1. Kinematics of every run at one smoothing cutoff (RunsIdentifyOptions; with none given,
///    chosen by torque cross-validation of the nominal model, as identify_runs does).
/// 2. Floor per run and joint: the torque's content above the cutoff (RunsDiagnosis::floor).
/// 3. Forward selection over the candidates. Each round tests every remaining candidate added to
///    the current model (a Stribeck term replacing its joint's Coulomb term; its width vs from a
///    grid, by held-out prediction). A candidate passes if its HAC Wald test rejects at
///    family_alpha after Holm, its held-out torque mean square drops by more than
///    min_prediction_gain (mean over the joints), and its physical values are admissible; the
///    passing candidate with the largest drop is named (a Stribeck term only if it beats its
///    joint's Coulomb term by min_prediction_gain). armature_j1 is never tested: its column
///    equals θ1's.
/// 4. Each named Coulomb term is tried with the atan shape, then with a level that differs by
///    direction (RunsDiagnosis::friction_shapes).
/// 5. The final model is fitted by identify_runs (QR, HAC std, each run left out in turn); the
///    named effects' values come from it. The rotor coupling of drive 2 is tested against it.
/// @throws std::invalid_argument as identify_runs does, or for bad options (names the problem).
SID_INLINE RunsDiagnosis diagnose_runs(const std::vector<Trajectory<double>>& runs,
                                       const RunsDiagnoseOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/diagnose_runs-inl.hpp>
#endif
