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
inline double smoothing_lambda_for_cutoff(double cutoff_hz, double mean_period) {
  if (!(cutoff_hz > 0.0) || !std::isfinite(cutoff_hz))
    throw std::invalid_argument("sid::smoothing_lambda_for_cutoff: cutoff must be finite and > 0 Hz");
  if (!(mean_period > 0.0) || !std::isfinite(mean_period))
    throw std::invalid_argument("sid::smoothing_lambda_for_cutoff: mean period must be finite and > 0 s");
  const double omega = 2.0 * 3.14159265358979323846 * cutoff_hz;
  return 1.0 / (mean_period * omega * omega * omega * omega);
}

/// @brief q, q̇, q̈ of every sample of a run from the penalty-form spline at cutoff_hz (unit
/// weights: all samples alike), derivatives analytic; τ as measured.
/// @throws std::invalid_argument on an invalid run or fewer than 3 samples.
inline Kinematics<double> kinematics_at_cutoff(const Trajectory<double>& run, double cutoff_hz,
                                               double* lambda_out = nullptr) {
  run.validate("sid::kinematics_at_cutoff");
  const Eigen::Index n = run.size();
  if (n < 3)
    throw std::invalid_argument("sid::kinematics_at_cutoff: a run needs at least 3 samples, got " +
                                std::to_string(n));
  const double lambda =
      smoothing_lambda_for_cutoff(cutoff_hz, (run.t[n - 1] - run.t[0]) / static_cast<double>(n - 1));
  if (lambda_out) *lambda_out = lambda;
  const SmoothingSpline<double> spline(run.t);
  Kinematics<double> k;
  k.t = run.t;
  k.tau = run.tau;
  k.q.resize(n, 2);
  k.qd.resize(n, 2);
  k.qdd.resize(n, 2);
  for (int j = 0; j < 2; ++j) {
    const auto fit = spline.fit_penalized(run.q.col(j), 1.0, 1.0 / lambda);
    fit.spline.derivatives_at_knots(0, k.q.col(j));
    fit.spline.derivatives_at_knots(1, k.qd.col(j));
    fit.spline.derivatives_at_knots(2, k.qdd.col(j));
  }
  return k;
}

namespace detail {

inline void check_runs_options(const RunsIdentifyOptions& o, const char* who) {
  const std::string prefix = std::string(who) + ": ";
  if (o.cutoff_hz && (!(*o.cutoff_hz > 0.0) || !std::isfinite(*o.cutoff_hz)))
    throw std::invalid_argument(prefix + "cutoff_hz must be finite and > 0");
  if (!(o.min_cutoff_hz > 0.0) || !std::isfinite(o.max_cutoff_hz) || !(o.max_cutoff_hz >= o.min_cutoff_hz))
    throw std::invalid_argument(prefix + "the cutoff range needs 0 < min_cutoff_hz <= max_cutoff_hz < inf");
  if (o.grid_points_per_octave < 1 || o.grid_points_per_octave > 64)
    throw std::invalid_argument(prefix + "grid_points_per_octave must be in 1..64");
  if (o.folds_per_run < 2) throw std::invalid_argument(prefix + "folds_per_run must be >= 2");
  if (!(o.skip >= 0.0) || !std::isfinite(o.skip) || !(o.skip_end >= 0.0) || !std::isfinite(o.skip_end))
    throw std::invalid_argument(prefix + "skip and skip_end must be finite and >= 0 s");
}

/// The samples of a run used in the regression: within [t₀ + skip, t_last − skip_end].
inline Kinematics<double> used_samples(const Kinematics<double>& all, const RunsIdentifyOptions& o) {
  return window(all, all.t[0] + o.skip, all.t[all.size() - 1] - o.skip_end);
}

/// Normal-equation pieces of one fold: XᵀX, Xᵀy, yᵀy and its number of equations.
struct FoldMoments {
  Eigen::MatrixXd gram;
  Eigen::VectorXd moment;
  double yy = 0.0;
  Eigen::Index rows = 0;
};

inline void add_fold_moments(const StackedRegression<double>& r, Eigen::Index n, int folds,
                             std::vector<FoldMoments>& out) {
  for (int b = 0; b < folds; ++b) {
    const Eigen::Index begin = n * b / folds, count = n * (b + 1) / folds - begin;
    FoldMoments m;
    m.gram = r.X.middleRows(begin, count).transpose() * r.X.middleRows(begin, count);
    m.gram += r.X.middleRows(n + begin, count).transpose() * r.X.middleRows(n + begin, count);
    m.moment = r.X.middleRows(begin, count).transpose() * r.y.segment(begin, count);
    m.moment += r.X.middleRows(n + begin, count).transpose() * r.y.segment(n + begin, count);
    m.yy = r.y.segment(begin, count).squaredNorm() + r.y.segment(n + begin, count).squaredNorm();
    m.rows = 2 * count;
    out.push_back(std::move(m));
  }
}

/// RMS of the held-out residuals when each fold is predicted from the others' fit. The normal
/// equations are accurate enough to rank cutoffs (they are column-scaled, p <= 32); the final
/// estimate is a QR fit. Infinite when a fit without some fold is singular.
inline double leave_fold_out_rms(const std::vector<FoldMoments>& folds) {
  const Eigen::Index p = folds.front().gram.rows();
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd moment = Eigen::VectorXd::Zero(p);
  Eigen::Index rows = 0;
  for (const auto& f : folds) {
    gram += f.gram;
    moment += f.moment;
    rows += f.rows;
  }
  double sse = 0.0;
  for (const auto& f : folds) {
    const Eigen::MatrixXd g = gram - f.gram;
    const Eigen::VectorXd scale = g.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(scale.asDiagonal() * g * scale.asDiagonal());
    if (ldlt.info() != Eigen::Success || !(ldlt.vectorD().minCoeff() > 1e-12 * ldlt.vectorD().maxCoeff()))
      return std::numeric_limits<double>::infinity();
    const Eigen::VectorXd theta = scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * (moment - f.moment));
    sse += std::max(0.0, theta.dot(f.gram * theta) - 2.0 * theta.dot(f.moment) + f.yy);
  }
  return std::sqrt(sse / static_cast<double>(rows));
}

}  // namespace detail

