#pragma once
/// @file
/// @brief Excitation design for a serial chain: the coefficients of a Fourier trajectory
/// (sid::FourierTrajectory) that make the base regressor well conditioned, within position,
/// velocity, acceleration and torque limits, starting and ending at rest.
///
/// This header alone needs NLopt (`<nlopt.h>`, its C API; CMake `find_package(NLopt)` and
/// `NLopt::nlopt`), so sid/sid.hpp leaves it out: the rest of sid stays Eigen-only.
///
/// The objective. W_b stacks the base regressor (the model's columns `columns`, usually
/// chain_base_parameters(model).independent) over one period of the trajectory; W_s is W_b with
/// unit-norm columns (the matrix whose condition number sid::identify_chain reports: scaling
/// makes it independent of the parameters' units). With lambda_i the eigenvalues of
/// G_s = W_s^T W_s (p of them), the design minimizes
///   f_k = (1 / 2k) log( mean_i lambda_i^k  mean_i lambda_i^-k ),
/// a smooth stand-in for log cond(W_s) = (1/2) log(lambda_max / lambda_min):
/// log cond - (log p) / k <= f_k <= log cond, and f_k -> log cond as k grows.
/// Why not cond itself: it is the ratio of the extreme singular values only, not differentiable
/// where they cross, and the smallest moves from one combination of parameters to another as
/// the optimizer improves it, which stalls a gradient method; f_k weighs every small singular
/// value. k = 1 gives half the log of the mean variance inflation factor (tr G_s^-1 / p: how much
/// the base parameters' variances grow because their columns are nearly combinations of each
/// other); k = 4, the default, follows cond closely enough that the designed cond is what is
/// minimized. Why not log det G (D-optimality): it rewards amplitude and the columns with large
/// units, and is satisfied by an excitation that leaves one combination almost undetermined.
/// The limits, aggregated per joint and quantity over the grid (Kreisselmeier-Steinhauser: a
/// smooth upper bound of the largest value), are NLopt inequality constraints; rest at the start
/// and the end is imposed exactly by eliminating the first harmonic (see
/// fourier_trajectory_at_rest). The gradient is analytic in W_b (derivatives of the eigenvalues)
/// and takes the regressor's derivatives in q and qd by central differences and in qdd by one
/// exact difference (the regressor is affine in qdd).

#include <sid/fourier_trajectory.hpp>
#include <sid/model/chain_model.hpp>

#include <nlopt.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <exception>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief The limits an excitation stays within, one entry per joint. Class invariant (checked
/// by design_excitation and random_excitation): every entry > 0; q_range, qd_max and qdd_max
/// finite; tau_max may be +infinity (no torque limit on that joint).
struct ExcitationLimits {
  Eigen::VectorXd q_range;  ///< largest |q_j - q0_j| [rad or m]
  Eigen::VectorXd qd_max;   ///< largest |qd_j| [rad/s or m/s]
  Eigen::VectorXd qdd_max;  ///< largest |qdd_j| [rad/s^2 or m/s^2]
  Eigen::VectorXd tau_max;  ///< largest |tau_j| of the inverse dynamics [N m or N]
};

/// @brief The optimizer NLopt runs.
enum class ExcitationAlgorithm {
  Slsqp,  ///< sequential quadratic programming (NLOPT_LD_SLSQP): few evaluations
  Mma,    ///< method of moving asymptotes (NLOPT_LD_MMA): iterates stay feasible
};

/// @brief Settings of design_excitation.
struct ExcitationDesignOptions {
  int harmonics = 5;            ///< H >= 2 (the first harmonic is spent on rest)
  double base_frequency = 0.1;  ///< f [Hz]; the period is 1 / f
  /// Grid points over one period, for the objective and the constraints; >= 8 H. The limits
  /// of q, qd and qdd are tightened by cos(pi H / N) (they then hold between grid points too),
  /// the torque's by cos(pi 3 H / N) (a heuristic: it is not a polynomial of degree H).
  int samples = 200;
  int max_evaluations = 300;         ///< NLopt's budget (not a time: the result depends only on it)
  double relative_tolerance = 1e-5;  ///< on f
  double aggregation = 200.0;        ///< rho of the constraints' smooth maximum
  /// k of the objective, >= 1: how closely it follows log cond (see the file comment).
  double sharpness = 4.0;
  ExcitationAlgorithm algorithm = ExcitationAlgorithm::Slsqp;
  /// Joints (0-based) whose angle-offset column joins `columns` in W_b: the torque's slope in an
  /// offset of the joint's measured angle at theta, d(Y theta)/dq_j, the column
  /// sid::diagnose_chain tests an encoder offset by (angle_offset_qN). An excitation designed
  /// with it is one on which the offset is told from the link parameters, where they do not
  /// absorb it on every motion.
  std::vector<int> angle_offsets;
};

/// @brief How much of each limit a trajectory uses: per joint, the largest |q - q0| / q_range,
/// |qd| / qd_max, |qdd| / qdd_max and |tau| / tau_max on a grid (<= 1: within the limits).
struct ExcitationUse {
  Eigen::VectorXd q, qd, qdd, tau;
  double largest() const {
    return std::max({q.maxCoeff(), qd.maxCoeff(), qdd.maxCoeff(), tau.maxCoeff()});
  }
};

/// @brief What design_excitation found.
struct ExcitationDesign {
  FourierTrajectory trajectory;  ///< the best feasible point evaluated
  double objective = 0.0;        ///< f_k at trajectory (exp(f_k) <= cond)
  double start_objective = 0.0;  ///< f_k at the start
  int evaluations = 0;      ///< of the objective and constraints (each with its gradient or not)
  std::string stop_reason;  ///< NLopt's result, e.g. "ftol reached"
};

/// @brief The same coefficients, except the first harmonic's, chosen so that qd_j(0) =
/// sum_l a_jl = 0 and qdd_j(0) = w sum_l l b_jl = 0: the trajectory is at rest at t = 0 and,
/// being periodic, at every multiple of 1 / f.
/// @throws std::invalid_argument for an invalid trajectory.
inline FourierTrajectory fourier_trajectory_at_rest(FourierTrajectory f) {
  f.validate("sid::fourier_trajectory_at_rest");
  for (int j = 0; j < f.joints(); ++j) {
    double a = 0.0, b = 0.0;
    for (int l = 2; l <= f.harmonics(); ++l) {
      a += f.a(j, l - 1);
      b += l * f.b(j, l - 1);
    }
    f.a(j, 0) = -a;
    f.b(j, 0) = -b;
  }
  return f;
}

