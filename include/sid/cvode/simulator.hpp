#pragma once
/// @file
/// @brief Simulation of a state-space model xdot = f(t, x) with SUNDIALS CVODE, sampled on a
/// given time grid. This header and the others under sid/cvode/ are the only ones that include
/// SUNDIALS (docs/design.md), so Eigen-only users never need it. They use CVODES, CVODE
/// with forward sensitivities (sid/cvode/sensitivity.hpp): the same solver and calls, and one
/// library, since the two define the same symbols.

#include <Eigen/Core>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_types.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>

namespace sid {

/// @brief How CVODE advances the solution. Measured on the paper's experiment (10 s, 4001
/// outputs, rtol = atol = 1e-10; bench/simulator_bench.cpp, tests/experiment_test.cpp):
/// AdamsNewton ~3100 steps, ~4100 RHS calls, max |q error| ~4e-9 rad; Bdf ~2800 steps but
/// ~4x the error (lower order); AdamsFixedPoint ~5700 steps, ~10000 RHS calls, and at 1e-12 it
/// needs 66000 steps, because the friction over the small link-2 inertia (|lambda| ~ 300 1/s)
/// limits the step for which functional iteration converges.
enum class IntegrationMethod {
  /// Adams-Moulton (orders 1-12), Newton iteration with a dense difference-quotient Jacobian.
  /// The default: the fastest accurate choice for the arm.
  AdamsNewton,
  /// Adams-Moulton solved by fixed-point (functional) iteration: no Jacobian and no linear
  /// algebra, best for truly non-stiff problems with a cheap RHS.
  AdamsFixedPoint,
  /// BDF (orders 1-5), Newton iteration with a dense difference-quotient Jacobian: the choice
  /// for stiff models (for example very large friction over very small inertia).
  Bdf,
};

/// @brief Settings of simulate(). The defaults integrate the paper's experiment to about
/// 4e-9 rad and 1e-8 rad/s (tests/experiment_test.cpp).
struct SimulatorOptions {
  /// Relative tolerance [-], > 0.
  double rtol = 1e-10;
  /// Absolute tolerance [units of the state], > 0.
  double atol = 1e-10;
  IntegrationMethod method = IntegrationMethod::AdamsNewton;
  /// Most internal steps CVODE may take between two consecutive output times, > 0.
  long max_steps = 100000;
  /// Largest internal step [s]; 0 means unlimited.
  double max_step = 0.0;
  /// First internal step [s]; 0 lets CVODE estimate it.
  double initial_step = 0.0;
};

/// @brief Outcome of a simulation; every value but Success means the states stop early.
enum class SimulationStatus {
  Success,
  TooMuchWork,          ///< CV_TOO_MUCH_WORK: max_steps taken before the next output time.
  TooMuchAccuracy,      ///< CV_TOO_MUCH_ACC: tolerances below what double precision can give.
  ErrorTestFailure,     ///< CV_ERR_FAILURE: local error test failed repeatedly (or |h| = hmin).
  ConvergenceFailure,   ///< CV_CONV_FAILURE: the nonlinear iteration failed repeatedly.
  LinearSolverFailure,  ///< CV_LSETUP_FAIL / CV_LSOLVE_FAIL: e.g. a singular Newton matrix.
  RhsFailure,           ///< The right-hand side threw an exception (see SimulationResult::message).
  NonFinite,            ///< The right-hand side or the state became NaN or infinite.
  OtherFailure,         ///< Any other CVODE failure (see flag_name and message).
};

/// @brief Name of a status, for messages ("Success", "TooMuchWork", ...).
inline const char* to_string(SimulationStatus status) {
  switch (status) {
    case SimulationStatus::Success:
      return "Success";
    case SimulationStatus::TooMuchWork:
      return "TooMuchWork";
    case SimulationStatus::TooMuchAccuracy:
      return "TooMuchAccuracy";
    case SimulationStatus::ErrorTestFailure:
      return "ErrorTestFailure";
    case SimulationStatus::ConvergenceFailure:
      return "ConvergenceFailure";
    case SimulationStatus::LinearSolverFailure:
      return "LinearSolverFailure";
    case SimulationStatus::RhsFailure:
      return "RhsFailure";
    case SimulationStatus::NonFinite:
      return "NonFinite";
    case SimulationStatus::OtherFailure:
      return "OtherFailure";
  }
  return "Unknown";
}

/// @brief CVODE's work counters for one simulation (cumulative over the whole grid).
struct SimulationStatistics {
  long steps = 0;
  /// All calls of the right-hand side, including those for difference-quotient Jacobians.
  long rhs_evaluations = 0;
  long error_test_failures = 0;
  long nonlinear_iterations = 0;
  long nonlinear_convergence_failures = 0;
  /// Jacobian evaluations (always 0 for IntegrationMethod::AdamsFixedPoint, which needs none).
  long jacobian_evaluations = 0;
};

/// @brief States of a simulation on its time grid.
/// Class invariant: states.rows() == t.size(); rows [0, completed) hold the states at t, the
/// rows from `completed` on (present only on failure) are NaN.
struct [[nodiscard]] SimulationResult {
  SimulationStatus status = SimulationStatus::Success;
  /// CVODE's name of the flag of the last CVode call ("CV_SUCCESS", "CV_TOO_MUCH_WORK", ...).
  std::string flag_name;
  /// Empty on success; otherwise CVODE's error message or the text of the RHS exception.
  std::string message;
  /// The output grid [s] (a copy of the argument).
  Eigen::VectorXd t;
  /// n_times x n_states.
  Eigen::MatrixXd states;
  /// Number of output times reached (t.size() on success).
  Eigen::Index completed = 0;
  /// Time CVODE reached [s]: the last grid time on success, the failure time otherwise.
  double t_reached = 0.0;
  SimulationStatistics statistics;

