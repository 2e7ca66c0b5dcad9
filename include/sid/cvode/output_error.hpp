#pragma once
/// @file
/// @brief Output-error estimation: the parameters of a model chosen so that its simulations,
/// driven by the applied torque, reproduce the measured angles over a set of time windows, each
/// with its own free initial state (multiple shooting).
///
/// Why, next to the torque-domain least squares: a regression on smoothed q̂̈ sees only what
/// survives the smoothing spline's bandwidth. Effects that act in tens of milliseconds (the
/// Stribeck bump at a velocity reversal) are smeared there, so the regression fixes only their
/// area. The measured angles keep the full bandwidth: a Cramér–Rao computation on the paper's
/// excitation (σq = 1e-3 rad, 1 s windows) bounds Fs's standard deviation at 3 % on joint 1 and
/// 0.3 % on joint 2, where the torque-domain fit leaves it 20–40 % low.

#include <sid/config.hpp>
#include <sid/cvode/free_simulation.hpp>
#include <sid/cvode/sensitivity.hpp>
#include <sid/cvode/simulator.hpp>
#include <sid/detail/parallel.hpp>
#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace sid {

/// @brief Settings of fit_output_error().
struct OutputErrorOptions {
  /// Levenberg–Marquardt steps, >= 1. Most cost one simulation per window (the Jacobian is
  /// updated, not recomputed), so more are allowed than a plain Gauss–Newton method would need.
  int max_iterations = 40;
  /// Stop when an accepted step lowers the cost by less than this fraction of it, > 0.
  double relative_tolerance = 1e-7;
  /// ... or by less than this [χ² units]: a change that no test or standard deviation notices.
  double absolute_tolerance = 0.1;
  /// When the fit is the worse side of a likelihood ratio against a fit of cost comparison_cost
  /// (-inf: none), also stop when a step lowers the cost by less than comparison_tolerance times
  /// the gap (cost − comparison_cost): the ratio is then known to about that fraction of itself,
  /// which decides the test as well as the exact minimum would. A model that misfits the data
  /// (Coulomb friction on a Stribeck bump) crawls towards its minimum: on joint 2 of the multisine
  /// excitation 14 of its 18 steps lowered a cost gap of 8800 by 250 in all. Such a fit also
  /// stops on an updated Jacobian, and its covariance comes from that one: it is the side of
  /// the test that is not the answer.
  double comparison_cost = -std::numeric_limits<double>::infinity();
  double comparison_tolerance = 1e-2;
  /// Threads over the windows (each window's simulations are independent); 0: the hardware's.
  /// The result does not depend on it.
  int threads = 0;
  /// CVODE settings of the simulations whose angles enter the cost. BDF: a friction term
  /// Fc tanh(q̇/ε) is stiff near a reversal. rtol 1e-8 keeps the integration error (~1e-8
  /// rad) far below σq, so the cost is smooth in the unknowns to well within the tolerances.
  SimulatorOptions simulator = [] {
    SimulatorOptions s;
    s.method = IntegrationMethod::Bdf;
    s.rtol = 1e-8;
    s.atol = 1e-9;
    s.max_steps = 20000;
    return s;
  }();
  /// Relative tolerance of the sensitivity simulations that give the Jacobian (absolute: a
  /// tenth of it), > 0. A Gauss–Newton step needs the Jacobian to a few digits, not to the
  /// cost's accuracy: at 1e-6 a window takes about half the steps it takes at 1e-8, and the
  /// fits' steps, minima and standard deviations on the Stribeck test cases did not change in
  /// their shown digits.
  double sensitivity_rtol = 1e-6;
};

/// @brief One multiple-shooting window: rows [begin, end) of the data, simulated from a free
/// initial state (q, q̇) that starts at the given guess (a previous fit's windows are a warm start).
struct OutputErrorWindow {
  Eigen::Index begin = 0, end = 0;
  Vector2<double> q0 = Vector2<double>::Zero(), qd0 = Vector2<double>::Zero();
  /// A constant torque added to the input over the window [N m], estimated from this start.
  Vector2<double> torque_offset = Vector2<double>::Zero();
  /// Its rate of change over the window [N m/s] (about the window's middle), likewise.
  Vector2<double> torque_slope = Vector2<double>::Zero();
};

