#pragma once
/// @file
/// @brief The identification pipeline of the paper: measured (t, q, τ) → q̇, q̈ by a chosen
/// method → window → regressor X, y (eq. 10) → QR least squares.

#include <sid/butterworth.hpp>
#include <sid/config.hpp>
#include <sid/finite_difference.hpp>
#include <sid/least_squares.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/smoothing_spline.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief How q̇ and q̈ are obtained from the measured q.
enum class DerivativeMethod {
  ForwardDifference,  ///< "raw": q̇ᵢ = (qᵢ₊₁ − qᵢ)/Ts, q̈ likewise from q̇ (paper eq. 47–48)
  FilteredDifference,  ///< "filtered": the same, then q, q̇, q̈ each filtered by filtfilt
  SmoothingSpline,     ///< "css": Reinsch spline per joint, derivatives analytic
};

/// @brief The method's short name as used by the apps and reports.
SID_INLINE const char* method_name(DerivativeMethod method);

/// @brief Parses "raw", "filtered" or "css". @throws std::invalid_argument otherwise.
SID_INLINE DerivativeMethod parse_derivative_method(const std::string& name);

/// @brief How CSS chooses its smoothing (the paper: the S constraint with δq = σq).
enum class SmoothingMode {
  SConstraint,  ///< F = Σ((g − q)/δq)² = S (default S = n): needs the noise level δq
  Gcv,          ///< λ minimising generalized cross-validation: needs no noise level
  Cv,           ///< λ minimising leave-one-out cross-validation
  Lambda,       ///< a given λ (penalty form, weights 1/δq²)
};

SID_INLINE const char* smoothing_mode_name(SmoothingMode mode);

/// @throws std::invalid_argument for a name other than s-constraint, gcv, cv, lambda.
SID_INLINE SmoothingMode parse_smoothing_mode(const std::string& name);

/// @brief What the CSS smoothing chose, per joint (NaN where a mode does not compute it).
struct SmoothingReport {
  Vector2<double> p = Vector2<double>::Constant(std::nan(""));       ///< Reinsch's p = 1/λ
  Vector2<double> lambda = Vector2<double>::Constant(std::nan(""));  ///< λ
  Vector2<double> trace = Vector2<double>::Constant(std::nan(""));   ///< tr A: degrees of freedom
  Vector2<double> sigma = Vector2<double>::Constant(std::nan(""));   ///< σ̂ [rad] (GCV/CV)
};

/// @brief Butterworth low-pass settings of the filtered method (order, cutoff relative to
/// Nyquist). Defaults are the paper's: 10 Hz, 3 Hz and 2 Hz at 400 Hz sampling.
struct DifferenceFilters {
  int q_order = 3;
  double q_cutoff = 0.05;
  int qd_order = 3;
  double qd_cutoff = 0.015;
  int qdd_order = 4;
  double qdd_cutoff = 0.01;
};

/// @brief IdentifyOptions::cross_validation_lambda_scale for the IV step (study method css_iv,
/// sid_identify --estimator iv): GCV's λ is optimal for q, but the smoothing bias it leaves in
/// q̇ and q̈ (θ5 −2.3 %, θ2 −3 % at σq² = 1e-4) is systematic and the IV step cannot remove it,
/// while the extra noise of a 4× smaller λ is exactly what IV does remove. Measured over
/// 300 runs at σq² = 1e-4: RMS relative error 2.39 % (scale 1), 2.30 % (0.5), 2.29 % (0.25),
/// oracle 2.04 %; scale 0.1 is worse again (the first LS estimate degrades).
inline constexpr double kInstrumentalVariableLambdaScale = 0.25;