  bool ok() const { return status == SimulationStatus::Success; }
};

namespace detail {

static_assert(std::is_same_v<sunrealtype, double>,
              "sid::simulate requires SUNDIALS built with double precision (sunrealtype)");

// RAII owners for the SUNDIALS handles. Members of CvodeObjects are declared in creation
// order, so the CVODE memory is freed before the solvers, vectors and context it refers to.
struct SunContextDeleter {
  void operator()(SUNContext ctx) const noexcept { SUNContext_Free(&ctx); }
};
struct NVectorDeleter {
  void operator()(N_Vector v) const noexcept { N_VDestroy(v); }
};
struct SunMatrixDeleter {
  void operator()(SUNMatrix m) const noexcept { SUNMatDestroy(m); }
};
struct SunLinearSolverDeleter {
  void operator()(SUNLinearSolver s) const noexcept { SUNLinSolFree(s); }
};
struct SunNonlinearSolverDeleter {
  void operator()(SUNNonlinearSolver s) const noexcept { SUNNonlinSolFree(s); }
};
struct CvodeMemDeleter {
  void operator()(void* mem) const noexcept { CVodeFree(&mem); }
};
using SunContextPtr = std::unique_ptr<std::remove_pointer_t<SUNContext>, SunContextDeleter>;
using NVectorPtr = std::unique_ptr<std::remove_pointer_t<N_Vector>, NVectorDeleter>;
using SunMatrixPtr = std::unique_ptr<std::remove_pointer_t<SUNMatrix>, SunMatrixDeleter>;
using SunLinearSolverPtr =
    std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, SunLinearSolverDeleter>;
using SunNonlinearSolverPtr =
    std::unique_ptr<std::remove_pointer_t<SUNNonlinearSolver>, SunNonlinearSolverDeleter>;
using CvodeMemPtr = std::unique_ptr<void, CvodeMemDeleter>;

/// CVODE's name of a return flag; CVodeGetReturnFlagName hands over a malloc'ed string.
inline std::string cvode_flag_name(int flag) {
  char* name = CVodeGetReturnFlagName(flag);
  if (name == nullptr) return "flag " + std::to_string(flag);
  std::string result(name);
  std::free(name);
  return result;
}

/// A time [s] with all its digits: "t = 1.000000" would hide how close to 1 a blow-up got.
inline std::string format_time(double t) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", t);
  return buffer;
}

/// Setup calls fail only on exhausted memory or a SUNDIALS bug, not on validated input.
inline void check_setup(int flag, const char* call) {
  if (flag < 0)
    throw std::runtime_error(std::string("sid::simulate: ") + call + " failed with " +
                             cvode_flag_name(flag));
}

template <typename Rhs>
struct RhsContext {
  const Rhs* rhs;
  Eigen::Index n;
  std::string rhs_error;      // text of the exception the RHS threw
  std::string nonfinite;      // where the RHS produced a non-finite derivative
  std::string cvode_error;    // CVODE's last error message
  void* extension = nullptr;  // what an extension of the run (sensitivities) needs in callbacks
};

/// The run of simulate() without extension: nothing attached, nothing recorded.
struct NoExtension {
  template <typename Context>
  int attach(void* /*cvode_mem*/, N_Vector /*y*/, SUNContext /*ctx*/, Context& /*context*/) {
    return 0;
  }
  void record(void* /*cvode_mem*/, Eigen::Index /*k*/) {}
};

template <typename Rhs>
void evaluate_rhs(const Rhs& rhs, double t, const Eigen::Map<const Eigen::VectorXd>& x,
                  Eigen::Map<Eigen::VectorXd>& xdot) {
  using ConstMap = Eigen::Map<const Eigen::VectorXd>;
  using Map = Eigen::Map<Eigen::VectorXd>;
  if constexpr (std::is_invocable_v<const Rhs&, double, const ConstMap&, Map&>) {
    rhs(t, x, xdot);
  } else {
    static_assert(std::is_invocable_v<const Rhs&, double, const ConstMap&>,
                  "sid::simulate: rhs must be callable as rhs(t, x, xdot) (writing xdot) or as "
                  "xdot = rhs(t, x)");
    const Eigen::VectorXd value = rhs(t, x);
    if (value.size() != xdot.size())
      throw std::length_error("rhs returned " + std::to_string(value.size()) + " derivatives for " +
                              std::to_string(xdot.size()) + " states");
    xdot = value;
  }
}

// The C boundary: no exception may leave this function (CVODE is C and would be skipped over).
// A failure is sticky: once the RHS has thrown or produced a non-finite value, every later call
// fails too. Otherwise CVODE's fixed-point iteration counts the failure as a convergence failure,
// shrinks the step and creeps towards the failing time until max_steps runs out.
template <typename Rhs>
int cvode_rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user_data) noexcept {
  auto* context = static_cast<RhsContext<Rhs>*>(user_data);
  if (!context->rhs_error.empty() || !context->nonfinite.empty()) return -1;
  try {
    const Eigen::Map<const Eigen::VectorXd> x(N_VGetArrayPointer(y), context->n);
    Eigen::Map<Eigen::VectorXd> xdot(N_VGetArrayPointer(ydot), context->n);
    evaluate_rhs(*context->rhs, t, x, xdot);
    if (xdot.allFinite()) return 0;
    // A NaN or infinity is a model defect or a blow-up, not an overshoot a smaller step cures.
    context->nonfinite = x.allFinite()
                             ? "rhs returned a non-finite derivative at t = " + format_time(t)
                             : "non-finite state at t = " + format_time(t);
    return -1;
  } catch (const std::exception& e) {
    context->rhs_error = e.what();
  } catch (...) {
    context->rhs_error = "unknown exception";
  }
  if (context->rhs_error.empty()) context->rhs_error = "exception with an empty message";
  return -1;
}

