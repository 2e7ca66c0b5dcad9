#pragma once
/// @file
/// @brief Model-discrepancy diagnosis of any serial chain: which drive terms (friction, offsets,
/// rotor inertia, springs on each joint or coupled motor) and encoder offsets the logs support
/// beyond a nominal sid::ChainModel, named only when they pass the tests and are of a size a
/// user could see.
///
/// The torque-domain selection of sid/diagnose.hpp on a chain's equations: every candidate but
/// the angle offsets is a sid::DriveTerm, so the model that comes out is a ChainModel like any
/// other (at the angles corrected by the named offsets) and sid_identify --robot, the simulator
/// and the forward dynamics take it as it is. Each round
/// tests every remaining candidate against the current model's residual (Frisch–Waugh–Lovell):
/// a HAC Wald test with Holm's correction over the round, a drop of BIC, a drop of the blocked
/// cross-validation error by more than min_cv_gain, an admissible value (friction, rotor inertia
/// and springs > 0) and a practical size (the change of the torque prediction relative to the
/// torque noise); of those that pass, the one with the largest BIC drop is added.

#include <sid/config.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <limits>
#include <string>
#include <vector>

namespace sid {

/// @brief How diagnose_chain() chooses its smoothing cutoffs when none are given.
enum class ChainSmoothingChoice {
  /// By the GCV of each joint's angles, unless GCV cannot smooth them: as Measured when a
  /// joint's angles move as a staircase (on a grid, sid::quantisation_step, by fewer than two
  /// steps per sample in the median) or GCV leaves them unsmoothed (its cutoff at the search
  /// range's top). GCV assumes white angle noise; on a 12-bit Baxter log it took the stairs for
  /// motion (56 Hz on joint 4), and the rates it left named a 0.2 N m torque offset, with every
  /// joint's free simulation far off. Where GCV works, even on an encoder's grid (16 bits at
  /// 1 kHz), it names better than the torque cross-validation (see Measured).
  Automatic,
  /// Each joint's by the GCV of its angles: chosen from the angles alone, so a cutoff cannot
  /// bend towards hiding what the nominal model lacks.
  AngleGcv,
  /// By held-out torque prediction (identify_chain's cross-validation) of the nominal model with
  /// Coulomb friction and a torque offset on every drive, the terms sid_identify --robot fits by
  /// default: the smoothing a measured log is identified at, with the two commonest missing
  /// terms already in, so that the cutoffs do not bend to absorb them. Its cutoffs are lower
  /// than GCV's, and on simulated arms whose angles GCV smooths well it names more spurious
  /// terms (on a Baxter logged at 1 kHz with 16-bit encoders, 5 of 21 logs against none).
  Measured,
};

/// @brief Options of diagnose_chain().
struct ChainDiagnoseOptions {
  /// Smoothing (cutoffs as `smoothing` chooses unless given), skips, regression rate and rest
  /// rule, as for identify_chain.
  ChainIdentifyOptions identify;
  ChainSmoothingChoice smoothing = ChainSmoothingChoice::Automatic;
  /// The kinds tried on every joint and coupled motor where the nominal model lacks them (offsets
  /// on joints only).
  std::vector<DriveTermKind> candidate_kinds = {DriveTermKind::Coulomb,  DriveTermKind::Offset,
                                                DriveTermKind::Armature, DriveTermKind::Spring,
                                                DriveTermKind::Viscous,  DriveTermKind::Stribeck};
  /// The widths vs [rad/s or m/s] a Stribeck candidate is tried at: in each round only the width
  /// that explains most of the residual is tested (its p-value is the smallest of the widths',
  /// a mild selection), and once one is named the others on that joint are dropped and its
  /// width is fitted within [half the smallest, twice the largest] before the next round.
  std::vector<double> stribeck_velocities = {0.03, 0.1, 0.3};
  /// Also try an offset δ of each joint's measured angle (measured q = true q − δ), through the
  /// nominal fit's torque linearised in that angle, ∂(Y θ̂)/∂q_j. Where the link parameters
  /// absorb the offset (a rotation of the link frames about the joint's axis, e.g. the first
  /// joint about a vertical axis or the last joint) it is reported as not separable: the
  /// torques cannot tell it.
  bool angle_offsets = true;
  double family_alpha = 0.01;  ///< of the HAC Wald tests, Holm over a round's candidates
  /// Contiguous time blocks per run of the blocked cross-validation (each predicted from the fit
  /// on all other blocks of all runs), >= 2. With three runs or more, each run is one block:
  /// every run is predicted from the fit on the others.
  int cv_blocks = 5;
  /// ... and that error must drop by more than this fraction. On measured logs the residuals
  /// are correlated and differ along the run, and a term that absorbs a piece of the model's
  /// error is significant even under a HAC covariance: on the real TX40 run a spring on joint 4
  /// passes the Wald test (p = 0.002 after Holm) but lowers the held-out error by 0.33 %. 0.5 %,
  /// as RunsDiagnoseOptions::min_prediction_gain for two-link runs: the held-out error moves by
  /// about that much between equally good models.
  double min_cv_gain = 0.005;
  /// A candidate whose column the current columns explain with (uncentred) R² above this is not
  /// separable (a joint-1 rotor about a vertical axis is that link's Izz).
  double separability_r2 = 0.995;
  /// Practical size: a candidate that passes the tests but changes no joint's torque prediction
  /// (RMS over its equations) by this fraction of the joint's torque noise is reported as
  /// significant but negligible, not named. Against the noise rather than the residual (as the
  /// two-link DiagnoseOptions::negligible_size): the fits use filtered torques, whose residual
  /// is far below the noise a user sees.
  double negligible_size = 0.075;
  /// A named term gets a caveat (ChainEffectTest::caveat) for each candidate, on any joint, that
  /// is not separable on this motion and may stand behind it: the parts of the two columns that
  /// the nominal model does not explain correlate above this; the value the candidate would
  /// need to give the named terms that take its trace their values (least squares over them) is
  /// admissible; and the final residual does not refute it (it holds what that hidden candidate
  /// would have left beyond the final model, one-sided HAC z within family_alpha). The residual
  /// does the telling: where the candidate is absent the z is about the named term's Wald z times
  /// sqrt(1 - r^2) / r, so only look-alikes above a correlation of about 0.8 survive by chance;
  /// this threshold only skips candidates that account for less than 1 % of the named term's part.
  /// On the simulated TX40 a spring on joint 2 (not separable from gravity there) is named as an
  /// offset with a correlation of 0.6 (z = 1.3); every other pair above 0.1 over 82 data sets is
  /// refuted at z > 13. On a UR5 an encoder offset of joint 2 is named as a torque offset on joint
  /// 3 (0.69) or as an encoder offset of joint 4 (0.2-0.47).
  double look_alike = 0.1;
  /// Threads for the angle offsets' linearisation and the fold Gram matrices (0 = hardware
  /// concurrency); the result does not depend on it.
  int threads = 0;
};

/// @brief One candidate drive term as the diagnosis judged it.
struct ChainEffectTest {
  /// The drive term tested; for an angle offset only term.index (the joint) is meaningful.
  DriveTerm term;
  /// An offset δ of the measured angle of joint term.index (measured q = true q − δ) [rad],
  /// not a drive term: no ChainModel holds it, ChainDiagnosis::angle_offset reports it.
  bool angle_offset = false;
  std::string id;    ///< e.g. coulomb_j3, armature_m5, angle_offset_q2
  std::string unit;  ///< of value
  double value = 0;  ///< the term's parameter (final fit for a named term, else at its test)
  double std = 0;    ///< its HAC standard deviation
  double wald = 0, p_value = 1;  ///< HAC Wald statistic and Holm-adjusted p-value
  /// For a tested term that was not named: the smallest |value| its round's Wald test would
  /// have called significant on its own (family_alpha over the candidates tested), in unit.
  /// A term hidden below it is beyond what this log can show. NaN where it was not tested.
  double detection_limit = std::numeric_limits<double>::quiet_NaN();
  double bic_drop = 0, cv_drop = 0;
  /// Per joint: RMS of the change to the torque prediction / the joint's torque noise.
  Eigen::VectorXd practical_size;
  std::string reason;  ///< why it was not named; empty for a named term
  /// For a named term: the candidates that are not separable from the model on this motion and
  /// may stand behind it (see ChainDiagnoseOptions::look_alike), each with the value it would
  /// need; empty when there is none. A motion that separates them: sid_excite --separate with
  /// the term's id and look_alikes.
  std::string caveat;
  std::vector<std::string> look_alikes;  ///< the ids the caveat names
};

/// @brief What diagnose_chain() found.
struct ChainDiagnosis {
  /// The nominal model's terms, then the named drive terms (not the angle offsets).
  std::vector<DriveTerm> final_terms;
  /// Per joint: the named angle offset δ [rad] (measured q = true q − δ), 0 where none is named.
  /// The final model is fitted and simulated at the measured angles plus these.
  Eigen::VectorXd angle_offset;
  std::vector<ChainEffectTest> named;  ///< in selection order
  std::vector<ChainEffectTest> not_named;
  /// σ of each joint's measured torque noise (a GCV smoothing spline per run; RMS over runs)
  /// [N m]: the residual a perfect model leaves.
  Eigen::VectorXd noise_floor;
  /// Per joint RMS of measured τ − model over the fitted equations (at the measured, unfiltered
  /// torque) of the nominal and the final model, and the final model's excess
  /// sqrt(max(0, rms² − floor²)): what no tried effect explains [N m].
  Eigen::VectorXd nominal_residual_rms, final_residual_rms, unexplained_rms;
  Eigen::VectorXd cutoff_hz;  ///< the smoothing used, per joint
  /// How cutoff_hz was chosen, in words ("given", "GCV of the angles", "held-out torque
  /// prediction ...", with the reason when Automatic chose it).
  std::string smoothing;
  /// Each run smoothed at cutoff_hz (angles, rates, accelerations, and the torque when
  /// identify.filter_torque): the states a free simulation restarts from and its drive.
  std::vector<ChainKinematics<double>> kinematics;
  Eigen::Index equations = 0;
  double seconds = 0;
};

/// @brief The id of a drive term: KIND_jN on a joint, KIND_mN on a coupled motor (1-based).
SID_INLINE std::string drive_term_id(const DriveTerm& term);

/// @brief Diagnoses which drive terms the runs support beyond `nominal`.
/// @throws std::invalid_argument on bad runs (as identify_chain) or options, naming the problem.
SID_INLINE ChainDiagnosis diagnose_chain(const ChainModel& nominal,
                                         const std::vector<ChainTrajectory<double>>& runs,
                                         const ChainDiagnoseOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/diagnose_chain-inl.hpp>
#endif