/// @brief Options of the identification pipeline.
struct IdentifyOptions {
  DerivativeMethod method = DerivativeMethod::SmoothingSpline;
  /// δq per joint [rad]: the standard deviation the CSS constraint assumes (paper: δq = σq).
  Vector2<double> sigma_q = Vector2<double>::Constant(1e-3);
  /// S of the CSS constraint; empty = number of samples (the paper's choice).
  std::optional<double> S;
  /// How CSS smooths; GCV and CV ignore sigma_q (all samples weigh the same).
  SmoothingMode smoothing = SmoothingMode::SConstraint;
  /// GCV and CV choose one λ for the whole record, so a sharp start transient (which the
  /// window drops anyway) would pull λ toward interpolation everywhere. They therefore smooth
  /// only the samples with t >= t₀ + cross_validation_skip [s] (keep it below `skip`: the
  /// natural end condition distorts q̈ over the first few samples of the fit).
  double cross_validation_skip = 0.125;
  /// GCV and CV use λ_chosen × this factor [-], > 0. GCV's λ is optimal for q itself; q̇ and q̈
  /// are best estimated with less smoothing, whose extra noise the IV step tolerates while the
  /// smoothing bias it removes would otherwise stay in θ̂ (see study method css_iv).
  double cross_validation_lambda_scale = 1.0;
  /// λ for SmoothingMode::Lambda (SciPy's `lam` with w = 1/δq²) [rad⁻² s³ units of ∫g''²].
  double lambda = std::nan("");
  /// Samples with t < t₀ + skip are dropped (the start transient) [s].
  double skip = 0.25;
  /// The filtered method drops t < t₀ + filtered_skip instead (filter start-up) [s].
  double filtered_skip = 1.7475;
  /// Samples with t > t_last − skip_end are dropped too [s]. The paper keeps them (0), but a
  /// natural spline has g'' = 0 at the last knot, so CSS's q̈ is wrong over the last few
  /// samples unless the motion happens to stop there.
  double skip_end = 0.0;
  DifferenceFilters filters;
  /// Gautier's weighted least squares (per-joint noise from a first fit) instead of plain LS.
  bool weighted = false;
  double gravity = kPaperGravity;  ///< [m/s²]
  LeastSquaresOptions least_squares;
};

/// @brief What the pipeline found, with everything needed to report it.
struct Identification {
  DerivativeMethod method = DerivativeMethod::SmoothingSpline;
  Kinematics<double> kinematics;  ///< the samples used (after the window)
  LeastSquaresResult<double> fit;
  /// Reinsch's p per joint (CSS only; NaN otherwise).
  Vector2<double> smoothing_p = Vector2<double>::Constant(std::nan(""));
  /// Everything the CSS smoothing chose (CSS only).
  SmoothingReport smoothing;

  Eigen::Index samples_used() const { return kinematics.size(); }
};

namespace detail {

/// Sampling period of a uniform grid. @throws std::invalid_argument if t is not uniform.
SID_INLINE double uniform_period(const VectorX<double>& t, const char* who);

SID_INLINE Kinematics<double> rows_of(const Trajectory<double>& data, Eigen::Index begin,
                                      Eigen::Index count);

}  // namespace detail

/// @brief q, q̇, q̈ (and τ) at every sample the method can produce: all n for CSS, the first
/// n − 2 for the difference methods (q̈ needs qᵢ₊₂). For the filtered method q, q̇, q̈ are the
/// filtered signals. Smoothing parameters p are written to *p_out when given.
/// @throws std::invalid_argument on an invalid trajectory, too few samples, non-uniform sampling
/// for the difference methods, or δq <= 0.
SID_INLINE Kinematics<double> estimate_kinematics(const Trajectory<double>& data,
                                                  const IdentifyOptions& options,
                                                  SmoothingReport* report = nullptr);

/// @brief The samples with t_from <= t <= t_to (a small tolerance keeps a sample that sits on a
/// bound despite rounding, e.g. 100 · 0.0025).
SID_INLINE Kinematics<double> window(const Kinematics<double>& k, double t_from,
                                     double t_to = std::numeric_limits<double>::infinity());

/// @brief The paper's 7 parameter names, "theta1".."theta7".
SID_INLINE std::vector<std::string> two_link_parameter_names();

/// @brief Least squares of the two-link arm on given kinematics (joint 1's rows, then joint 2's).
/// @throws std::invalid_argument if there are not more equations than parameters.
SID_INLINE LeastSquaresResult<double> fit_two_link(const Kinematics<double>& k, double gravity,
                                                   LeastSquaresOptions options = {});

/// @brief Gautier's IDIM-WLS: an ordinary fit first, then each joint's rows weighted by
/// 1/σ̂ⱼ² from that fit's per-joint residual variance, so a joint with noisier torques counts
/// less. The result's covariance is then σ̂²(XᵀWX)⁻¹ with σ̂² ≈ 1, and its relative standard
/// deviations are the ones Gautier reports. A rank-deficient first fit is returned as it is.
SID_INLINE LeastSquaresResult<double> fit_two_link_weighted(const Kinematics<double>& k,
                                                            double gravity,
                                                            LeastSquaresOptions options = {});

/// @brief The whole pipeline: derivatives by options.method, window, least squares.
/// A rank-deficient regressor is reported in result.fit.status (not thrown).
/// @throws std::invalid_argument on bad input (see estimate_kinematics) or when the window
/// leaves too few samples.
SID_INLINE Identification identify(const Trajectory<double>& data,
                                   const IdentifyOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/identify-inl.hpp>
#endif
