#pragma once
// Definitions of <sid/identify_chain.hpp>: inline in header-only mode, compiled once in the
// compiled library (see sid/config.hpp).

#include <sid/detail/parallel.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/identify_chain.hpp>
#include <sid/identify_runs.hpp>
#include <sid/quantisation.hpp>
#include <sid/smoothing_spline.hpp>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {
namespace detail {

/// One run smoothed at the current cutoffs: every sample's kinematics and filtered torque.
struct SmoothedChainRun {
  const ChainTrajectory<double>* run = nullptr;
  SmoothingSpline<double> spline;
  double mean_period = 0.0;
  double torque_delay = 0.0;
  ChainKinematics<double> k;
  std::vector<Eigen::Index> samples;  ///< the samples equations are taken at

  SmoothedChainRun(const ChainTrajectory<double>& r, const ChainIdentifyOptions& o)
      : run(&r), spline(r.t), torque_delay(o.torque_delay) {
    const Eigen::Index n = r.size(), joints = r.joints();
    mean_period = (r.t[n - 1] - r.t[0]) / static_cast<double>(n - 1);
    k.t = r.t;
    k.q.resize(n, joints);
    k.qd.resize(n, joints);
    k.qdd.resize(n, joints);
    k.tau = r.tau;
    const auto stride = static_cast<Eigen::Index>(
        std::max(1.0, std::round(1.0 / (mean_period * o.regression_rate_hz))));
    for (Eigen::Index i = 0; i < n; i += stride)
      if (r.t[i] >= r.t[0] + o.skip && r.t[i] <= r.t[n - 1] - o.skip_end) samples.push_back(i);
  }

  void smooth_joint(int j, double cutoff_hz, bool filter_torque) {
    const double p = 1.0 / smoothing_lambda_for_cutoff(cutoff_hz, mean_period);
    const auto fit = spline.fit_penalized(run->q.col(j), 1.0, p);
    if (torque_delay != 0.0) {
      // The angles when the logged torque was applied; the skips keep every sample an
      // equation is taken at inside the log. Before its start (after its end) the log's first
      // (last) state stands: the end piece's cubic, extrapolated, wanders.
      const Eigen::Index last = run->t.size() - 1;
      const Eigen::VectorXd at =
          (run->t.array() - torque_delay).max(run->t[0]).min(run->t[last]).matrix();
      k.q.col(j) = fit.spline.evaluate(at, 0);
      k.qd.col(j) = fit.spline.evaluate(at, 1);
      k.qdd.col(j) = fit.spline.evaluate(at, 2);
    } else {
      fit.spline.derivatives_at_knots(0, k.q.col(j));
      fit.spline.derivatives_at_knots(1, k.qd.col(j));
      fit.spline.derivatives_at_knots(2, k.qdd.col(j));
    }
    if (filter_torque)
      spline.fit_penalized(run->tau.col(j), 1.0, p).spline.derivatives_at_knots(0, k.tau.col(j));
  }
};

/// The equations of one run on the base columns; row r is joint joint[r] at samples[at[r]].
struct ChainEquations {
  Eigen::MatrixXd x;
  Eigen::VectorXd y, y_unfiltered;
  std::vector<int> joint;
  std::vector<Eigen::Index> at;
};

/// The model's regressor on the rows of e (joint, sample) from the run as smoothed now, on the
/// base columns.
inline Eigen::MatrixXd regressor_on_rows(const ChainModel& model, const SmoothedChainRun& s,
                                         const ChainEquations& e,
                                         const std::vector<Eigen::Index>& columns) {
  const int n = model.joints();
  Eigen::MatrixXd y(n, model.parameters());
  Eigen::VectorXd q(n), qd(n), qdd(n);
  Eigen::MatrixXd x(e.y.size(), static_cast<Eigen::Index>(columns.size()));
  Eigen::Index last = -1;
  for (Eigen::Index r = 0; r < e.y.size(); ++r) {
    const Eigen::Index a = e.at[static_cast<std::size_t>(r)];
    if (a != last) {
      const Eigen::Index i = s.samples[static_cast<std::size_t>(a)];
      q = s.k.q.row(i).transpose();
      qd = s.k.qd.row(i).transpose();
      qdd = s.k.qdd.row(i).transpose();
      model.regressor(q, qd, qdd, y);
      last = a;
    }
    x.row(r) = y.row(e.joint[static_cast<std::size_t>(r)])(columns);
  }
  return x;
}

inline ChainEquations chain_equations(const ChainModel& model, const SmoothedChainRun& s,
                                      const std::vector<Eigen::Index>& columns,
                                      double rest_fraction) {
  const int n = model.joints();
  Eigen::VectorXd rest(n);
  for (int j = 0; j < n; ++j) {
    double sum = 0.0;
    for (const Eigen::Index i : s.samples) sum += s.k.qd(i, j) * s.k.qd(i, j);
    rest[j] = rest_fraction * std::sqrt(sum / static_cast<double>(s.samples.size()));
  }
  std::vector<std::pair<Eigen::Index, int>> rows;  // (sample position, joint)
  for (std::size_t a = 0; a < s.samples.size(); ++a)
    for (int j = 0; j < n; ++j)
      if (std::abs(s.k.qd(s.samples[a], j)) >= rest[j])
        rows.emplace_back(static_cast<Eigen::Index>(a), j);
  ChainEquations e;
  const auto m = static_cast<Eigen::Index>(rows.size());
  e.y.resize(m);
  e.y_unfiltered.resize(m);
  for (Eigen::Index r = 0; r < m; ++r) {
    const auto [a, j] = rows[static_cast<std::size_t>(r)];
    const Eigen::Index i = s.samples[static_cast<std::size_t>(a)];
    e.y[r] = s.k.tau(i, j);
    e.y_unfiltered[r] = s.run->tau(i, j);
    e.joint.push_back(j);
    e.at.push_back(a);
  }
  e.x = regressor_on_rows(model, s, e, columns);
  return e;
}

/// Deterministic uniform numbers in [lo, hi) from a generator whose output the standard fixes.
inline double uniform(std::mt19937& g, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(g()) + 0.5) / 4294967296.0;
}

