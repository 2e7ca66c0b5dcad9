#pragma once
/// @file
/// @brief Identification of a payload fixed to a chain's tip link with the arm held at an
/// earlier identification: the ten standard parameters of the load, a real body, with standard
/// deviations of its mass, centre of mass and inertia that hold for residuals correlated in time.
///
/// A body fixed to the tip link adds its standard parameters to the tip link's ten (they are
/// linear in the mass distribution), so with the arm's parameters θ_arm held,
///   τ − Y(q, q̇, q̈) θ_arm = Y_tip(q, q̇, q̈) φ_payload,
/// Y_tip the tip link's ten columns of the chain regressor. The rows are the identification's
/// (sid::identify_chain): the run smoothed at the arm's cutoffs with its torque through the same
/// smoother, equations at most at regression_rate_hz, the skips at both ends, and a joint's
/// equation left out while the joint is nearly at rest. Taking the arm's rows matters: its
/// parameters fit the torque as that smoothing and rest rule see it, and a payload fitted on
/// other rows would absorb the difference.
///
/// The ten columns must be independent on the run's rows (sid::base_parameters_in_order with the
/// identification's data_tolerance), and each must be determined to within a fraction of its
/// natural scale (PayloadOptions::max_relative_std): a motion that does not rotate the tip about
/// enough axes leaves some inertia combinations, or the centre of mass along gravity,
/// undetermined, and the fit refuses (PayloadNotIdentifiable names them) instead of inventing
/// them. Mass and centre of mass are not given alone then: the missing columns regroup onto the
/// others, the mass and first moments among them, and would bias them unseen.
///
/// When the least-squares estimate is not a real body (noise on a small or nearly flat load), the
/// reported one is the nearest real body in the least-squares metric, ‖X (φ − φ̂)‖² over the
/// pseudo-inertia's positive definite cone (Wensing, Kim & Slotine 2018), found by an interior
/// point (Newton on t ‖X (φ − φ̂)‖² − log det J(φ), t growing tenfold), which starts strictly
/// inside from the log-Cholesky projection of sid/chain_consistency.hpp.
///
/// The load is identified in the tip link's frame and reported in PayloadOptions::frame (a tool
/// flange fixed to the tip link) by the exact change of frame, linear in φ
/// (sid::expressed_in_parent): φ_frame = A φ_tip, covariances A C Aᵀ. Identifying in the flange's
/// frame instead (columns Y_tip A⁻¹) gives the same φ but not the same std: the HAC estimate
/// (prewhitening, bandwidth) is not equivariant under a change of the columns, and moved them by
/// up to 2 % on the UR5's tool0, so one body would have two uncertainties.

#include <sid/base_parameters.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/chain_regression.hpp>
#include <sid/diagnosis/hac.hpp>
#include <sid/identify_chain.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Cholesky>
#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief The names of a link's ten standard parameters, in sid::standard_parameters' order.
inline const std::array<std::string, 10>& payload_parameter_names() {
  static const std::array<std::string, 10> names = {"m",   "mx",  "my",  "mz",  "Ixx",
                                                    "Ixy", "Iyy", "Ixz", "Iyz", "Izz"};
  return names;
}

/// @brief Thrown when the run's motion does not determine every one of the ten parameters.
/// parameters() names those that regroup onto the others (standard-parameter names: m, mx, ...).
class PayloadNotIdentifiable : public std::invalid_argument {
 public:
  PayloadNotIdentifiable(const std::string& message, std::vector<std::string> parameters)
      : std::invalid_argument(message), parameters_(std::move(parameters)) {}
  const std::vector<std::string>& parameters() const noexcept { return parameters_; }

 private:
  std::vector<std::string> parameters_;
};