template <typename Rhs>
void cvode_error_handler(int error_code, const char* module, const char* function, char* msg,
                         void* user_data) noexcept {
  if (error_code == CV_WARNING) return;  // e.g. "t + h = t": CVODE carries on; nothing to report
  auto* context = static_cast<RhsContext<Rhs>*>(user_data);
  try {
    context->cvode_error = std::string(module ? module : "CVODE") +
                           "::" + (function ? function : "?") + ": " + (msg ? msg : "");
  } catch (...) {
    // Out of memory while formatting: keep the flag name alone.
  }
}

inline SimulationStatus status_from_flag(int flag, bool rhs_threw, bool nonfinite) {
  // The RHS's own failure is the cause, whichever way CVODE reports its consequence.
  if (rhs_threw) return SimulationStatus::RhsFailure;
  if (nonfinite) return SimulationStatus::NonFinite;
  switch (flag) {
    case CV_TOO_MUCH_WORK:
      return SimulationStatus::TooMuchWork;
    case CV_TOO_MUCH_ACC:
      return SimulationStatus::TooMuchAccuracy;
    case CV_ERR_FAILURE:
      return SimulationStatus::ErrorTestFailure;
    case CV_CONV_FAILURE:
    case CV_NLS_FAIL:
      return SimulationStatus::ConvergenceFailure;
    case CV_LINIT_FAIL:
    case CV_LSETUP_FAIL:
    case CV_LSOLVE_FAIL:
      return SimulationStatus::LinearSolverFailure;
    case CV_RHSFUNC_FAIL:
    case CV_FIRST_RHSFUNC_ERR:
    case CV_REPTD_RHSFUNC_ERR:
    case CV_UNREC_RHSFUNC_ERR:
      return SimulationStatus::RhsFailure;
    default:
      return SimulationStatus::OtherFailure;
  }
}