/// @brief An output-error problem. The model may depend on one nonlinear scalar s > 0 (a
/// Stribeck velocity): model_at(s) builds it; s is estimated in log s. Without it
/// (estimate_nonlinear false) model_at is called with s0 only.
struct OutputErrorProblem {
  std::function<Model<double>(double)> model_at;
  Eigen::VectorXd theta0;  ///< start of the model's parameters
  /// Indices into theta0 of parameters held at their start values (each free one adds a
  /// sensitivity to every window's Jacobian).
  std::vector<Eigen::Index> fixed_parameters;
  double s0 = 1.0;  ///< start of the nonlinear scalar (> 0)
  /// Bounds the estimate of s is kept within (where its bump vanishes, s has no gradient and
  /// would otherwise wander off).
  double s_min = 1e-6, s_max = 1e6;
  bool estimate_nonlinear = false;
  /// Independent Gaussian priors on the parameters (empty, or theta0.size() entries; an
  /// infinite std is no prior): what another estimate (the torque-domain fit) already says.
  Eigen::VectorXd prior_mean, prior_std;
  Eigen::VectorXd t;            ///< sample times [s], strictly increasing
  MatrixX2<double> q_measured;  ///< measured angles [rad]
  MatrixX2<double> tau;         ///< the applied torque at t [N m] (smooth: see the caller)
  Vector2<double> sigma_q = Vector2<double>::Ones();  ///< angle noise per joint [rad]
  std::vector<OutputErrorWindow> windows;
};

/// @brief The result of fit_output_error().
struct [[nodiscard]] OutputErrorFit {
  Eigen::VectorXd theta;                                ///< the model's parameters
  double s = std::numeric_limits<double>::quiet_NaN();  ///< the nonlinear scalar (if estimated)
  /// Covariance of (theta, s) from the Gauss–Newton information, scaled by the fit's mean
  /// square normalised residual (1 when sigma_q is right and the model fits).
  Eigen::MatrixXd covariance;
  double initial_cost = 0, cost = 0;  ///< Σ ((q − q_sim)/σq)² over the windows (+ prior term)
  double data_cost = 0;               ///< the same without the prior term
  Eigen::Index residuals = 0;         ///< number of angle residuals
  /// Unknowns the fit moved: the free parameters, log s if estimated, and the windows' own.
  Eigen::Index free_unknowns = 0;
  int iterations = 0;
  bool converged = false;
  bool start_failed = false;               ///< the simulation from the starting values failed
  std::string message;                     ///< why not ok / not converged
  std::vector<OutputErrorWindow> windows;  ///< with the estimated initial states
  /// What a test of a parameter added at the solution needs (output_error_score_test): per
  /// window, the normalised residuals at the solution and d(q_sim)/du over the window's unknowns
  /// (the free globals, then its own 8), and the Gauss–Newton normal matrix over all unknowns
  /// (prior included; a fixed parameter's row and column are the identity's).
  std::vector<Eigen::VectorXd> window_residuals;
  std::vector<Eigen::MatrixXd> window_jacobians;
  std::vector<std::vector<Eigen::Index>> window_columns;
  Eigen::MatrixXd normal;
  /// The gradient Jᵀr − prior pull the fit stopped at, over all unknowns (zero for the fixed
  /// ones): what is left of it is the part of the cost the fit did not take.
  Eigen::VectorXd gradient;

  /// The fit ran (it may still have stopped before converging: see converged and message).
  bool ok() const noexcept { return !start_failed; }
};

namespace detail {

/// A window's own unknowns in the fit's order: q0, qd0, torque offset, torque slope.
constexpr Eigen::Index kWindowUnknowns = 8;
using WindowUnknowns = Eigen::Matrix<double, kWindowUnknowns, 1>;

inline WindowUnknowns window_unknowns(const OutputErrorWindow& w) {
  WindowUnknowns u;
  u << w.q0, w.qd0, w.torque_offset, w.torque_slope;
  return u;
}

inline void set_window_unknowns(OutputErrorWindow& w, const Eigen::Ref<const WindowUnknowns>& u) {
  w.q0 = u.segment<2>(0);
  w.qd0 = u.segment<2>(2);
  w.torque_offset = u.segment<2>(4);
  w.torque_slope = u.segment<2>(6);
}

/// The middle of window w [s]: its torque slope acts about it.
SID_INLINE double window_middle(const Eigen::VectorXd& t, const OutputErrorWindow& w);

/// The window's state equation: the model driven by the applied torque plus the window's offset
/// and slope. Throws on a blow-up (the simulation then fails).
SID_INLINE auto window_rhs(const Model<double>& model, const Eigen::VectorXd& theta,
                           const TorqueInterpolator& torque, double middle,
                           const Vector2<double>& torque_offset,
                           const Vector2<double>& torque_slope);

/// Simulated angles of one window with parameters theta, or false if CVODE failed.
SID_INLINE bool simulate_window(const Model<double>& model, const Eigen::VectorXd& theta,
                                const TorqueInterpolator& torque, const Eigen::VectorXd& t,
                                const OutputErrorWindow& w, const Vector2<double>& q0,
                                const Vector2<double>& qd0, const Vector2<double>& torque_offset,
                                const Vector2<double>& torque_slope,
                                const SimulatorOptions& options, Eigen::MatrixXd& q_out);

/// What window_jacobian() differentiates by, besides the window's own unknowns.
struct WindowParameters {
  std::vector<Eigen::Index> theta;  ///< indices into theta, in column order
  /// The nonlinear scalar's column (after theta's) if not null: the model at s e^log_step.
  const Model<double>* model_at_larger_s = nullptr;
  double log_step = 0;
};

/// d(q_sim)/du over window w by forward sensitivities, u = (the parameters, then the window's
/// q0, qd0, torque offset and torque slope), divided by σq: rows as normalised_residual's.
/// false if CVODES failed.
///
/// The sensitivity of q̈ = D⁻¹(τ − h) follows from inverse dynamics ID(q, q̇, q̈; θ) = τ:
/// D ∂q̈/∂u = ∂τ/∂u − ∂ID/∂q s_q − ∂ID/∂q̇ s_q̇ − ∂ID/∂u, with ∂ID/∂θ_i the regressor's column
/// i. ∂ID/∂q and ∂ID/∂q̇ are forward differences (step 1e-7: relative error ~1e-5 at the tanh
/// friction's curvature, as the difference Jacobian it replaces).
SID_INLINE bool window_jacobian(const Model<double>& model, const Eigen::VectorXd& theta,
                                const WindowParameters& parameters,
                                const TorqueInterpolator& torque, const Eigen::VectorXd& t,
                                const OutputErrorWindow& w, const Vector2<double>& q0,
                                const Vector2<double>& qd0, const Vector2<double>& torque_offset,
                                const Vector2<double>& torque_slope, const Vector2<double>& sigma_q,
                                const SimulatorOptions& options, Eigen::MatrixXd& jacobian);

/// (measured − simulated q)/σq of window w, joint 1's samples then joint 2's.
SID_INLINE Eigen::VectorXd normalised_residual(const OutputErrorProblem& problem,
                                               const OutputErrorWindow& w,
                                               const Eigen::MatrixXd& q_simulated);

/// Threads for `windows` windows: options.threads, or the hardware's when 0.
SID_INLINE int output_error_threads(const OutputErrorOptions& options, Eigen::Index windows);

}  // namespace detail

