#pragma once
/// @file
/// @brief Identification from one or several measured runs of the same arm, with the smoothing
/// chosen for the regression rather than for the angles.
///
/// Each run is smoothed on its own time grid (which may be non-uniform), its equations are
/// stacked with every other run's, and one least-squares fit of a sid::Model gives θ. How much
/// the splines smooth is a cutoff frequency shared by all runs and joints. With no cutoff given
/// it is the one whose estimate best predicts torques it was not fitted on: K-fold
/// cross-validation over contiguous blocks of each run.
///
/// Why not GCV: GCV (and generalized maximum likelihood) choose λ for the angles, assuming
/// independent noise. Encoder angles are quantised and slowly varying, so their error is strongly
/// correlated from sample to sample; the jitter of a logged time grid adds more of the same.
/// Both criteria then take that error for signal and nearly interpolate (on 2 ms encoder logs
/// tr A reaches 40–100 % of n), and q̈ — which the regression needs — is dominated by the steps.
/// Cross-validating the torque prediction looks at what the regression needs and is not fooled
/// by correlated angle error: a q̈ that follows the steps predicts held-out torques badly.

#include <sid/config.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/identify.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/model.hpp>
#include <sid/model/regressor.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace sid {

/// @brief Options of identify_runs.
struct RunsIdentifyOptions {
  /// The smoothing cutoff [Hz], > 0; empty: chosen by torque cross-validation.
  std::optional<double> cutoff_hz;
  /// The cross-validation searches a geometric grid of cutoffs in [min, max] [Hz].
  double min_cutoff_hz = 0.25;
  double max_cutoff_hz = 64.0;
  int grid_points_per_octave = 4;
  /// Contiguous blocks each run is split into for the cross-validation, >= 2. Contiguous, not
  /// random, because neighbouring samples share their smoothing error: a random split would
  /// leave a sample's neighbours in the fit and reward interpolation again.
  int folds_per_run = 5;
  /// Samples within skip [s] of a run's start or skip_end of its end are not used: the natural
  /// spline's zero curvature at its ends distorts q̈ over about one cutoff period.
  double skip = 0.1;
  double skip_end = 0.1;
  /// Threads for the cutoff search (0 = hardware concurrency).
  int threads = 0;
  LeastSquaresOptions least_squares;
};

/// @brief What identify_runs found.
struct RunsIdentification {
  /// Per run: q, q̇, q̈ and τ at the samples used.
  std::vector<Kinematics<double>> kinematics;
  /// The fit of all runs' equations: rows are joint 1's of every run in order, then joint 2's.
  LeastSquaresResult<double> fit;
  /// The smoothing used [Hz] and whether the cross-validation chose it.
  double cutoff_hz = std::nan("");
  bool cutoff_chosen = false;
  /// The criterion over the grid: RMS of the held-out torque residuals [N m] (empty when the
  /// cutoff was given). Infinite where a fold's fit was singular.
  std::vector<double> grid_hz;
  std::vector<double> cross_validation_rms;
  /// Standard deviations of θ from the HAC covariance (Newey–West with prewhitening, per run,
  /// runs independent). The fit's own std_dev assumes uncorrelated residuals; residuals on
  /// smoothed measured data are correlated over tens of samples, and then it is several times
  /// too small. Empty unless the fit succeeded.
  Eigen::VectorXd hac_std_dev;
  /// With three runs or more, each run is also left out in turn (same cutoff): the torque RMS
  /// per joint with which the fit of the others predicts it, and the jackknife standard
  /// deviations of θ over those fits, √((R − 1)/R Σ(θ̂₍ᵣ₎ − θ̄)²). These include what differs
  /// from run to run (the motions reveal different model errors), which neither covariance sees.
  std::vector<Vector2<double>> left_out_prediction_rms;
  Eigen::VectorXd jackknife_std_dev;
  /// Per run: λ of the penalty form (the same for both joints) and the residual RMS per joint.
  std::vector<double> lambda;
  std::vector<Vector2<double>> residual_rms;
};

/// @brief λ of the penalty form Σ(g(tᵢ) − qᵢ)² + λ∫g''² whose smoother halves a sinusoid of
/// frequency cutoff_hz [Hz] on a grid of mean spacing h [s]: for dense samples the smoother's
/// gain at angular frequency ω is 1 / (1 + λ h ω⁴), so λ = 1 / (h (2π f)⁴). A cutoff makes the
/// choice comparable between runs logged at different rates, which one λ would not.
/// @throws std::invalid_argument unless cutoff_hz > 0 and mean_period > 0, both finite.
SID_INLINE double smoothing_lambda_for_cutoff(double cutoff_hz, double mean_period);

/// @brief The inverse of smoothing_lambda_for_cutoff: the cutoff [Hz] at which the smoother of
/// penalty λ halves a sinusoid on a grid of mean spacing h [s], (1 / (h λ))^(1/4) / (2π).
/// @throws std::invalid_argument unless lambda > 0 and mean_period > 0, both finite.
SID_INLINE double smoothing_cutoff_for_lambda(double lambda, double mean_period);

/// @brief q, q̇, q̈ of every sample of a run from the penalty-form spline at cutoff_hz (unit
/// weights: all samples alike), derivatives analytic; τ as measured.
/// @throws std::invalid_argument on an invalid run or fewer than 3 samples.
SID_INLINE Kinematics<double> kinematics_at_cutoff(const Trajectory<double>& run, double cutoff_hz,
                                                   double* lambda_out = nullptr);