/// @brief The equations of several runs in one regression: joint 1's rows of every run in order,
/// then joint 2's (the order least_squares' per-joint statistics expect).
inline StackedRegression<double> stack_runs(const Model<double>& model,
                                            const std::vector<Kinematics<double>>& runs) {
  Eigen::Index total = 0;
  for (const auto& k : runs) total += k.size();
  StackedRegression<double> all;
  all.X.resize(2 * total, model.num_parameters());
  all.y.resize(2 * total);
  Eigen::Index at = 0;
  for (const auto& k : runs) {
    const Eigen::Index n = k.size();
    const StackedRegression<double> r = stack_regression(model, k);
    all.X.middleRows(at, n) = r.X.topRows(n);
    all.X.middleRows(total + at, n) = r.X.bottomRows(n);
    all.y.segment(at, n) = r.y.head(n);
    all.y.segment(total + at, n) = r.y.tail(n);
    at += n;
  }
  return all;
}

/// @brief The geometric grid of cutoffs the cross-validation searches [Hz].
inline std::vector<double> cutoff_grid(const RunsIdentifyOptions& options) {
  detail::check_runs_options(options, "sid::cutoff_grid");
  std::vector<double> grid;
  const double ratio = std::pow(2.0, 1.0 / options.grid_points_per_octave);
  for (double f = options.min_cutoff_hz; f <= options.max_cutoff_hz * (1.0 + 1e-12); f *= ratio) grid.push_back(f);
  return grid;
}

/// @brief The cross-validated torque RMS at each cutoff of the grid (see RunsIdentification).
/// @throws std::invalid_argument as identify_runs.
inline std::vector<double> cutoff_cross_validation(const std::vector<Trajectory<double>>& runs,
                                                   const Model<double>& model, const std::vector<double>& grid_hz,
                                                   const RunsIdentifyOptions& options = {}) {
  std::vector<double> score(grid_hz.size());
  const int threads = options.threads > 0 ? options.threads : static_cast<int>(std::thread::hardware_concurrency());
  detail::for_each_index(static_cast<Eigen::Index>(grid_hz.size()), threads, [&](Eigen::Index g, int) {
    std::vector<detail::FoldMoments> folds;
    for (const auto& run : runs) {
      const Kinematics<double> k = detail::used_samples(kinematics_at_cutoff(run, grid_hz[static_cast<std::size_t>(g)]), options);
      detail::add_fold_moments(stack_regression(model, k), k.size(), options.folds_per_run, folds);
    }
    score[static_cast<std::size_t>(g)] = detail::leave_fold_out_rms(folds);
  });
  return score;
}

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
inline Eigen::MatrixXd hac_covariance(const StackedRegression<double>& all,
                                      const std::vector<Kinematics<double>>& kinematics,
                                      const LeastSquaresResult<double>& fit) {
  const Eigen::Index p = all.X.cols(), total = all.X.rows() / 2;
  Eigen::MatrixXd long_run = Eigen::MatrixXd::Zero(p, p);
  Eigen::Index at = 0;
  for (const auto& k : kinematics) {
    const Eigen::Index n = k.size();
    const Eigen::MatrixXd scores =
        all.X.middleRows(at, n).array().colwise() * fit.residual.segment(at, n).array() +
        all.X.middleRows(total + at, n).array().colwise() * fit.residual.segment(total + at, n).array();
    long_run += hac_long_run_sum(scores);
    at += n;
  }
  const Eigen::MatrixXd inverse_gram = fit.covariance / fit.sigma2;
  return inverse_gram * long_run * inverse_gram;
}