/// @brief The times of `samples` equispaced points over one period [s], t_k = k / (samples f).
inline Eigen::VectorXd excitation_grid(double base_frequency, int samples) {
  if (!(base_frequency > 0.0) || !std::isfinite(base_frequency) || samples < 1)
    throw std::invalid_argument(
        "sid::excitation_grid: base_frequency must be finite and > 0 and samples >= 1");
  return Eigen::VectorXd::LinSpaced(samples, 0.0, (samples - 1.0) / (samples * base_frequency));
}

/// @brief The regressor's columns `columns` stacked over the times (joints() rows per time).
/// @throws std::invalid_argument if the trajectory does not match the model or a column is out
///         of range.
inline Eigen::MatrixXd excitation_regressor(const ChainModel& model,
                                            const std::vector<Eigen::Index>& columns,
                                            const FourierTrajectory& trajectory,
                                            const Eigen::Ref<const Eigen::VectorXd>& times) {
  const char* who = "sid::excitation_regressor";
  trajectory.validate(who);
  const int n = model.joints();
  if (trajectory.joints() != n)
    throw std::invalid_argument(std::string(who) + ": the trajectory has " +
                                std::to_string(trajectory.joints()) + " joints, the model " +
                                std::to_string(n));
  for (const Eigen::Index c : columns)
    if (c < 0 || c >= model.parameters())
      throw std::invalid_argument(std::string(who) + ": column " + std::to_string(c) +
                                  " is not one of the model's " +
                                  std::to_string(model.parameters()));
  Eigen::MatrixXd w(times.size() * n, static_cast<Eigen::Index>(columns.size()));
  Eigen::MatrixXd y(n, model.parameters());
  ChainModel::Vector q(n), qd(n), qdd(n);
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    trajectory.evaluate(times[k], q, qd, qdd);
    model.regressor(q, qd, qdd, y);
    w.middleRows(k * n, n) = y(Eigen::all, columns);
  }
  return w;
}

namespace detail {

/// Per joint of `joints`, d(Y theta)/dq_j at one state by central differences into out
/// (n x joints.size()). The step keeps truncation (~h^2 |d3 tau|) and rounding (~1e-16 |tau| /
/// h) below 1e-8 of the torque, and leaves room for a second difference of the column in the
/// design's gradient.
inline void angle_offset_columns(const ChainModel& model, const Eigen::VectorXd& theta,
                                 const std::vector<int>& joints, const ChainModel::Vector& q,
                                 const ChainModel::Vector& qd, const ChainModel::Vector& qdd,
                                 Eigen::MatrixXd& y, Eigen::MatrixXd& out) {
  constexpr double kStep = 1e-4;
  out.resize(model.joints(), static_cast<Eigen::Index>(joints.size()));
  ChainModel::Vector shifted = q;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    const int j = joints[i];
    shifted[j] = q[j] + kStep;
    model.regressor(shifted, qd, qdd, y);
    out.col(static_cast<Eigen::Index>(i)) = y * theta;
    shifted[j] = q[j] - kStep;
    model.regressor(shifted, qd, qdd, y);
    out.col(static_cast<Eigen::Index>(i)) -= y * theta;
    out.col(static_cast<Eigen::Index>(i)) /= 2.0 * kStep;
    shifted[j] = q[j];
  }
}

inline void check_angle_offsets(const char* who, const std::vector<int>& joints, int n) {
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (joints[i] < 0 || joints[i] >= n)
      throw std::invalid_argument(std::string(who) + ": angle offset joint " +
                                  std::to_string(joints[i]) + " is not one of the chain's " +
                                  std::to_string(n) + " (0-based)");
    if (std::find(joints.begin(), joints.begin() + static_cast<std::ptrdiff_t>(i), joints[i]) !=
        joints.begin() + static_cast<std::ptrdiff_t>(i))
      throw std::invalid_argument(std::string(who) + ": angle offset joint " +
                                  std::to_string(joints[i]) + " is given twice");
  }
}

}  // namespace detail

/// @brief excitation_regressor's columns, then per joint of `angle_offsets` (0-based) its
/// angle-offset column d(Y theta)/dq_j (ExcitationDesignOptions::angle_offsets): the W_b
/// design_excitation conditions when it is given those joints.
/// @throws std::invalid_argument as excitation_regressor, for a theta that does not match the
///         model or a joint out of range or repeated.
inline Eigen::MatrixXd excitation_regressor(const ChainModel& model,
                                            const std::vector<Eigen::Index>& columns,
                                            const FourierTrajectory& trajectory,
                                            const Eigen::Ref<const Eigen::VectorXd>& times,
                                            const Eigen::Ref<const Eigen::VectorXd>& theta,
                                            const std::vector<int>& angle_offsets) {
  const char* who = "sid::excitation_regressor";
  const Eigen::MatrixXd base = excitation_regressor(model, columns, trajectory, times);
  const int n = model.joints();
  if (theta.size() != model.parameters())
    throw std::invalid_argument(std::string(who) + ": theta needs " +
                                std::to_string(model.parameters()) + " entries, has " +
                                std::to_string(theta.size()));
  detail::check_angle_offsets(who, angle_offsets, n);
  const auto m = static_cast<Eigen::Index>(angle_offsets.size());
  Eigen::MatrixXd w(base.rows(), base.cols() + m);
  w.leftCols(base.cols()) = base;
  const Eigen::VectorXd at = theta;
  Eigen::MatrixXd y(n, model.parameters()), slopes;
  ChainModel::Vector q(n), qd(n), qdd(n);
  for (Eigen::Index k = 0; k < times.size(); ++k) {
    trajectory.evaluate(times[k], q, qd, qdd);
    detail::angle_offset_columns(model, at, angle_offsets, q, qd, qdd, y, slopes);
    w.block(k * n, base.cols(), n, m) = slopes;
  }
  return w;
}