/// @brief Options of identify_payload.
struct PayloadOptions {
  /// The rows as the arm's identification takes them: skip, skip_end, regression_rate_hz,
  /// rest_fraction, filter_torque, and data_tolerance as the rank rule (cutoffs: the argument).
  ChainIdentifyOptions rows;
  /// A parameter counts as shown by the motion when its standard deviation (HAC, the parameters
  /// before it in the standard order estimated with it, those after it held) is at most this
  /// fraction of its natural scale: the load's mass m̂ for the mass, m̂ L for a first moment,
  /// m̂ L² for an inertia, L = length_scale. Why: a joint held still still moves by its angle
  /// noise, and the smoothed noise makes the columns it alone would excite independent in
  /// exact arithmetic, so the rank rule alone passes a motion that shows nothing.
  double max_relative_std = 0.5;
  double length_scale = 0.1;  ///< L [m], the size of a typical load
  /// The consistent estimate's RSS is within this fraction of the least-squares RSS of the
  /// optimum over real bodies.
  double tolerance = 1e-7;
  int max_iterations = 500;  ///< Newton steps of the interior point in all
  /// The frame the load is reported in, as its pose in the frame of the model's last link: a tool
  /// flange fixed to that link (a URDF's tool0), where vendors give a load's centre of mass.
  /// Identity: the last link's own frame. Every figure of PayloadIdentification is in this frame;
  /// the parameters PayloadNotIdentifiable names are the last link's (where the motion is judged).
  FramePose<double> frame;
};

/// @brief What identify_payload found, in the frame of PayloadOptions::frame (the tip link's by
/// default). Inertias are about the centre of mass in that frame's axes, ordered ixx, iyy, izz,
/// ixy, ixz, iyz.
struct PayloadIdentification {
  LinkParameters<double> phi;            ///< the reported estimate: a real body
  LinkParameters<double> least_squares;  ///< the least-squares estimate
  /// The least-squares estimate was not a real body (least_squares_inconsistency says why) and
  /// phi is the nearest real one.
  bool projected = false;
  std::string least_squares_inconsistency;
  bool converged = true;  ///< the projection reached its tolerance (true when not projected)
  int iterations = 0;     ///< Newton steps of the projection
  /// (φ − φ̂)ᵀ C⁻¹ (φ − φ̂): the projection's move in the estimate's own (HAC) uncertainty, about
  /// χ² with at most 10 degrees of freedom when the load is a real body plus noise.
  double projection_misfit = 0.0;
  /// HAC covariance of the ten (Newey–West with prewhitening per run, runs independent).
  Eigen::Matrix<double, 10, 10> covariance;
  /// The same for the uncorrelated-residual formula σ² (XᵀX)⁻¹, for comparison.
  Eigen::Matrix<double, 10, 10> covariance_uncorrelated;
  LinkInertia<double> body;  ///< phi as mass, centre of mass [m] and inertia about it
  double mass_std = 0.0;     ///< [kg]
  Vector3<double> com_std = Vector3<double>::Zero();                              ///< [m]
  Eigen::Matrix<double, 6, 1> inertia_std = Eigen::Matrix<double, 6, 1>::Zero();  ///< [kg m²]
  /// ‖τ − Y θ_arm‖ / ‖τ‖ over the rows (the load ignored), and with the load's columns: at the
  /// least-squares and at the reported estimate.
  double relative_residual_before = 0.0;
  double relative_residual_after = 0.0;
  double relative_residual_least_squares = 0.0;
  double condition_number = 0.0;  ///< of the ten column-scaled columns
  Eigen::Index equations = 0;
};

namespace detail {

/// v with three significant digits, for messages.
inline std::string payload_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", v);
  return buffer;
}

/// The inertia about the centre of mass as [ixx, iyy, izz, ixy, ixz, iyz].
inline Eigen::Matrix<double, 6, 1> inertia_six(const Matrix3<double>& i) {
  Eigen::Matrix<double, 6, 1> v;
  v << i(0, 0), i(1, 1), i(2, 2), i(0, 1), i(0, 2), i(1, 2);
  return v;
}