/// @brief The standard deviations of hac_covariance.
inline Eigen::VectorXd hac_standard_deviations(const StackedRegression<double>& all,
                                               const std::vector<Kinematics<double>>& kinematics,
                                               const LeastSquaresResult<double>& fit) {
  return hac_covariance(all, kinematics, fit).diagonal().cwiseMax(0.0).cwiseSqrt();
}

namespace detail {

/// Every run valid with enough samples for its folds after the skips, and more equations than
/// parameters in all.
inline void check_runs(const std::vector<Trajectory<double>>& runs, const Model<double>& model,
                       const RunsIdentifyOptions& options, const char* who) {
  check_runs_options(options, who);
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  if (model.num_parameters() < 1) throw std::invalid_argument(std::string(who) + ": the model has no parameters");
  Eigen::Index total = 0;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const std::string run_name = std::string(who) + " (run " + std::to_string(r + 1) + ")";
    runs[r].validate(run_name.c_str());
    const auto& t = runs[r].t;
    Eigen::Index used = 0;
    for (Eigen::Index i = 0; i < t.size(); ++i)
      used += t[i] >= t[0] + options.skip - 1e-9 && t[i] <= t[t.size() - 1] - options.skip_end + 1e-9;
    if (used < 3 * options.folds_per_run)
      throw std::invalid_argument(run_name + ": only " + std::to_string(used) + " samples are left after skipping " +
                                  std::to_string(options.skip) + " s at the start and " +
                                  std::to_string(options.skip_end) + " s at the end; need at least " +
                                  std::to_string(3 * options.folds_per_run));
    total += used;
  }
  if (2 * total <= model.num_parameters())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(2 * total) + " equations for " +
                                std::to_string(model.num_parameters()) + " parameters");
}

/// Each run predicted by the fit of the others (see RunsIdentification::left_out_prediction_rms).
inline void leave_each_run_out(const Model<double>& model, const LeastSquaresOptions& ls, RunsIdentification& result) {
  const std::size_t runs = result.kinematics.size();
  Eigen::MatrixXd estimates(static_cast<Eigen::Index>(runs), result.fit.theta.size());
  for (std::size_t r = 0; r < runs; ++r) {
    std::vector<Kinematics<double>> others;
    for (std::size_t k = 0; k < runs; ++k)
      if (k != r) others.push_back(result.kinematics[k]);
    const StackedRegression<double> fitted = stack_runs(model, others);
    const LeastSquaresResult<double> fit = least_squares(fitted.X, fitted.y, 2, ls);
    if (!fit.ok()) {
      result.left_out_prediction_rms.clear();
      result.jackknife_std_dev.resize(0);
      return;
    }
    estimates.row(static_cast<Eigen::Index>(r)) = fit.theta.transpose();
    const StackedRegression<double> left_out = stack_regression(model, result.kinematics[r]);
    const Eigen::VectorXd e = left_out.y - left_out.X * fit.theta;
    const Eigen::Index n = result.kinematics[r].size();
    result.left_out_prediction_rms.emplace_back(std::sqrt(e.head(n).squaredNorm() / n),
                                                std::sqrt(e.tail(n).squaredNorm() / n));
  }
  const Eigen::RowVectorXd mean = estimates.colwise().mean();
  const double factor = static_cast<double>(runs - 1) / static_cast<double>(runs);
  result.jackknife_std_dev = ((estimates.rowwise() - mean).array().square().colwise().sum() * factor).sqrt().transpose();
}

}  // namespace detail