/// @brief The 2-norm condition number of w with its columns scaled to unit norm (what
/// sid::identify_chain reports), by an SVD; infinite when w is rank deficient.
inline double scaled_condition_number(const Eigen::Ref<const Eigen::MatrixXd>& w) {
  Eigen::VectorXd norms = w.colwise().norm().transpose();
  if (w.size() == 0 || !(norms.array() > 0.0).all()) return std::numeric_limits<double>::infinity();
  const Eigen::MatrixXd scaled = w * norms.cwiseInverse().asDiagonal();
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(scaled);
  const Eigen::VectorXd& s = svd.singularValues();
  return s[s.size() - 1] > 0.0 ? s[0] / s[s.size() - 1] : std::numeric_limits<double>::infinity();
}

/// @brief How much of each limit the trajectory uses on `samples` equispaced points of a period,
/// the torque by the model's inverse dynamics at theta.
/// @throws std::invalid_argument for sizes that do not match.
inline ExcitationUse excitation_use(const ChainModel& model,
                                    const Eigen::Ref<const Eigen::VectorXd>& theta,
                                    const FourierTrajectory& trajectory,
                                    const ExcitationLimits& limits, int samples) {
  const int n = model.joints();
  if (theta.size() != model.parameters() || trajectory.joints() != n ||
      limits.q_range.size() != n || limits.qd_max.size() != n || limits.qdd_max.size() != n ||
      limits.tau_max.size() != n)
    throw std::invalid_argument(
        "sid::excitation_use: theta, the trajectory and the limits must match the model");
  ExcitationUse use{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n),
                    Eigen::VectorXd::Zero(n)};
  const Eigen::VectorXd t = excitation_grid(trajectory.base_frequency, samples);
  Eigen::MatrixXd y(n, model.parameters());
  ChainModel::Vector q(n), qd(n), qdd(n);
  for (Eigen::Index k = 0; k < t.size(); ++k) {
    trajectory.evaluate(t[k], q, qd, qdd);
    model.regressor(q, qd, qdd, y);
    const Eigen::VectorXd tau = y * theta;
    for (int j = 0; j < n; ++j) {
      use.q[j] = std::max(use.q[j], std::abs(q[j] - trajectory.q0[j]) / limits.q_range[j]);
      use.qd[j] = std::max(use.qd[j], std::abs(qd[j]) / limits.qd_max[j]);
      use.qdd[j] = std::max(use.qdd[j], std::abs(qdd[j]) / limits.qdd_max[j]);
      use.tau[j] = std::max(use.tau[j], std::abs(tau[j]) / limits.tau_max[j]);
    }
  }
  return use;
}

namespace detail {

inline void check_excitation_limits(const char* who, const ExcitationLimits& limits, int n) {
  const auto bad = [n](const Eigen::VectorXd& v, bool finite) {
    return v.size() != n || !(v.array() > 0.0).all() || (finite && !v.allFinite()) || v.hasNaN();
  };
  if (bad(limits.q_range, true) || bad(limits.qd_max, true) || bad(limits.qdd_max, true) ||
      bad(limits.tau_max, false))
    throw std::invalid_argument(std::string(who) + ": the limits need one entry > 0 per joint (" +
                                std::to_string(n) +
                                "), finite for q_range, qd_max and qdd_max (tau_max may be inf)");
}

/// The design problem in the reduced variables: per joint a_j2..a_jH then b_j2..b_jH (the
/// first harmonic follows from rest). Evaluates f, the constraints and their gradients at once
/// and keeps the last point, since NLopt asks for the objective and the constraints separately.
class ExcitationProblem {
 public:
  ExcitationProblem(const ChainModel& model, const Eigen::VectorXd& theta,
                    std::vector<Eigen::Index> columns, const Eigen::VectorXd& q0,
                    const ExcitationLimits& limits, const ExcitationDesignOptions& options)
      : model_(model),
        theta_(theta),
        columns_(std::move(columns)),
        q0_(q0),
        options_(options),
        n_(model.joints()),
        h_(options.harmonics),
        w_(2.0 * kPi * options.base_frequency),
        t_(excitation_grid(options.base_frequency, options.samples)) {
    const double linear_guard = std::cos(kPi * h_ / options.samples);
    const double torque_guard = std::cos(std::min(0.45, 3.0 * h_ / options.samples) * kPi);
    limit_.resize(n_, 4);
    limit_.col(0) = limits.q_range * linear_guard;
    limit_.col(1) = limits.qd_max * linear_guard;
    limit_.col(2) = limits.qdd_max * linear_guard;
    limit_.col(3) = limits.tau_max * torque_guard;
    // basis_(k, s, l): d(state s of a joint at t_k) / d(a_jl), then the same for b_jl, l >= 2,
    // with the first harmonic's dependence folded in.
    const Eigen::Index k_count = t_.size();
    basis_a_.resize(3 * k_count, h_ - 1);
    basis_b_.resize(3 * k_count, h_ - 1);
    for (Eigen::Index k = 0; k < k_count; ++k) {
      const double s1 = std::sin(w_ * t_[k]), c1 = std::cos(w_ * t_[k]);
      for (int l = 2; l <= h_; ++l) {
        const double lw = l * w_, s = std::sin(lw * t_[k]), c = std::cos(lw * t_[k]);
        basis_a_(3 * k, l - 2) = s / lw - s1 / w_;
        basis_a_(3 * k + 1, l - 2) = c - c1;
        basis_a_(3 * k + 2, l - 2) = -lw * s + w_ * s1;
        basis_b_(3 * k, l - 2) = -c / lw + l * c1 / w_;
        basis_b_(3 * k + 1, l - 2) = s - l * s1;
        basis_b_(3 * k + 2, l - 2) = lw * c - l * w_ * c1;
      }
    }
  }

  int variables() const noexcept { return 2 * n_ * (h_ - 1); }
  int constraints() const noexcept { return 4 * n_; }