/// The equations of several runs stacked, leaving out run `skip` (none when negative).
struct StackedChainEquations {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

inline StackedChainEquations stack_equations(const std::vector<ChainEquations>& equations,
                                             std::ptrdiff_t skip = -1) {
  Eigen::Index rows = 0, columns = equations.empty() ? 0 : equations.front().x.cols();
  for (std::size_t r = 0; r < equations.size(); ++r)
    if (static_cast<std::ptrdiff_t>(r) != skip) rows += equations[r].y.size();
  StackedChainEquations out{Eigen::MatrixXd(rows, columns), Eigen::VectorXd(rows)};
  Eigen::Index at = 0;
  for (std::size_t r = 0; r < equations.size(); ++r) {
    if (static_cast<std::ptrdiff_t>(r) == skip) continue;
    out.x.middleRows(at, equations[r].y.size()) = equations[r].x;
    out.y.segment(at, equations[r].y.size()) = equations[r].y;
    at += equations[r].y.size();
  }
  return out;
}

/// The base parameters of the data: structural base columns that the runs' equations do not
/// tell apart from the columns before them (relative distance below data_tolerance at unit
/// norm, e.g. an asymmetric Coulomb level when no equation is at rest) regroup onto those, so
/// that every parameter reported is one the data determine.
inline BaseParameters<double> data_base_parameters(const ChainModel& model,
                                                   const BaseParameters<double>& structural,
                                                   const std::vector<ChainEquations>& equations,
                                                   double data_tolerance) {
  const Eigen::Index r = structural.rank();
  const Eigen::MatrixXd x = stack_equations(equations).x;
  if (x.rows() < r) return structural;
  const BaseParameters<double> in_data = base_parameters_in_order(x, data_tolerance);
  if (in_data.rank() == r) return structural;
  // beta_data = E beta_structural, beta_structural = M theta: compose E M.
  const Eigen::Index p = model.parameters();
  Eigen::MatrixXd m = Eigen::MatrixXd::Zero(r, p);
  for (Eigen::Index a = 0; a < r; ++a) {
    m(a, structural.independent[static_cast<std::size_t>(a)]) = 1.0;
    for (Eigen::Index b = 0; b < structural.K.cols(); ++b)
      m(a, structural.dependent[static_cast<std::size_t>(b)]) = structural.K(a, b);
  }
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(in_data.rank(), r);
  for (Eigen::Index a = 0; a < in_data.rank(); ++a) {
    e(a, in_data.independent[static_cast<std::size_t>(a)]) = 1.0;
    for (Eigen::Index b = 0; b < in_data.K.cols(); ++b)
      e(a, in_data.dependent[static_cast<std::size_t>(b)]) = in_data.K(a, b);
  }
  const Eigen::MatrixXd combined = e * m;
  BaseParameters<double> base;
  for (const Eigen::Index a : in_data.independent)
    base.independent.push_back(structural.independent[static_cast<std::size_t>(a)]);
  for (Eigen::Index c = 0; c < p; ++c)
    if (std::find(base.independent.begin(), base.independent.end(), c) == base.independent.end())
      base.dependent.push_back(c);
  base.K = combined(Eigen::all, base.dependent);
  base.rank_gap = std::min(structural.rank_gap, in_data.rank_gap);
  return base;
}

inline void check_chain_options(const ChainIdentifyOptions& o, int joints, const char* who) {
  const std::string prefix = std::string(who) + ": ";
  const auto positive = [](double v) { return v > 0.0 && std::isfinite(v); };
  if (!o.cutoff_hz.empty() && o.cutoff_hz.size() != 1 &&
      o.cutoff_hz.size() != static_cast<std::size_t>(joints))
    throw std::invalid_argument(prefix + "give one cutoff or one per joint (" +
                                std::to_string(joints) + "), not " +
                                std::to_string(o.cutoff_hz.size()));
  if (!(std::isfinite(o.torque_delay) &&
        std::abs(o.torque_delay) <= std::min(o.skip, o.skip_end) + 1e-12))
    throw std::invalid_argument(prefix + "torque_delay must be finite and within the skips (" +
                                std::to_string(std::min(o.skip, o.skip_end)) + " s)");
  for (const double c : o.cutoff_hz)
    if (!positive(c)) throw std::invalid_argument(prefix + "a cutoff must be finite and > 0 Hz");
  if (!positive(o.min_cutoff_hz) || !positive(o.max_cutoff_hz) || o.max_cutoff_hz < o.min_cutoff_hz)
    throw std::invalid_argument(prefix + "the cutoff range needs 0 < min <= max < inf");
  if (o.grid_points_per_octave < 1 || o.grid_points_per_octave > 64)
    throw std::invalid_argument(prefix + "grid_points_per_octave must be in 1..64");
  if (o.folds_per_run < 2) throw std::invalid_argument(prefix + "folds_per_run must be >= 2");
  if (o.threads < 0) throw std::invalid_argument(prefix + "threads must be >= 0");
  if (!(o.skip >= 0.0) || !(o.skip_end >= 0.0) || !std::isfinite(o.skip + o.skip_end))
    throw std::invalid_argument(prefix + "skip and skip_end must be finite and >= 0 s");
  if (!positive(o.regression_rate_hz))
    throw std::invalid_argument(prefix + "regression_rate_hz must be finite and > 0");
  if (!(o.rest_fraction >= 0.0 && o.rest_fraction < 1.0))
    throw std::invalid_argument(prefix + "rest_fraction must be in [0, 1)");
  if (!(o.base_tolerance > 0.0 && o.base_tolerance < 1.0))
    throw std::invalid_argument(prefix + "base_tolerance must be in (0, 1)");
  if (!(o.data_tolerance > 0.0 && o.data_tolerance < 1.0))
    throw std::invalid_argument(prefix + "data_tolerance must be in (0, 1)");
  if (o.base_samples < 1) throw std::invalid_argument(prefix + "base_samples must be >= 1");
}

inline void check_chain_run(const ChainModel& model, const ChainTrajectory<double>& run,
                            const std::string& who) {
  run.validate(who.c_str());
  if (run.joints() != model.joints())
    throw std::invalid_argument(who + ": the run has " + std::to_string(run.joints()) +
                                " joints, the model " + std::to_string(model.joints()));
  if (run.size() < 4) throw std::invalid_argument(who + ": a run needs at least 4 samples");
}

inline Eigen::VectorXd expand_cutoffs(const std::vector<double>& given, int joints) {
  Eigen::VectorXd c(joints);
  for (int j = 0; j < joints; ++j)
    c[j] = given.size() == 1 ? given[0] : given[static_cast<std::size_t>(j)];
  return c;
}

/// The cross-validation criterion: each joint's held-out RSS over its measured torque's sum of
/// squares, averaged over joints; infinite where a fold cannot be fitted.
inline double chain_cross_validation(const std::vector<ChainEquations>& equations, int joints,
                                     int folds) {
  Eigen::VectorXd yy = Eigen::VectorXd::Zero(joints);
  for (const auto& e : equations)
    for (Eigen::Index r = 0; r < e.y.size(); ++r)
      yy[e.joint[static_cast<std::size_t>(r)]] += e.y_unfiltered[r] * e.y_unfiltered[r];
  const Eigen::Index p = equations.front().x.cols();
  std::vector<Eigen::MatrixXd> gram;
  std::vector<Eigen::VectorXd> moment;
  std::vector<double> fold_yy;
  for (const auto& e : equations) {
    const Eigen::Index positions = e.at.empty() ? 0 : e.at.back() + 1;
    Eigen::Index begin = 0;
    for (int f = 0; f < folds; ++f) {
      Eigen::Index end = begin;
      const Eigen::Index last = positions * (f + 1) / folds;
      while (end < e.y.size() && e.at[static_cast<std::size_t>(end)] < last) ++end;
      Eigen::MatrixXd xw = e.x.middleRows(begin, end - begin);
      Eigen::VectorXd yw = e.y_unfiltered.segment(begin, end - begin);
      for (Eigen::Index r = 0; r < xw.rows(); ++r) {
        const double w = 1.0 / std::sqrt(yy[e.joint[static_cast<std::size_t>(begin + r)]] * joints);
        xw.row(r) *= w;
        yw[r] *= w;
      }
      Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p, p);  // half the work of xwᵀ xw
      g.selfadjointView<Eigen::Lower>().rankUpdate(xw.transpose());
      gram.push_back(g.selfadjointView<Eigen::Lower>());
      moment.push_back(xw.transpose() * yw);
      fold_yy.push_back(yw.squaredNorm());
      begin = end;
    }
  }
  Eigen::MatrixXd total_gram = Eigen::MatrixXd::Zero(p, p);
  Eigen::VectorXd total_moment = Eigen::VectorXd::Zero(p);
  for (std::size_t f = 0; f < gram.size(); ++f) {
    total_gram += gram[f];
    total_moment += moment[f];
  }
  // Columns scaled to a unit diagonal: the Cholesky factor's pivots then say how well a fold's
  // complement determines each parameter whatever the units.
  const Eigen::VectorXd scale = total_gram.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  double score = 0.0;
  for (std::size_t f = 0; f < gram.size(); ++f) {
    // A tiny ridge: a fold's complement may leave a parameter the data barely excite undecided,
    // and the prediction is then scored with it near zero instead of failing.
    Eigen::MatrixXd g = scale.asDiagonal() * (total_gram - gram[f]) * scale.asDiagonal();
    g.diagonal().array() += 1e-9;
    const Eigen::LLT<Eigen::MatrixXd> llt(g);
    if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
    const Eigen::VectorXd theta =
        scale.asDiagonal() * llt.solve(scale.asDiagonal() * (total_moment - moment[f]));
    score += fold_yy[f] - 2.0 * theta.dot(moment[f]) + theta.dot(gram[f] * theta);
  }
  return score;
}

