#pragma once
// Definitions of sid/diagnose_chain.hpp (see sid/config.hpp). The compiled library holds them in
// the same unit as identify_chain's, whose equation builders they share.

#include <sid/detail/golden_section.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/diagnose_chain.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/diagnosis/noise_floor.hpp>
#include <sid/identify_chain-inl.hpp>
#include <sid/quantisation.hpp>
#include <sid/smoothing_spline.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <optional>
#include <sstream>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace sid {

SID_INLINE std::string drive_term_id(const DriveTerm& term) {
  return std::string(drive_term_keyword(term.kind)) + (term.on_motor ? "_m" : "_j") +
         std::to_string(term.index + 1);
}

namespace detail {

inline const char* drive_term_unit(DriveTermKind kind) {
  switch (kind) {
    case DriveTermKind::Viscous:
      return "N m s/rad";
    case DriveTermKind::Coulomb:
    case DriveTermKind::CoulombAsymmetry:
    case DriveTermKind::Offset:
    case DriveTermKind::Stribeck:
      return "N m";
    case DriveTermKind::Armature:
      return "kg m^2";
    case DriveTermKind::Spring:
      return "N m/rad";
  }
  return "";
}

/// The candidates: every kind on every joint and coupled motor the nominal model lacks, a
/// Stribeck term at each of the widths.
inline std::vector<DriveTerm> chain_candidates(const ChainModel& nominal,
                                               const std::vector<DriveTermKind>& kinds,
                                               const std::vector<double>& stribeck_velocities) {
  std::vector<DriveTerm> out;
  for (const DriveTerm& t : drive_terms(kinds, nominal.transmission())) {
    const bool present = std::any_of(nominal.terms().begin(), nominal.terms().end(),
                                     [&](const DriveTerm& n) { return same_place(n, t); });
    if (present) continue;
    if (t.kind != DriveTermKind::Stribeck) {
      out.push_back(t);
      continue;
    }
    for (const double vs : stribeck_velocities) {
      DriveTerm w = t;
      w.velocity = vs;
      out.push_back(w);
    }
  }
  return out;
}

/// In place: of the tests of Stribeck candidates at one place, only the width whose column
/// explains most of the residual (largest reduction `gain`) stays; the others wait for the next
/// round. Keeps the parallel vectors in step.
inline void keep_best_stribeck_width(std::vector<ChainEffectTest>& tests,
                                     std::vector<Eigen::Index>& tested, std::vector<double>& p_raw,
                                     std::vector<double>& gain) {
  std::vector<bool> keep(tests.size(), true);
  for (std::size_t i = 0; i < tests.size(); ++i) {
    if (tests[i].term.kind != DriveTermKind::Stribeck) continue;
    for (std::size_t k = 0; k < tests.size(); ++k)
      if (k != i && same_place(tests[k].term, tests[i].term) &&
          (gain[k] > gain[i] || (gain[k] == gain[i] && k < i)))
        keep[i] = false;
  }
  std::size_t out = 0;
  for (std::size_t i = 0; i < tests.size(); ++i) {
    if (!keep[i]) continue;
    if (out != i) tests[out] = std::move(tests[i]);
    tested[out] = tested[i];
    p_raw[out] = p_raw[i];
    gain[out] = gain[i];
    ++out;
  }
  tests.resize(out);
  tested.resize(out);
  p_raw.resize(out);
  gain.resize(out);
}

/// Every equation of the runs on every column the diagnosis may use (the nominal model's base
/// columns, then one per candidate), each column scaled to unit norm so that the fold Gram
/// matrices of the cross-validation stay well conditioned.
struct ChainDiagnosisEquations {
  Eigen::MatrixXd x;
  Eigen::VectorXd scale;  ///< the columns' norms before scaling
  Eigen::VectorXd y, y_measured;
  std::vector<int> joint;
  std::vector<Eigen::Index> run_rows;   ///< first row of each run, then the row count
  std::vector<Eigen::Index> at;         ///< sample position of each row within its run
  std::vector<Eigen::Index> positions;  ///< sample positions per run
  /// Per cross-validation fold (contiguous sample blocks of one run): rows [begin, end), X_fᵀX_f,
  /// X_fᵀy_f and y_fᵀy_f over all columns.
  std::vector<std::pair<Eigen::Index, Eigen::Index>> folds;
  std::vector<Eigen::MatrixXd> gram;
  std::vector<Eigen::VectorXd> moment;
  std::vector<double> energy;
  Eigen::MatrixXd gram_total;
  Eigen::VectorXd moment_total;
  int joints = 0;
};

inline ChainDiagnosisEquations chain_diagnosis_equations(const std::vector<ChainEquations>& runs,
                                                         int joints, int blocks, int threads) {
  ChainDiagnosisEquations d;
  d.joints = joints;
  Eigen::Index rows = 0;
  for (const auto& e : runs) rows += e.y.size();
  const Eigen::Index columns = runs.front().x.cols();
  d.x.resize(rows, columns);
  d.y.resize(rows);
  d.y_measured.resize(rows);
  Eigen::Index at = 0;
  for (const auto& e : runs) {
    d.run_rows.push_back(at);
    const Eigen::Index m = e.y.size();
    d.x.middleRows(at, m) = e.x;
    d.y.segment(at, m) = e.y;
    d.y_measured.segment(at, m) = e.y_unfiltered;
    d.joint.insert(d.joint.end(), e.joint.begin(), e.joint.end());
    d.at.insert(d.at.end(), e.at.begin(), e.at.end());
    const Eigen::Index positions = e.at.empty() ? 0 : e.at.back() + 1;
    d.positions.push_back(positions);
    // Rows run sample by sample, so a block of samples is a block of rows. With three runs or
    // more each run is a fold: the terms are judged by how they predict runs they were not
    // fitted on.
    const int per_run = runs.size() >= 3 ? 1 : blocks;
    Eigen::Index begin = 0;
    for (int b = 1; b <= per_run; ++b) {
      const Eigen::Index last_position = positions * b / per_run;
      Eigen::Index end = begin;
      while (end < m && e.at[static_cast<std::size_t>(end)] < last_position) ++end;
      if (end > begin) d.folds.emplace_back(at + begin, at + end);
      begin = end;
    }
    at += m;
  }
  d.run_rows.push_back(rows);
  d.scale = d.x.colwise().norm().transpose().cwiseMax(1e-300);
  d.x = d.x * d.scale.cwiseInverse().asDiagonal();
  const auto folds = static_cast<Eigen::Index>(d.folds.size());
  d.gram.resize(d.folds.size());
  d.moment.resize(d.folds.size());
  d.energy.resize(d.folds.size());
  for_each_index(folds, threads, [&](Eigen::Index f, int) {
    const auto k = static_cast<std::size_t>(f);
    const auto [begin, end] = d.folds[k];
    const auto xf = d.x.middleRows(begin, end - begin);
    const auto yf = d.y.segment(begin, end - begin);
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(columns, columns);  // half the work of xfᵀ xf
    g.selfadjointView<Eigen::Lower>().rankUpdate(xf.transpose());
    d.gram[k] = g.selfadjointView<Eigen::Lower>();
    d.moment[k] = xf.transpose() * yf;
    d.energy[k] = yf.squaredNorm();
  });
  d.gram_total = Eigen::MatrixXd::Zero(columns, columns);
  d.moment_total = Eigen::VectorXd::Zero(columns);
  for (std::size_t f = 0; f < d.folds.size(); ++f) {
    d.gram_total += d.gram[f];
    d.moment_total += d.moment[f];
  }
  return d;
}

/// Sets column c of the equations to `column` (unscaled), with its scale and its entries of the
/// fold Gram matrices and moments.
inline void set_column(ChainDiagnosisEquations& d, Eigen::Index c, const Eigen::VectorXd& column) {
  d.scale[c] = std::max(column.norm(), 1e-300);
  d.x.col(c) = column / d.scale[c];
  d.gram_total.row(c).setZero();
  d.gram_total.col(c).setZero();
  d.moment_total[c] = 0.0;
  for (std::size_t f = 0; f < d.folds.size(); ++f) {
    const auto [begin, end] = d.folds[f];
    const auto xf = d.x.middleRows(begin, end - begin);
    const Eigen::VectorXd g = xf.transpose() * xf.col(c);
    d.gram[f].col(c) = g;
    d.gram[f].row(c) = g.transpose();
    d.moment[f][c] = xf.col(c).dot(d.y.segment(begin, end - begin));
    d.gram_total.col(c) += g;
    d.moment_total[c] += d.moment[f][c];
  }
  d.gram_total.row(c) = d.gram_total.col(c).transpose();
}

/// The smoothed states the equations are taken at, in the equations' order (one per sample
/// position that has equations), and for each equation the index of its state.
struct EquationStates {
  std::vector<std::pair<std::size_t, Eigen::Index>> states;  ///< (run, sample)
  std::vector<Eigen::Index> of_row;
};

inline EquationStates equation_states(const std::vector<SmoothedChainRun>& runs,
                                      const ChainDiagnosisEquations& d) {
  EquationStates e;
  e.of_row.reserve(d.at.size());
  for (std::size_t r = 0; r < runs.size(); ++r) {
    Eigen::Index last = -1;
    for (Eigen::Index row = d.run_rows[r]; row < d.run_rows[r + 1]; ++row) {
      const Eigen::Index a = d.at[static_cast<std::size_t>(row)];
      if (a != last) {
        e.states.emplace_back(r, runs[r].samples[static_cast<std::size_t>(a)]);
        last = a;
      }
      e.of_row.push_back(static_cast<Eigen::Index>(e.states.size()) - 1);
    }
  }
  return e;
}

/// Per equation: how the torque prediction of `model` at `theta` on the equation's joint changes
/// per radian of offset of each joint's measured angle, ∂(Y θ)/∂q_j by forward differences at
/// the smoothed states (one column per joint), the states spread over `threads`.
inline Eigen::MatrixXd angle_offset_slopes(const ChainModel& model,
                                           const std::vector<SmoothedChainRun>& runs,
                                           const ChainDiagnosisEquations& d,
                                           const Eigen::VectorXd& theta, int threads) {
  // Truncation ~h |∂²τ/∂q²| and rounding ~1e-16 |τ| / h: both far below the torque noise, at
  // n + 1 torque evaluations per sample.
  constexpr double h = 1e-6;
  const int n = model.joints();
  // Of the drive terms only the springs depend on the angles: the others' torques are the same
  // at both ends of a difference, and leaving them out changes the slopes by rounding only. The
  // links' torques come from the Newton-Euler recursion with their parameters, O(n) instead of
  // the regressor's O(n^2) columns: that too changes them by rounding only.
  const Eigen::Index links = model.rigid_body_parameters();
  std::vector<std::pair<std::size_t, double>> springs;  // (the model's term, its value)
  for (std::size_t a = 0; a < model.terms().size(); ++a) {
    const double value = theta[links + static_cast<Eigen::Index>(a)];
    if (model.terms()[a].kind == DriveTermKind::Spring && value != 0.0)
      springs.emplace_back(a + 1, value);  // the model's term 0 is the links'
  }
  const auto& terms = model.model().terms();
  const auto theta_links = theta.head(links);

  const EquationStates e = equation_states(runs, d);
  const auto count = static_cast<Eigen::Index>(e.states.size());
  Eigen::MatrixXd slopes(n * n, count);  // per state, (torque of joint, angle shifted)
  constexpr Eigen::Index kBlock = 256;
  for_each_index((count + kBlock - 1) / kBlock, threads, [&](Eigen::Index block, int) {
    ChainModel::Vector q(n), qd(n), qdd(n), shifted(n), tau(n), tau_shifted(n);
    Eigen::MatrixXd column(n, 1);
    const auto torque = [&](const ChainModel::Vector& at, ChainModel::Vector& out) {
      detail::chain_link_torques_unchecked(model.chain(), theta_links, at, qd, qdd, out);
      for (const auto& [term, value] : springs) {
        terms[term].columns(at, qd, qdd, RegressorView<double, Eigen::Dynamic>(column));
        out += value * column.col(0);
      }
    };
    for (Eigen::Index s = block * kBlock; s < std::min(count, (block + 1) * kBlock); ++s) {
      const auto [run, i] = e.states[static_cast<std::size_t>(s)];
      const ChainKinematics<double>& k = runs[run].k;
      q = k.q.row(i).transpose();
      qd = k.qd.row(i).transpose();
      qdd = k.qdd.row(i).transpose();
      torque(q, tau);
      shifted = q;
      auto slope = slopes.col(s).reshaped(n, n);
      for (int j = 0; j < n; ++j) {
        shifted[j] = q[j] + h;
        torque(shifted, tau_shifted);
        slope.col(j) = (tau_shifted - tau) / h;
        shifted[j] = q[j];
      }
    }
  });
  Eigen::MatrixXd out(d.y.size(), n);
  for (Eigen::Index row = 0; row < out.rows(); ++row)
    out.row(row) = slopes.col(e.of_row[static_cast<std::size_t>(row)])
                       .reshaped(n, n)
                       .row(d.joint[static_cast<std::size_t>(row)]);
  return out;
}

/// Per equation: the column of `model`'s last drive term (the one wanted) at the smoothed
/// states, on the equation's joint: that term's column function alone.
inline Eigen::VectorXd last_drive_column(const ChainModel& model,
                                         const std::vector<SmoothedChainRun>& runs,
                                         const ChainDiagnosisEquations& d) {
  const auto& term = model.model().terms().back();
  const int n = model.joints();
  const EquationStates e = equation_states(runs, d);
  Eigen::MatrixXd columns(n, static_cast<Eigen::Index>(e.states.size()));
  ChainModel::Vector q(n), qd(n), qdd(n);
  Eigen::MatrixXd one(n, 1);
  for (std::size_t s = 0; s < e.states.size(); ++s) {
    const auto [run, i] = e.states[s];
    const ChainKinematics<double>& k = runs[run].k;
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    term.columns(q, qd, qdd, RegressorView<double, Eigen::Dynamic>(one));
    columns.col(static_cast<Eigen::Index>(s)) = one;
  }
  Eigen::VectorXd out(d.y.size());
  for (Eigen::Index row = 0; row < out.size(); ++row)
    out[row] =
        columns(d.joint[static_cast<std::size_t>(row)], e.of_row[static_cast<std::size_t>(row)]);
  return out;
}

/// The width of a named Stribeck curve that leaves the least residual, the other columns held
/// (Frisch–Waugh–Lovell): a log-spaced scan of [lo, hi], then a golden-section search about
/// its best point. q is an orthonormal basis of the other columns; column_at(vs) gives the
/// curve's unscaled column at width vs.
template <typename ColumnAt>
double fitted_stribeck_width(const ChainDiagnosisEquations& d, const Eigen::MatrixXd& q, double lo,
                             double hi, const ColumnAt& column_at) {
  const Eigen::VectorXd r0 = d.y_measured - q * (q.transpose() * d.y_measured);
  const auto rss = [&](double log_vs) {
    const Eigen::VectorXd z = column_at(std::exp(log_vs));
    const Eigen::VectorXd zr = z - q * (q.transpose() * z);
    const double zz = zr.squaredNorm();
    return zz > 0.0 ? r0.squaredNorm() - zr.dot(r0) * zr.dot(r0) / zz : r0.squaredNorm();
  };
  constexpr int kScan = 9;
  const double a = std::log(lo), step = (std::log(hi) - a) / (kScan - 1);
  int best = 0;
  double best_rss = rss(a);
  for (int k = 1; k < kScan; ++k) {
    const double value = rss(a + k * step);
    if (value < best_rss) {
      best_rss = value;
      best = k;
    }
  }
  const double found = golden_section_minimum(rss, a + std::max(best - 1, 0) * step,
                                              a + std::min(best + 1, kScan - 1) * step, 5e-3);
  return rss(found) < best_rss ? std::exp(found) : std::exp(a + best * step);
}

/// Blocked cross-validation error of the model on `columns`: each fold predicted by the fit on
/// all others, from the fold Gram matrices (one small solve per fold).
inline double chain_cv_error(const ChainDiagnosisEquations& d,
                             const std::vector<Eigen::Index>& columns) {
  const Eigen::MatrixXd g = d.gram_total(columns, columns);
  const Eigen::VectorXd b = d.moment_total(columns);
  double error = 0.0;
  for (std::size_t f = 0; f < d.folds.size(); ++f) {
    const Eigen::MatrixXd gf = d.gram[f](columns, columns);
    const Eigen::VectorXd bf = d.moment[f](columns);
    const Eigen::VectorXd theta = (g - gf).ldlt().solve(b - bf);
    error += d.energy[f] - 2.0 * theta.dot(bf) + theta.dot(gf * theta);
  }
  return error;
}

/// Per-joint sums of squares of a vector over the equations.
inline Eigen::VectorXd per_joint_squares(const ChainDiagnosisEquations& d,
                                         const Eigen::Ref<const Eigen::VectorXd>& v) {
  Eigen::VectorXd out = Eigen::VectorXd::Zero(d.joints);
  for (Eigen::Index r = 0; r < v.size(); ++r)
    out[d.joint[static_cast<std::size_t>(r)]] += v[r] * v[r];
  return out;
}

/// The HAC long-run sum of scores x_r e_r summed per sample (a sample's joints are one
/// observation), runs independent.
inline Eigen::MatrixXd chain_long_run(const ChainDiagnosisEquations& d,
                                      const Eigen::Ref<const Eigen::MatrixXd>& x,
                                      const Eigen::Ref<const Eigen::VectorXd>& e) {
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(x.cols(), x.cols());
  for (std::size_t run = 0; run + 1 < d.run_rows.size(); ++run) {
    Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(d.positions[run], x.cols());
    for (Eigen::Index r = d.run_rows[run]; r < d.run_rows[run + 1]; ++r)
      scores.row(d.at[static_cast<std::size_t>(r)]) += e[r] * x.row(r);
    sum += hac_long_run_sum(scores);
  }
  return sum;
}

/// vᵀ S v for each column v of `directions` (a row per column), S the HAC long-run sum of
/// chain_long_run(d, d.x(:, columns), e), without forming S.
inline Eigen::VectorXd chain_long_run_quadratic(
    const ChainDiagnosisEquations& d, const std::vector<Eigen::Index>& columns,
    const Eigen::Ref<const Eigen::VectorXd>& e,
    const Eigen::Ref<const Eigen::MatrixXd>& directions) {
  const auto k = static_cast<Eigen::Index>(columns.size());
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(directions.cols());
  for (std::size_t run = 0; run + 1 < d.run_rows.size(); ++run) {
    Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(d.positions[run], k);
    for (Eigen::Index c = 0; c < k; ++c) {
      const auto x = d.x.col(columns[static_cast<std::size_t>(c)]);
      auto score = scores.col(c);
      for (Eigen::Index r = d.run_rows[run]; r < d.run_rows[run + 1]; ++r)
        score[d.at[static_cast<std::size_t>(r)]] += e[r] * x[r];
    }
    sum += hac_long_run_quadratic(scores, directions);
  }
  return sum;
}

/// The fit of a selection round: the columns' QR factors (an orthonormal basis kept whole,
/// against which every candidate is projected), the values, the residual.
struct ChainRound {
  std::vector<Eigen::Index> columns;
  Eigen::MatrixXd q;    ///< orthonormal basis of the columns
  Eigen::MatrixXd r;    ///< upper triangular, q r = the columns
  Eigen::VectorXd qty;  ///< qᵀ y
  Eigen::VectorXd theta, residual, rss;
  double cv_error = 0;