  Eigen::VectorXd variables_of(const FourierTrajectory& f) const {
    Eigen::VectorXd x(variables());
    const int m = h_ - 1;
    for (int j = 0; j < n_; ++j) {
      x.segment(2 * m * j, m) = f.a.row(j).tail(m).transpose();
      x.segment(2 * m * j + m, m) = f.b.row(j).tail(m).transpose();
    }
    return x;
  }

  FourierTrajectory trajectory_of(const double* x) const {
    FourierTrajectory f;
    f.base_frequency = options_.base_frequency;
    f.q0 = q0_;
    f.a = Eigen::MatrixXd::Zero(n_, h_);
    f.b = Eigen::MatrixXd::Zero(n_, h_);
    const int m = h_ - 1;
    for (int j = 0; j < n_; ++j)
      for (int l = 0; l < m; ++l) {
        f.a(j, l + 1) = x[2 * m * j + l];
        f.b(j, l + 1) = x[2 * m * j + m + l];
      }
    return fourier_trajectory_at_rest(std::move(f));
  }

  /// f, the constraints c (<= 0 within the limits) and, with gradient, their gradients.
  void evaluate(const double* x, bool gradient) {
    const int nv = variables();
    if (!last_x_.empty() && std::equal(x, x + nv, last_x_.begin()) && (!gradient || last_gradient_))
      return;
    last_x_.assign(x, x + nv);
    last_gradient_ = gradient;
    ++evaluations_;
    const FourierTrajectory f = trajectory_of(x);
    const Sampled sampled = sample(f);
    const Eigen::MatrixXd c = evaluate_objective(sampled.wb, gradient);
    const Eigen::MatrixXd weight = evaluate_constraints(sampled);
    if (!gradient) return;

    // d f / d state and d tau / d state per sample, from the regressor's differences.
    objective_gradient_ = Eigen::VectorXd::Zero(nv);
    constraint_gradient_ = Eigen::MatrixXd::Zero(constraints(), nv);
    const StateGradients d = state_gradients(f, sampled.wb, c, weight);
    apply_chain_rule(d);
  }

  double objective() const noexcept { return objective_; }
  const Eigen::VectorXd& objective_gradient() const noexcept { return objective_gradient_; }
  const Eigen::VectorXd& constraint_values() const noexcept { return constraint_; }
  const Eigen::MatrixXd& constraint_gradient() const noexcept { return constraint_gradient_; }
  int evaluations() const noexcept { return evaluations_; }
  static constexpr double kRankDeficient = 1e3;
  static constexpr double kSmallestEigenvalue = 1e-14;

 private:
  static constexpr double kPi = 3.14159265358979323846;
  static constexpr double kStep = 1e-6;
  static constexpr double kOffsetStep = 1e-4;

  /// The trajectory on the grid: its states (rows 3k..3k+2 hold q - q0, qd, qdd at t_k; one
  /// column per joint), the torque at theta and W_b.
  struct Sampled {
    Eigen::MatrixXd state, tau, wb;
  };

  /// The derivatives of f and of the constraints in the states: row 3k + s of df is d f /
  /// d state (k, s) of each joint (a column each); dc has a block of constraints() columns per
  /// joint.
  struct StateGradients {
    Eigen::MatrixXd df, dc;
  };

  /// What the derivatives of the regressor at one state take, kept between states.
  struct DifferenceScratch {
    Eigen::MatrixXd y_plus, y_minus, dy, scratch, slopes_plus, slopes_minus, dslopes;
  };

  Sampled sample(const FourierTrajectory& f) const {
    const auto regressor_columns = static_cast<Eigen::Index>(columns_.size());
    const auto offsets = static_cast<Eigen::Index>(options_.angle_offsets.size());
    const Eigen::Index k_count = t_.size(), p = regressor_columns + offsets;
    Eigen::MatrixXd slopes;
    // States per sample: rows 3k..3k+2 hold q, qd, qdd; one column per joint.
    Eigen::MatrixXd state(3 * k_count, n_), tau(k_count, n_);
    Eigen::MatrixXd wb(k_count * n_, p), y(n_, model_.parameters());
    ChainModel::Vector q(n_), qd(n_), qdd(n_);
    for (Eigen::Index k = 0; k < k_count; ++k) {
      f.evaluate(t_[k], q, qd, qdd);
      state.row(3 * k) = (q - q0_).transpose();
      state.row(3 * k + 1) = qd.transpose();
      state.row(3 * k + 2) = qdd.transpose();
      model_.regressor(q, qd, qdd, y);
      wb.block(k * n_, 0, n_, regressor_columns) = y(Eigen::all, columns_);
      tau.row(k) = (y * theta_).transpose();
      if (offsets > 0) {
        detail::angle_offset_columns(model_, theta_, options_.angle_offsets, q, qd, qdd, y, slopes);
        wb.block(k * n_, regressor_columns, n_, offsets) = slopes;
      }
    }
    return {std::move(state), std::move(tau), std::move(wb)};
  }

  /// Sets objective_ from W_b; with gradient returns c, d f / d W_b = W_b c (empty when the
  /// columns are rank deficient).
  Eigen::MatrixXd evaluate_objective(const Eigen::MatrixXd& wb, bool gradient) {
    const Eigen::Index p = wb.cols();
    Eigen::MatrixXd g = Eigen::MatrixXd::Zero(p, p);
    g.selfadjointView<Eigen::Lower>().rankUpdate(wb.transpose());
    g.triangularView<Eigen::Upper>() = g.transpose();
    const Eigen::VectorXd diagonal = g.diagonal();
    Eigen::MatrixXd c;  // d f / d W_b = W_b c
    objective_ = kRankDeficient;
    if ((diagonal.array() > 0.0).all() && diagonal.allFinite()) {
      const Eigen::VectorXd d = diagonal.cwiseSqrt().cwiseInverse();
      const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(d.asDiagonal() * g *
                                                                 d.asDiagonal());
      const Eigen::VectorXd& lambda = eigen.eigenvalues();  // ascending
      const double low = lambda[0], high = lambda[p - 1], k = options_.sharpness;
      if (eigen.info() == Eigen::Success && low > kSmallestEigenvalue * high) {
        const Eigen::ArrayXd up = (lambda.array() / high).pow(k),
                             down = (low / lambda.array()).pow(k);
        const double s_up = up.sum(), s_down = down.sum();
        objective_ = 0.5 * std::log(high / low) + std::log(s_up * s_down / double(p * p)) / (2 * k);
        if (gradient) {
          // d lambda_i = tr(C_i dG), C_i = u_i u_i^T - lambda_i diag(v_i^2 / G_jj), u_i = D v_i
          // (v_i the eigenvector of D G D); then d f = tr(C dG) with C = sum_i w_i C_i.
          const Eigen::VectorXd w = (0.5 * (up / s_up - down / s_down) / lambda.array()).matrix();
          const Eigen::MatrixXd u = d.asDiagonal() * eigen.eigenvectors();
          c = u * w.asDiagonal() * u.transpose();
          const Eigen::VectorXd shift =
              (eigen.eigenvectors().array().square().matrix() * w.cwiseProduct(lambda))
                  .cwiseQuotient(diagonal);
          c.diagonal() -= shift;
          c *= 2.0;  // dG = dW^T W + W^T dW
        }
      }
    }
    return c;
  }