inline std::vector<ChainEquations> all_equations(const ChainModel& model,
                                                 const std::vector<SmoothedChainRun>& runs,
                                                 const std::vector<Eigen::Index>& columns,
                                                 double rest_fraction) {
  std::vector<ChainEquations> e;
  for (const auto& s : runs) e.push_back(chain_equations(model, s, columns, rest_fraction));
  return e;
}

/// The cross-validation's criterion for the runs with joint `joint` (every joint when negative)
/// smoothed at cutoff c [Hz]; the runs stay smoothed so.
inline double cutoff_score(const ChainModel& model, std::vector<SmoothedChainRun>& runs,
                           const std::vector<Eigen::Index>& columns, const ChainIdentifyOptions& o,
                           int joint, double c) {
  for (auto& s : runs)
    for (int j = 0; j < model.joints(); ++j)
      if (joint < 0 || j == joint) s.smooth_joint(j, c, false);
  return chain_cross_validation(all_equations(model, runs, columns, o.rest_fraction),
                                model.joints(), o.folds_per_run);
}

/// The first stage of the cutoff choice: the one cutoff for every joint, on the grid, whose
/// held-out prediction is best; `score` gets the criterion there.
inline double choose_shared_cutoff(const ChainModel& model,
                                   const std::vector<SmoothedChainRun>& runs,
                                   const std::vector<Eigen::Index>& columns,
                                   const ChainIdentifyOptions& o, double& score) {
  const double step = std::pow(2.0, 1.0 / o.grid_points_per_octave);
  std::vector<double> grid;
  for (double c = o.min_cutoff_hz; c <= o.max_cutoff_hz * (1.0 + 1e-9); c *= step)
    grid.push_back(c);
  // Each score is computed on a copy of the runs of its own thread's, so the scores, and with
  // them the choice, do not depend on the thread count.
  const int threads = thread_count(o.threads);
  std::vector<std::vector<SmoothedChainRun>> copies(static_cast<std::size_t>(threads), runs);
  std::vector<double> scores(grid.size());
  for_each_index(static_cast<Eigen::Index>(grid.size()), threads, [&](Eigen::Index g, int worker) {
    scores[static_cast<std::size_t>(g)] =
        cutoff_score(model, copies[static_cast<std::size_t>(worker)], columns, o, -1,
                     grid[static_cast<std::size_t>(g)]);
  });
  score = std::numeric_limits<double>::infinity();
  double shared = grid.front();
  for (std::size_t g = 0; g < grid.size(); ++g)
    if (scores[g] < score) {
      score = scores[g];
      shared = grid[g];
    }
  if (!std::isfinite(score))
    throw std::invalid_argument(
        "sid::identify_chain: no cutoff gives a fit on every fold; the runs do not excite the "
        "model's base parameters (or are too short for the folds)");
  return shared;
}