inline void validate_simulation_input(const Eigen::Ref<const Eigen::VectorXd>& x0,
                                      const Eigen::Ref<const Eigen::VectorXd>& t,
                                      const SimulatorOptions& options) {
  using std::isfinite;
  if (x0.size() == 0) throw std::invalid_argument("sid::simulate: x0 must not be empty");
  if (!x0.allFinite()) throw std::invalid_argument("sid::simulate: x0 must be finite");
  if (t.size() == 0) throw std::invalid_argument("sid::simulate: t must not be empty");
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    if (!isfinite(t[i]))
      throw std::invalid_argument("sid::simulate: t[" + std::to_string(i) + "] is not finite");
    if (i > 0 && !(t[i] > t[i - 1]))
      throw std::invalid_argument("sid::simulate: t must be strictly increasing (t[" +
                                  std::to_string(i) + "] <= t[" + std::to_string(i - 1) + "])");
  }
  if (!(options.rtol > 0.0) || !isfinite(options.rtol))
    throw std::invalid_argument("sid::simulate: options.rtol must be finite and > 0");
  if (!(options.atol > 0.0) || !isfinite(options.atol))
    throw std::invalid_argument("sid::simulate: options.atol must be finite and > 0");
  if (options.max_steps <= 0)
    throw std::invalid_argument("sid::simulate: options.max_steps must be > 0");
  if (!(options.max_step >= 0.0) || !isfinite(options.max_step))
    throw std::invalid_argument("sid::simulate: options.max_step must be finite and >= 0");
  if (!(options.initial_step >= 0.0) || !isfinite(options.initial_step))
    throw std::invalid_argument("sid::simulate: options.initial_step must be finite and >= 0");
}

}  // namespace detail

namespace detail {

/// Newton iteration with a dense linear solver, unless the method is fixed-point iteration.
inline bool uses_newton(const SimulatorOptions& options) {
  return options.method != IntegrationMethod::AdamsFixedPoint;
}

/// The SUNDIALS objects of one run (see the deleters above for why this order).
struct CvodeObjects {
  SunContextPtr ctx;
  NVectorPtr y;
  SunMatrixPtr jacobian;
  SunLinearSolverPtr linear_solver;
  SunNonlinearSolverPtr fixed_point;
  CvodeMemPtr mem;
};

/// Creates the context, the state vector holding x0, the solver options.method needs and the
/// CVODE memory, in the order of CvodeObjects' members.
inline void create_cvode_objects(CvodeObjects& cvode, const Eigen::Ref<const Eigen::VectorXd>& x0,
                                 const SimulatorOptions& options) {
  const Eigen::Index n = x0.size();
  SUNContext raw_ctx = nullptr;
  check_setup(SUNContext_Create(nullptr, &raw_ctx), "SUNContext_Create");
  cvode.ctx.reset(raw_ctx);

  cvode.y.reset(N_VNew_Serial(static_cast<sunindextype>(n), cvode.ctx.get()));
  if (!cvode.y) throw std::bad_alloc();
  Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(cvode.y.get()), n) = x0;
  // Fused vector operations: one call per linear combination instead of one per term. The
  // arm's state has 4 entries, so CVODE's time goes into calls, not arithmetic.
  check_setup(N_VEnableFusedOps_Serial(cvode.y.get(), SUNTRUE), "N_VEnableFusedOps_Serial");

  if (uses_newton(options)) {
    cvode.jacobian.reset(SUNDenseMatrix(static_cast<sunindextype>(n), static_cast<sunindextype>(n),
                                        cvode.ctx.get()));
    if (!cvode.jacobian) throw std::bad_alloc();
    cvode.linear_solver.reset(
        SUNLinSol_Dense(cvode.y.get(), cvode.jacobian.get(), cvode.ctx.get()));
    if (!cvode.linear_solver) throw std::bad_alloc();
  } else {
    cvode.fixed_point.reset(SUNNonlinSol_FixedPoint(cvode.y.get(), 0, cvode.ctx.get()));
    if (!cvode.fixed_point) throw std::bad_alloc();
  }