/// d[m, c, ixx, iyy, izz, ixy, ixz, iyz] / dφ at φ (mass > 0): c = h / m and
/// I_c = I_o − (|h|² 1 − h hᵀ) / m, h the first moments.
inline Eigen::Matrix<double, 10, 10> body_jacobian(const LinkParameters<double>& phi) {
  const double m = phi[0];
  const Vector3<double> h = phi.segment<3>(1);
  Eigen::Matrix<double, 10, 10> g = Eigen::Matrix<double, 10, 10>::Zero();
  g(0, 0) = 1.0;
  for (int a = 0; a < 3; ++a) {
    g(1 + a, 0) = -h[a] / (m * m);
    g(1 + a, 1 + a) = 1.0 / m;
  }
  // Rows 4..9 in inertia_six's order; (a, b) the entry, param its standard parameter's index.
  const int entry[6][3] = {{0, 0, 4}, {1, 1, 6}, {2, 2, 9}, {0, 1, 5}, {0, 2, 7}, {1, 2, 8}};
  const Matrix3<double> d = h.squaredNorm() * Matrix3<double>::Identity() - h * h.transpose();
  for (int r = 0; r < 6; ++r) {
    const int a = entry[r][0], b = entry[r][1];
    g(4 + r, entry[r][2]) = 1.0;
    g(4 + r, 0) = d(a, b) / (m * m);
    for (int k = 0; k < 3; ++k) {
      const double dd = (a == b ? 2.0 * h[k] : 0.0) - (a == k ? h[b] : 0.0) - (b == k ? h[a] : 0.0);
      g(4 + r, 1 + k) = -dd / m;
    }
  }
  return g;
}

}  // namespace detail

/// @brief The real body nearest to phi_hat in the metric ‖a (φ − phi_hat)‖² (a: 10 columns, e.g.
/// the triangular factor of the fit's regressor, so that the metric is the growth of its residual
/// sum of squares): the interior point of the file comment, to within tolerance · scale of the
/// optimum's cost.
/// @param[out] iterations Newton steps taken; @param[out] converged tolerance reached within
///        max_iterations (else the last iterate, a real body all the same).
/// @throws std::invalid_argument if a has not 10 columns, or a, phi_hat or scale is not finite.
inline LinkParameters<double> nearest_real_body(const LinkParameters<double>& phi_hat,
                                                const Eigen::Ref<const Eigen::MatrixXd>& a,
                                                double scale, double tolerance, int max_iterations,
                                                int& iterations, bool& converged) {
  if (a.cols() != 10 || !a.allFinite() || !phi_hat.allFinite() || !std::isfinite(scale))
    throw std::invalid_argument(
        "sid::nearest_real_body: needs a finite metric of 10 columns and a finite estimate");
  const Eigen::Matrix<double, 10, 10> ata = a.transpose() * a;
  std::array<Eigen::Matrix4d, 10> basis;
  for (int c = 0; c < 10; ++c)
    basis[static_cast<std::size_t>(c)] =
        pseudo_inertia(LinkParameters<double>(LinkParameters<double>::Unit(c)));
  const auto cost = [&](const LinkParameters<double>& p) {
    const LinkParameters<double> d = p - phi_hat;
    return d.dot(ata * d);
  };
  // −log det J, with its gradient and Hessian when asked; +∞ outside the cone.
  const auto barrier = [&](const LinkParameters<double>& p, LinkParameters<double>* g,
                           Eigen::Matrix<double, 10, 10>* h) {
    const Eigen::LLT<Eigen::Matrix4d> llt(pseudo_inertia(p));
    if (llt.info() != Eigen::Success || !(llt.matrixLLT().diagonal().minCoeff() > 0.0))
      return std::numeric_limits<double>::infinity();
    if (g) {
      const Eigen::Matrix4d inverse = llt.solve(Eigen::Matrix4d::Identity());
      std::array<Eigen::Matrix4d, 10> ie;
      for (std::size_t c = 0; c < 10; ++c) ie[c] = inverse * basis[c];
      for (std::size_t c = 0; c < 10; ++c) {
        (*g)[static_cast<int>(c)] -= ie[c].trace();
        for (std::size_t e = 0; e < 10; ++e)
          (*h)(static_cast<int>(c), static_cast<int>(e)) += (ie[c] * ie[e]).trace();
      }
    }
    return -2.0 * llt.matrixLLT().diagonal().array().log().sum();
  };
  LinkParameters<double> p =
      link_parameters_from_log_cholesky(log_cholesky_from_link_parameters(phi_hat));
  const double floor = std::max(scale, 1e-300);
  double t = 4.0 / std::max(cost(p), 1e-12 * floor);
  iterations = 0;
  converged = false;
  while (iterations < max_iterations) {
    // Newton on t cost + barrier to t's centre (a decrement of 1e-8 of the barrier's size, 4).
    bool centred = false;
    for (; iterations < max_iterations && !centred; ++iterations) {
      LinkParameters<double> g = 2.0 * t * (ata * (p - phi_hat));
      Eigen::Matrix<double, 10, 10> h = 2.0 * t * ata;
      const double value = t * cost(p) + barrier(p, &g, &h);
      const LinkParameters<double> step = h.ldlt().solve(-g);
      const double decrement = -g.dot(step);
      if (!(decrement > 4e-8) ||
          !(decrement > 64.0 * std::numeric_limits<double>::epsilon() * std::abs(value))) {
        centred = true;
        break;
      }
      double length = 1.0;
      bool descended = false;
      for (int halving = 0; halving < 60 && !descended; ++halving) {
        const LinkParameters<double> trial = p + length * step;
        const double b = barrier(trial, nullptr, nullptr);
        descended = std::isfinite(b) && t * cost(trial) + b <= value - 0.25 * length * decrement;
        if (!descended) length *= 0.5;
      }
      if (!descended) {
        centred = true;  // round-off: no step descends any more, t's centre is here
        break;
      }
      p += length * step;
    }
    if (!centred) break;
    // The centre at t is within 4 / t (the barrier's size over t) of the optimum's cost.
    if (4.0 / t <= tolerance * floor) {
      converged = true;
      break;
    }
    t *= 10.0;
  }
  return p;
}