/// Whether joint j's angles move as a staircase in some run: on a grid, by fewer than two of its
/// steps per sample (sid::median_move_in_steps). Their error is then a slow sawtooth, which a
/// joint's own cutoff can follow while the held-out torque does not tell: on a simulated light
/// arm with 12-bit encoders, cutoffs moved per joint (1 to 64 Hz) left 15 to 100 times the
/// true torque's error of the one shared cutoff.
inline bool staircase_joint(const std::vector<SmoothedChainRun>& runs, int j) {
  for (const auto& s : runs) {
    const double step = quantisation_step(s.run->q.col(j));
    if (step > 0.0 && median_move_in_steps(s.run->q.col(j), step) < 2.0) return true;
  }
  return false;
}

/// Chooses each joint's cutoff (see the file comment of identify_chain.hpp); leaves the runs
/// smoothed at the choice and returns the criterion there.
inline double choose_chain_cutoffs(const ChainModel& model, std::vector<SmoothedChainRun>& runs,
                                   const std::vector<Eigen::Index>& columns,
                                   const ChainIdentifyOptions& o, Eigen::VectorXd& cutoff) {
  const int n = model.joints();
  double best = 0.0;
  cutoff = Eigen::VectorXd::Constant(n, choose_shared_cutoff(model, runs, columns, o, best));
  (void)cutoff_score(model, runs, columns, o, -1, cutoff[0]);
  const int threads = thread_count(o.threads);
  std::vector<std::vector<SmoothedChainRun>> copies(static_cast<std::size_t>(threads - 1), runs);
  const auto runs_of = [&](int worker) -> std::vector<SmoothedChainRun>& {
    return worker == 0 ? runs : copies[static_cast<std::size_t>(worker - 1)];
  };
  const auto score_on = [&](std::vector<SmoothedChainRun>& on, int joint, double c) {
    return cutoff_score(model, on, columns, o, joint, c);
  };
  const auto score_at = [&](int joint, double c) { return score_on(runs, joint, c); };
  // Half-octave moves per joint while the held-out prediction improves: up, then down. A joint
  // that moved up does not move down (that is where it came from), so the first step of each
  // way is scored at once, on a copy of its own.
  const double move = std::sqrt(2.0);
  const auto inside = [&](double c) {
    return c >= o.min_cutoff_hz * (1.0 - 1e-9) && c <= o.max_cutoff_hz * (1.0 + 1e-9);
  };
  for (int j = 0; j < n; ++j) {
    if (staircase_joint(runs, j)) continue;
    const double first[2] = {cutoff[j] * move, cutoff[j] / move};
    double first_score[2] = {std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::infinity()};
    for_each_index(2, std::min(threads, 2), [&](Eigen::Index way, int worker) {
      if (inside(first[way])) first_score[way] = score_on(runs_of(worker), j, first[way]);
    });
    for (int way = 0; way < 2; ++way) {
      if (!(first_score[way] < best)) continue;
      const double factor = way == 0 ? move : 1.0 / move;
      best = first_score[way];
      cutoff[j] = first[way];
      for (;;) {
        const double c = cutoff[j] * factor;
        if (!inside(c)) break;
        const double score = score_at(j, c);
        if (!(score < best)) break;
        best = score;
        cutoff[j] = c;
      }
      break;
    }
    for (auto& s : runs) s.smooth_joint(j, cutoff[j], false);
    for (auto& copy : copies)
      for (auto& s : copy) s.smooth_joint(j, cutoff[j], false);
  }
  return best;
}