  cvode.mem.reset(
      CVodeCreate(options.method == IntegrationMethod::Bdf ? CV_BDF : CV_ADAMS, cvode.ctx.get()));
  if (!cvode.mem) throw std::bad_alloc();
}

/// Connects the CVODE memory to the RHS, the error handler, the tolerances and step limits of
/// options, the stop time t.back() and the solver create_cvode_objects made.
template <typename Rhs>
void configure_cvode(const CvodeObjects& cvode, RhsContext<Rhs>& context,
                     const Eigen::Ref<const Eigen::VectorXd>& t, const SimulatorOptions& options) {
  void* cv = cvode.mem.get();
  check_setup(CVodeSetErrHandlerFn(cv, &cvode_error_handler<Rhs>, &context),
              "CVodeSetErrHandlerFn");
  check_setup(CVodeInit(cv, &cvode_rhs<Rhs>, t[0], cvode.y.get()), "CVodeInit");
  check_setup(CVodeSetUserData(cv, &context), "CVodeSetUserData");
  check_setup(CVodeSStolerances(cv, options.rtol, options.atol), "CVodeSStolerances");
  check_setup(CVodeSetMaxNumSteps(cv, options.max_steps), "CVodeSetMaxNumSteps");
  if (options.max_step > 0.0) check_setup(CVodeSetMaxStep(cv, options.max_step), "CVodeSetMaxStep");
  if (options.initial_step > 0.0)
    check_setup(CVodeSetInitStep(cv, options.initial_step), "CVodeSetInitStep");
  check_setup(CVodeSetStopTime(cv, t[t.size() - 1]), "CVodeSetStopTime");
  if (uses_newton(options)) {
    check_setup(CVodeSetLinearSolver(cv, cvode.linear_solver.get(), cvode.jacobian.get()),
                "CVodeSetLinearSolver");
  } else {
    check_setup(CVodeSetNonlinearSolver(cv, cvode.fixed_point.get()), "CVodeSetNonlinearSolver");
  }
}

/// Advances from output time to output time, storing each state in result, until the grid ends
/// or CVODE fails or the state turns non-finite; returns the flag of the last CVode call.
template <typename Rhs, typename Extension>
int integrate_over_grid(void* cv, N_Vector y, const Eigen::Ref<const Eigen::VectorXd>& t,
                        RhsContext<Rhs>& context, Extension& extension, SimulationResult& result) {
  int flag = CV_SUCCESS;
  const Eigen::Map<const Eigen::VectorXd> y_view(N_VGetArrayPointer(y), context.n);
  for (Eigen::Index k = 1; k < t.size(); ++k) {
    sunrealtype t_returned = t[k - 1];
    flag = CVode(cv, t[k], y, &t_returned, CV_NORMAL);
    result.t_reached = t_returned;
    if (flag < 0) {
      result.status =
          status_from_flag(flag, !context.rhs_error.empty(), !context.nonfinite.empty());
      break;
    }
    if (!y_view.allFinite()) {
      result.status = SimulationStatus::NonFinite;
      context.nonfinite = "non-finite state at t = " + format_time(t_returned);
      break;
    }
    result.states.row(k) = y_view.transpose();
    extension.record(cv, k);
    result.completed = k + 1;
  }
  return flag;
}

/// The message of a failed run: the RHS's own failure, then CVODE's error message.
template <typename Rhs>
void set_failure_message(const RhsContext<Rhs>& context, SimulationResult& result) {
  if (!context.rhs_error.empty())
    result.message = "rhs threw: " + context.rhs_error;
  else if (result.status == SimulationStatus::NonFinite)
    result.message = context.nonfinite;
  if (!context.cvode_error.empty())
    result.message += (result.message.empty() ? "" : "; ") + context.cvode_error;
}

