#pragma once
/// @file
/// @brief Drive gains from a known payload (Gautier & Briot's global identification): logs whose
/// "torques" are motor currents [A], one run with a load of known inertial parameters fixed to
/// the chain's tip link and one or more without it, give the arm's base parameters and every
/// motor's current-to-torque gain K_m [N m/A] together.
///
/// With G the transmission's ratio (q_motor = G q) and i the motor currents, the joint torques
/// are Gᵀ diag(K) i, so per joint j and sample
///   Σ_m G_mj K_m i_m = (Y_b β)_j                      without the load,
///   Σ_m G_mj K_m i_m = (Y_b β)_j + (Y_tip φ)_j        with it,
/// φ the load's ten standard parameters (sid::standard_parameters) and Y_tip the tip link's ten
/// columns of the chain regressor. Stacked over the runs as [Y_b, −G-weighted currents] (β, K) =
/// (0 or −Y_tip φ), this is linear in (β, K). Without the load's known torque the right side is
/// zero and (β, K) is only found up to a common scale: the load is what fixes it, and a motor
/// whose torque the load does not reach keeps its gain's scale free.
///
/// The angles are smoothed as sid::identify_chain smooths them (same rest rule and regression
/// rate), and the currents and every regressor column pass through each joint's smoother (see
/// DriveGainOptions::parallel_filtering), so that a gain found at some cutoffs converts currents
/// into the torques identify_chain then fits at those cutoffs.
/// The fit is Gautier's weighted least squares (each joint's equations weighted by the inverse
/// of its residual variance in a first unweighted fit: the joints' torques differ by orders of
/// magnitude), with HAC standard deviations as identify_chain's.

#include <sid/base_parameters.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/identify_chain.hpp>
#include <sid/identify_runs.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief Options of identify_drive_gains.
struct DriveGainOptions {
  /// The skips, regression rate, rest rule, torque filtering, base tolerances and base samples
  /// (its cutoffs, estimator and statistics flags are not used: the cutoffs are an argument).
  ChainIdentifyOptions chain;
  /// A motor whose load torque (RMS over the loaded runs' window) is at most this fraction of
  /// the largest motor's is not reached by the load: its gain cannot be found.
  double reach_tolerance = 1e-6;
  /// Gautier's weighting of the joints (see the file comment); false: plain least squares.
  bool weighted = true;
  /// Filter the currents and every column of the regressor (the load's torque too) by each
  /// joint's smoother: then both sides of each equation are the same linear filter of what
  /// they were, so the fit is as exact as on the raw signals while the currents' noise above
  /// the cutoff leaves. Filtering the currents alone (identify_chain's parallel filtering)
  /// smears each Coulomb step that the model keeps sharp; unfiltered currents put their noise
  /// into the gains' columns (errors in variables): where the load barely reaches a joint (a
  /// vertical first axis) either biased its gain by 1-15 % in the simulated tests.
  bool parallel_filtering = true;
};

/// @brief What identify_drive_gains found.
struct DriveGainIdentification {
  Eigen::VectorXd gain;                  ///< K per motor [N m/A]
  Eigen::VectorXd std_dev;               ///< HAC (Newey–West, prewhitened, per run)
  Eigen::VectorXd std_dev_uncorrelated;  ///< the fit's own, for uncorrelated residuals
  Eigen::VectorXd cutoff_hz;             ///< the smoothing used, per joint
  /// Per motor, the RMS of the load's torque over the loaded runs' window [N m]: how strongly
  /// the load speaks to each gain.
  Eigen::VectorXd payload_torque_rms;
  Eigen::Index arm_parameters = 0;  ///< base parameters of the arm fitted alongside
  Eigen::Index equations = 0;
  /// The weighted fit: columns the arm's base parameters, then the gains.
  LeastSquaresResult<double> fit;
};