inline ChainPrediction chain_prediction(const std::vector<ChainEquations>& equations, int joints,
                                        const Eigen::VectorXd& theta) {
  Eigen::VectorXd rss = Eigen::VectorXd::Zero(joints), yy = rss, rss_raw = rss, yy_raw = rss;
  ChainPrediction p;
  p.equations = Eigen::VectorXi::Zero(joints);
  for (const auto& e : equations) {
    const Eigen::VectorXd fitted = e.x * theta;
    for (Eigen::Index r = 0; r < e.y.size(); ++r) {
      const int j = e.joint[static_cast<std::size_t>(r)];
      rss[j] += (e.y[r] - fitted[r]) * (e.y[r] - fitted[r]);
      yy[j] += e.y[r] * e.y[r];
      rss_raw[j] += (e.y_unfiltered[r] - fitted[r]) * (e.y_unfiltered[r] - fitted[r]);
      yy_raw[j] += e.y_unfiltered[r] * e.y_unfiltered[r];
      ++p.equations[j];
    }
  }
  p.residual_rms = (rss.array() / p.equations.cast<double>().array().max(1.0)).sqrt();
  p.relative_per_joint = (rss.array() / yy.array()).sqrt();
  p.relative_residual = std::sqrt(rss.sum() / yy.sum());
  p.relative_residual_unfiltered = std::sqrt(rss_raw.sum() / yy_raw.sum());
  return p;
}

/// The same prediction against the measured torque at every sample of the window, at rest too
/// and unfiltered: what a model predicts of the log as it was recorded.
inline void add_measured(ChainPrediction& p, const std::vector<ChainEquations>& every_sample,
                         int joints, const Eigen::VectorXd& theta) {
  Eigen::VectorXd rss = Eigen::VectorXd::Zero(joints), yy = rss;
  Eigen::VectorXd count = Eigen::VectorXd::Zero(joints);
  for (const auto& e : every_sample) {
    const Eigen::VectorXd fitted = e.x * theta;
    for (Eigen::Index r = 0; r < e.y.size(); ++r) {
      const int j = e.joint[static_cast<std::size_t>(r)];
      const double residual = e.y_unfiltered[r] - fitted[r];
      rss[j] += residual * residual;
      yy[j] += e.y_unfiltered[r] * e.y_unfiltered[r];
      count[j] += 1.0;
    }
  }
  p.measured_residual_rms = (rss.array() / count.array().max(1.0)).sqrt();
  p.measured_relative_residual = std::sqrt(rss.sum() / yy.sum());
}

inline std::vector<SmoothedChainRun> smoothed_runs(const ChainModel& model,
                                                   const std::vector<ChainTrajectory<double>>& runs,
                                                   const ChainIdentifyOptions& o, const char* who) {
  std::vector<SmoothedChainRun> smoothed;
  smoothed.reserve(runs.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    check_chain_run(model, runs[r], std::string(who) + ": run " + std::to_string(r + 1));
    smoothed.emplace_back(runs[r], o);
    if (smoothed.back().samples.size() < static_cast<std::size_t>(2 * o.folds_per_run))
      throw std::invalid_argument(std::string(who) + ": run " + std::to_string(r + 1) +
                                  " has too few samples left after the skips");
  }
  return smoothed;
}

/// Standard deviations from the HAC covariance of a fit on the stacked equations (see
/// ChainIdentification::std_dev); row weights as the fit's.
inline Eigen::VectorXd chain_hac_std_dev(const std::vector<ChainEquations>& equations,
                                         const LeastSquaresResult<double>& fit,
                                         const Eigen::VectorXd& row_weight) {
  const Eigen::Index p = fit.theta.size();
  if (!fit.ok()) return Eigen::VectorXd::Constant(p, std::nan(""));
  std::vector<Eigen::VectorXd> weighted;
  std::vector<HacRun> runs;
  Eigen::Index offset = 0;
  for (const auto& e : equations) {
    weighted.push_back(row_weight.segment(offset, e.y.size()).cwiseProduct(e.y - e.x * fit.theta));
    offset += e.y.size();
  }
  for (std::size_t r = 0; r < equations.size(); ++r) {
    const ChainEquations& e = equations[r];
    runs.push_back({e.x, weighted[r], e.at, e.at.empty() ? 0 : e.at.back() + 1});
  }
  return hac_sandwich(runs, fit.inverse_gram()).diagonal().cwiseMax(0.0).cwiseSqrt();
}

/// Least squares on the stacked equations, or Gautier's weighted least squares: each joint's
/// equations weighted by the inverse of its residual variance in a first unweighted fit. weight
/// receives the row weights used (ones for least squares).
inline LeastSquaresResult<double> chain_fit(const std::vector<ChainEquations>& equations,
                                            const StackedChainEquations& stacked, int joints,
                                            bool weighted, const LeastSquaresOptions& ls,
                                            Eigen::VectorXd& weight) {
  LeastSquaresResult<double> fit = least_squares(stacked.x, stacked.y, 1, ls);
  weight = Eigen::VectorXd::Ones(stacked.y.size());
  if (!weighted || !fit.ok()) return fit;
  const ChainPrediction first = chain_prediction(equations, joints, fit.theta);
  Eigen::Index at = 0;
  for (const auto& e : equations)
    for (Eigen::Index r = 0; r < e.y.size(); ++r, ++at) {
      const double rms = first.residual_rms[e.joint[static_cast<std::size_t>(r)]];
      weight[at] = 1.0 / std::max(rms * rms, 1e-300);
    }
  return weighted_least_squares(stacked.x, stacked.y, weight, 1, ls);
}