/// CVODE's counters; a counter CVODE cannot report keeps its value in stats.
inline void read_cvode_statistics(void* cv, bool newton, SimulationStatistics& stats) {
  long count = 0;
  if (CVodeGetNumSteps(cv, &count) == CV_SUCCESS) stats.steps = count;
  if (CVodeGetNumRhsEvals(cv, &count) == CV_SUCCESS) stats.rhs_evaluations = count;
  if (CVodeGetNumErrTestFails(cv, &count) == CV_SUCCESS) stats.error_test_failures = count;
  if (CVodeGetNumNonlinSolvIters(cv, &count) == CV_SUCCESS) stats.nonlinear_iterations = count;
  if (CVodeGetNumNonlinSolvConvFails(cv, &count) == CV_SUCCESS)
    stats.nonlinear_convergence_failures = count;
  if (newton) {
    if (CVodeGetNumJacEvals(cv, &count) == CV_SUCCESS) stats.jacobian_evaluations = count;
    if (CVodeGetNumLinRhsEvals(cv, &count) == CV_SUCCESS) stats.rhs_evaluations += count;
  }
}

/// simulate(), with `extension` attached after the solver's setup (attach returns what must
/// live as long as the solver) and told of each output time reached (record).
template <typename Rhs, typename Extension>
SimulationResult run_cvode(const Rhs& rhs, const Eigen::Ref<const Eigen::VectorXd>& x0,
                           const Eigen::Ref<const Eigen::VectorXd>& t,
                           const SimulatorOptions& options, Extension& extension) {
  detail::validate_simulation_input(x0, t, options);
  const Eigen::Index n = x0.size();
  const Eigen::Index n_times = t.size();

  SimulationResult result;
  result.t = t;
  result.states.setConstant(n_times, n, std::numeric_limits<double>::quiet_NaN());
  result.states.row(0) = x0.transpose();
  result.completed = 1;
  result.t_reached = t[0];
  result.flag_name = detail::cvode_flag_name(CV_SUCCESS);
  if (n_times == 1) return result;

  detail::RhsContext<Rhs> context{&rhs, n, {}, {}, {}, nullptr};
  detail::CvodeObjects cvode;
  detail::create_cvode_objects(cvode, x0, options);
  detail::configure_cvode(cvode, context, t, options);
  void* cv = cvode.mem.get();
  [[maybe_unused]] const auto attachment =
      extension.attach(cv, cvode.y.get(), cvode.ctx.get(), context);

  const int flag = detail::integrate_over_grid(cv, cvode.y.get(), t, context, extension, result);
  result.flag_name = detail::cvode_flag_name(flag);
  if (!result.ok()) detail::set_failure_message(context, result);
  detail::read_cvode_statistics(cv, detail::uses_newton(options), result.statistics);
  return result;
}

}  // namespace detail

/// @brief Integrates xdot = f(t, x) from x(t[0]) = x0 and returns x at every time of t.
///
/// CVODE (Hindmarsh et al., ACM TOMS 31(3), 2005) steps with its own step size and interpolates
/// to each output time (CV_NORMAL mode); the stop time is set to t.back(), so the right-hand
/// side is never evaluated past the grid. An input u(t) is folded into rhs by the caller.
///
/// @tparam Rhs callable as `rhs(t, x, xdot)` writing the derivative into xdot (preferred: no
///   allocation), or as `xdot = rhs(t, x)` returning an Eigen vector. x is passed as
///   `const Eigen::Map<const Eigen::VectorXd>&`, xdot as `Eigen::Map<Eigen::VectorXd>&`; lambdas
///   taking `const Eigen::Ref<const Eigen::VectorXd>&` / `Eigen::Ref<Eigen::VectorXd>` or
///   `const auto&` / `auto&` work too. It may throw: the exception is caught at the C boundary
///   and reported as SimulationStatus::RhsFailure with its what() in the message.
/// @param[in] rhs right-hand side f(t [s], x) [state units / s].
/// @param[in] x0 initial state at t[0], finite, not empty.
/// @param[in] t output times [s], finite and strictly increasing; t[0] is the initial time.
/// @param[in] options tolerances, method and step limits.
/// @return the states (row k = x(t[k]), row 0 = x0), status, CVODE flag name and statistics.
/// @throws std::invalid_argument if x0, t or options are invalid (message names the argument).
template <typename Rhs>
SimulationResult simulate(const Rhs& rhs, const Eigen::Ref<const Eigen::VectorXd>& x0,
                          const Eigen::Ref<const Eigen::VectorXd>& t,
                          const SimulatorOptions& options = SimulatorOptions()) {
  detail::NoExtension none;
  return detail::run_cvode(rhs, x0, t, options, none);
}

}  // namespace sid