/// @brief Why a payload cannot be a real body, or an empty string if it can. Unlike
/// sid::link_inconsistency a point mass (zero inertia about its centre of mass) is a body here:
/// a load is often given so. The mass must be positive and finite, the inertia symmetric and
/// positive semidefinite with principal moments that satisfy the triangle inequality.
/// @param tolerance slack on the inertia tests, relative to the largest principal moment.
inline std::string payload_inconsistency(const LinkInertia<double>& payload,
                                         double tolerance = 1e-9) {
  if (!(std::isfinite(payload.mass) && payload.mass > 0.0))
    return "the mass must be finite and > 0 kg";
  if (!payload.com.allFinite() || !payload.inertia_com.allFinite())
    return "a centre-of-mass or inertia value is not finite";
  if ((payload.inertia_com - payload.inertia_com.transpose()).cwiseAbs().maxCoeff() >
      tolerance * payload.inertia_com.cwiseAbs().maxCoeff())
    return "the inertia is not symmetric";
  const Eigen::Vector3d moments =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(payload.inertia_com).eigenvalues();
  const double slack = tolerance * moments.cwiseAbs().maxCoeff();
  if (moments[0] < -slack)
    return "the inertia about the centre of mass is not positive semidefinite (principal "
           "moment " +
           std::to_string(moments[0]) + " kg m^2)";
  if (moments[2] > moments[0] + moments[1] + slack)
    return "the principal moments of inertia break the triangle inequality (each must be at "
           "most the sum of the other two)";
  return {};
}

/// @brief The torque a load of standard parameters phi fixed to the chain's tip link adds at
/// each joint, along the kinematics k: (Y_tip(q, q̇, q̈) phi) per sample (rows) and joint
/// (columns) [N m or N].
/// @throws std::invalid_argument if k does not have the model's joint count.
inline Eigen::MatrixXd payload_torque(const ChainModel& model, const ChainKinematics<double>& k,
                                      const LinkParameters<double>& phi) {
  const int n = model.joints();
  if (k.q.cols() != n || k.qd.cols() != n || k.qdd.cols() != n || k.qd.rows() != k.q.rows() ||
      k.qdd.rows() != k.q.rows())
    throw std::invalid_argument("sid::payload_torque: the kinematics do not have the model's " +
                                std::to_string(n) + " joints");
  const Eigen::Index tip = model.rigid_body_parameters() - kLinkParameters;
  Eigen::MatrixXd out(k.q.rows(), n);
  Eigen::MatrixXd y(n, model.parameters());
  Eigen::VectorXd q(n), qd(n), qdd(n);
  for (Eigen::Index i = 0; i < k.q.rows(); ++i) {
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    model.regressor(q, qd, qdd, y);
    out.row(i) = (y.middleCols<kLinkParameters>(tip) * phi).transpose();
  }
  return out;
}

/// @brief A joint-side run whose tau holds motor currents [A] with the joint torques
/// Gᵀ diag(gain) i instead [N m].
/// @throws std::invalid_argument if the run's or the gains' size is not the model's.
inline ChainTrajectory<double> torques_from_currents(const ChainModel& model,
                                                     ChainTrajectory<double> run,
                                                     const Eigen::VectorXd& gain) {
  const int n = model.joints();
  if (run.tau.cols() != n || gain.size() != n)
    throw std::invalid_argument("sid::torques_from_currents: needs " + std::to_string(n) +
                                " current columns and gains");
  run.tau = run.tau * gain.asDiagonal() * model.transmission().ratio();
  return run;
}