/// The jackknife standard deviations over the fits that leave one run out in turn (empty if
/// one of them fails).
inline Eigen::VectorXd chain_jackknife_std_dev(const std::vector<ChainEquations>& equations,
                                               const LeastSquaresOptions& ls) {
  const auto runs = static_cast<double>(equations.size());
  std::vector<Eigen::VectorXd> left_out;
  for (std::size_t r = 0; r < equations.size(); ++r) {
    const StackedChainEquations others = stack_equations(equations, static_cast<std::ptrdiff_t>(r));
    const LeastSquaresResult<double> fit = least_squares(others.x, others.y, 1, ls);
    if (!fit.ok()) return {};
    left_out.push_back(fit.theta);
  }
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(left_out.front().size()), sum2 = mean;
  for (const auto& t : left_out) mean += t / runs;
  for (const auto& t : left_out) sum2 += (t - mean).cwiseAbs2();
  return ((runs - 1.0) / runs * sum2).cwiseSqrt();
}

}  // namespace detail

SID_INLINE BaseParameters<double> chain_base_parameters(const ChainModel& model,
                                                        const ChainIdentifyOptions& o) {
  const int n = model.joints();
  detail::check_chain_options(o, model.joints(), "sid::chain_base_parameters");
  std::mt19937 g(o.base_seed);
  Eigen::MatrixXd w(static_cast<Eigen::Index>(o.base_samples) * n, model.parameters());
  Eigen::MatrixXd y(n, model.parameters());
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (int s = 0; s < o.base_samples; ++s) {
    for (int j = 0; j < n; ++j) {
      q[j] = detail::uniform(g, -3.14159265358979, 3.14159265358979);
      qd[j] = detail::uniform(g, -2.0, 2.0);
      qdd[j] = detail::uniform(g, -10.0, 10.0);
    }
    model.regressor(q, qd, qdd, y);
    w.middleRows(static_cast<Eigen::Index>(s) * n, n) = y;
  }
  return base_parameters_in_order(w, o.base_tolerance);
}

namespace detail {

/// The base parameters the runs determine (data_base_parameters). Which structural parameters
/// they leave undetermined does not hinge on the smoothing: judged at one cutoff, the geometric
/// middle of the search range unless given.
inline BaseParameters<double> runs_base_parameters(const ChainModel& model,
                                                   const BaseParameters<double>& structural,
                                                   std::vector<SmoothedChainRun>& smoothed,
                                                   const ChainIdentifyOptions& options) {
  const int n = model.joints();
  const Eigen::VectorXd c =
      options.cutoff_hz.empty()
          ? Eigen::VectorXd::Constant(n, std::sqrt(options.min_cutoff_hz * options.max_cutoff_hz))
          : expand_cutoffs(options.cutoff_hz, n);
  for (auto& s : smoothed)
    for (int j = 0; j < n; ++j) s.smooth_joint(j, c[j], false);
  return data_base_parameters(
      model, structural,
      all_equations(model, smoothed, structural.independent, options.rest_fraction),
      options.data_tolerance);
}

/// Smooths the runs at id.cutoff_hz and fits id's base parameters to their equations: id.fit,
/// id.fitted over the fitted equations, the fit's own standard deviations. Returns the
/// equations; `weight` gets the rows' weights (Gautier's WLS).
inline std::vector<ChainEquations> fit_at_cutoffs(const ChainModel& model,
                                                  std::vector<SmoothedChainRun>& smoothed,
                                                  const ChainIdentifyOptions& options,
                                                  const char* who, ChainIdentification& id,
                                                  Eigen::VectorXd& weight) {
  const int n = model.joints();
  for (auto& s : smoothed)
    for (int j = 0; j < n; ++j) s.smooth_joint(j, id.cutoff_hz[j], options.filter_torque);
  std::vector<ChainEquations> equations =
      all_equations(model, smoothed, id.base.independent, options.rest_fraction);
  const StackedChainEquations stacked = stack_equations(equations);
  if (stacked.x.rows() <= stacked.x.cols())
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(stacked.x.rows()) +
                                " equations for " + std::to_string(stacked.x.cols()) +
                                " base parameters; give longer or more runs");
  LeastSquaresOptions ls = options.least_squares;
  ls.column_names = id.parameter_names;
  id.fit = chain_fit(equations, stacked, n, options.weighted, ls, weight);
  id.std_dev = id.fit.std_dev;
  id.relative_std_dev = 100.0 * id.std_dev.array() / id.fit.theta.array().abs();
  id.fitted = chain_prediction(equations, n, id.fit.theta);
  return equations;
}

inline void check_earlier(const ChainModel& model, const ChainIdentification& earlier,
                          const char* who) {
  if (!earlier.fit.ok() || earlier.cutoff_hz.size() != model.joints() ||
      earlier.fit.theta.size() != earlier.base.rank() ||
      static_cast<Eigen::Index>(earlier.base.independent.size() + earlier.base.dependent.size()) !=
          model.parameters())
    throw std::invalid_argument(std::string(who) +
                                ": the earlier identification failed or is of another model");
}

/// An identification of earlier's base parameters at its cutoffs, not yet fitted.
inline ChainIdentification same_parameters(const ChainIdentification& earlier) {
  ChainIdentification id;
  id.base = earlier.base;
  id.structural_rank = earlier.structural_rank;
  id.parameter_names = earlier.parameter_names;
  id.parameter_combinations = earlier.parameter_combinations;
  id.cutoff_hz = earlier.cutoff_hz;
  id.cross_validation_score = std::nan("");
  return id;
}