  /// Sets constraint_ from the sampled states and torques; returns d c / d v_k, one column per
  /// constraint.
  Eigen::MatrixXd evaluate_constraints(const Sampled& sampled) {
    const Eigen::MatrixXd &state = sampled.state, &tau = sampled.tau;
    const Eigen::Index k_count = t_.size();
    // Constraints: a smooth maximum over the grid of (v / limit)^2 - 1, per joint and quantity.
    const double rho = options_.aggregation;
    constraint_.resize(constraints());
    Eigen::MatrixXd weight(k_count, constraints());  // d c / d v_k
    for (int s = 0; s < 4; ++s)
      for (int j = 0; j < n_; ++j) {
        const double limit = limit_(j, s);
        Eigen::VectorXd v(k_count);
        for (Eigen::Index k = 0; k < k_count; ++k) v[k] = s < 3 ? state(3 * k + s, j) : tau(k, j);
        const int index = s * n_ + j;
        if (!std::isfinite(limit)) {
          constraint_[index] = -1.0;
          weight.col(index).setZero();
          continue;
        }
        const Eigen::ArrayXd r = (v / limit).array().square();
        const double top = r.maxCoeff();
        const Eigen::ArrayXd e = (rho * (r - top)).exp();
        const double total = e.sum();
        constraint_[index] = top - 1.0 + std::log(total) / rho;
        weight.col(index) = (e / total * 2.0 * v.array() / (limit * limit)).matrix();
      }
    return weight;
  }

  /// Into scratch.dy, d Y / d s[kind][i] at the state s (y = Y there); with offset_columns, into
  /// scratch.dslopes the angle-offset columns' own derivative. Leaves s as it was.
  void regressor_derivative(ChainModel::Vector (&s)[3], int kind, int i, const Eigen::MatrixXd& y,
                            bool offset_columns, DifferenceScratch& scratch) const {
    Eigen::MatrixXd &y_plus = scratch.y_plus, &y_minus = scratch.y_minus, &dy = scratch.dy;
    Eigen::MatrixXd &slopes_plus = scratch.slopes_plus, &slopes_minus = scratch.slopes_minus,
                    &dslopes = scratch.dslopes;
    const double value = s[kind][i];
    if (kind == 2) {  // affine in qdd: one exact difference
      s[kind][i] = value + 1.0;
      model_.regressor(s[0], s[1], s[2], y_plus);
      dy = y_plus - y;
    } else {
      const double step = kStep * std::max(1.0, std::abs(value));
      s[kind][i] = value + step;
      model_.regressor(s[0], s[1], s[2], y_plus);
      s[kind][i] = value - step;
      model_.regressor(s[0], s[1], s[2], y_minus);
      dy = (y_plus - y_minus) / (2.0 * step);
    }
    if (offset_columns) {
      // The angle-offset columns' own differences: a larger step, since they are
      // differences already (their rounding ~1e-12 |tau| over the step stays ~1e-8 |tau|).
      const double step = kind == 2 ? 1.0 : kOffsetStep * std::max(1.0, std::abs(value));
      s[kind][i] = value + step;
      detail::angle_offset_columns(model_, theta_, options_.angle_offsets, s[0], s[1], s[2],
                                   scratch.scratch, slopes_plus);
      if (kind == 2) {
        s[kind][i] = value;
        detail::angle_offset_columns(model_, theta_, options_.angle_offsets, s[0], s[1], s[2],
                                     scratch.scratch, slopes_minus);
        dslopes = slopes_plus - slopes_minus;
      } else {
        s[kind][i] = value - step;
        detail::angle_offset_columns(model_, theta_, options_.angle_offsets, s[0], s[1], s[2],
                                     scratch.scratch, slopes_minus);
        dslopes = (slopes_plus - slopes_minus) / (2.0 * step);
      }
    }
    s[kind][i] = value;
  }

  /// d f / d state from c (see evaluate_objective) and d c / d state from the constraints'
  /// weights, per sample.
  StateGradients state_gradients(const FourierTrajectory& f, const Eigen::MatrixXd& wb,
                                 const Eigen::MatrixXd& c, const Eigen::MatrixXd& weight) const {
    const auto regressor_columns = static_cast<Eigen::Index>(columns_.size());
    const auto offsets = static_cast<Eigen::Index>(options_.angle_offsets.size());
    const Eigen::Index k_count = t_.size();
    Eigen::MatrixXd df_dstate = Eigen::MatrixXd::Zero(3 * k_count, n_);
    Eigen::MatrixXd dc_dstate = Eigen::MatrixXd::Zero(3 * k_count, n_ * constraints());
    Eigen::MatrixXd y(n_, model_.parameters());
    DifferenceScratch scratch{y, y, y, y, {}, {}, {}};
    const Eigen::MatrixXd &dy = scratch.dy, &dslopes = scratch.dslopes;
    ChainModel::Vector q(n_), qd(n_), qdd(n_);
    for (Eigen::Index k = 0; k < k_count; ++k) {
      ChainModel::Vector s[3] = {q, qd, qdd};
      f.evaluate(t_[k], s[0], s[1], s[2]);
      model_.regressor(s[0], s[1], s[2], y);
      Eigen::MatrixXd pk;
      if (c.size()) pk = wb.middleRows(k * n_, n_) * c;
      for (int kind = 0; kind < 3; ++kind)
        for (int i = 0; i < n_; ++i) {
          regressor_derivative(s, kind, i, y, pk.size() && offsets > 0, scratch);
          if (pk.size()) {
            df_dstate(3 * k + kind, i) =
                pk.leftCols(regressor_columns).cwiseProduct(dy(Eigen::all, columns_)).sum();
            if (offsets > 0)
              df_dstate(3 * k + kind, i) += pk.rightCols(offsets).cwiseProduct(dslopes).sum();
          }
          const Eigen::VectorXd dtau = dy * theta_;
          for (int j = 0; j < n_; ++j)
            dc_dstate(3 * k + kind, i * constraints() + 3 * n_ + j) =
                weight(k, 3 * n_ + j) * dtau[j];
        }
      for (int s_kind = 0; s_kind < 3; ++s_kind)
        for (int j = 0; j < n_; ++j)
          dc_dstate(3 * k + s_kind, j * constraints() + s_kind * n_ + j) +=
              weight(k, s_kind * n_ + j);
    }
    return {std::move(df_dstate), std::move(dc_dstate)};
  }

