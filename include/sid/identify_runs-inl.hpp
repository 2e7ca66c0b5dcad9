#pragma once
// Definitions of sid/identify_runs.hpp (see sid/config.hpp).

#include <sid/identify_runs.hpp>

namespace sid {

SID_INLINE double smoothing_lambda_for_cutoff(double cutoff_hz, double mean_period) {
  if (!(cutoff_hz > 0.0) || !std::isfinite(cutoff_hz))
    throw std::invalid_argument(
        "sid::smoothing_lambda_for_cutoff: cutoff must be finite and > 0 Hz");
  if (!(mean_period > 0.0) || !std::isfinite(mean_period))
    throw std::invalid_argument(
        "sid::smoothing_lambda_for_cutoff: mean period must be finite and > 0 s");
  const double omega = 2.0 * 3.14159265358979323846 * cutoff_hz;
  return 1.0 / (mean_period * omega * omega * omega * omega);
}

SID_INLINE double smoothing_cutoff_for_lambda(double lambda, double mean_period) {
  if (!(lambda > 0.0) || !std::isfinite(lambda))
    throw std::invalid_argument("sid::smoothing_cutoff_for_lambda: lambda must be finite and > 0");
  if (!(mean_period > 0.0) || !std::isfinite(mean_period))
    throw std::invalid_argument(
        "sid::smoothing_cutoff_for_lambda: mean period must be finite and > 0 s");
  return std::pow(1.0 / (mean_period * lambda), 0.25) / (2.0 * 3.14159265358979323846);
}

SID_INLINE Kinematics<double> kinematics_at_cutoff(const Trajectory<double>& run, double cutoff_hz,
                                                   double* lambda_out) {
  run.validate("sid::kinematics_at_cutoff");
  const Eigen::Index n = run.size();
  if (n < 3)
    throw std::invalid_argument("sid::kinematics_at_cutoff: a run needs at least 3 samples, got " +
                                std::to_string(n));
  const double lambda = smoothing_lambda_for_cutoff(
      cutoff_hz, (run.t[n - 1] - run.t[0]) / static_cast<double>(n - 1));
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

SID_INLINE void check_runs_options(const RunsIdentifyOptions& o, const char* who) {
  const std::string prefix = std::string(who) + ": ";
  if (o.cutoff_hz && (!(*o.cutoff_hz > 0.0) || !std::isfinite(*o.cutoff_hz)))
    throw std::invalid_argument(prefix + "cutoff_hz must be finite and > 0");
  if (!(o.min_cutoff_hz > 0.0) || !std::isfinite(o.max_cutoff_hz) ||
      !(o.max_cutoff_hz >= o.min_cutoff_hz))
    throw std::invalid_argument(prefix +
                                "the cutoff range needs 0 < min_cutoff_hz <= max_cutoff_hz < inf");
  if (o.grid_points_per_octave < 1 || o.grid_points_per_octave > 64)
    throw std::invalid_argument(prefix + "grid_points_per_octave must be in 1..64");
  if (o.folds_per_run < 2) throw std::invalid_argument(prefix + "folds_per_run must be >= 2");
  if (!(o.skip >= 0.0) || !std::isfinite(o.skip) || !(o.skip_end >= 0.0) ||
      !std::isfinite(o.skip_end))
    throw std::invalid_argument(prefix + "skip and skip_end must be finite and >= 0 s");
}

SID_INLINE Kinematics<double> used_samples(const Kinematics<double>& all,
                                           const RunsIdentifyOptions& o) {
  return window(all, all.t[0] + o.skip, all.t[all.size() - 1] - o.skip_end);
}

SID_INLINE void add_fold_moments(const StackedRegression<double>& r, Eigen::Index n, int folds,
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

SID_INLINE double leave_fold_out_rms(const std::vector<FoldMoments>& folds) {
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
    const Eigen::VectorXd scale =
        g.diagonal().cwiseMax(std::numeric_limits<double>::min()).cwiseSqrt().cwiseInverse();
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(scale.asDiagonal() * g * scale.asDiagonal());
    if (ldlt.info() != Eigen::Success ||
        !(ldlt.vectorD().minCoeff() > 1e-12 * ldlt.vectorD().maxCoeff()))
      return std::numeric_limits<double>::infinity();
    const Eigen::VectorXd theta =
        scale.asDiagonal() * ldlt.solve(scale.asDiagonal() * (moment - f.moment));
    sse += std::max(0.0, theta.dot(f.gram * theta) - 2.0 * theta.dot(f.moment) + f.yy);
  }
  return std::sqrt(sse / static_cast<double>(rows));
}

}  // namespace detail

SID_INLINE StackedRegression<double> stack_runs(const Model<double>& model,
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

SID_INLINE std::vector<double> cutoff_grid(const RunsIdentifyOptions& options) {
  detail::check_runs_options(options, "sid::cutoff_grid");
  std::vector<double> grid;
  const double ratio = std::pow(2.0, 1.0 / options.grid_points_per_octave);
  for (double f = options.min_cutoff_hz; f <= options.max_cutoff_hz * (1.0 + 1e-12); f *= ratio)
    grid.push_back(f);
  return grid;
}

SID_INLINE std::vector<double> cutoff_cross_validation(const std::vector<Trajectory<double>>& runs,
                                                       const Model<double>& model,
                                                       const std::vector<double>& grid_hz,
                                                       const RunsIdentifyOptions& options) {
  std::vector<double> score(grid_hz.size());
  const int threads = detail::thread_count(options.threads);
  detail::for_each_index(
      static_cast<Eigen::Index>(grid_hz.size()), threads, [&](Eigen::Index g, int) {
        std::vector<detail::FoldMoments> folds;
        for (const auto& run : runs) {
          const Kinematics<double> k = detail::used_samples(
              kinematics_at_cutoff(run, grid_hz[static_cast<std::size_t>(g)]), options);
          detail::add_fold_moments(stack_regression(model, k), k.size(), options.folds_per_run,
                                   folds);
        }
        score[static_cast<std::size_t>(g)] = detail::leave_fold_out_rms(folds);
      });
  return score;
}

SID_INLINE Eigen::MatrixXd hac_covariance(const StackedRegression<double>& all,
                                          const std::vector<Kinematics<double>>& kinematics,
                                          const LeastSquaresResult<double>& fit) {
  const Eigen::Index p = all.X.cols(), total = all.X.rows() / 2;
  Eigen::MatrixXd long_run = Eigen::MatrixXd::Zero(p, p);
  Eigen::Index at = 0;
  for (const auto& k : kinematics) {
    const Eigen::Index n = k.size();
    const Eigen::MatrixXd scores =
        all.X.middleRows(at, n).array().colwise() * fit.residual.segment(at, n).array() +
        all.X.middleRows(total + at, n).array().colwise() *
            fit.residual.segment(total + at, n).array();
    long_run += hac_long_run_sum(scores);
    at += n;
  }
  const Eigen::MatrixXd inverse_gram = fit.covariance / fit.sigma2;
  return inverse_gram * long_run * inverse_gram;
}

SID_INLINE Eigen::VectorXd hac_standard_deviations(
    const StackedRegression<double>& all, const std::vector<Kinematics<double>>& kinematics,
    const LeastSquaresResult<double>& fit) {
  return hac_covariance(all, kinematics, fit).diagonal().cwiseMax(0.0).cwiseSqrt();
}

namespace detail {

SID_INLINE void check_runs(const std::vector<Trajectory<double>>& runs, const Model<double>& model,
                           const RunsIdentifyOptions& options, const char* who) {
  check_runs_options(options, who);
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  if (model.num_parameters() < 1)
    throw std::invalid_argument(std::string(who) + ": the model has no parameters");
  Eigen::Index total = 0;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const std::string run_name = std::string(who) + " (run " + std::to_string(r + 1) + ")";
    runs[r].validate(run_name.c_str());
    const auto& t = runs[r].t;
    Eigen::Index used = 0;
    for (Eigen::Index i = 0; i < t.size(); ++i)
      used +=
          t[i] >= t[0] + options.skip - 1e-9 && t[i] <= t[t.size() - 1] - options.skip_end + 1e-9;
    if (used < 3 * options.folds_per_run)
      throw std::invalid_argument(
          run_name + ": only " + std::to_string(used) + " samples are left after skipping " +
          std::to_string(options.skip) + " s at the start and " + std::to_string(options.skip_end) +
          " s at the end; need at least " + std::to_string(3 * options.folds_per_run));
    total += used;
  }
  if (2 * total <= model.num_parameters())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(2 * total) +
                                " equations for " + std::to_string(model.num_parameters()) +
                                " parameters");
}

SID_INLINE void leave_each_run_out(const Model<double>& model, const LeastSquaresOptions& ls,
                                   RunsIdentification& result) {
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
  result.jackknife_std_dev =
      ((estimates.rowwise() - mean).array().square().colwise().sum() * factor).sqrt().transpose();
}

}  // namespace detail