/// The rows of e from `begin` on, `count` of them.
inline ChainEquations equation_rows(const ChainEquations& e, Eigen::Index begin,
                                    Eigen::Index count) {
  const auto first = static_cast<std::ptrdiff_t>(begin);
  const auto last = static_cast<std::ptrdiff_t>(begin + count);
  return {e.x.middleRows(begin, count),
          e.y.segment(begin, count),
          e.y_unfiltered.segment(begin, count),
          {e.joint.begin() + first, e.joint.begin() + last},
          {e.at.begin() + first, e.at.begin() + last}};
}

}  // namespace detail

SID_INLINE ChainIdentification identify_chain(const ChainModel& model,
                                              const std::vector<ChainTrajectory<double>>& runs,
                                              const ChainIdentifyOptions& options) {
  const char* who = "sid::identify_chain";
  detail::check_chain_options(options, model.joints(), who);
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  const int n = model.joints();
  std::vector<detail::SmoothedChainRun> smoothed = detail::smoothed_runs(model, runs, options, who);

  ChainIdentification id;
  const BaseParameters<double> structural = chain_base_parameters(model, options);
  id.base = detail::runs_base_parameters(model, structural, smoothed, options);
  id.parameter_names = base_parameter_names(id.base, model.parameter_names(), 6);
  id.parameter_combinations = base_parameter_names(id.base, model.parameter_names(), 0);
  id.structural_rank = structural.rank();
  const std::vector<Eigen::Index>& columns = id.base.independent;

  if (options.cutoff_hz.empty()) {
    id.cross_validation_score =
        detail::choose_chain_cutoffs(model, smoothed, columns, options, id.cutoff_hz);
    id.cutoff_chosen = true;
  } else {
    id.cutoff_hz = detail::expand_cutoffs(options.cutoff_hz, n);
    id.cross_validation_score = std::nan("");
  }
  Eigen::VectorXd weight;
  const std::vector<detail::ChainEquations> equations =
      detail::fit_at_cutoffs(model, smoothed, options, who, id, weight);
  if (!options.statistics) return id;
  id.std_dev = detail::chain_hac_std_dev(equations, id.fit, weight);
  id.relative_std_dev = 100.0 * id.std_dev.array() / id.fit.theta.array().abs();
  for (std::size_t r = 0; r < equations.size(); ++r) {
    id.per_run.push_back(detail::chain_prediction({equations[r]}, n, id.fit.theta));
    detail::add_measured(id.per_run.back(),
                         {detail::chain_equations(model, smoothed[r], columns, 0.0)}, n,
                         id.fit.theta);
  }
  detail::add_measured(id.fitted, detail::all_equations(model, smoothed, columns, 0.0), n,
                       id.fit.theta);

  if (runs.size() >= 3 && id.fit.ok()) {
    LeastSquaresOptions ls = options.least_squares;
    ls.column_names = id.parameter_names;
    id.jackknife_std_dev = detail::chain_jackknife_std_dev(equations, ls);
  }
  return id;
}

SID_INLINE ChainPrediction predict_chain(const ChainModel& model,
                                         const ChainIdentification& identification,
                                         const ChainTrajectory<double>& run,
                                         const ChainIdentifyOptions& options) {
  const char* who = "sid::predict_chain";
  detail::check_chain_options(options, model.joints(), who);
  if (identification.fit.theta.size() != identification.base.rank() ||
      identification.cutoff_hz.size() != model.joints())
    throw std::invalid_argument(std::string(who) +
                                ": the identification does not belong to this model");
  if (!identification.fit.theta.allFinite())
    throw std::invalid_argument(std::string(who) + ": the identification failed");
  detail::check_chain_run(model, run, std::string(who));
  detail::SmoothedChainRun s(run, options);
  if (s.samples.empty())
    throw std::invalid_argument(std::string(who) + ": the run has no samples after the skips");
  for (int j = 0; j < model.joints(); ++j)
    s.smooth_joint(j, identification.cutoff_hz[j], options.filter_torque);
  const std::vector<Eigen::Index>& columns = identification.base.independent;
  ChainPrediction p =
      detail::chain_prediction({detail::chain_equations(model, s, columns, options.rest_fraction)},
                               model.joints(), identification.fit.theta);
  detail::add_measured(p, {detail::chain_equations(model, s, columns, 0.0)}, model.joints(),
                       identification.fit.theta);
  return p;
}

SID_INLINE ChainIdentification refit_chain(const ChainModel& model,
                                           const ChainIdentification& earlier,
                                           const std::vector<ChainTrajectory<double>>& runs,
                                           const ChainIdentifyOptions& options) {
  const char* who = "sid::refit_chain";
  const int n = model.joints();
  detail::check_chain_options(options, n, who);
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  detail::check_earlier(model, earlier, who);
  std::vector<detail::SmoothedChainRun> smoothed = detail::smoothed_runs(model, runs, options, who);
  ChainIdentification id = detail::same_parameters(earlier);
  Eigen::VectorXd weight;
  (void)detail::fit_at_cutoffs(model, smoothed, options, who, id, weight);
  return id;
}