  /// The state derivatives into objective_gradient_ and constraint_gradient_.
  void apply_chain_rule(const StateGradients& d) {
    const Eigen::MatrixXd &df_dstate = d.df, &dc_dstate = d.dc;
    // Chain rule to the variables of joint i: d / d x = sum_k sum_s d / d state(k, s, i) basis.
    const int m = h_ - 1;
    for (int i = 0; i < n_; ++i) {
      const Eigen::VectorXd df = df_dstate.col(i);
      objective_gradient_.segment(2 * m * i, m) = basis_a_.transpose() * df;
      objective_gradient_.segment(2 * m * i + m, m) = basis_b_.transpose() * df;
      const auto dc = dc_dstate.middleCols(i * constraints(), constraints());
      constraint_gradient_.middleCols(2 * m * i, m) = dc.transpose() * basis_a_;
      constraint_gradient_.middleCols(2 * m * i + m, m) = dc.transpose() * basis_b_;
    }
  }

  const ChainModel& model_;
  Eigen::VectorXd theta_;
  std::vector<Eigen::Index> columns_;
  Eigen::VectorXd q0_;
  ExcitationDesignOptions options_;
  int n_, h_;
  double w_;
  Eigen::VectorXd t_;
  Eigen::MatrixXd limit_;  ///< n x 4 (q, qd, qdd, tau), tightened by the guards
  Eigen::MatrixXd basis_a_, basis_b_;
  std::vector<double> last_x_;
  bool last_gradient_ = false;
  int evaluations_ = 0;
  double objective_ = 0.0;
  Eigen::VectorXd objective_gradient_, constraint_;
  Eigen::MatrixXd constraint_gradient_;
};

struct ExcitationRun {
  /// SQP ends on its active constraints to within roundoff: (v / limit)^2 within 1e-6 of 1.
  static constexpr double kFeasible = 1e-6;
  ExcitationProblem* problem = nullptr;
  std::exception_ptr error;
  std::vector<double> best_x;
  double best = std::numeric_limits<double>::infinity();
  nlopt_opt opt = nullptr;

  // NLopt is C: an exception must not cross it, so it is kept and the run stopped.
  template <typename Body>
  void guarded(Body body) {
    try {
      body();
      const Eigen::VectorXd& c = problem->constraint_values();
      if (c.maxCoeff() <= kFeasible && problem->objective() < best) {
        best = problem->objective();
        best_x.assign(last_point_.begin(), last_point_.end());
      }
    } catch (...) {
      error = std::current_exception();
      nlopt_force_stop(opt);
    }
  }
  std::vector<double> last_point_;
};

inline double excitation_objective(unsigned nv, const double* x, double* grad, void* data) {
  auto* run = static_cast<ExcitationRun*>(data);
  double value = ExcitationProblem::kRankDeficient;
  run->last_point_.assign(x, x + nv);
  run->guarded([&] {
    run->problem->evaluate(x, grad != nullptr);
    value = run->problem->objective();
    if (grad) Eigen::Map<Eigen::VectorXd>(grad, nv) = run->problem->objective_gradient();
  });
  return value;
}

inline void excitation_constraints(unsigned m, double* result, unsigned nv, const double* x,
                                   double* grad, void* data) {
  auto* run = static_cast<ExcitationRun*>(data);
  run->last_point_.assign(x, x + nv);
  run->guarded([&] {
    run->problem->evaluate(x, grad != nullptr);
    Eigen::Map<Eigen::VectorXd>(result, m) = run->problem->constraint_values();
    if (grad)  // NLopt's layout: row i is constraint i's gradient, row-major
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          grad, m, nv) = run->problem->constraint_gradient();
  });
}

inline const char* nlopt_result_text(nlopt_result r) {
  switch (r) {
    case NLOPT_SUCCESS:
      return "success";
    case NLOPT_STOPVAL_REACHED:
      return "stopval reached";
    case NLOPT_FTOL_REACHED:
      return "relative tolerance on the objective reached";
    case NLOPT_XTOL_REACHED:
      return "tolerance on the coefficients reached";
    case NLOPT_MAXEVAL_REACHED:
      return "evaluation budget used";
    case NLOPT_MAXTIME_REACHED:
      return "time budget used";
    case NLOPT_ROUNDOFF_LIMITED:
      return "stopped by roundoff";
    case NLOPT_FORCED_STOP:
      return "stopped";
    case NLOPT_OUT_OF_MEMORY:
      return "out of memory";
    case NLOPT_INVALID_ARGS:
      return "invalid arguments";
    default:
      return "failure";
  }
}