  ChainRound(const ChainDiagnosisEquations& d, std::vector<Eigen::Index> cols, int threads)
      : columns(std::move(cols)) {
    const Eigen::MatrixXd x = d.x(Eigen::all, columns);
    const Eigen::HouseholderQR<Eigen::MatrixXd> qr(x);
    // The basis is the reflectors applied to the identity's columns, in fixed blocks of columns
    // over threads.
    const Eigen::Index s = x.cols();
    q = Eigen::MatrixXd::Identity(x.rows(), s);
    const auto reflectors = qr.householderQ();
    constexpr Eigen::Index kBlock = 16;
    for_each_index((s + kBlock - 1) / kBlock, threads, [&](Eigen::Index b, int) {
      auto block = q.middleCols(b * kBlock, std::min(kBlock, s - b * kBlock));
      reflectors.applyThisOnTheLeft(block);
    });
    r = qr.matrixQR().topRows(x.cols()).triangularView<Eigen::Upper>();
    qty = q.transpose() * d.y;
    theta = qr.solve(d.y);
    finish(d);
  }

  /// The next round's fit, with `column` added: a Gram–Schmidt step (repeated once, which keeps
  /// the basis orthogonal to rounding) instead of a new factorization of 60 000 rows.
  void add(const ChainDiagnosisEquations& d, Eigen::Index column) {
    const Eigen::Index s = q.cols();
    Eigen::VectorXd z = d.x.col(column);
    Eigen::VectorXd a = q.transpose() * z;
    z.noalias() -= q * a;
    const Eigen::VectorXd again = q.transpose() * z;
    z.noalias() -= q * again;
    a += again;
    const double rho = z.norm();
    q.conservativeResize(Eigen::NoChange, s + 1);
    q.col(s) = z / rho;
    r.conservativeResize(s + 1, s + 1);
    r.col(s).head(s) = a;
    r.row(s).setZero();
    r(s, s) = rho;
    qty.conservativeResize(s + 1);
    qty[s] = q.col(s).dot(d.y);
    theta = r.triangularView<Eigen::Upper>().solve(qty);
    columns.push_back(column);
    finish(d);
  }