/// @brief The grid cutoff with the smallest cross-validated torque RMS (see cutoff_grid and
/// cutoff_cross_validation). @throws std::invalid_argument when every cutoff leaves a fold
/// whose fit is singular (the runs do not excite every parameter).
inline CutoffChoice choose_cutoff(const std::vector<Trajectory<double>>& runs, const Model<double>& model,
                                  const RunsIdentifyOptions& options = {}) {
  CutoffChoice choice;
  choice.grid_hz = cutoff_grid(options);
  choice.cross_validation_rms = cutoff_cross_validation(runs, model, choice.grid_hz, options);
  std::size_t best = 0;
  for (std::size_t g = 1; g < choice.grid_hz.size(); ++g)
    if (choice.cross_validation_rms[g] < choice.cross_validation_rms[best]) best = g;
  if (!std::isfinite(choice.cross_validation_rms[best]))
    throw std::invalid_argument(
        "sid::choose_cutoff: every cutoff leaves a fold whose fit is singular: the runs do not excite "
        "every parameter of the model");
  choice.cutoff_hz = choice.grid_hz[best];
  return choice;
}

/// @brief Identifies model's θ from all runs together.
/// @throws std::invalid_argument if there are no runs, a run is invalid (see Trajectory), a run
///         has too few samples for its folds after the skips, the options are invalid, or there
///         are not more equations than parameters. A regressor whose columns are dependent is
///         reported in fit.status, as by least_squares.
inline RunsIdentification identify_runs(const std::vector<Trajectory<double>>& runs, const Model<double>& model,
                                        const RunsIdentifyOptions& options = {}) {
  detail::check_runs(runs, model, options, "sid::identify_runs");
  RunsIdentification result;
  if (options.cutoff_hz) {
    result.cutoff_hz = *options.cutoff_hz;
  } else {
    CutoffChoice choice = choose_cutoff(runs, model, options);
    result.grid_hz = std::move(choice.grid_hz);
    result.cross_validation_rms = std::move(choice.cross_validation_rms);
    result.cutoff_hz = choice.cutoff_hz;
    result.cutoff_chosen = true;
  }
  for (const auto& run : runs) {
    double lambda = 0.0;
    result.kinematics.push_back(detail::used_samples(kinematics_at_cutoff(run, result.cutoff_hz, &lambda), options));
    result.lambda.push_back(lambda);
  }
  LeastSquaresOptions ls = options.least_squares;
  if (ls.column_names.empty()) ls.column_names = model.parameter_names();
  const StackedRegression<double> all = stack_runs(model, result.kinematics);
  result.fit = least_squares(all.X, all.y, 2, ls);
  if (result.fit.ok() && result.fit.sigma2 > 0.0)
    result.hac_std_dev = hac_standard_deviations(all, result.kinematics, result.fit);
  if (result.fit.ok() && runs.size() >= 3) detail::leave_each_run_out(model, ls, result);
  const Eigen::Index total = all.X.rows() / 2;
  Eigen::Index at = 0;
  for (const auto& k : result.kinematics) {
    const Eigen::Index n = k.size();
    result.residual_rms.emplace_back(std::sqrt(result.fit.residual.segment(at, n).squaredNorm() / n),
                                     std::sqrt(result.fit.residual.segment(total + at, n).squaredNorm() / n));
    at += n;
  }
  return result;
}

/// @brief How well θ predicts the torques of a run: the run smoothed at cutoff_hz, the same
/// skips, residual τ − Z θ per joint.
struct TorquePrediction {
  Vector2<double> residual_rms = Vector2<double>::Constant(std::nan(""));  ///< [N m]
  Eigen::Index samples = 0;
};

/// @throws std::invalid_argument on an invalid run, θ of the wrong size or too few samples.
inline TorquePrediction predict_torque(const Trajectory<double>& run, const Model<double>& model,
                                       const Eigen::Ref<const Eigen::VectorXd>& theta, double cutoff_hz,
                                       const RunsIdentifyOptions& options = {}) {
  constexpr const char* who = "sid::predict_torque";
  detail::check_runs_options(options, who);
  if (theta.size() != model.num_parameters())
    throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                " entries, the model " + std::to_string(model.num_parameters()));
  const Kinematics<double> k = detail::used_samples(kinematics_at_cutoff(run, cutoff_hz), options);
  if (k.size() < 1) throw std::invalid_argument(std::string(who) + ": no samples left after the skips");
  const StackedRegression<double> r = stack_regression(model, k);
  const Eigen::VectorXd residual = r.y - r.X * theta;
  const Eigen::Index n = k.size();
  TorquePrediction out;
  out.samples = n;
  out.residual_rms << std::sqrt(residual.head(n).squaredNorm() / n), std::sqrt(residual.tail(n).squaredNorm() / n);
  return out;
}

}  // namespace sid