inline void check_excitation_inputs(const char* who, const ChainModel& model,
                                    const Eigen::Ref<const Eigen::VectorXd>& theta,
                                    const std::vector<Eigen::Index>& columns,
                                    const Eigen::Ref<const Eigen::VectorXd>& q0,
                                    const ExcitationLimits& limits,
                                    const ExcitationDesignOptions& options) {
  const int n = model.joints();
  if (theta.size() != model.parameters() || !theta.allFinite())
    throw std::invalid_argument(std::string(who) + ": theta needs " +
                                std::to_string(model.parameters()) + " finite entries, has " +
                                std::to_string(theta.size()));
  if (q0.size() != n || !q0.allFinite())
    throw std::invalid_argument(std::string(who) + ": q0 needs one finite entry per joint");
  if (columns.empty()) throw std::invalid_argument(std::string(who) + ": no base columns given");
  for (const Eigen::Index c : columns)
    if (c < 0 || c >= model.parameters())
      throw std::invalid_argument(std::string(who) + ": column " + std::to_string(c) +
                                  " is not one of the model's");
  check_excitation_limits(who, limits, n);
  if (options.harmonics < 2 || options.harmonics > 50)
    throw std::invalid_argument(std::string(who) +
                                ": harmonics must be 2..50 (the first is spent on rest)");
  if (!(options.base_frequency > 0.0) || !std::isfinite(options.base_frequency))
    throw std::invalid_argument(std::string(who) + ": base_frequency must be finite and > 0");
  if (options.samples < 8 * options.harmonics)
    throw std::invalid_argument(std::string(who) + ": samples must be >= 8 harmonics (" +
                                std::to_string(8 * options.harmonics) + ")");
  check_angle_offsets(who, options.angle_offsets, n);
  if (static_cast<Eigen::Index>(options.samples) * n <=
      static_cast<Eigen::Index>(columns.size() + options.angle_offsets.size()))
    throw std::invalid_argument(std::string(who) + ": " + std::to_string(options.samples) +
                                " samples give fewer equations than base parameters");
  if (options.max_evaluations < 1 || !(options.relative_tolerance >= 0.0) ||
      !(options.aggregation > 0.0) || !std::isfinite(options.aggregation))
    throw std::invalid_argument(std::string(who) +
                                ": max_evaluations must be >= 1, relative_tolerance >= 0 and "
                                "aggregation finite and > 0");
}

inline void check_excitation_start(const char* who, const ChainModel& model,
                                   const FourierTrajectory& start,
                                   const ExcitationDesignOptions& options) {
  start.validate(who);
  if (start.joints() != model.joints() || start.harmonics() != options.harmonics)
    throw std::invalid_argument(
        std::string(who) + ": the start has " + std::to_string(start.joints()) + " joints and " +
        std::to_string(start.harmonics()) + " harmonics; expected " +
        std::to_string(model.joints()) + " and " + std::to_string(options.harmonics));
}

/// The optimizer's bounds on the variables.
struct ExcitationBounds {
  std::vector<double> lower, upper;
};

inline ExcitationBounds excitation_bounds(int joints, std::size_t variables,
                                          const ExcitationLimits& limits, int harmonics) {
  // Each coefficient of a trigonometric polynomial is at most twice its largest value.
  std::vector<double> lower(variables), upper(variables);
  const int m = harmonics - 1;
  for (int j = 0; j < joints; ++j)
    for (int v = 0; v < 2 * m; ++v) {
      upper[static_cast<std::size_t>(2 * m * j + v)] = 2.0 * limits.qd_max[j];
      lower[static_cast<std::size_t>(2 * m * j + v)] = -2.0 * limits.qd_max[j];
    }
  return {std::move(lower), std::move(upper)};
}

/// Gives run's optimizer the bounds, the objective, the constraints and the stopping rules.
inline void configure_excitation_run(const char* who, ExcitationRun& run,
                                     const ExcitationBounds& bounds,
                                     const ExcitationDesignOptions& options) {
  const ExcitationProblem& problem = *run.problem;
  const std::vector<double> tolerances(static_cast<std::size_t>(problem.constraints()), 1e-9);
  if (nlopt_set_lower_bounds(run.opt, bounds.lower.data()) < 0 ||
      nlopt_set_upper_bounds(run.opt, bounds.upper.data()) < 0 ||
      nlopt_set_min_objective(run.opt, excitation_objective, &run) < 0 ||
      nlopt_add_inequality_mconstraint(run.opt, static_cast<unsigned>(problem.constraints()),
                                       excitation_constraints, &run, tolerances.data()) < 0 ||
      nlopt_set_maxeval(run.opt, options.max_evaluations) < 0 ||
      nlopt_set_ftol_rel(run.opt, options.relative_tolerance) < 0)
    throw std::runtime_error(std::string(who) + ": NLopt refused the problem's settings");
}

/// SQP converges onto its active limits from outside: shrink its last point x onto them
/// (exactly for q, qd and qdd, which scale with the coefficients; nearly so for the torque),
/// keeping it in run as the best point if it is.
inline void shrink_onto_limits(ExcitationProblem& problem, ExcitationRun& run,
                               std::vector<double>& x) {
  for (int i = 0; i < 30; ++i) {
    problem.evaluate(x.data(), false);
    const double violation = problem.constraint_values().maxCoeff();
    if (violation <= ExcitationRun::kFeasible) {
      if (problem.objective() < run.best) {
        run.best = problem.objective();
        run.best_x = x;
      }
      break;
    }
    if (violation > 0.1) break;
    for (double& v : x) v *= 0.9999 / std::sqrt(1.0 + violation);
  }
}

}  // namespace detail

