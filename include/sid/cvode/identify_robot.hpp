#pragma once
/// @file
/// @brief The whole identification of a serial chain from its logs, as `sid_identify --robot`
/// makes it: the smoothing cutoffs chosen by held-out torque prediction, the fit (least squares,
/// weighted least squares, or IDIM-IV whose instruments come from simulations of the arm), the HAC
/// standard deviations, the prediction of held-out runs and the physically consistent links near
/// what the robot's description says. One call gives a C++ program the tool's numbers.
///
/// It lives under cvode/ because the IV estimator simulates the arm with CVODE.

#include <sid/chain_consistency.hpp>
#include <sid/config.hpp>
#include <sid/description_prior.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/torque_delay.hpp>

#include <Eigen/Core>

#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace sid {

/// @brief How the base parameters are estimated from the smoothed runs.
enum class ChainEstimator {
  LeastSquares,          ///< ordinary least squares (QR)
  WeightedLeastSquares,  ///< each joint's equations weighted by 1/σ_j² of a first fit
  /// IDIM-IV: the regressor rebuilt from open-loop simulations of the physically consistent arm
  /// nearest each estimate, used only where that simulated motion follows the measured one.
  InstrumentalVariables,
};

/// @brief Options of identify_robot().
struct RobotIdentifyOptions {
  /// The smoothing, the equations and the fit. Its `weighted` is set from `estimator`.
  ChainIdentifyOptions fit;
  ChainEstimator estimator = ChainEstimator::LeastSquares;
  /// In (0, 1): the single run's last fraction is held back and predicted from a fit of the rest
  /// (validation[0]); 0: every sample is fitted.
  double validate_fraction = 0.0;
  /// What the robot's description says (description_dynamics() of a URDF): the physically
  /// consistent fit, and the arm the IV simulates, stay near it where the data say little.
  /// Empty: none (a DH table has no inertias).
  DescriptionDynamics description;
  /// An IV estimate whose residual on its rows exceeds this many times least squares' is not
  /// used: the simulated motion did not follow the measured one and the instruments are weak.
  /// Where it follows, IV moves the residual by under 20 % (1.16 on a real Staubli TX40 run,
  /// 1.00-1.01 on simulated arms with rotors).
  double weak_instruments = 1.5;
  /// Without held-out runs, what the consistent links cost in torque error is judged by blocked
  /// cross-validation on the fit's own equations (chain_folds): each of this many spans of time
  /// predicted by the fit of the others and by that fit's consistent links. On the equations it
  /// fitted, least squares always wins by what it fits of the noise; on a block it has not seen
  /// it does not. 0: judged on the fitted equations.
  int consistency_folds = 5;
  /// Estimate how far the torque lags the angles (estimate_torque_delay) and fit, validate and
  /// judge with the torque paired at that delay; fit.torque_delay is then not used.
  std::optional<TorqueDelaySearch> estimate_torque_delay;
};

/// @brief What the IV refinement did (estimator InstrumentalVariables).
struct ChainIvRefinement {
  bool used = false;     ///< the estimator was InstrumentalVariables
  bool applied = false;  ///< its estimate is the one reported (else the least-squares fit)
  int iterations = 0;
  bool converged = false;
  double residual_ratio = 0.0;        ///< its residual on its rows over least squares'
  std::string message;                ///< why it was not applied
  Eigen::VectorXd least_squares;      ///< the first fit on the IV's rows
  std::vector<ChainPrediction> runs;  ///< the IV estimate on each fitted run, when applied
};

/// @brief The blocked cross-validation of the consistent links (consistency_folds): the pooled
/// relative torque error ‖τ − Yβ‖ / ‖τ‖ over every block, each block predicted by the fit of the
/// others (estimate) and by the real bodies nearest that fit (consistent). The folds keep the
/// whole fit's inflation of the variance by the residuals' correlation, which sets the prior's
/// weight.
struct ConsistentCrossValidation {
  int folds = 0;  ///< 0: not made
  double consistent = std::numeric_limits<double>::quiet_NaN();
  double estimate = std::numeric_limits<double>::quiet_NaN();
  /// Why it was not made though asked for (an IV estimate, runs too short for the folds, a
  /// fold's consistent fit that did not converge); "" otherwise.
  std::string skipped;
};

