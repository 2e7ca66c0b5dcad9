#pragma once
/// @file
/// @brief Identification of a serial chain (any number of joints) from one or several measured
/// runs: per-joint smoothing chosen by held-out torque prediction, base parameters named by the
/// combinations they stand for, least squares (or Gautier's weighted least squares) and
/// uncertainties that hold for correlated residuals.
///
/// Per run and joint, the angle is smoothed by the Reinsch spline at a cutoff frequency
/// (sid::smoothing_lambda_for_cutoff), velocities and accelerations taken from the spline. The
/// measured torque of each joint goes through the same smoother as its angle (parallel
/// filtering): what the smoothed motion cannot explain is not asked of the model, and the
/// torque's own noise above the cutoff leaves the residual. Equations are taken at most at
/// regression_rate_hz, and a joint's equation is left out while the joint is nearly at rest
/// (friction there is stiction, which no velocity term describes); which equations are used
/// depends on the smoothed motion only, never on the torque.
///
/// With no cutoff given, each joint's is chosen by K-fold cross-validation over contiguous blocks
/// of each run against the measured (unfiltered) torque, whose noise is independent of the fit:
/// first one cutoff for all joints on a grid, then each joint's moved by half octaves while the
/// held-out prediction improves.

#include <sid/base_parameters.hpp>
#include <sid/config.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid {

/// @brief Options of identify_chain.
struct ChainIdentifyOptions {
  /// Smoothing cutoffs [Hz]: empty = chosen by cross-validation; one value for every joint; or
  /// one per joint.
  std::vector<double> cutoff_hz;
  /// The cross-validation's grid: 2^(k / grid_points_per_octave) Hz within [min, max].
  double min_cutoff_hz = 1.0;
  double max_cutoff_hz = 64.0;
  int grid_points_per_octave = 2;
  /// Contiguous blocks each run is split into for the cross-validation, >= 2.
  int folds_per_run = 5;
  /// Time left out at each run's start and end [s]: the natural spline's ends distort q̈.
  double skip = 0.1;
  double skip_end = 0.1;
  /// Equations are taken at most at this rate [Hz] (every k-th sample of a denser log): after
  /// the smoothing, neighbouring samples carry the same information and cost memory.
  double regression_rate_hz = 500.0;
  /// Joint j's equation at a sample is left out when |q̇_j| < rest_fraction · RMS(q̇_j) of its
  /// run, in [0, 1); 0 keeps every equation.
  double rest_fraction = 0.1;
  /// Smooth the measured torques as their joints' angles (see the file comment).
  bool filter_torque = true;
  /// [s] How far the logged torque lags the angles (a servo's current and position sent over
  /// separate paths): the torque logged at t is paired with the angles' spline at t − delay,
  /// q, q̇ and q̈ alike, so that the torque itself is not interpolated; negative: the angles
  /// lag. |delay| at most the skips.
  double torque_delay = 0.0;
  /// Weighted least squares with each joint's equations weighted by 1/σ_j² from an unweighted
  /// fit first (Gautier's WLS).
  bool weighted = false;
  /// Base parameters: a column is kept when its distance from the columns before it (all at unit
  /// norm, on random states) exceeds this.
  double base_tolerance = 1e-8;
  /// Then the runs' own equations: a base parameter whose column is within this relative
  /// distance of the columns before it (unit norm) is not determined by the data and regroups.
  double data_tolerance = 1e-6;
  /// Random states the base parameters are found on, and the generator's seed.
  int base_samples = 600;
  unsigned base_seed = 1;
  /// The HAC and jackknife standard deviations and the predictions at every sample (per run and
  /// over all, against the measured torque): two thirds of the time on a 20 s six-joint log.
  /// Without them std_dev is the fit's own and `fitted` holds the figures over the fitted
  /// equations only: what a caller that needs the fit alone (the diagnosis, a bootstrap) takes.
  bool statistics = true;
  /// Threads the cutoff search scores its candidates on (0: every core); the cutoffs and the
  /// fit do not depend on it. 1 by default: a caller that runs fits side by side (a study, a
  /// bootstrap) has the cores busy already.
  int threads = 1;
  LeastSquaresOptions least_squares;
};

