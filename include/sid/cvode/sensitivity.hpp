#pragma once
/// @file
/// @brief Simulation with forward sensitivities (CVODES): x(t) and S(t) = dx(t)/dp for a set of
/// parameters p, from ṡ_i = (∂f/∂x) s_i + ∂f/∂p_i integrated beside the state.
///
/// Why, next to finite differences of simulate(): a difference quotient costs one simulation per
/// parameter, and its accuracy is bounded by the integrator's (its step must be large against
/// rtol and small against the curvature). The sensitivity system reuses the state's steps and
/// Newton matrix, so many parameters cost a few simulations' time, and it is exact to the
/// integrator's accuracy.

#include <sid/cvode/simulator.hpp>

#include <Eigen/Core>

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>

#include <exception>
#include <limits>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace sid {

/// @brief A simulation's states and their sensitivities on its time grid.
struct [[nodiscard]] SensitivityResult {
  SimulationResult simulation;
  /// n_times x (n_states * n_parameters): row k is dx(t_k)/dp stored column by column (the
  /// state index runs fastest); rows from simulation.completed on are NaN.
  Eigen::MatrixXd sensitivities;

  bool ok() const { return simulation.ok(); }
  /// dx(t_k)/dp, n_states x n_parameters.
  Eigen::MatrixXd at(Eigen::Index k) const {
    const Eigen::Index n = simulation.states.cols();
    return Eigen::Map<const Eigen::MatrixXd, 0, Eigen::InnerStride<>>(
        sensitivities.row(k).data(), n, sensitivities.cols() / n,
        Eigen::InnerStride<>(sensitivities.outerStride()));
  }
};

namespace detail {

struct NVectorArrayDeleter {
  int count;
  void operator()(N_Vector* v) const noexcept { N_VDestroyVectorArray(v, count); }
};
using NVectorArrayPtr = std::unique_ptr<N_Vector, NVectorArrayDeleter>;

template <typename SensitivityRhs>
struct SensitivityExtension {
  const SensitivityRhs* sensitivity_rhs;
  const Eigen::MatrixXd* initial;  // n x ns
  double rtol, atol;
  Eigen::MatrixXd* out;     // n_times x n*ns
  Eigen::MatrixXd s, sdot;  // n x ns, copies of CVODES's vectors for the callback
  N_Vector* vectors = nullptr;

  Eigen::Index states() const { return initial->rows(); }
  int count() const { return static_cast<int>(initial->cols()); }

  template <typename Rhs>
  NVectorArrayPtr attach(void* cv, N_Vector y, SUNContext /*ctx*/, RhsContext<Rhs>& context);

  void record(void* cv, Eigen::Index k) {
    sunrealtype t_returned = 0;
    check_setup(CVodeGetSens(cv, &t_returned, vectors), "CVodeGetSens");
    const Eigen::Index n = states();
    for (int i = 0; i < count(); ++i)
      out->row(k).segment(i * n, n) =
          Eigen::Map<const Eigen::VectorXd>(N_VGetArrayPointer(vectors[i]), n).transpose();
  }
};

// The C boundary of the sensitivity right-hand side: no exception may leave it.
template <typename Rhs, typename SensitivityRhs>
int cvodes_sensitivity_rhs(int ns, sunrealtype t, N_Vector y, N_Vector ydot, N_Vector* ys,
                           N_Vector* ysdot, void* user_data, N_Vector /*tmp1*/,
                           N_Vector /*tmp2*/) noexcept {
  auto* context = static_cast<RhsContext<Rhs>*>(user_data);
  auto* extension = static_cast<SensitivityExtension<SensitivityRhs>*>(context->extension);
  if (!context->rhs_error.empty() || !context->nonfinite.empty()) return -1;
  const Eigen::Index n = context->n;
  try {
    for (int i = 0; i < ns; ++i)
      extension->s.col(i) = Eigen::Map<const Eigen::VectorXd>(N_VGetArrayPointer(ys[i]), n);
    const Eigen::Map<const Eigen::VectorXd> x(N_VGetArrayPointer(y), n);
    const Eigen::Map<const Eigen::VectorXd> xdot(N_VGetArrayPointer(ydot), n);
    (*extension->sensitivity_rhs)(t, x, xdot, extension->s, extension->sdot);
    if (!extension->sdot.allFinite()) {
      context->nonfinite =
          "the sensitivity rhs returned a non-finite derivative at t = " + format_time(t);
      return -1;
    }
    for (int i = 0; i < ns; ++i)
      Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(ysdot[i]), n) = extension->sdot.col(i);
    return 0;
  } catch (const std::exception& e) {
    context->rhs_error = std::string("sensitivity rhs: ") + e.what();
  } catch (...) {
    context->rhs_error = "sensitivity rhs: unknown exception";
  }
  return -1;
}