/// @brief What identify_robot() found.
struct RobotIdentification {
  /// The runs fitted, joint side (with validate_fraction, the first one cut to its fitted part).
  std::vector<NamedChainRun> fitted_runs;
  /// The estimate. With IV applied, its fit and std_dev are the IV's (std_dev assumes
  /// uncorrelated residuals) and `fitted` is the first run's prediction.
  ChainIdentification identification;
  ChainIvRefinement iv;
  std::vector<ChainPrediction> validation;  ///< one per held-out run, named as given
  /// The held-out runs, joint side (with validate_fraction, the first is the run's end).
  std::vector<NamedChainRun> held_out_runs;
  ChainConsistentFit consistent;  ///< real bodies near the estimate and the prior
  /// The consistent model's prediction of each held-out run, beside `validation`'s.
  std::vector<ChainPrediction> consistent_validation;
  /// Without held-out runs, the consistent links judged by blocked cross-validation.
  ConsistentCrossValidation consistent_cross_validation;
  /// [s] The torque's lag behind the angles the runs were fitted and predicted with: the
  /// options' fit.torque_delay, or the estimate.
  double torque_delay = 0.0;
  std::optional<TorqueDelayEstimate> torque_delay_estimate;  ///< when asked for
  /// An IV estimate not used; an ill-conditioned fit; a delay estimate at the search's edge.
  std::vector<std::string> warnings;
};

/// @brief Identifies model from runs (joint side) and predicts held_out with the estimate.
/// @throws std::invalid_argument naming the run or option at fault: no runs, a validate_fraction
///         outside [0, 1) or with several runs, a run the identification cannot use, base
///         parameters the runs do not determine, a held-out run of another size.
SID_INLINE RobotIdentification identify_robot(const ChainModel& model,
                                              std::vector<NamedChainRun> runs,
                                              std::vector<NamedChainRun> held_out = {},
                                              const RobotIdentifyOptions& options = {});

/// @brief The drive terms identify_robot's users fit on every joint: viscous friction and armature,
/// which every geared drive has, plus `added` (Coulomb friction and a torque offset by default),
/// in DriveTermKind's order so that the same terms always give the same parameters.
SID_INLINE std::vector<DriveTermKind> robot_drive_term_kinds(
    const std::vector<DriveTermKind>& added = {DriveTermKind::Coulomb, DriveTermKind::Offset});

/// @brief What the consistent model's torque error costs against the estimate's: over the
/// held-out runs where there are any (their relative residuals' mean), else by the blocked
/// cross-validation where it was made, else over the fitted equations
/// (ChainConsistentFit::relative_residual beside least squares').
struct ConsistentCost {
  double consistent = 0.0;  ///< the consistent model's relative torque error
  double estimate = 0.0;    ///< the estimate's
  bool held_out = false;    ///< measured on held-out runs
  int folds = 0;            ///< > 0: by blocked cross-validation over this many blocks
  /// What the errors were measured on, in words: "held-out runs", "N blocks of the fitted
  /// equations, each predicted from the others" or "fitted equations".
  std::string measured_on() const;
  /// consistent / estimate − 1: the share of error the real bodies add.
  double extra() const noexcept { return estimate > 0.0 ? consistent / estimate - 1.0 : 0.0; }
};

SID_INLINE ConsistentCost consistent_cost(const RobotIdentification& result);

/// @brief When the consistent links are a result to write.
struct ConsistentLinksPolicy {
  /// The most torque error the real bodies may add to the estimate's (consistent_cost()), as a
  /// fraction. On a real arm some unmodelled effect always remains, so real bodies never
  /// reproduce the estimate within its noise alone; what matters is what they cost.
  double max_extra_error = 0.10;
  /// Also refuse links that do not reproduce the estimate within its uncertainty (the misfit
  /// test, ChainConsistentFit::fits_estimate).
  bool strict = false;
};

/// @brief Whether the consistent links are a result: the fit converged and, under `policy`,
/// they cost little enough torque error (and, strict, reproduce the estimate).
/// @return "" when they are, else the reason.
SID_INLINE std::string consistent_links_problem(const RobotIdentification& result,
                                                const ConsistentLinksPolicy& policy = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/identify_robot-inl.hpp>
#endif