/// @brief Levenberg–Marquardt on the normalised angle errors of every window, over the model's
/// parameters, log s (if estimated) and each window's initial state and torque correction, with
/// a Jacobian from forward sensitivities (one CVODES simulation per window, sid/cvode/
/// sensitivity.hpp) kept current between evaluations by Broyden updates.
/// @throws std::invalid_argument on inconsistent sizes or settings.
SID_INLINE OutputErrorFit fit_output_error(const OutputErrorProblem& problem,
                                           const OutputErrorOptions& options = {});

/// @brief Where the fit of a nested model (`fit`'s with some parameters held at given values)
/// starts: `fit`'s parameters and windows with the held ones moved and every other free unknown
/// re-adjusted to first order, the minimiser of the cost linearised at `fit` (the nonlinear
/// scalar held too: the held values are to remove what it shapes).
struct OutputErrorStart {
  Eigen::VectorXd theta;                   ///< fit.theta with the held values and the re-adjustment
  std::vector<OutputErrorWindow> windows;  ///< fit.windows, re-adjusted
};

/// @brief The first-order start (see OutputErrorStart) of a fit with parameters `held` (indices
/// into fit.theta) at `values`, from a fit that converged or stopped with its Jacobian.
/// @throws std::invalid_argument if the fit holds no normal matrix and gradient, or `held` and
///   `values` differ in size or name a parameter that does not exist.
SID_INLINE OutputErrorStart nested_start(const OutputErrorFit& fit,
                                         const std::vector<Eigen::Index>& held,
                                         const Eigen::Ref<const Eigen::VectorXd>& values);

/// @brief The score (Lagrange multiplier) test of one parameter added to a fitted model: does
/// moving it away from its null value lower the cost, once the fit's own unknowns re-adjust?
struct [[nodiscard]] OutputErrorScore {
  /// Squared score over its variance, scaled like the likelihood ratio: to first order the drop
  /// of the cost a refit with the parameter would give, in units of the noise (χ²(1) under the
  /// null when the residuals are independent).
  double statistic = 0;
  /// > 0: the cost falls as the parameter grows from its null value (< 0: as it shrinks).
  double direction = 0;
  bool completed = false;  ///< false if the fit had failed or a simulation failed

  bool ok() const noexcept { return completed; }
};

/// @brief Score test at `fit` (a solution of `problem`) of the model `extended`, whose parameters
/// are `theta_extended`: the fit's parameters with one added at index `added`, at its null value
/// (where `extended` is the fitted model). Costs one simulation per window, with the added
/// parameter moved by `step`.
/// @throws std::invalid_argument if the sizes do not match the fit's.
SID_INLINE OutputErrorScore output_error_score_test(const OutputErrorProblem& problem,
                                                    const OutputErrorFit& fit,
                                                    const Model<double>& extended,
                                                    const Eigen::VectorXd& theta_extended,
                                                    Eigen::Index added, double step,
                                                    const OutputErrorOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/output_error-inl.hpp>
#endif