namespace detail {

/// The equations of one run for the gains: row r is joint joint[r] at the run's position at[r].
struct GainEquations {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
  std::vector<int> joint;
  std::vector<Eigen::Index> at;
  Eigen::Index positions = 0;
};

/// Samples at about options.regression_rate_hz inside the skips, as identify_chain takes them.
inline std::vector<Eigen::Index> gain_samples(const Eigen::VectorXd& t,
                                              const ChainIdentifyOptions& o) {
  const Eigen::Index n = t.size();
  const double period = (t[n - 1] - t[0]) / static_cast<double>(n - 1);
  const auto stride =
      static_cast<Eigen::Index>(std::max(1.0, std::round(1.0 / (period * o.regression_rate_hz))));
  std::vector<Eigen::Index> samples;
  for (Eigen::Index i = 0; i < n; i += stride)
    if (t[i] >= t[0] + o.skip && t[i] <= t[n - 1] - o.skip_end) samples.push_back(i);
  return samples;
}

inline void check_drive_gain_inputs(const ChainModel& model,
                                    const std::vector<ChainTrajectory<double>>& runs,
                                    const std::vector<bool>& loaded,
                                    const LinkInertia<double>& payload,
                                    const Eigen::VectorXd& cutoff_hz,
                                    const DriveGainOptions& options) {
  const std::string who = "sid::identify_drive_gains";
  const int n = model.joints();
  if (runs.size() != loaded.size())
    throw std::invalid_argument(who + ": one loaded flag per run is needed");
  if (std::find(loaded.begin(), loaded.end(), true) == loaded.end())
    throw std::invalid_argument(
        who +
        ": no run carries the payload; without its known torque the gains' scale is not "
        "identifiable");
  if (std::find(loaded.begin(), loaded.end(), false) == loaded.end())
    throw std::invalid_argument(
        who +
        ": every run carries the payload; a run without it is needed, else the payload "
        "merges with the tip link and the gains' scale is not identifiable");
  if (const std::string why = payload_inconsistency(payload); !why.empty())
    throw std::invalid_argument(who + ": the payload is not a real body: " + why);
  if (cutoff_hz.size() != n || !(cutoff_hz.array() > 0.0).all() || !cutoff_hz.allFinite())
    throw std::invalid_argument(who + ": needs one finite cutoff > 0 Hz per joint (" +
                                std::to_string(n) + ")");
  if (!(options.reach_tolerance >= 0.0 && options.reach_tolerance < 1.0))
    throw std::invalid_argument(who + ": reach_tolerance must be in [0, 1)");
}

/// What every run's equations share: the arm's base columns, the load and the transmission.
struct GainSetup {
  BaseParameters<double> structural;
  Eigen::Index b = 0;    ///< the arm's base parameters
  Eigen::Index tip = 0;  ///< the tip link's first column
  LinkParameters<double> phi;
  Eigen::MatrixXd ratio_inverse;
};

/// The load's torque on each motor, summed over the loaded runs' samples as squares.
struct GainReach {
  Eigen::VectorXd sum;
  double count = 0.0;
};

/// Per joint j, at every sample of the run: the base columns, the load's torque and the motors'
/// currents as they enter the joint's torque (ratio(m, j) i_m).
inline std::vector<Eigen::MatrixXd> gain_columns(const ChainModel& model, const GainSetup& setup,
                                                 const ChainTrajectory<double>& run,
                                                 const ChainKinematics<double>& k) {
  const int n = model.joints();
  const Eigen::Index b = setup.b, tip = setup.tip;
  const Eigen::MatrixXd& ratio = model.transmission().ratio();
  Eigen::MatrixXd y(n, model.parameters());
  Eigen::VectorXd q(n), qd(n), qdd(n);
  const Eigen::Index samples_all = run.size();
  std::vector<Eigen::MatrixXd> columns(static_cast<std::size_t>(n),
                                       Eigen::MatrixXd(samples_all, b + 1 + n));
  for (Eigen::Index i = 0; i < samples_all; ++i) {
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    model.regressor(q, qd, qdd, y);
    const Eigen::VectorXd load = y.middleCols<kLinkParameters>(tip) * setup.phi;
    for (int j = 0; j < n; ++j) {
      Eigen::MatrixXd& c = columns[static_cast<std::size_t>(j)];
      c.row(i).head(b) = y.row(j)(setup.structural.independent);
      c(i, b) = load[j];
      for (int m = 0; m < n; ++m) c(i, b + 1 + m) = ratio(m, j) * run.tau(i, m);
    }
  }
  return columns;
}

/// Each joint's columns through its smoother (DriveGainOptions::parallel_filtering).
inline void filter_gain_columns(const Eigen::VectorXd& t, const Eigen::VectorXd& cutoff_hz,
                                std::vector<Eigen::MatrixXd>& columns) {
  const auto n = static_cast<int>(columns.size());
  const Eigen::Index samples_all = t.size();
  const SmoothingSpline<double> spline(t);
  const double period = (t[samples_all - 1] - t[0]) / static_cast<double>(samples_all - 1);
  for (int j = 0; j < n; ++j) {
    const double p_j = 1.0 / smoothing_lambda_for_cutoff(cutoff_hz[j], period);
    Eigen::MatrixXd& c = columns[static_cast<std::size_t>(j)];
    for (Eigen::Index col = 0; col < c.cols(); ++col) {
      if (c.col(col).isZero(0.0)) continue;
      const auto fit = spline.fit_penalized(c.col(col), 1.0, p_j);
      fit.spline.derivatives_at_knots(0, c.col(col));
    }
  }
}

/// The rest rule of identify_chain: friction at rest is stiction, which no term describes.
inline Eigen::VectorXd gain_rest_levels(const ChainKinematics<double>& k,
                                        const std::vector<Eigen::Index>& samples,
                                        double rest_fraction) {
  const auto n = static_cast<int>(k.qd.cols());
  Eigen::VectorXd rest(n);
  for (int j = 0; j < n; ++j) {
    double sum = 0.0;
    for (const Eigen::Index i : samples) sum += k.qd(i, j) * k.qd(i, j);
    rest[j] = rest_fraction * std::sqrt(sum / static_cast<double>(samples.size()));
  }
  return rest;
}

/// The run's equations at the samples where a joint moves; a loaded run adds its load's torque
/// on each motor to reach.
inline GainEquations gain_run_equations(const std::vector<Eigen::MatrixXd>& columns,
                                        const ChainKinematics<double>& k,
                                        const std::vector<Eigen::Index>& samples,
                                        const Eigen::VectorXd& rest, bool loaded,
                                        const GainSetup& setup, GainReach& reach) {
  const auto n = static_cast<int>(columns.size());
  const Eigen::Index b = setup.b;
  GainEquations e;
  e.positions = static_cast<Eigen::Index>(samples.size());
  Eigen::Index rows = 0;
  for (const Eigen::Index i : samples)
    for (int j = 0; j < n; ++j)
      if (std::abs(k.qd(i, j)) >= rest[j]) ++rows;
  e.x.resize(rows, b + n);
  e.y.resize(rows);
  Eigen::Index row = 0;
  Eigen::VectorXd load(n);
  for (std::size_t a = 0; a < samples.size(); ++a) {
    const Eigen::Index i = samples[a];
    for (int j = 0; j < n; ++j) load[j] = columns[static_cast<std::size_t>(j)](i, b);
    if (loaded) {
      // The load's torque on each motor: joint torques are Gᵀ times the motors'.
      reach.sum += (setup.ratio_inverse.transpose() * load).cwiseAbs2();
      reach.count += 1.0;
    }
    for (int j = 0; j < n; ++j) {
      if (!(std::abs(k.qd(i, j)) >= rest[j])) continue;
      const Eigen::MatrixXd& c = columns[static_cast<std::size_t>(j)];
      e.x.row(row).head(b) = c.row(i).head(b);
      e.x.row(row).tail(n) = -c.row(i).tail(n);
      e.y[row] = loaded ? -load[j] : 0.0;
      e.joint.push_back(j);
      e.at.push_back(static_cast<Eigen::Index>(a));
      ++row;
    }
  }
  return e;
}

/// The equations of run r (0-based), `loaded` if it carries the payload.
inline GainEquations drive_gain_run_equations(const ChainModel& model, const GainSetup& setup,
                                              const ChainTrajectory<double>& run, std::size_t r,
                                              bool loaded, const Eigen::VectorXd& cutoff_hz,
                                              const DriveGainOptions& options, GainReach& reach) {
  const std::string who = "sid::identify_drive_gains";
  const int n = model.joints();
  const ChainIdentifyOptions& o = options.chain;
  const std::string run_who = who + ": run " + std::to_string(r + 1);
  if (run.joints() != n)
    throw std::invalid_argument(run_who + " has " + std::to_string(run.joints()) +
                                " joints, the model " + std::to_string(n));
  if (run.size() < 4) throw std::invalid_argument(run_who + " needs at least 4 samples");
  // Kinematics only: the currents are filtered below with the regressor.
  ChainIdentifyOptions smoothing = o;
  smoothing.filter_torque = false;
  const ChainKinematics<double> k = smooth_chain_run(run, cutoff_hz, smoothing);
  const std::vector<Eigen::Index> samples = gain_samples(run.t, o);
  if (samples.size() < 2)
    throw std::invalid_argument(run_who + " has too few samples left after the skips");
  std::vector<Eigen::MatrixXd> columns = gain_columns(model, setup, run, k);
  if (options.parallel_filtering) filter_gain_columns(run.t, cutoff_hz, columns);
  const Eigen::VectorXd rest = gain_rest_levels(k, samples, o.rest_fraction);
  return gain_run_equations(columns, k, samples, rest, loaded, setup, reach);
}

/// Refuses a motor whose load torque is at most reach_tolerance of the largest motor's.
inline void check_payload_reach(const ChainModel& model, const Eigen::VectorXd& payload_torque_rms,
                                double reach_tolerance) {
  const std::string who = "sid::identify_drive_gains";
  const int n = model.joints();
  const auto joint_name = [&](int j) { return model.joint_names()[static_cast<std::size_t>(j)]; };
  std::string unreached;
  const double largest = payload_torque_rms.maxCoeff();
  for (int m = 0; m < n; ++m)
    if (!(payload_torque_rms[m] > reach_tolerance * largest))
      unreached += (unreached.empty() ? "" : ", ") + joint_name(m);
  if (!unreached.empty())
    throw std::invalid_argument(
        who + ": the payload's torque does not reach " + unreached +
        " in the loaded run: the gain there cannot be found (its scale is free); move the "
        "payload's centre of mass off that axis, give it inertia about it, or move the joints "
        "that carry it");
}

/// Every run's equations, stacked in run order, with each row's joint.
struct GainRows {
  Eigen::MatrixXd x;
  Eigen::VectorXd rhs;
  std::vector<int> row_joint;
};

inline GainRows stacked_gain_equations(const std::vector<GainEquations>& equations,
                                       Eigen::Index m_rows, Eigen::Index columns) {
  GainRows out{Eigen::MatrixXd(m_rows, columns), Eigen::VectorXd(m_rows), {}};
  out.row_joint.reserve(static_cast<std::size_t>(m_rows));
  Eigen::Index at = 0;
  for (const auto& e : equations) {
    out.x.middleRows(at, e.y.size()) = e.x;
    out.rhs.segment(at, e.y.size()) = e.y;
    out.row_joint.insert(out.row_joint.end(), e.joint.begin(), e.joint.end());
    at += e.y.size();
  }
  return out;
}

/// What the runs determine, the arm's columns before the gains (base_parameters_in_order's
/// test: each unit-norm column's distance from those before it). An arm column they leave
/// undetermined is dropped, which regroups it; a gain's column that the others explain is a
/// gain these runs cannot find.
inline std::vector<Eigen::Index> determined_gain_columns(const ChainModel& model,
                                                         const Eigen::MatrixXd& x, Eigen::Index b,
                                                         double data_tolerance) {
  const std::string who = "sid::identify_drive_gains";
  const int n = model.joints();
  const auto joint_name = [&](int j) { return model.joint_names()[static_cast<std::size_t>(j)]; };
  std::vector<Eigen::Index> kept;
  Eigen::MatrixXd scaled = x;
  for (Eigen::Index c = 0; c < scaled.cols(); ++c) {
    const double norm = scaled.col(c).norm();
    if (norm > 0.0) scaled.col(c) /= norm;
  }
  const Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(scaled);
  std::string undetermined;
  for (Eigen::Index c = 0; c < b + n; ++c) {
    const bool independent = std::abs(qr.matrixQR()(c, c)) > data_tolerance;
    if (independent) kept.push_back(c);
    if (!independent && c >= b)
      undetermined += (undetermined.empty() ? "" : ", ") + joint_name(static_cast<int>(c - b));
  }
  if (!undetermined.empty())
    throw std::invalid_argument(who + ": the gains of " + undetermined +
                                " cannot be found: these runs do not tell them apart from the "
                                "arm's parameters (rank deficient)");
  return kept;
}

/// The fit and the weight of each row it used.
struct GainFit {
  LeastSquaresResult<double> fit;
  Eigen::VectorXd weight;
};

/// Least squares, then Gautier's weighting of the joints when asked (see the file comment).
inline GainFit weighted_gain_fit(const Eigen::MatrixXd& xk, const Eigen::VectorXd& rhs,
                                 const std::vector<int>& row_joint, int n,
                                 const DriveGainOptions& options) {
  const ChainIdentifyOptions& o = options.chain;
  const Eigen::Index m_rows = rhs.size();
  LeastSquaresResult<double> fit = least_squares(xk, rhs, 1, o.least_squares);
  Eigen::VectorXd weight = Eigen::VectorXd::Ones(m_rows);
  if (options.weighted && fit.ok()) {
    Eigen::VectorXd rss = Eigen::VectorXd::Zero(n), count = rss;
    for (Eigen::Index r = 0; r < m_rows; ++r) {
      const int j = row_joint[static_cast<std::size_t>(r)];
      rss[j] += fit.residual[r] * fit.residual[r];
      count[j] += 1.0;
    }
    for (Eigen::Index r = 0; r < m_rows; ++r) {
      const int j = row_joint[static_cast<std::size_t>(r)];
      weight[r] = 1.0 / std::max(rss[j] / std::max(count[j], 1.0), 1e-300);
    }
    fit = weighted_least_squares(xk, rhs, weight, 1, o.least_squares);
  }
  return {std::move(fit), std::move(weight)};
}

/// The gains' HAC standard deviations as identify_chain's: scores summed per sample position,
/// runs independent.
inline Eigen::VectorXd gain_hac_std_dev(const std::vector<GainEquations>& equations,
                                        const Eigen::MatrixXd& xk, const GainFit& g, int n) {
  const Eigen::VectorXd weighted_residual = g.weight.cwiseProduct(g.fit.residual);
  std::vector<HacRun> per_run;
  Eigen::Index offset = 0;
  for (const auto& e : equations) {
    per_run.push_back({xk.middleRows(offset, e.y.size()),
                       weighted_residual.segment(offset, e.y.size()), e.at, e.positions});
    offset += e.y.size();
  }
  return hac_sandwich(per_run, g.fit.inverse_gram()).diagonal().tail(n).cwiseMax(0.0).cwiseSqrt();
}

}  // namespace detail