namespace detail {

inline void check_payload_inputs(const ChainModel& model, const Eigen::VectorXd& arm_theta,
                                 const std::vector<ChainTrajectory<double>>& runs,
                                 const Eigen::VectorXd& cutoff_hz, const PayloadOptions& options) {
  const std::string who = "sid::identify_payload: ";
  const int n = model.joints();
  const Eigen::Index p = model.parameters();
  const ChainIdentifyOptions& o = options.rows;
  if (runs.empty()) throw std::invalid_argument(who + "no run given");
  if (arm_theta.size() != p || !arm_theta.allFinite())
    throw std::invalid_argument(who + "the arm has " + std::to_string(arm_theta.size()) +
                                " parameters or one that is not finite; the model has " +
                                std::to_string(p));
  if (cutoff_hz.size() != n || !(cutoff_hz.array() > 0.0).all() || !cutoff_hz.allFinite())
    throw std::invalid_argument(who + "needs one finite cutoff > 0 per joint (" +
                                std::to_string(n) + ")");
  if (!(o.skip >= 0.0) || !(o.skip_end >= 0.0) || !(o.regression_rate_hz > 0.0) ||
      !(o.rest_fraction >= 0.0 && o.rest_fraction < 1.0) ||
      !(o.data_tolerance > 0.0 && o.data_tolerance < 1.0) || !(options.tolerance > 0.0) ||
      options.max_iterations < 1 || !(options.max_relative_std > 0.0) ||
      !(options.length_scale > 0.0))
    throw std::invalid_argument(who +
                                "invalid options (skips >= 0, rate > 0, rest_fraction in [0, 1), "
                                "data_tolerance in (0, 1), tolerance, max_relative_std and "
                                "length_scale > 0, max_iterations >= 1)");
  constexpr double kRotationTolerance = 1e-9;
  const Matrix3<double>& frame_rotation = options.frame.rotation;
  if (!frame_rotation.allFinite() || !options.frame.translation.allFinite() ||
      !(frame_rotation.transpose() * frame_rotation)
           .isApprox(Matrix3<double>::Identity(), kRotationTolerance) ||
      !(frame_rotation.determinant() > 0.0))
    throw std::invalid_argument(who +
                                "options.frame is not a rigid pose (a finite translation "
                                "and a rotation matrix)");
}

/// One run's rows: their positions (sample index, joint) and their regression.
struct PayloadRunRows {
  Eigen::MatrixXd x;             // tip columns
  Eigen::VectorXd y, tau;        // τ − Y θ_arm, and τ (filtered)
  std::vector<Eigen::Index> at;  // the row's sample position in the run
  Eigen::Index positions = 0;
};

/// The rows of run r (0-based) as identify_chain takes them.
inline PayloadRunRows payload_run_rows(const ChainModel& model, const Eigen::VectorXd& arm_theta,
                                       const ChainTrajectory<double>& run, std::size_t r,
                                       const Eigen::VectorXd& cutoff_hz,
                                       const ChainIdentifyOptions& o) {
  const std::string who = "sid::identify_payload: ";
  const int n = model.joints();
  const Eigen::Index p = model.parameters(), tip = 10 * static_cast<Eigen::Index>(n - 1);
  const std::string where = who + "run " + std::to_string(r + 1) + ": ";
  run.validate(("sid::identify_payload: run " + std::to_string(r + 1)).c_str());
  if (run.joints() != n)
    throw std::invalid_argument(where + "has " + std::to_string(run.joints()) +
                                " joints, the model " + std::to_string(n));
  if (run.size() < 4) throw std::invalid_argument(where + "needs at least 4 samples");
  const ChainKinematics<double> k = smooth_chain_run(run, cutoff_hz, o);
  // The samples identify_chain takes: every stride-th, within the skips.
  const Eigen::Index size = run.size();
  std::vector<Eigen::Index> samples;
  for (const Eigen::Index i : chain_regression_samples(run.t, o.regression_rate_hz))
    if (run.t[i] >= run.t[0] + o.skip && run.t[i] <= run.t[size - 1] - o.skip_end)
      samples.push_back(i);
  if (samples.empty()) throw std::invalid_argument(where + "has no samples after the skips");
  Eigen::VectorXd rest(n);
  for (int j = 0; j < n; ++j) {
    double sum = 0.0;
    for (const Eigen::Index i : samples) sum += k.qd(i, j) * k.qd(i, j);
    rest[j] = o.rest_fraction * std::sqrt(sum / static_cast<double>(samples.size()));
  }
  PayloadRunRows e;
  e.positions = static_cast<Eigen::Index>(samples.size());
  e.x.resize(e.positions * n, 10);
  e.y.resize(e.positions * n);
  e.tau.resize(e.positions * n);
  Eigen::MatrixXd y(n, p);
  Eigen::VectorXd q(n), qd(n), qdd(n);
  Eigen::Index m = 0;
  for (Eigen::Index a = 0; a < e.positions; ++a) {
    const Eigen::Index i = samples[static_cast<std::size_t>(a)];
    q = k.q.row(i).transpose();
    qd = k.qd.row(i).transpose();
    qdd = k.qdd.row(i).transpose();
    model.regressor(q, qd, qdd, y);
    for (int j = 0; j < n; ++j) {
      if (!(std::abs(qd[j]) >= rest[j])) continue;
      e.x.row(m) = y.row(j).segment<10>(tip);
      e.tau[m] = k.tau(i, j);
      e.y[m] = k.tau(i, j) - y.row(j).dot(arm_theta);
      e.at.push_back(a);
      ++m;
    }
  }
  e.x.conservativeResize(m, 10);
  e.y.conservativeResize(m);
  e.tau.conservativeResize(m);
  return e;
}

/// Every run's rows, stacked in run order.
struct PayloadRows {
  Eigen::MatrixXd x;
  Eigen::VectorXd y, tau;
};

inline PayloadRows stacked_payload_rows(const std::vector<PayloadRunRows>& rows,
                                        Eigen::Index total) {
  PayloadRows out{Eigen::MatrixXd(total, 10), Eigen::VectorXd(total), Eigen::VectorXd(total)};
  Eigen::Index at = 0;
  for (const auto& e : rows) {
    out.x.middleRows(at, e.y.size()) = e.x;
    out.y.segment(at, e.y.size()) = e.y;
    out.tau.segment(at, e.y.size()) = e.tau;
    at += e.y.size();
  }
  return out;
}

/// Refuses columns the rows leave dependent: the identification's own rule for what the data
/// determine (data_tolerance on unit columns).
inline void check_payload_rank(const Eigen::MatrixXd& x, double data_tolerance,
                               Eigen::Index total) {
  const std::string who = "sid::identify_payload: ";
  const BaseParameters<double> base = base_parameters_in_order(x, data_tolerance);
  if (base.rank() < 10) {
    std::vector<std::string> missing;
    std::string list;
    for (const Eigen::Index c : base.dependent) {
      missing.push_back(payload_parameter_names()[static_cast<std::size_t>(c)]);
      list += (list.empty() ? "" : ", ") + missing.back();
    }
    throw PayloadNotIdentifiable(
        who + "the motion does not determine the load's " + list + " (rank " +
            std::to_string(base.rank()) + " of 10 over " + std::to_string(total) +
            " equations): they act on the torques only together with the others; move the tip "
            "about more axes (the wrist joints) and faster",
        std::move(missing));
  }
}

/// HAC: each sample's score summed over its joints (their residuals are correlated too), the
/// long-run sum per run, runs independent; the sandwich around (XᵀX)⁻¹, made symmetric.
inline Eigen::Matrix<double, 10, 10> payload_hac_covariance(const std::vector<PayloadRunRows>& rows,
                                                            const LeastSquaresResult<double>& fit) {
  Eigen::Matrix<double, 10, 10> covariance;
  {
    std::vector<HacRun> per_run;
    Eigen::Index offset = 0;
    for (const auto& e : rows) {
      per_run.push_back({e.x, fit.residual.segment(offset, e.y.size()), e.at, e.positions});
      offset += e.y.size();
    }
    covariance = hac_sandwich(per_run, fit.inverse_gram());
  }
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  return covariance;
}

/// Refuses parameters the motion does not show: those whose standard deviation exceeds
/// options.max_relative_std of their natural scale (PayloadOptions::max_relative_std).
inline void check_payload_determined(const Eigen::MatrixXd& x,
                                     const LeastSquaresResult<double>& fit,
                                     const Eigen::Matrix<double, 10, 10>& covariance,
                                     const PayloadOptions& options) {
  const std::string who = "sid::identify_payload: ";
  // The noise as the HAC covariance sees it: the fit's σ inflated by the residuals'
  // correlation in time (the mean variance ratio, as sid::consistent_chain_parameters' κ).
  double inflation = 0.0;
  for (int c = 0; c < 10; ++c)
    inflation += covariance(c, c) / std::max(fit.covariance(c, c), 1e-300) / 10.0;
  const double sigma = std::sqrt(fit.sigma2 * std::max(inflation, 1.0));
  const double mass = std::max(std::abs(fit.theta[0]), 1e-6), l = options.length_scale;
  Eigen::Matrix<double, 10, 1> scale;
  scale << mass, Eigen::Vector3d::Constant(mass * l),
      Eigen::Matrix<double, 6, 1>::Constant(mass * l * l);
  // Gram–Schmidt in the standard order on the columns in natural units: σ over a column's
  // distance from the kept ones before it is its standard deviation in its own scale.
  Eigen::MatrixXd kept(x.rows(), 10);
  int count = 0;
  std::vector<std::string> missing;
  std::string list;
  for (int c = 0; c < 10; ++c) {
    Eigen::VectorXd v = x.col(c) * scale[c];
    for (int k = 0; k < count; ++k) v -= kept.col(k).dot(v) * kept.col(k);
    for (int k = 0; k < count; ++k) v -= kept.col(k).dot(v) * kept.col(k);  // re-orthogonalise
    const double distance = v.norm();
    if (sigma < options.max_relative_std * distance) {
      kept.col(count++) = v / distance;
      continue;
    }
    missing.push_back(payload_parameter_names()[static_cast<std::size_t>(c)]);
    list += (list.empty() ? "" : ", ") + missing.back() + " (std " +
            payload_number(distance > 0.0 ? sigma / distance : HUGE_VAL) + ")";
  }
  if (!missing.empty())
    throw PayloadNotIdentifiable(
        who + "the motion does not determine the load's " + list +
            ": their standard deviations, in units of the load's mass and of it times " +
            payload_number(l) + " m and its square, exceed " +
            payload_number(options.max_relative_std) +
            "; move the tip about more axes (the wrist joints) and faster",
        std::move(missing));
}

/// Moves out's estimates and covariances from the tip link's frame into `frame`, and gives the
/// body and its standard deviations there.
inline void express_payload_in_frame(PayloadIdentification& out, const FramePose<double>& frame) {
  // The report's frame: A is linear, so its columns are the unit loads moved there.
  const FramePose<double> tip_in_frame = inverse_pose(frame);
  Eigen::Matrix<double, 10, 10> to_frame;
  for (int c = 0; c < 10; ++c)
    to_frame.col(c) =
        expressed_in_parent(LinkParameters<double>(LinkParameters<double>::Unit(c)), tip_in_frame);
  out.phi = to_frame * out.phi;
  out.least_squares = to_frame * out.least_squares;
  out.covariance = to_frame * out.covariance * to_frame.transpose();
  out.covariance_uncorrelated = to_frame * out.covariance_uncorrelated * to_frame.transpose();
  out.body = link_inertia(out.phi);
  const Eigen::Matrix<double, 10, 10> g = body_jacobian(out.phi);
  const Eigen::Matrix<double, 10, 1> variance =
      (g * out.covariance * g.transpose()).diagonal().cwiseMax(0.0);
  out.mass_std = std::sqrt(variance[0]);
  out.com_std = variance.segment<3>(1).cwiseSqrt();
  out.inertia_std = variance.tail<6>().cwiseSqrt();
}

}  // namespace detail