  /// Each column of z (columns of d.x) less its part in the basis, in blocks of columns
  /// spread over threads (fixed blocks: the same bits on any number of threads).
  Eigen::MatrixXd unexplained(const Eigen::Ref<const Eigen::MatrixXd>& z, int threads) const {
    Eigen::MatrixXd out = z;
    constexpr Eigen::Index kBlock = 8;
    for_each_index((z.cols() + kBlock - 1) / kBlock, threads, [&](Eigen::Index b, int) {
      const Eigen::Index first = b * kBlock, count = std::min(kBlock, z.cols() - first);
      const Eigen::MatrixXd a = q.transpose() * z.middleCols(first, count);
      out.middleCols(first, count).noalias() -= q * a;
    });
    return out;
  }

 private:
  void finish(const ChainDiagnosisEquations& d) {
    residual = d.y;
    for (std::size_t k = 0; k < columns.size(); ++k)
      residual -= theta[static_cast<Eigen::Index>(k)] * d.x.col(columns[k]);
    rss = per_joint_squares(d, residual);
    cv_error = chain_cv_error(d, columns);
  }
};

inline void check_chain_diagnose_options(const ChainDiagnoseOptions& o, int joints) {
  const std::string who = "sid::diagnose_chain: ";
  check_chain_options(o.identify, joints, "sid::diagnose_chain");
  if (o.candidate_kinds.empty()) throw std::invalid_argument(who + "no candidate kinds given");
  const bool stribeck = std::find(o.candidate_kinds.begin(), o.candidate_kinds.end(),
                                  DriveTermKind::Stribeck) != o.candidate_kinds.end();
  if (stribeck && o.stribeck_velocities.empty())
    throw std::invalid_argument(who + "Stribeck candidates need at least one width");
  for (const double vs : o.stribeck_velocities)
    if (!(vs > 0.0) || !std::isfinite(vs))
      throw std::invalid_argument(who + "stribeck_velocities must be finite and > 0");
  if (!(o.family_alpha > 0.0 && o.family_alpha < 1.0))
    throw std::invalid_argument(who + "family_alpha must be in (0, 1)");
  if (o.cv_blocks < 2) throw std::invalid_argument(who + "cv_blocks must be >= 2");
  if (o.threads < 0) throw std::invalid_argument(who + "threads must be >= 0");
  if (!(o.min_cv_gain >= 0.0 && o.min_cv_gain < 1.0))
    throw std::invalid_argument(who + "min_cv_gain must be in [0, 1)");
  if (!(o.separability_r2 > 0.0 && o.separability_r2 < 1.0))
    throw std::invalid_argument(who + "separability_r2 must be in (0, 1)");
  if (!(o.negligible_size >= 0.0 && o.negligible_size < 1.0))
    throw std::invalid_argument(who + "negligible_size must be in [0, 1)");
  if (!(o.look_alike >= 0.0 && o.look_alike <= 1.0))
    throw std::invalid_argument(who + "look_alike must be in [0, 1]");
}

/// Per joint, the cutoff of the GCV smoothing spline of its angles (geometric mean over the
/// runs, within the options' search range): chosen from the angles alone, because a cutoff
/// chosen by the nominal model's torque prediction bends towards hiding what the model lacks.
inline std::vector<double> gcv_cutoffs(const ChainModel& model,
                                       const std::vector<ChainTrajectory<double>>& runs,
                                       const ChainIdentifyOptions& o, int threads) {
  const int n = model.joints();
  std::vector<double> log_sum(static_cast<std::size_t>(n), 0.0);
  for (std::size_t r = 0; r < runs.size(); ++r) {
    const ChainTrajectory<double>& run = runs[r];
    check_chain_run(model, run, "sid::diagnose_chain: run " + std::to_string(r + 1));
    const double h = (run.t[run.size() - 1] - run.t[0]) / static_cast<double>(run.size() - 1);
    const SmoothingSpline<double> spline(run.t);
    std::vector<double> lambda(static_cast<std::size_t>(n));
    for_each_index(n, threads, [&](Eigen::Index j, int) {
      lambda[static_cast<std::size_t>(j)] = spline.fit_cross_validated(run.q.col(j)).lambda;
    });
    for (int j = 0; j < n; ++j) {
      const double cutoff = smoothing_cutoff_for_lambda(lambda[static_cast<std::size_t>(j)], h);
      log_sum[static_cast<std::size_t>(j)] +=
          std::log(std::clamp(cutoff, o.min_cutoff_hz, o.max_cutoff_hz));
    }
  }
  std::vector<double> cutoff;
  for (const double s : log_sum) cutoff.push_back(std::exp(s / static_cast<double>(runs.size())));
  return cutoff;
}

inline std::string significant(double value, int digits) {
  std::ostringstream out;
  out << std::setprecision(digits) << value;
  return out.str();
}

/// The cutoffs identify_chain chooses by held-out torque prediction for the nominal model with
/// Coulomb friction and a torque offset on every drive that lacks them.
inline std::vector<double> torque_cv_cutoffs(const ChainModel& nominal,
                                             const std::vector<ChainTrajectory<double>>& runs,
                                             ChainIdentifyOptions o, int threads) {
  std::vector<DriveTerm> terms = nominal.terms();
  for (const DriveTerm& t :
       chain_candidates(nominal, {DriveTermKind::Coulomb, DriveTermKind::Offset}, {}))
    terms.push_back(t);
  const ChainModel model(nominal.chain(), nominal.joint_names(), terms, nominal.transmission(),
                         nominal.coulomb_epsilon());
  o.cutoff_hz.clear();
  o.statistics = false;
  o.threads = threads;
  const ChainIdentification id = identify_chain(model, runs, o);
  return {id.cutoff_hz.data(), id.cutoff_hz.data() + id.cutoff_hz.size()};
}

/// The cutoffs options.smoothing chooses (options.identify's when given), and how, in words.
inline std::pair<std::vector<double>, std::string> diagnosis_cutoffs(
    const ChainModel& nominal, const std::vector<ChainTrajectory<double>>& runs,
    const ChainDiagnoseOptions& options, int threads) {
  const ChainIdentifyOptions& o = options.identify;
  if (!o.cutoff_hz.empty()) return {o.cutoff_hz, "given"};
  const std::string torque_cv =
      "held-out torque prediction (the nominal model with Coulomb friction and a torque offset)";
  if (options.smoothing == ChainSmoothingChoice::Measured)
    return {torque_cv_cutoffs(nominal, runs, o, threads), torque_cv + ", as for a measured log"};
  const auto measured = [&](const std::string& why) {
    return std::make_pair(torque_cv_cutoffs(nominal, runs, o, threads),
                          torque_cv + ": " + why + ", as on a measured log");
  };
  if (options.smoothing == ChainSmoothingChoice::Automatic) {
    // Angles that move as a staircase (a coarse encoder on a slow joint): their error is a
    // sawtooth, not white noise, and GCV follows the stairs.
    for (int j = 0; j < nominal.joints(); ++j)
      for (std::size_t r = 0; r < runs.size(); ++r) {
        check_chain_run(nominal, runs[r], "sid::diagnose_chain: run " + std::to_string(r + 1));
        const double step = quantisation_step(runs[r].q.col(j));
        if (step > 0.0 && median_move_in_steps(runs[r].q.col(j), step) < 2.0)
          return measured("the angles of " + nominal.joint_names()[static_cast<std::size_t>(j)] +
                          " move by fewer than two steps of their grid (" + significant(step, 2) +
                          " rad) per sample: a staircase GCV would follow");
      }
  }
  std::vector<double> gcv = gcv_cutoffs(nominal, runs, o, threads);
  if (options.smoothing == ChainSmoothingChoice::AngleGcv) return {gcv, "GCV of the angles"};
  std::string top;
  for (std::size_t j = 0; j < gcv.size(); ++j)
    if (gcv[j] >= o.max_cutoff_hz * (1.0 - 1e-9))
      top += (top.empty() ? "" : ", ") + nominal.joint_names()[j];
  if (top.empty()) return {gcv, "GCV of the angles"};
  return measured("GCV leaves the angles of " + top + " unsmoothed");
}

inline std::string percent(double fraction) {
  std::string s = std::to_string(std::round(1000.0 * fraction) / 10.0);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

/// The nominal model's identification at the diagnosis's cutoffs (options.smoothing's choice),
/// the identification options with those cutoffs, and how they were chosen.
struct NominalDiagnosisFit {
  ChainIdentifyOptions given;
  ChainIdentification id;
  std::string smoothing;
};

inline NominalDiagnosisFit fit_nominal_for_diagnosis(
    const ChainModel& nominal, const std::vector<ChainTrajectory<double>>& runs,
    const ChainDiagnoseOptions& options, int threads) {
  NominalDiagnosisFit out;
  ChainIdentifyOptions& given = out.given;
  given = options.identify;
  std::tie(given.cutoff_hz, out.smoothing) = diagnosis_cutoffs(nominal, runs, options, threads);
  given.statistics = false;
  out.id = identify_chain(nominal, runs, given);
  if (!out.id.fit.ok())
    throw std::invalid_argument("sid::diagnose_chain: the nominal model's fit failed: " +
                                out.id.fit.message);
  return out;
}

/// Every candidate as its test starts: the drive terms, then the angle offsets.
inline std::vector<ChainEffectTest> candidate_prototypes(const std::vector<DriveTerm>& candidates,
                                                         int n, bool angle_offsets) {
  std::vector<ChainEffectTest> prototypes;
  for (const DriveTerm& term : candidates) {
    ChainEffectTest t;
    t.term = term;
    t.id = drive_term_id(term);
    t.unit = drive_term_unit(term.kind);
    prototypes.push_back(std::move(t));
  }
  for (int j = 0; angle_offsets && j < n; ++j) {
    ChainEffectTest t;
    t.term.index = j;
    t.angle_offset = true;
    t.id = "angle_offset_q" + std::to_string(j + 1);
    t.unit = "rad";
    prototypes.push_back(std::move(t));
  }
  for (ChainEffectTest& t : prototypes) t.practical_size = Eigen::VectorXd::Zero(n);
  return prototypes;
}

/// What every round of the selection works on: the candidates as their tests start, the nominal
/// model with every drive term candidate, the runs smoothed at the diagnosis's cutoffs, and their
/// equations on the nominal model's base columns, then the drive term candidates' columns, then
/// the angle offsets' (which each round sets anew).
struct ChainDiagnosisSetup {
  explicit ChainDiagnosisSetup(ChainModel with_candidates) : full(std::move(with_candidates)) {}

  ChainModel full;
  std::vector<ChainEffectTest> prototypes;
  std::vector<Eigen::Index> base_parameters;  ///< the nominal model's parameter of each base column
  std::vector<SmoothedChainRun> smoothed;
  ChainDiagnosisEquations d;
  Eigen::Index base_count = 0, angle_columns = 0, first_angle_column = 0;
  double log_rows = 0;
  Eigen::VectorXd joint_rows;  ///< how many equations each joint has
  int threads = 1;

  ChainEffectTest make_test(Eigen::Index c) const {
    return prototypes[static_cast<std::size_t>(c)];
  }
};

/// Sets result's cutoffs, smoothing and equation count.
inline ChainDiagnosisSetup chain_diagnosis_setup(const ChainModel& nominal,
                                                 const std::vector<ChainTrajectory<double>>& runs,
                                                 const ChainDiagnoseOptions& options, int threads,
                                                 ChainDiagnosis& result) {
  const int n = nominal.joints();
  NominalDiagnosisFit nominal_fit = fit_nominal_for_diagnosis(nominal, runs, options, threads);
  const ChainIdentifyOptions& given = nominal_fit.given;
  const ChainIdentification& id = nominal_fit.id;
  result.cutoff_hz = id.cutoff_hz;
  result.smoothing = std::move(nominal_fit.smoothing);
  const std::vector<DriveTerm> candidates =
      chain_candidates(nominal, options.candidate_kinds, options.stribeck_velocities);
  std::vector<ChainEffectTest> prototypes =
      candidate_prototypes(candidates, n, options.angle_offsets);
  std::vector<DriveTerm> all_terms = nominal.terms();
  all_terms.insert(all_terms.end(), candidates.begin(), candidates.end());
  ChainDiagnosisSetup setup(ChainModel(nominal.chain(), nominal.joint_names(), all_terms,
                                       nominal.transmission(), nominal.coulomb_epsilon()));
  setup.prototypes = std::move(prototypes);
  setup.base_parameters = id.base.independent;
  setup.threads = threads;

  std::vector<SmoothedChainRun>& smoothed = setup.smoothed;
  smoothed = smoothed_runs(setup.full, runs, given, "sid::diagnose_chain");
  for (auto& s : smoothed)
    for (int j = 0; j < n; ++j) s.smooth_joint(j, id.cutoff_hz[j], given.filter_torque);
  std::vector<Eigen::Index> columns = id.base.independent;
  setup.base_count = static_cast<Eigen::Index>(columns.size());
  for (std::size_t c = 0; c < candidates.size(); ++c)
    columns.push_back(nominal.parameters() + static_cast<Eigen::Index>(c));
  std::vector<ChainEquations> equations =
      all_equations(setup.full, smoothed, columns, given.rest_fraction);
  // The angle offsets' columns depend on the fit: each round sets them.
  const auto angle_columns = static_cast<Eigen::Index>(setup.prototypes.size() - candidates.size());
  setup.angle_columns = angle_columns;
  for (ChainEquations& e : equations) {
    e.x.conservativeResize(Eigen::NoChange, e.x.cols() + angle_columns);
    e.x.rightCols(angle_columns).setZero();
  }
  setup.d = chain_diagnosis_equations(equations, n, options.cv_blocks, threads);
  setup.first_angle_column = static_cast<Eigen::Index>(setup.base_count + candidates.size());
  result.equations = setup.d.y.size();
  setup.log_rows = std::log(static_cast<double>(setup.d.y.size()));
  setup.joint_rows = Eigen::VectorXd::Zero(n);
  for (const int j : setup.d.joint) setup.joint_rows[j] += 1.0;
  return setup;
}

/// σ of each joint's measured torque noise (RMS over the runs). Practical sizes are judged
/// against it: the fits use filtered torques, whose residual is far below it.
inline Eigen::VectorXd torque_noise_floor(const std::vector<ChainTrajectory<double>>& runs, int n,
                                          int threads) {
  Eigen::MatrixXd sigma(n, static_cast<Eigen::Index>(runs.size()));
  for_each_index(sigma.size(), threads, [&](Eigen::Index k, int) {
    const auto& run = runs[static_cast<std::size_t>(k / n)];
    sigma(k % n, k / n) = noise_sigma_gcv(run.t, run.tau.col(k % n));
  });
  Eigen::VectorXd noise_floor = Eigen::VectorXd::Zero(n);
  for (Eigen::Index r = 0; r < sigma.cols(); ++r)
    for (int j = 0; j < n; ++j)
      noise_floor[j] += sigma(j, r) * sigma(j, r) / static_cast<double>(runs.size());
  return noise_floor.cwiseSqrt().cwiseMax(1e-300);
}

/// The residual against the measured torque, per joint: the figure the report compares.
inline Eigen::VectorXd measured_rms(const ChainDiagnosisSetup& setup, const ChainRound& round) {
  const ChainDiagnosisEquations& d = setup.d;
  const Eigen::VectorXd e = d.y_measured - d.x(Eigen::all, round.columns) * round.theta;
  return Eigen::VectorXd(
      (per_joint_squares(d, e).array() / setup.joint_rows.array().max(1.0)).sqrt());
}

/// The forward selection as it goes. Each round's fit grows from the last one's by the column
/// named, and so does each candidate's column less its part in the model's columns
/// (`unexplained`, zr), by one step per column named; the angle offsets' columns, which change
/// each round, are projected anew.
struct ChainSelection {
  std::vector<Eigen::Index> selected;   ///< columns of the equations in the model
  std::vector<Eigen::Index> remaining;  ///< positions in the prototypes
  std::vector<ChainEffectTest> last_round;
  std::vector<Eigen::Index> last_tested, inseparable, named_positions;
  Eigen::MatrixXd nominal_q;  ///< orthonormal basis of the nominal model's columns
  bool angle_columns_stale = false;
  std::optional<ChainRound> fit;
  Eigen::MatrixXd unexplained;
};

inline ChainSelection start_selection(const ChainDiagnosisSetup& setup) {
  const Eigen::Index base_count = setup.base_count;
  ChainSelection s;
  s.selected.resize(static_cast<std::size_t>(base_count));
  for (Eigen::Index c = 0; c < base_count; ++c) s.selected[static_cast<std::size_t>(c)] = c;
  for (std::size_t c = 0; c < setup.prototypes.size(); ++c)
    s.remaining.push_back(static_cast<Eigen::Index>(c));
  s.angle_columns_stale = setup.angle_columns > 0;
  s.unexplained.resize(setup.d.y.size(), static_cast<Eigen::Index>(setup.prototypes.size()));
  return s;
}

/// The candidates at `positions` (in the prototypes) less their part in the current fit's columns.
inline void project_anew(const ChainDiagnosisSetup& setup, ChainSelection& selection,
                         const std::vector<Eigen::Index>& positions) {
  if (positions.empty()) return;
  const ChainDiagnosisEquations& d = setup.d;
  Eigen::MatrixXd z(d.y.size(), static_cast<Eigen::Index>(positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i)
    z.col(static_cast<Eigen::Index>(i)) = d.x.col(setup.base_count + positions[i]);
  z = selection.fit->unexplained(z, setup.threads);
  for (std::size_t i = 0; i < positions.size(); ++i)
    selection.unexplained.col(positions[i]) = z.col(static_cast<Eigen::Index>(i));
}

/// An angle offset is the current model's torque linearised in the angle: at the nominal fit a
/// missing term elsewhere bends the link parameters (a spring on joint 5 hides an offset of
/// 0.3 rad on joint 4), so each round takes the model fitted so far, named terms included.
inline void linearise_angle_offsets(const ChainModel& nominal, ChainDiagnosisSetup& setup,
                                    ChainSelection& selection, const ChainRound& round) {
  ChainDiagnosisEquations& d = setup.d;
  const std::vector<Eigen::Index>& selected = selection.selected;
  const Eigen::Index base_count = setup.base_count, first_angle_column = setup.first_angle_column;
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(setup.full.parameters());
  for (std::size_t k = 0; k < selected.size(); ++k) {
    const Eigen::Index column = selected[k];
    const double value = round.theta[static_cast<Eigen::Index>(k)] / d.scale[column];
    if (column < base_count)
      theta[setup.base_parameters[static_cast<std::size_t>(column)]] = value;
    else if (column < first_angle_column)
      theta[nominal.parameters() + column - base_count] = value;
  }
  const Eigen::MatrixXd slopes =
      angle_offset_slopes(setup.full, setup.smoothed, d, theta, setup.threads);
  std::vector<Eigen::Index> angles;
  for (const Eigen::Index c : selection.remaining) {
    const Eigen::Index column = base_count + c;
    if (column >= first_angle_column) {
      set_column(d, column, slopes.col(column - first_angle_column));
      angles.push_back(c);
    }
  }
  project_anew(setup, selection, angles);
  selection.angle_columns_stale = false;
}

/// The round's fit (the first round's is the nominal model's, whose residual it reports) and the
/// remaining candidates' columns less their part in it.
inline const ChainRound& fit_round(const ChainModel& nominal, ChainDiagnosisSetup& setup,
                                   ChainSelection& selection, ChainDiagnosis& result) {
  const Eigen::Index base_count = setup.base_count, first_angle_column = setup.first_angle_column;
  std::optional<ChainRound>& fit = selection.fit;
  if (!fit) {
    fit.emplace(setup.d, selection.selected, setup.threads);
    std::vector<Eigen::Index> drive;
    for (const Eigen::Index c : selection.remaining)
      if (base_count + c < first_angle_column) drive.push_back(c);
    project_anew(setup, selection, drive);
  } else {
    fit->add(setup.d, selection.selected.back());
    // The column added, less its part in the others, is the basis's last: each candidate
    // loses its part along it.
    const auto added = fit->q.col(fit->q.cols() - 1);
    for (const Eigen::Index c : selection.remaining)
      if (base_count + c < first_angle_column)
        selection.unexplained.col(c) -= added.dot(selection.unexplained.col(c)) * added;
  }
  const ChainRound& round = *fit;
  if (result.nominal_residual_rms.size() == 0) {
    result.nominal_residual_rms = measured_rms(setup, round);
    selection.nominal_q = round.q;
  }
  if (selection.angle_columns_stale) linearise_angle_offsets(nominal, setup, selection, round);
  return round;
}

/// A round's tests of the candidates that are separable from the model, and in step with them
/// their positions in the prototypes, raw p-values and the residual each explains.
struct RoundTests {
  std::vector<ChainEffectTest> tests;
  std::vector<Eigen::Index> tested;
  std::vector<double> p_raw, gain;
};

/// Tests every remaining candidate against the round's residual (Frisch–Waugh–Lovell); one the
/// model's columns explain leaves the selection as not separable.
inline RoundTests test_candidates(const ChainDiagnoseOptions& options,
                                  const ChainDiagnosisSetup& setup, ChainSelection& selection,
                                  const ChainRound& round, ChainDiagnosis& result) {
  const ChainDiagnosisEquations& d = setup.d;
  const int n = d.joints;
  const Eigen::VectorXd& joint_rows = setup.joint_rows;
  std::vector<Eigen::Index>& remaining = selection.remaining;
  RoundTests out;
  for (auto it = remaining.begin(); it != remaining.end();) {
    const Eigen::Index column = setup.base_count + *it;
    ChainEffectTest t = setup.make_test(*it);
    const auto z = d.x.col(column);
    const auto zr = selection.unexplained.col(*it);
    const double zz = zr.squaredNorm();
    if (!(zz > (1.0 - options.separability_r2) * z.squaredNorm())) {
      t.reason =
          "not separable: the model's columns explain its column (R^2 > " +
          significant(options.separability_r2, 6) + ")" +
          (t.angle_offset ? ": the link parameters absorb it, the torques cannot tell it" : "");
      result.not_named.push_back(std::move(t));
      selection.inseparable.push_back(*it);
      it = remaining.erase(it);
      continue;
    }
    const double gamma = zr.dot(round.residual) / zz;
    const Eigen::VectorXd change = gamma * zr;
    const Eigen::VectorXd e = round.residual - change;
    const double variance = chain_long_run(d, zr, e)(0, 0) / (zz * zz);
    t.value = gamma / d.scale[column];
    t.std = std::sqrt(std::max(variance, 0.0)) / d.scale[column];
    t.wald = variance > 0.0 ? gamma * gamma / variance : 0.0;
    out.p_raw.push_back(chi_square_tail(t.wald, 1.0));
    const Eigen::VectorXd rss = per_joint_squares(d, e);
    t.bic_drop = -setup.log_rows;
    for (int j = 0; j < n; ++j)
      if (joint_rows[j] > 0.0 && rss[j] > 0.0)
        t.bic_drop += joint_rows[j] * std::log(round.rss[j] / rss[j]);
    std::vector<Eigen::Index> with = selection.selected;
    with.push_back(column);
    t.cv_drop = (round.cv_error - chain_cv_error(d, with)) / round.cv_error;
    const Eigen::VectorXd changed = per_joint_squares(d, change);
    for (int j = 0; j < n; ++j)
      t.practical_size[j] =
          joint_rows[j] > 0.0 ? std::sqrt(changed[j] / joint_rows[j]) / result.noise_floor[j] : 0.0;
    out.tests.push_back(std::move(t));
    out.tested.push_back(*it);
    out.gain.push_back(gamma * gamma * zz);
    ++it;
  }
  keep_best_stribeck_width(out.tests, out.tested, out.p_raw, out.gain);
  selection.last_tested = out.tested;
  return out;
}

/// Holm's adjustment over the round, each test's detection limit and why it is not named; the
/// test to name (of those that pass, the largest BIC drop), -1 for none.
inline int judge_round(const ChainDiagnoseOptions& options, RoundTests& round_tests) {
  std::vector<ChainEffectTest>& tests = round_tests.tests;
  const std::vector<double> p = holm_adjusted(round_tests.p_raw);
  const double critical_z =
      std::sqrt(chi_square_critical(options.family_alpha / static_cast<double>(tests.size()), 1.0));
  int best = -1;
  for (std::size_t i = 0; i < tests.size(); ++i) {
    ChainEffectTest& t = tests[i];
    t.p_value = p[i];
    t.detection_limit = critical_z * t.std;
    const bool positive = t.angle_offset || t.term.kind == DriveTermKind::Offset || t.value > 0.0;
    if (!(t.p_value < options.family_alpha))
      t.reason = "not significant (HAC Wald p = " + significant(t.p_value, 2) + " after Holm)";
    else if (!(t.bic_drop > 0.0))
      t.reason = "no BIC drop";
    else if (!(t.cv_drop > options.min_cv_gain))
      t.reason = "blocked-CV error drops by " + percent(t.cv_drop) + " %, not more than " +
                 percent(options.min_cv_gain) + " %";
    else if (!positive)
      t.reason = "not admissible: the value is not positive";
    else if (t.practical_size.maxCoeff() < options.negligible_size)
      t.reason = "significant but negligible: it would change the torque prediction by " +
                 percent(t.practical_size.maxCoeff()) + " % of the torque noise at most (below " +
                 percent(options.negligible_size) + " %)";
    if (t.reason.empty() &&
        (best < 0 || t.bic_drop > tests[static_cast<std::size_t>(best)].bic_drop))
      best = static_cast<int>(i);
  }
  return best;
}

/// A named Stribeck curve's width is fitted before the next round: the grid only chose among its
/// widths, and a curve between them leaves a residual that looks like Coulomb friction (a curve
/// of 0.4 rad/s, tried at 0.3, was named with a Coulomb term that the fitted width makes zero).
inline void fit_named_stribeck_width(const ChainModel& nominal, const ChainDiagnoseOptions& options,
                                     ChainDiagnosisSetup& setup, const ChainRound& round,
                                     Eigen::Index chosen, ChainEffectTest& named) {
  const DriveTerm chosen_term = named.term;
  const auto column_at = [&](double vs) {
    DriveTerm curve = chosen_term;
    curve.velocity = vs;
    const ChainModel one(nominal.chain(), nominal.joint_names(), {curve}, nominal.transmission(),
                         nominal.coulomb_epsilon());
    return last_drive_column(one, setup.smoothed, setup.d);
  };
  const auto [lo, hi] =
      std::minmax_element(options.stribeck_velocities.begin(), options.stribeck_velocities.end());
  const double width = fitted_stribeck_width(setup.d, round.q, 0.5 * *lo, 2.0 * *hi, column_at);
  named.term.velocity = width;
  set_column(setup.d, setup.base_count + chosen, column_at(width));
}

/// Names the round's test `best`: the model takes its column, and the selection drops it and,
/// for a Stribeck curve, the other widths on its joint.
inline void name_best(const ChainModel& nominal, const ChainDiagnoseOptions& options,
                      ChainDiagnosisSetup& setup, ChainSelection& selection,
                      const ChainRound& round, RoundTests& tests, int best,
                      ChainDiagnosis& result) {
  std::vector<Eigen::Index>& remaining = selection.remaining;
  const Eigen::Index chosen = tests.tested[static_cast<std::size_t>(best)];
  ChainEffectTest named = std::move(tests.tests[static_cast<std::size_t>(best)]);
  named.reason.clear();
  named.detection_limit = std::numeric_limits<double>::quiet_NaN();
  const DriveTerm chosen_term = named.term;
  const bool chosen_stribeck = !named.angle_offset && chosen_term.kind == DriveTermKind::Stribeck;
  result.named.push_back(std::move(named));
  if (chosen_stribeck)
    fit_named_stribeck_width(nominal, options, setup, round, chosen, result.named.back());
  selection.named_positions.push_back(chosen);
  selection.selected.push_back(setup.base_count + chosen);
  selection.angle_columns_stale = setup.angle_columns > 0;
  remaining.erase(std::find(remaining.begin(), remaining.end(), chosen));
  // One Stribeck curve per joint: the other widths there are not another effect.
  for (auto it = remaining.begin(); it != remaining.end();) {
    const ChainEffectTest& other = setup.prototypes[static_cast<std::size_t>(*it)];
    if (!chosen_stribeck || other.angle_offset || !same_place(other.term, chosen_term)) {
      ++it;
      continue;
    }
    ChainEffectTest t = setup.make_test(*it);
    t.reason = "the Stribeck curve named on this joint, tried at width " +
               significant(chosen_term.velocity, 3) + " and fitted to " +
               significant(result.named.back().term.velocity, 3) + ", fits it better";
    result.not_named.push_back(std::move(t));
    it = remaining.erase(it);
  }
}

/// The last round's tests, and the candidates it did not test: Stribeck widths where another
/// width of theirs fitted better.
inline void report_last_round(const ChainDiagnosisSetup& setup, const ChainSelection& selection,
                              ChainDiagnosis& result) {
  const std::vector<ChainEffectTest>& last_round = selection.last_round;
  const std::vector<Eigen::Index>& last_tested = selection.last_tested;
  result.not_named.insert(result.not_named.end(), last_round.begin(), last_round.end());
  for (const Eigen::Index c : selection.remaining)
    if (std::find(last_tested.begin(), last_tested.end(), c) == last_tested.end()) {
      ChainEffectTest t = setup.make_test(c);
      t.reason = "another Stribeck width fits this joint better";
      result.not_named.push_back(std::move(t));
    }
}

/// The final fit: values and HAC standard deviations of the named terms, and the final model's
/// terms and angle offsets.
inline const ChainRound& fit_final(const ChainModel& nominal, const ChainDiagnosisSetup& setup,
                                   ChainSelection& selection, ChainDiagnosis& result) {
  const ChainDiagnosisEquations& d = setup.d;
  const std::vector<Eigen::Index>& selected = selection.selected;
  std::optional<ChainRound>& fit = selection.fit;
  if (!fit) fit.emplace(d, selected, setup.threads);
  while (fit->columns.size() < selected.size()) fit->add(d, selected[fit->columns.size()]);
  const ChainRound& final_round = *fit;
  // Only the named terms' variances are reported: the rows of (XᵀX)⁻¹ that give them.
  const auto named_count = static_cast<Eigen::Index>(result.named.size());
  const Eigen::MatrixXd bread =
      d.gram_total(selected, selected)
          .ldlt()
          .solve(Eigen::MatrixXd::Identity(static_cast<Eigen::Index>(selected.size()),
                                           static_cast<Eigen::Index>(selected.size())))
          .rightCols(named_count);
  const Eigen::VectorXd variance =
      chain_long_run_quadratic(d, selected, final_round.residual, bread);
  result.final_terms = nominal.terms();
  result.angle_offset = Eigen::VectorXd::Zero(nominal.joints());
  for (std::size_t i = 0; i < result.named.size(); ++i) {
    const std::size_t k = static_cast<std::size_t>(setup.base_count) + i;
    const Eigen::Index column = selected[k];
    ChainEffectTest& t = result.named[i];
    t.value = final_round.theta[static_cast<Eigen::Index>(k)] / d.scale[column];
    t.std = std::sqrt(std::max(variance[static_cast<Eigen::Index>(i)], 0.0)) / d.scale[column];
    if (t.angle_offset)
      result.angle_offset[t.term.index] = t.value;
    else
      result.final_terms.push_back(t.term);
  }
  return final_round;
}

/// Adds `other` to the caveats of the named terms `takers` (positions in result.named), which
/// would take its trace up with the correlations given if it stood hidden at `implied`.
inline void add_look_alike(const ChainEffectTest& other, double implied,
                           const std::vector<std::size_t>& takers,
                           const std::vector<double>& correlations, ChainDiagnosis& result) {
  for (std::size_t n_taker = 0; n_taker < takers.size(); ++n_taker) {
    ChainEffectTest& t = result.named[takers[n_taker]];
    t.look_alikes.push_back(other.id);
    t.caveat += (t.caveat.empty() ? "" : "; ") + other.id + " (not separable on this motion) " +
                "may stand behind it: hidden at about " + significant(implied, 2) + " " +
                other.unit + " it would leave " +
                (takers.size() > 1 ? "the named terms' traces" : "this term's trace") +
                " (what the nominal model leaves of the two columns correlates at " +
                significant(correlations[n_taker], 2) + "), and the residual does not refute it";
  }
}

/// A named term may stand for a candidate, on any joint, that this motion cannot separate: such
/// a term, hidden, leaves in the residual the part b of its column that the nominal model does
/// not explain, and named terms whose own parts a look like it (correlation above look_alike)
/// take that trace up, one or several. The hidden term would then have had the value v that
/// gives them their values in the final fit (least squares over them), and would have left in
/// its residual what the final model cannot explain of v times its column: where the residual
/// lacks that (HAC z beyond the Wald tests' level) the data refute the look-alike. On the
/// simulated TX40 every pair above a correlation of 0.1 but the spring's on joint 2 was refuted
/// so, at z > 13. Neither can a candidate stand behind named terms that would have to be
/// inadmissible, nor one the model explains exactly (it leaves no trace).
inline void add_look_alike_caveats(const ChainDiagnoseOptions& options,
                                   const ChainDiagnosisSetup& setup,
                                   const ChainSelection& selection, const ChainRound& final_round,
                                   ChainDiagnosis& result) {
  if (selection.inseparable.empty() || selection.named_positions.empty()) return;
  const ChainDiagnosisEquations& d = setup.d;
  const Eigen::Index base_count = setup.base_count;
  const std::vector<Eigen::Index>& selected = selection.selected;
  // 1 - R^2 of 1e-10: an angle offset's column by forward differences is good to about 1e-7.
  constexpr double kExplainedExactly = 1e-5;
  const auto given_nominal = [&](Eigen::Index c) {
    const Eigen::VectorXd z = d.x.col(base_count + c);
    return Eigen::VectorXd(z - selection.nominal_q * (selection.nominal_q.transpose() * z));
  };
  const Eigen::LDLT<Eigen::MatrixXd> final_gram(d.gram_total(selected, selected));
  std::vector<Eigen::VectorXd> parts;  // of the named terms
  for (const Eigen::Index c : selection.named_positions) parts.push_back(given_nominal(c));
  for (const Eigen::Index c : selection.inseparable) {
    const ChainEffectTest& other = setup.prototypes[static_cast<std::size_t>(c)];
    const Eigen::VectorXd b = given_nominal(c);
    if (!(b.norm() > kExplainedExactly)) continue;
    // Columns are scaled to unit norm: values in scaled units, then in the other's own.
    const Eigen::VectorXd z = d.x.col(base_count + c);
    // Per unit of the other: its least squares on the final columns.
    const Eigen::VectorXd share = final_gram.solve(d.x(Eigen::all, selected).transpose() * z);
    std::vector<std::size_t> takers;
    std::vector<double> correlations;
    double along = 0.0, squares = 0.0;
    for (std::size_t i = 0; i < parts.size(); ++i) {
      const Eigen::VectorXd& a = parts[i];
      const double correlation = std::abs(a.dot(b)) / std::max(a.norm() * b.norm(), 1e-300);
      const auto k = static_cast<Eigen::Index>(static_cast<std::size_t>(base_count) + i);
      if (!(correlation > options.look_alike) || share[k] == 0.0) continue;
      takers.push_back(i);
      correlations.push_back(correlation);
      along += share[k] * final_round.theta[k];
      squares += share[k] * share[k];
    }
    if (takers.empty()) continue;
    const double v = along / squares;
    const double implied = v / d.scale[base_count + c];
    const bool positive = other.angle_offset || other.term.kind == DriveTermKind::Offset;
    if (!positive && !(implied > 0.0)) continue;
    const Eigen::VectorXd left = v * (z - final_round.q * (final_round.q.transpose() * z));
    const double expected = left.norm();
    if (expected > 0.0) {
      const Eigen::VectorXd e = left / expected;
      const double variance = chain_long_run(d, e, final_round.residual)(0, 0);
      const double missing =
          (expected - e.dot(final_round.residual)) / std::sqrt(std::max(variance, 1e-300));
      if (missing > 0.0 && chi_square_tail(missing * missing, 1.0) < options.family_alpha) continue;
    }
    add_look_alike(other, implied, takers, correlations, result);
  }
}

/// The nominal and the final model's residuals against the measured torque, what the final
/// model leaves beyond the noise, and the smoothed runs.
inline void report_residuals(ChainDiagnosisSetup& setup, const ChainRound& final_round,
                             ChainDiagnosis& result) {
  if (result.nominal_residual_rms.size() == 0)  // no candidate was tried: nothing was named
    result.nominal_residual_rms = measured_rms(setup, final_round);
  result.final_residual_rms = measured_rms(setup, final_round);
  result.unexplained_rms =
      (result.final_residual_rms.array().square() - result.noise_floor.array().square())
          .max(0.0)
          .sqrt();
  for (auto& run : setup.smoothed) result.kinematics.push_back(std::move(run.k));
}

}  // namespace detail

SID_INLINE ChainDiagnosis diagnose_chain(const ChainModel& nominal,
                                         const std::vector<ChainTrajectory<double>>& runs,
                                         const ChainDiagnoseOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int n = nominal.joints();
  detail::check_chain_diagnose_options(options, n);
  if (runs.empty()) throw std::invalid_argument("sid::diagnose_chain: no runs given");
  const int threads = detail::thread_count(options.threads);
  ChainDiagnosis result;
  detail::ChainDiagnosisSetup setup =
      detail::chain_diagnosis_setup(nominal, runs, options, threads, result);
  result.noise_floor = detail::torque_noise_floor(runs, n, threads);

  detail::ChainSelection selection = detail::start_selection(setup);
  while (!selection.remaining.empty()) {
    const detail::ChainRound& round = detail::fit_round(nominal, setup, selection, result);
    detail::RoundTests tests = detail::test_candidates(options, setup, selection, round, result);
    if (tests.tests.empty()) break;
    const int best = detail::judge_round(options, tests);
    if (best < 0) {
      selection.last_round = std::move(tests.tests);
      break;
    }
    detail::name_best(nominal, options, setup, selection, round, tests, best, result);
  }
  detail::report_last_round(setup, selection, result);

  const detail::ChainRound& final_round = detail::fit_final(nominal, setup, selection, result);
  detail::add_look_alike_caveats(options, setup, selection, final_round, result);
  detail::report_residuals(setup, final_round, result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

}  // namespace sid
