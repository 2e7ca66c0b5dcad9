#pragma once
/// @file
/// @brief Heteroskedasticity- and autocorrelation-consistent (HAC) covariance by Newey & West
/// (1987) with Andrews' (1991) data-driven bandwidth, the Wald test it feeds, and the chi-square
/// tail probabilities and quantiles the test needs.
///
/// Why: residuals of a fit on smoothed kinematics are coloured (a smoothing spline's error in q̈
/// is correlated over tens of samples), so an ordinary least-squares covariance is over-confident
/// and would "discover" effects in pure noise.

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sid/config.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

namespace detail {

/// Regularized lower incomplete gamma P(a, x) by its series (converges fast for x < a + 1).
SID_INLINE double gamma_p_series(double a, double x);

/// Regularized upper incomplete gamma Q(a, x) by Lentz's continued fraction (x >= a + 1).
SID_INLINE double gamma_q_continued_fraction(double a, double x);

}  // namespace detail

/// @brief Regularized upper incomplete gamma function Q(a, x) = Γ(a, x)/Γ(a) (Numerical Recipes
/// §6.2: series below a + 1, continued fraction above).
/// @throws std::invalid_argument for a <= 0 or x < 0 (or NaN).
SID_INLINE double regularized_gamma_q(double a, double x);

/// @brief P(χ²_df > x), the chi-square tail probability (p-value of a statistic x).
/// @throws std::invalid_argument for df <= 0 or x < 0.
SID_INLINE double chi_square_tail(double x, double df);

/// @brief The x with P(χ²_df > x) = alpha (the critical value of a level-alpha test), by
/// bisection on the monotone tail (to 1e-12 relative).
/// @throws std::invalid_argument for alpha outside (0, 1) or df <= 0.
SID_INLINE double chi_square_critical(double alpha, double df);

/// @brief Andrews' (1991, eq. 6.2 and 6.4) AR(1) plug-in bandwidth of the Bartlett kernel for the
/// rows of scores (n x k, one time per row): L = 1.1447 (α̂ n)^(1/3) with
/// α̂ = Σ_a 4ρ_a²σ_a⁴/((1−ρ_a)⁶(1+ρ_a)²) / Σ_a σ_a⁴/(1−ρ_a)⁴ from an AR(1) fit per column.
/// ρ is clipped to [-0.97, 0.97] (a unit root has no long-run variance) and L to [1, n/4].
/// @return the truncation lag L (the Bartlett weights are 1 − l/(L + 1)).
SID_INLINE int newey_west_bandwidth(const Eigen::Ref<const Eigen::MatrixXd>& scores);

/// @brief Newey–West long-run sum S = Σ_{|l|<=L} (1 − |l|/(L+1)) Γ_l, Γ_l = Σ_t g_t g_{t−l}ᵀ, of
/// the score rows g_t (scores n x k). For OLS scores g_t = x_t e_t the HAC covariance of θ̂ is
/// (XᵀX)⁻¹ S (XᵀX)⁻¹. The scores are used as they are (not centred: OLS scores sum to zero).
/// @throws std::invalid_argument for lag < 0.
SID_INLINE Eigen::MatrixXd newey_west_sum(const Eigen::Ref<const Eigen::MatrixXd>& scores, int lag);

/// @brief HAC long-run sum of score rows with VAR(1) prewhitening (Andrews & Monahan 1992):
/// fit g_t = Bᵀ g_{t−1} + u_t by least squares (singular values of B capped at 0.97), take the
/// Newey–West sum of u at Andrews' bandwidth, and recolour: S = (I − Bᵀ)⁻¹ S_u (I − Bᵀ)⁻ᵀ.
/// Why: Bartlett's kernel alone under-estimates a strongly autocorrelated long-run variance (about
/// −10 % for an AR(1) with φ = 0.8 at n = 4000), which would make the tests anti-conservative;
/// the residuals of fits on smoothed kinematics are that strongly correlated.
/// Scaled by n/(n − 1) for the sample the whitening loses. Falls back to plain Newey–West for
/// fewer than 3 k + 8 rows.
SID_INLINE Eigen::MatrixXd hac_long_run_sum(const Eigen::Ref<const Eigen::MatrixXd>& scores);

/// @brief vᵀ S v for each column v of `directions` (k rows), S = hac_long_run_sum(scores): the
/// same prewhitening and bandwidth, but each form is the Newey–West sum of one series, the
/// whitened scores times (I − B)⁻¹ v, so the k × k lagged products are never formed.
/// Why: the variance of a few combinations of many parameters (the named terms of a fit on 60
/// columns) in O(n k²) instead of O(n k² L), L the bandwidth; equal to S's forms to rounding.
SID_INLINE Eigen::VectorXd hac_long_run_quadratic(
    const Eigen::Ref<const Eigen::MatrixXd>& scores,
    const Eigen::Ref<const Eigen::MatrixXd>& directions);

/// @brief One run's rows of a least-squares fit on stacked runs, for hac_sandwich(): the rows'
/// columns x (as fitted), each row's weight times its residual, and the sample each row belongs
/// to, at[r] in [0, positions): a sample's rows (one per joint) share one score, their residuals
/// being correlated too.
struct HacRun {
  Eigen::Ref<const Eigen::MatrixXd> x;
  Eigen::Ref<const Eigen::VectorXd> weighted_residual;
  const std::vector<Eigen::Index>& at;
  Eigen::Index positions;
};

/// @brief The HAC covariance of a least-squares estimate on stacked runs: per run, the scores
/// (each sample's rows' weighted residual times their columns, summed) and their long-run sum
/// (hac_long_run_sum); runs independent, the sums added; the sandwich bread S bread around
/// bread = (XᵀWX)⁻¹.
/// @throws std::invalid_argument when a run's sizes disagree or a row's sample is out of range.
SID_INLINE Eigen::MatrixXd hac_sandwich(const std::vector<HacRun>& runs,
                                        const Eigen::Ref<const Eigen::MatrixXd>& bread);

/// @brief Wald statistic γ̂ᵀ V⁻¹ γ̂ (V symmetric positive definite; pseudo-inverse otherwise).
SID_INLINE double wald_statistic(const Eigen::Ref<const Eigen::VectorXd>& gamma,
                                 const Eigen::Ref<const Eigen::MatrixXd>& covariance);

/// @brief Holm's step-down adjustment of a family's p-values: the r-th smallest is multiplied by
/// the number of hypotheses not yet rejected and kept monotone, capped at 1.
SID_INLINE std::vector<double> holm_adjusted(const std::vector<double>& p);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/diagnosis/hac-inl.hpp>
#endif