SID_INLINE std::vector<ChainFold> chain_folds(const ChainModel& model,
                                              const ChainIdentification& identification,
                                              const std::vector<ChainTrajectory<double>>& runs,
                                              const ChainIdentifyOptions& options, int folds) {
  const char* who = "sid::chain_folds";
  const int n = model.joints();
  detail::check_chain_options(options, n, who);
  if (folds < 2) throw std::invalid_argument(std::string(who) + ": folds must be >= 2");
  if (runs.empty()) throw std::invalid_argument(std::string(who) + ": no runs given");
  detail::check_earlier(model, identification, who);
  std::vector<detail::SmoothedChainRun> smoothed = detail::smoothed_runs(model, runs, options, who);
  for (auto& s : smoothed)
    for (int j = 0; j < n; ++j)
      s.smooth_joint(j, identification.cutoff_hz[j], options.filter_torque);
  const std::vector<detail::ChainEquations> equations = detail::all_equations(
      model, smoothed, identification.base.independent, options.rest_fraction);
  LeastSquaresOptions ls = options.least_squares;
  ls.column_names = identification.parameter_names;
  std::vector<ChainFold> out(static_cast<std::size_t>(folds));
  for (int f = 0; f < folds; ++f) {
    ChainFold& fold = out[static_cast<std::size_t>(f)];
    std::vector<detail::ChainEquations> train, test;
    for (const detail::ChainEquations& e : equations) {
      // Rows run in time (sample position, then joint): a span of time is a span of rows.
      const Eigen::Index positions = e.at.empty() ? 0 : e.at.back() + 1;
      const auto row_at = [&](Eigen::Index position) {
        return static_cast<Eigen::Index>(std::lower_bound(e.at.begin(), e.at.end(), position) -
                                         e.at.begin());
      };
      const Eigen::Index begin = row_at(positions * f / folds);
      const Eigen::Index end = row_at(positions * (f + 1) / folds);
      train.push_back(detail::equation_rows(e, 0, begin));
      train.push_back(detail::equation_rows(e, end, e.y.size() - end));
      test.push_back(detail::equation_rows(e, begin, end - begin));
    }
    const detail::StackedChainEquations stacked = detail::stack_equations(train);
    if (stacked.x.rows() <= stacked.x.cols())
      throw std::invalid_argument(std::string(who) + ": fold " + std::to_string(f + 1) +
                                  " leaves " + std::to_string(stacked.x.rows()) +
                                  " equations for " + std::to_string(stacked.x.cols()) +
                                  " base parameters; give longer or more runs, or fewer folds");
    fold.fit = detail::same_parameters(identification);
    Eigen::VectorXd weight;
    fold.fit.fit = detail::chain_fit(train, stacked, n, options.weighted, ls, weight);
    fold.fit.std_dev = fold.fit.fit.std_dev;
    fold.fit.relative_std_dev = 100.0 * fold.fit.std_dev.array() / fold.fit.fit.theta.array().abs();
    fold.fit.fitted = detail::chain_prediction(train, n, fold.fit.fit.theta);
    detail::StackedChainEquations held = detail::stack_equations(test);
    fold.x = std::move(held.x);
    fold.y = std::move(held.y);
  }
  return out;
}

SID_INLINE Eigen::MatrixXd chain_torque(const ChainModel& model,
                                        const ChainIdentification& identification,
                                        const ChainTrajectory<double>& run,
                                        const ChainIdentifyOptions& options) {
  const char* who = "sid::chain_torque";
  if (identification.fit.theta.size() != identification.base.rank() ||
      identification.cutoff_hz.size() != model.joints())
    throw std::invalid_argument(std::string(who) +
                                ": the identification does not belong to this model");
  detail::check_chain_run(model, run, std::string(who));
  const ChainKinematics<double> k = smooth_chain_run(run, identification.cutoff_hz, options);
  const std::vector<Eigen::Index>& independent = identification.base.independent;
  Eigen::MatrixXd w(model.joints(), model.parameters());
  Eigen::MatrixXd tau(k.size(), model.joints());
  for (Eigen::Index i = 0; i < k.size(); ++i) {
    model.regressor(k.q.row(i).transpose(), k.qd.row(i).transpose(), k.qdd.row(i).transpose(), w);
    tau.row(i) = (w(Eigen::all, independent) * identification.fit.theta).transpose();
  }
  return tau;
}

SID_INLINE ChainKinematics<double> smooth_chain_run(const ChainTrajectory<double>& run,
                                                    const Eigen::VectorXd& cutoff_hz,
                                                    const ChainIdentifyOptions& options) {
  const char* who = "sid::smooth_chain_run";
  run.validate(who);
  if (run.size() < 3) throw std::invalid_argument(std::string(who) + ": needs 3 samples or more");
  if (cutoff_hz.size() != run.joints() || !(cutoff_hz.array() > 0.0).all())
    throw std::invalid_argument(std::string(who) + ": needs one cutoff > 0 per joint (" +
                                std::to_string(run.joints()) + ")");
  detail::SmoothedChainRun s(run, options);
  for (int j = 0; j < run.joints(); ++j) s.smooth_joint(j, cutoff_hz[j], options.filter_torque);
  return std::move(s.k);
}

SID_INLINE std::pair<ChainTrajectory<double>, ChainTrajectory<double>> split_run(
    const ChainTrajectory<double>& run, double fraction) {
  const char* who = "sid::split_run";
  run.validate(who);
  if (!(fraction > 0.0 && fraction < 1.0))
    throw std::invalid_argument(std::string(who) + ": the fraction must be in (0, 1)");
  const double at = run.t[0] + fraction * (run.t[run.size() - 1] - run.t[0]);
  Eigen::Index k = 0;
  while (k < run.size() && run.t[k] < at) ++k;
  if (k == 0 || k == run.size())
    throw std::invalid_argument(std::string(who) + ": one part would have no samples");
  ChainTrajectory<double> first{run.t.head(k), run.q.topRows(k), run.tau.topRows(k)};
  const Eigen::Index rest = run.size() - k;
  ChainTrajectory<double> second{run.t.tail(rest), run.q.bottomRows(rest),
                                 run.tau.bottomRows(rest)};
  return {std::move(first), std::move(second)};
}

}  // namespace sid