/// @brief Identifies the ten standard parameters of a load fixed to model's tip link from runs
/// that carry it, the arm held at arm_theta (every parameter of model: the load-free arm, a
/// physically consistent fit), smoothed at cutoff_hz (the arm fit's, one per joint). See the
/// file comment.
/// @throws PayloadNotIdentifiable if the runs' rows do not determine every parameter;
///         std::invalid_argument on an empty run list, a run that is invalid, of another joint
///         count or without equations after the skips, arm_theta or cutoff_hz of the wrong size,
///         or invalid options.
inline PayloadIdentification identify_payload(const ChainModel& model,
                                              const Eigen::VectorXd& arm_theta,
                                              const std::vector<ChainTrajectory<double>>& runs,
                                              const Eigen::VectorXd& cutoff_hz,
                                              const PayloadOptions& options = {}) {
  const std::string who = "sid::identify_payload: ";
  const ChainIdentifyOptions& o = options.rows;
  detail::check_payload_inputs(model, arm_theta, runs, cutoff_hz, options);

  std::vector<detail::PayloadRunRows> rows;
  Eigen::Index total = 0;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    rows.push_back(detail::payload_run_rows(model, arm_theta, runs[r], r, cutoff_hz, o));
    total += rows.back().y.size();
  }
  if (total <= 10)
    throw std::invalid_argument(who + std::to_string(total) +
                                " equations for 10 parameters; give a longer run");
  const detail::PayloadRows stacked = detail::stacked_payload_rows(rows, total);
  const Eigen::MatrixXd& x = stacked.x;
  const Eigen::VectorXd &y = stacked.y, &tau = stacked.tau;

  detail::check_payload_rank(x, o.data_tolerance, total);
  LeastSquaresOptions ls;
  ls.column_names.assign(payload_parameter_names().begin(), payload_parameter_names().end());
  const LeastSquaresResult<double> fit = least_squares(x, y, 1, ls);
  if (!fit.ok())
    throw PayloadNotIdentifiable(
        who + "the load's columns are numerically dependent: " + fit.message, {});

  PayloadIdentification out;
  out.equations = total;
  out.condition_number = fit.condition_number;
  out.least_squares = fit.theta;
  out.covariance_uncorrelated = fit.covariance;
  out.covariance = detail::payload_hac_covariance(rows, fit);
  detail::check_payload_determined(x, fit, out.covariance, options);

  const double yy = std::max(tau.squaredNorm(), 1e-300);
  const double rss = fit.residual.squaredNorm();
  out.relative_residual_before = std::sqrt(y.squaredNorm() / yy);
  out.relative_residual_least_squares = std::sqrt(rss / yy);
  out.phi = fit.theta;
  out.least_squares_inconsistency = link_inconsistency(out.least_squares);
  if (!out.least_squares_inconsistency.empty()) {
    out.projected = true;
    const Eigen::MatrixXd a = fit.r * fit.column_scale.asDiagonal();
    out.phi = nearest_real_body(out.least_squares, a, rss, options.tolerance,
                                options.max_iterations, out.iterations, out.converged);
    const LinkParameters<double> d = out.phi - out.least_squares;
    const Eigen::LDLT<Eigen::Matrix<double, 10, 10>> c(out.covariance);
    out.projection_misfit = d.dot(c.solve(d));
  }
  out.relative_residual_after = std::sqrt((y - x * out.phi).squaredNorm() / yy);
  detail::express_payload_in_frame(out, options.frame);
  return out;
}

}  // namespace sid