/// @brief Identifies the motors' current-to-torque gains from runs whose tau columns are motor
/// currents [A] (angles joint-side), the runs marked `loaded` carrying `payload` on the chain's
/// tip link (its mass [kg], centre of mass [m] and inertia about it [kg m^2] in the tip link's
/// frame), together with the arm's base parameters (see the file comment).
/// @param cutoff_hz the smoothing per joint [Hz], as identify_chain's cutoff_hz.
/// @throws std::invalid_argument naming the problem: sizes, no loaded or no unloaded run, an
///         inconsistent payload, a run too short for the skips, too few equations, or gains the
///         runs cannot determine (a motor the load's torque does not reach, or a gain whose
///         column the others explain), named by their joints.
inline DriveGainIdentification identify_drive_gains(
    const ChainModel& model, const std::vector<ChainTrajectory<double>>& runs,
    const std::vector<bool>& loaded, const LinkInertia<double>& payload,
    const Eigen::VectorXd& cutoff_hz, const DriveGainOptions& options = {}) {
  const std::string who = "sid::identify_drive_gains";
  const int n = model.joints();
  const ChainIdentifyOptions& o = options.chain;
  detail::check_drive_gain_inputs(model, runs, loaded, payload, cutoff_hz, options);

  detail::GainSetup setup;
  setup.structural = chain_base_parameters(model, o);
  setup.b = setup.structural.rank();
  setup.tip = model.rigid_body_parameters() - kLinkParameters;
  setup.phi = standard_parameters(payload);
  setup.ratio_inverse = model.transmission().ratio().inverse();
  const Eigen::Index b = setup.b;

  DriveGainIdentification result;
  result.cutoff_hz = cutoff_hz;
  std::vector<detail::GainEquations> equations;
  detail::GainReach reach{Eigen::VectorXd::Zero(n), 0.0};
  for (std::size_t r = 0; r < runs.size(); ++r)
    equations.push_back(detail::drive_gain_run_equations(model, setup, runs[r], r, loaded[r],
                                                         cutoff_hz, options, reach));
  result.payload_torque_rms = (reach.sum / std::max(reach.count, 1.0)).cwiseSqrt();
  detail::check_payload_reach(model, result.payload_torque_rms, options.reach_tolerance);

  Eigen::Index m_rows = 0;
  for (const auto& e : equations) m_rows += e.y.size();
  if (m_rows <= b + n)
    throw std::invalid_argument(who + ": " + std::to_string(m_rows) + " equations for " +
                                std::to_string(b + n) + " parameters; give longer or more runs");
  detail::GainRows rows = detail::stacked_gain_equations(equations, m_rows, b + n);
  const std::vector<Eigen::Index> kept =
      detail::determined_gain_columns(model, rows.x, b, o.data_tolerance);
  result.arm_parameters = static_cast<Eigen::Index>(kept.size()) - n;
  result.equations = m_rows;
  const Eigen::MatrixXd xk = rows.x(Eigen::all, kept);
  rows.x.resize(0, 0);

  detail::GainFit g = detail::weighted_gain_fit(xk, rows.rhs, rows.row_joint, n, options);
  if (!g.fit.ok())
    throw std::invalid_argument(who + ": the fit of the gains failed: " + g.fit.message);
  result.gain = g.fit.theta.tail(n);
  result.std_dev_uncorrelated = g.fit.std_dev.tail(n);
  result.std_dev = detail::gain_hac_std_dev(equations, xk, g, n);
  result.fit = std::move(g.fit);
  return result;
}

}  // namespace sid