template <typename SensitivityRhs>
template <typename Rhs>
NVectorArrayPtr SensitivityExtension<SensitivityRhs>::attach(void* cv, N_Vector y,
                                                             SUNContext /*ctx*/,
                                                             RhsContext<Rhs>& context) {
  const int ns = count();
  NVectorArrayPtr owner(N_VCloneVectorArray(ns, y), NVectorArrayDeleter{ns});
  if (!owner) throw std::bad_alloc();
  vectors = owner.get();
  for (int i = 0; i < ns; ++i)
    Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(vectors[i]), states()) = initial->col(i);
  context.extension = this;
  // Staggered: the state's corrector converges first, then the sensitivities' (linear in S)
  // reuse its Newton matrix. The sensitivities stay out of the error test: the steps are the
  // state's, so adding them changes nothing the caller simulates without them.
  check_setup(
      CVodeSensInit(cv, ns, CV_STAGGERED, &cvodes_sensitivity_rhs<Rhs, SensitivityRhs>, vectors),
      "CVodeSensInit");
  std::vector<double> atol_s(static_cast<std::size_t>(ns), atol);
  check_setup(CVodeSensSStolerances(cv, rtol, atol_s.data()), "CVodeSensSStolerances");
  check_setup(CVodeSetSensErrCon(cv, SUNFALSE), "CVodeSetSensErrCon");
  return owner;
}

}  // namespace detail

/// @brief Integrates xdot = f(t, x) from x0 together with S = dx/dp from S(t[0]) = s0.
/// @tparam Rhs as for simulate().
/// @tparam SensitivityRhs callable as `sensitivity_rhs(t, x, xdot, S, Sdot)` with x and xdot as
///   `const Eigen::Map<const Eigen::VectorXd>&` (xdot = f(t, x), already evaluated), S as
///   `const Eigen::MatrixXd&` (n x n_parameters) and Sdot as `Eigen::MatrixXd&` (the same size,
///   to be written): Sdot = (∂f/∂x) S + ∂f/∂p. It may throw, like rhs.
/// @param s0 dx0/dp, x0.size() x n_parameters, finite, at least one column.
/// @return the states as simulate() returns them, and the sensitivities at every output time.
/// @throws std::invalid_argument as simulate() does, or if s0 has the wrong size or is not finite.
template <typename Rhs, typename SensitivityRhs>
SensitivityResult simulate_with_sensitivities(
    const Rhs& rhs, const SensitivityRhs& sensitivity_rhs,
    const Eigen::Ref<const Eigen::VectorXd>& x0, const Eigen::Ref<const Eigen::MatrixXd>& s0,
    const Eigen::Ref<const Eigen::VectorXd>& t,
    const SimulatorOptions& options = SimulatorOptions()) {
  if (s0.rows() != x0.size() || s0.cols() < 1)
    throw std::invalid_argument(
        "sid::simulate_with_sensitivities: s0 must have x0.size() rows and >= 1 column");
  if (!s0.allFinite())
    throw std::invalid_argument("sid::simulate_with_sensitivities: s0 must be finite");
  if (options.method == IntegrationMethod::AdamsFixedPoint)
    throw std::invalid_argument(
        "sid::simulate_with_sensitivities: needs a Newton method (AdamsNewton or Bdf)");
  const Eigen::MatrixXd initial = s0;
  SensitivityResult result;
  result.sensitivities.setConstant(t.size(), s0.size(), std::numeric_limits<double>::quiet_NaN());
  if (t.size() > 0)
    result.sensitivities.row(0) = Eigen::Map<const Eigen::VectorXd>(initial.data(), initial.size());
  detail::SensitivityExtension<SensitivityRhs> extension{
      &sensitivity_rhs,      &initial, options.rtol, options.atol,
      &result.sensitivities, initial,  initial,      nullptr};
  result.simulation = detail::run_cvode(rhs, x0, t, options, extension);
  return result;
}

}  // namespace sid