namespace detail {

SID_INLINE void check_runs_options(const RunsIdentifyOptions& o, const char* who);

/// The samples of a run used in the regression: within [t₀ + skip, t_last − skip_end].
SID_INLINE Kinematics<double> used_samples(const Kinematics<double>& all,
                                           const RunsIdentifyOptions& o);

/// Normal-equation pieces of one fold: XᵀX, Xᵀy, yᵀy and its number of equations.
struct FoldMoments {
  Eigen::MatrixXd gram;
  Eigen::VectorXd moment;
  double yy = 0.0;
  Eigen::Index rows = 0;
};

SID_INLINE void add_fold_moments(const StackedRegression<double>& r, Eigen::Index n, int folds,
                                 std::vector<FoldMoments>& out);

/// RMS of the held-out residuals when each fold is predicted from the others' fit. The normal
/// equations are accurate enough to rank cutoffs (they are column-scaled, p <= 32); the final
/// estimate is a QR fit. Infinite when a fit without some fold is singular.
SID_INLINE double leave_fold_out_rms(const std::vector<FoldMoments>& folds);

}  // namespace detail

/// @brief The equations of several runs in one regression: joint 1's rows of every run in order,
/// then joint 2's (the order least_squares' per-joint statistics expect).
SID_INLINE StackedRegression<double> stack_runs(const Model<double>& model,
                                                const std::vector<Kinematics<double>>& runs);

/// @brief The geometric grid of cutoffs the cross-validation searches [Hz].
SID_INLINE std::vector<double> cutoff_grid(const RunsIdentifyOptions& options);

/// @brief The cross-validated torque RMS at each cutoff of the grid (see RunsIdentification).
/// @throws std::invalid_argument as identify_runs.
SID_INLINE std::vector<double> cutoff_cross_validation(const std::vector<Trajectory<double>>& runs,
                                                       const Model<double>& model,
                                                       const std::vector<double>& grid_hz,
                                                       const RunsIdentifyOptions& options = {});

/// @brief The cutoff the cross-validation chooses, with the criterion over the grid.
struct CutoffChoice {
  std::vector<double> grid_hz;
  std::vector<double> cross_validation_rms;
  double cutoff_hz = std::nan("");
};

/// @brief The covariance of a least-squares θ̂ whose residuals are correlated in time: the
/// HAC sandwich (XᵀX)⁻¹ (Σ_runs S_run) (XᵀX)⁻¹, where S_run is the prewhitened Newey–West
/// long-run sum of the run's scores g_t = Σ_joints x_{t,j} e_{t,j} (both joints' equations at
/// one time form one score, so their correlation is kept). Runs are independent.
/// @param fit a successful fit of stack_runs(model, kinematics).
SID_INLINE Eigen::MatrixXd hac_covariance(const StackedRegression<double>& all,
                                          const std::vector<Kinematics<double>>& kinematics,
                                          const LeastSquaresResult<double>& fit);

/// @brief The standard deviations of hac_covariance.
SID_INLINE Eigen::VectorXd hac_standard_deviations(
    const StackedRegression<double>& all, const std::vector<Kinematics<double>>& kinematics,
    const LeastSquaresResult<double>& fit);

namespace detail {

/// Every run valid with enough samples for its folds after the skips, and more equations than
/// parameters in all.
SID_INLINE void check_runs(const std::vector<Trajectory<double>>& runs, const Model<double>& model,
                           const RunsIdentifyOptions& options, const char* who);

/// Each run predicted by the fit of the others (see RunsIdentification::left_out_prediction_rms).
SID_INLINE void leave_each_run_out(const Model<double>& model, const LeastSquaresOptions& ls,
                                   RunsIdentification& result);

}  // namespace detail

/// @brief The grid cutoff with the smallest cross-validated torque RMS (see cutoff_grid and
/// cutoff_cross_validation). @throws std::invalid_argument when every cutoff leaves a fold
/// whose fit is singular (the runs do not excite every parameter).
SID_INLINE CutoffChoice choose_cutoff(const std::vector<Trajectory<double>>& runs,
                                      const Model<double>& model,
                                      const RunsIdentifyOptions& options = {});

/// @brief Identifies model's θ from all runs together.
/// @throws std::invalid_argument if there are no runs, a run is invalid (see Trajectory), a run
///         has too few samples for its folds after the skips, the options are invalid, or there
///         are not more equations than parameters. A regressor whose columns are dependent is
///         reported in fit.status, as by least_squares.
SID_INLINE RunsIdentification identify_runs(const std::vector<Trajectory<double>>& runs,
                                            const Model<double>& model,
                                            const RunsIdentifyOptions& options = {});

/// @brief How well θ predicts the torques of a run: the run smoothed at cutoff_hz, the same
/// skips, residual τ − Z θ per joint.
struct TorquePrediction {
  Vector2<double> residual_rms = Vector2<double>::Constant(std::nan(""));  ///< [N m]
  Eigen::Index samples = 0;
};

/// @throws std::invalid_argument on an invalid run, θ of the wrong size or too few samples.
SID_INLINE TorquePrediction predict_torque(const Trajectory<double>& run,
                                           const Model<double>& model,
                                           const Eigen::Ref<const Eigen::VectorXd>& theta,
                                           double cutoff_hz,
                                           const RunsIdentifyOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/identify_runs-inl.hpp>
#endif