SID_INLINE CutoffChoice choose_cutoff(const std::vector<Trajectory<double>>& runs,
                                      const Model<double>& model,
                                      const RunsIdentifyOptions& options) {
  CutoffChoice choice;
  choice.grid_hz = cutoff_grid(options);
  choice.cross_validation_rms = cutoff_cross_validation(runs, model, choice.grid_hz, options);
  std::size_t best = 0;
  for (std::size_t g = 1; g < choice.grid_hz.size(); ++g)
    if (choice.cross_validation_rms[g] < choice.cross_validation_rms[best]) best = g;
  if (!std::isfinite(choice.cross_validation_rms[best]))
    throw std::invalid_argument(
        "sid::choose_cutoff: every cutoff leaves a fold whose fit is singular: the runs do not "
        "excite "
        "every parameter of the model");
  choice.cutoff_hz = choice.grid_hz[best];
  return choice;
}

SID_INLINE RunsIdentification identify_runs(const std::vector<Trajectory<double>>& runs,
                                            const Model<double>& model,
                                            const RunsIdentifyOptions& options) {
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
    result.kinematics.push_back(
        detail::used_samples(kinematics_at_cutoff(run, result.cutoff_hz, &lambda), options));
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
    result.residual_rms.emplace_back(
        std::sqrt(result.fit.residual.segment(at, n).squaredNorm() / n),
        std::sqrt(result.fit.residual.segment(total + at, n).squaredNorm() / n));
    at += n;
  }
  return result;
}

SID_INLINE TorquePrediction predict_torque(const Trajectory<double>& run,
                                           const Model<double>& model,
                                           const Eigen::Ref<const Eigen::VectorXd>& theta,
                                           double cutoff_hz, const RunsIdentifyOptions& options) {
  constexpr const char* who = "sid::predict_torque";
  detail::check_runs_options(options, who);
  if (theta.size() != model.num_parameters())
    throw std::invalid_argument(std::string(who) + ": theta has " + std::to_string(theta.size()) +
                                " entries, the model " + std::to_string(model.num_parameters()));
  const Kinematics<double> k = detail::used_samples(kinematics_at_cutoff(run, cutoff_hz), options);
  if (k.size() < 1)
    throw std::invalid_argument(std::string(who) + ": no samples left after the skips");
  const StackedRegression<double> r = stack_regression(model, k);
  const Eigen::VectorXd residual = r.y - r.X * theta;
  const Eigen::Index n = k.size();
  TorquePrediction out;
  out.samples = n;
  out.residual_rms << std::sqrt(residual.head(n).squaredNorm() / n),
      std::sqrt(residual.tail(n).squaredNorm() / n);
  return out;
}

}  // namespace sid