/// @brief A random excitation within the limits, at rest at t = k / f: coefficients uniform in
/// [-1, 1] for the harmonics 2..H, the first from rest (fourier_trajectory_at_rest), each
/// joint's series scaled to its q, qd and qdd limits (whichever binds, bounded between the
/// `samples` grid points as in random_fourier_trajectory), then all of them by the largest
/// factor in (0, 1] (bisection) that keeps the torque of the inverse dynamics at theta within
/// tau_max on the grid. Deterministic for a generator state. The start design_excitation takes.
/// @throws std::invalid_argument on invalid inputs, or when the torque at rest at q0 already
///         exceeds tau_max (no excitation about q0 can satisfy the limits).
template <typename Generator>
FourierTrajectory random_excitation(const ChainModel& model,
                                    const Eigen::Ref<const Eigen::VectorXd>& theta,
                                    const Eigen::Ref<const Eigen::VectorXd>& q0,
                                    const ExcitationLimits& limits,
                                    const ExcitationDesignOptions& options, Generator& rng) {
  const char* who = "sid::random_excitation";
  detail::check_excitation_inputs(who, model, theta, {0}, q0, limits, options);
  const int n = model.joints(), h = options.harmonics;
  constexpr double kPi = 3.14159265358979323846;
  FourierTrajectory f;
  f.base_frequency = options.base_frequency;
  f.q0 = q0;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  f.a = Eigen::MatrixXd::NullaryExpr(n, h, [&] { return u(rng); });
  f.b = Eigen::MatrixXd::NullaryExpr(n, h, [&] { return u(rng); });
  f = fourier_trajectory_at_rest(std::move(f));
  const Eigen::VectorXd t = excitation_grid(options.base_frequency, options.samples);
  Eigen::VectorXd largest = Eigen::VectorXd::Zero(3 * n);
  ChainModel::Vector q(n), qd(n), qdd(n);
  for (Eigen::Index k = 0; k < t.size(); ++k) {
    f.evaluate(t[k], q, qd, qdd);
    largest.segment(0, n) = largest.segment(0, n).cwiseMax((q - q0).cwiseAbs());
    largest.segment(n, n) = largest.segment(n, n).cwiseMax(qd.cwiseAbs());
    largest.segment(2 * n, n) = largest.segment(2 * n, n).cwiseMax(qdd.cwiseAbs());
  }
  const double guard = 1.0 / std::cos(kPi * h / options.samples);
  for (int j = 0; j < n; ++j) {
    const double scale = std::min({limits.q_range[j] / (guard * largest[j]),
                                   limits.qd_max[j] / (guard * largest[n + j]),
                                   limits.qdd_max[j] / (guard * largest[2 * n + j])});
    f.a.row(j) *= scale;
    f.b.row(j) *= scale;
  }
  const auto torque_use = [&](double s) {
    FourierTrajectory g = f;
    g.a *= s;
    g.b *= s;
    return excitation_use(model, theta, g, limits, options.samples).tau.maxCoeff();
  };
  if (torque_use(1.0) <= 1.0) return f;
  if (torque_use(0.0) > 1.0)
    throw std::invalid_argument(std::string(who) +
                                ": the torque holding the chain at rest at q0 already exceeds "
                                "tau_max; raise the torque limits or move q0");
  double low = 0.0, high = 1.0;
  for (int i = 0; i < 40; ++i) {
    const double middle = 0.5 * (low + high);
    (torque_use(middle) <= 1.0 ? low : high) = middle;
  }
  f.a *= low;
  f.b *= low;
  return f;
}

/// @brief The excitation that minimizes f_k, a smooth stand-in for the log condition number of
/// the column-scaled base regressor (see the file comment), within the limits, at rest at every t =
/// k / f, from a start within the limits (e.g. random_excitation), by NLopt. Deterministic: the
/// budget is in evaluations.
/// @param theta the model's parameters the torques are computed with (e.g. a URDF's links).
/// @param columns the base parameters' columns of the model.
/// @param q0 the offsets, kept fixed (the start's q0 is replaced by them).
/// @return the best point evaluated that satisfies the (aggregated) limits; the start when none
///         did better.
/// @throws std::invalid_argument on invalid inputs, a start with another joint count or
///         harmonic count, or one whose regressor is rank deficient.
inline ExcitationDesign design_excitation(const ChainModel& model,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta,
                                          const std::vector<Eigen::Index>& columns,
                                          const Eigen::Ref<const Eigen::VectorXd>& q0,
                                          const ExcitationLimits& limits,
                                          const FourierTrajectory& start,
                                          const ExcitationDesignOptions& options = {}) {
  const char* who = "sid::design_excitation";
  detail::check_excitation_inputs(who, model, theta, columns, q0, limits, options);
  detail::check_excitation_start(who, model, start, options);
  detail::ExcitationProblem problem(model, theta, columns, q0, limits, options);
  const int nv = problem.variables();
  std::vector<double> x(static_cast<std::size_t>(nv));
  Eigen::Map<Eigen::VectorXd>(x.data(), nv) = problem.variables_of(start);
  problem.evaluate(x.data(), false);
  ExcitationDesign design;
  design.start_objective = problem.objective();
  if (design.start_objective >= detail::ExcitationProblem::kRankDeficient)
    throw std::invalid_argument(std::string(who) +
                                ": the start's base regressor is rank deficient; start elsewhere");

  detail::ExcitationRun run;
  run.problem = &problem;
  if (problem.constraint_values().maxCoeff() <= detail::ExcitationRun::kFeasible) {
    run.best = design.start_objective;
    run.best_x = x;
  }
  run.opt =
      nlopt_create(options.algorithm == ExcitationAlgorithm::Mma ? NLOPT_LD_MMA : NLOPT_LD_SLSQP,
                   static_cast<unsigned>(nv));
  if (!run.opt) throw std::runtime_error(std::string(who) + ": nlopt_create failed");
  struct Destroy {
    nlopt_opt opt;
    ~Destroy() { nlopt_destroy(opt); }
  } destroy{run.opt};
  const detail::ExcitationBounds bounds =
      detail::excitation_bounds(model.joints(), x.size(), limits, options.harmonics);
  for (std::size_t i = 0; i < x.size(); ++i)
    x[i] = std::clamp(x[i], bounds.lower[i], bounds.upper[i]);
  detail::configure_excitation_run(who, run, bounds, options);
  double value = 0.0;
  const nlopt_result result = nlopt_optimize(run.opt, x.data(), &value);
  if (run.error) std::rethrow_exception(run.error);
  design.stop_reason = detail::nlopt_result_text(result);
  detail::shrink_onto_limits(problem, run, x);
  design.evaluations = problem.evaluations();
  if (run.best_x.empty()) {  // nothing feasible seen: the start as it was
    design.trajectory = problem.trajectory_of(problem.variables_of(start).data());
    design.objective = design.start_objective;
    design.stop_reason += "; no point within the limits improved on the start";
    return design;
  }
  design.trajectory = problem.trajectory_of(run.best_x.data());
  design.objective = run.best;
  return design;
}

}  // namespace sid