/// @brief How well a parameter set predicts a run's torques: over the equations used (the
/// torque filtered, equations at rest left out, as the fit), and over the log as recorded.
struct ChainPrediction {
  std::string source;                  ///< a label (the file name, for the apps)
  Eigen::VectorXd residual_rms;        ///< RMS of τ − Yθ per joint [N m]
  Eigen::VectorXd relative_per_joint;  ///< ‖τ_j − (Yθ)_j‖ / ‖τ_j‖ per joint
  double relative_residual = 0.0;      ///< ‖τ − Yθ‖ / ‖τ‖ over all joints
  /// The same against the measured torque without its filtering (its noise included).
  double relative_residual_unfiltered = 0.0;
  /// Against the measured torque at every sample of the window (at rest too, unfiltered): the
  /// prediction of the log as recorded, noise and stiction included. Comparable with any
  /// model's prediction of the same samples.
  Eigen::VectorXd measured_residual_rms;
  double measured_relative_residual = 0.0;
  Eigen::VectorXi equations;  ///< equations used per joint
};

/// @brief A log of the chain, joint-side, with the name the results call it by.
struct NamedChainRun {
  std::string name;
  ChainTrajectory<double> data;
};

/// @brief What identify_chain found.
struct ChainIdentification {
  BaseParameters<double> base;  ///< the base parameters in the model's columns
  /// The number of base parameters of the model on random states; base.rank() is smaller when
  /// the runs leave some of them undetermined.
  Eigen::Index structural_rank = 0;
  /// Each base parameter written as its combination: shortened (at most six terms) and in full.
  std::vector<std::string> parameter_names;
  std::vector<std::string> parameter_combinations;
  /// The fit of the base parameters; its std_dev assumes uncorrelated residuals.
  LeastSquaresResult<double> fit;
  /// Standard deviations from the HAC covariance (Newey–West with prewhitening per run; runs
  /// independent): residuals on smoothed data are correlated over many samples, and then the
  /// fit's own std_dev is several times too small. NaN where the fit failed.
  Eigen::VectorXd std_dev;
  Eigen::VectorXd relative_std_dev;  ///< 100 std_dev / |θ| [%]
  /// With three runs or more: the jackknife standard deviations over the fits that leave one run
  /// out (what differs from run to run), else empty.
  Eigen::VectorXd jackknife_std_dev;
  Eigen::VectorXd cutoff_hz;  ///< the smoothing used, per joint
  bool cutoff_chosen = false;
  /// The cross-validation's criterion at the chosen cutoffs: the mean over joints of the held-out
  /// residual's share of the measured torque, ‖r_j‖² / ‖τ_j‖² (NaN when the cutoffs were given).
  double cross_validation_score = 0.0;
  ChainPrediction fitted;  ///< over all runs fitted
  std::vector<ChainPrediction> per_run;

  Eigen::VectorXd theta() const { return fit.theta; }
};

/// @brief The model's base parameters on options.base_samples random states (options.base_seed,
/// options.base_tolerance): what no motion of the chain can tell apart, in the columns' order
/// (sid::base_parameters_in_order), so a link's parameters are kept before the drive terms that
/// repeat them.
/// @throws std::invalid_argument on invalid options.
SID_INLINE BaseParameters<double> chain_base_parameters(const ChainModel& model,
                                                        const ChainIdentifyOptions& options = {});

/// @brief Identifies the base parameters of model from runs (joint side, model.joints() columns).
/// @throws std::invalid_argument on an empty run list, an invalid run, a run with another joint
///         count or too short for the skips and folds, or invalid options.
SID_INLINE ChainIdentification identify_chain(const ChainModel& model,
                                              const std::vector<ChainTrajectory<double>>& runs,
                                              const ChainIdentifyOptions& options = {});

/// @brief How the identified parameters predict a run not fitted (same cutoffs, skips and rest
/// rule as the fit).
/// @throws std::invalid_argument as identify_chain, or if the identification failed.
SID_INLINE ChainPrediction predict_chain(const ChainModel& model,
                                         const ChainIdentification& identification,
                                         const ChainTrajectory<double>& run,
                                         const ChainIdentifyOptions& options = {});

/// @brief One block of a blocked cross-validation on an identification's own equations.
struct ChainFold {
  /// The fit of every equation outside the block: the same base parameters, cutoffs and
  /// estimator; std_dev is the fit's own, as refit_chain's.
  ChainIdentification fit;
  /// The block's equations: regressor rows in the base parameters' columns and the torque they
  /// predict (as fitted: filtered when the fit filters it).
  Eigen::MatrixXd x;
  Eigen::VectorXd y;

  /// ‖y − x θ‖²: what the base parameters θ leave unexplained of the block.
  double residual_sum_of_squares(const Eigen::VectorXd& theta) const {
    return (y - x * theta).squaredNorm();
  }
};

/// @brief The folds of a blocked cross-validation on the equations of runs at an identification's
/// cutoffs: each run's equations cut in `folds` spans of equal time, fold k holding out span k of
/// every run. The runs are smoothed whole, as for the fit, so a block has no edges of its own:
/// it judges a model on the rows the fit used, without the fit having seen them. Smoothed
/// neighbours leak a little across each cut; with a few blocks that is a few cuts in a run.
/// @throws std::invalid_argument as refit_chain, or if folds < 2 or a fold leaves fewer
///         equations than base parameters.
SID_INLINE std::vector<ChainFold> chain_folds(const ChainModel& model,
                                              const ChainIdentification& identification,
                                              const std::vector<ChainTrajectory<double>>& runs,
                                              const ChainIdentifyOptions& options = {},
                                              int folds = 5);

/// @brief Fits an earlier identification's base parameters to other runs of the same model at
/// its cutoffs: the smoothing, the equations and least squares only. No base-parameter search, no
/// cutoff choice, no HAC or jackknife deviations (std_dev is the fit's own) and no per-run or
/// measured-torque predictions (fitted holds the figures over the fitted equations): what a
/// bootstrap repeats many times.
/// @throws std::invalid_argument as identify_chain, or if `earlier` failed or belongs to
///         another model.
SID_INLINE ChainIdentification refit_chain(const ChainModel& model,
                                           const ChainIdentification& earlier,
                                           const std::vector<ChainTrajectory<double>>& runs,
                                           const ChainIdentifyOptions& options = {});

/// @brief The identified model's torque at every sample of a run (rows: samples, columns:
/// joints), on its motion smoothed at the identification's cutoffs.
/// @throws std::invalid_argument as predict_chain.
SID_INLINE Eigen::MatrixXd chain_torque(const ChainModel& model,
                                        const ChainIdentification& identification,
                                        const ChainTrajectory<double>& run,
                                        const ChainIdentifyOptions& options = {});

/// @brief A run smoothed as identify_chain smooths it at the given cutoffs [Hz] (one per joint):
/// the angles, rates and accelerations at every sample, and the torque filtered as the angles
/// when options.filter_torque (else as measured).
/// @throws std::invalid_argument for an invalid run or a cutoff count other than the joints'.
SID_INLINE ChainKinematics<double> smooth_chain_run(const ChainTrajectory<double>& run,
                                                    const Eigen::VectorXd& cutoff_hz,
                                                    const ChainIdentifyOptions& options = {});

/// @brief The samples of a run before (first) and from (second) the time t0 + fraction (t_end -
/// t0): the time split of a single run into a part to fit and a part to predict.
/// @throws std::invalid_argument unless 0 < fraction < 1 and both parts have samples.
SID_INLINE std::pair<ChainTrajectory<double>, ChainTrajectory<double>> split_run(
    const ChainTrajectory<double>& run, double fraction);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/identify_chain-inl.hpp>
#endif
