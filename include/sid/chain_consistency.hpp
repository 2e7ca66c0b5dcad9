#pragma once
/// @file
/// @brief Physically consistent link parameters for an identified chain: the standard parameters
/// of every link (mass, centre of mass, inertia) that reproduce the identified base parameters
/// as closely as the data allow while each link is a real body, and stay near a prior (the
/// description's CAD values) where the data say nothing.
///
/// A link's ten parameters are a real body exactly when its pseudo-inertia
/// J = [[Σ, h], [hᵀ, m]] (Σ = tr(I)/2 · 1 − I about the frame's origin, h = m c) is positive
/// semidefinite (Wensing, Kim & Slotine 2018); a drive is real when its rotor inertia and its
/// viscous and Coulomb friction are positive (a log barrier each). The log-Cholesky parametrisation
/// (Rucker & Wensing 2022) writes J = U Uᵀ with U upper triangular, U = e^α [[e^d1, s12, s13, t1],
/// [0, e^d2, s23, t2], [0, 0, e^d3, t3], [0, 0, 0, 1]]: every one of its ten unconstrained
/// numbers gives a real body (J positive definite), and every real body with J positive definite
/// has one. The fit minimises
///   F(θ) = ‖R S (β(θ) − β̂)‖² + γ RSS ‖(θ − θ₀) / s‖²
/// over the parameters whose links are all real bodies: R S the triangular factor of the
/// identification's column-scaled base regressor, so the first term is the growth of the residual
/// sum of squares over the least-squares fit; the second holds the links near the prior (the
/// description) where the data say little, with s scaling each link's parameters by its prior
/// mass m0 and radius of gyration r0 (m0; m0 r0 for first moments; m0 r0² for inertias; a link
/// the prior gives no mass takes the mean m0 and r0² of those it does) and each drive term by
/// 1 + |its prior|.
///
/// γ is the prior's weight relative to the least-squares RSS. Read as a Gaussian prior of
/// standard deviation σ_p (ChainConsistencyOptions::prior_std) on each parameter in its link's
/// scale, F is the negative log posterior up to the factor 2 σ² when the first term is measured
/// in the estimate's own uncertainty: σ² = κ RSS / (N − r), N equations and r base parameters,
/// and κ ≥ 1 the factor by which the residuals' correlation in time inflates the variance of the
/// base parameters (the mean over them of the HAC variance over the uncorrelated one, when the
/// identification has HAC standard deviations; else 1). So γ = κ / ((N − r) σ_p²). Without κ a
/// misfit whose residuals are smooth in time (a drive term missing from the model) counts as
/// thousands of independent equations, and the fit turns the base parameters it biases into
/// bodies far from any real link (a 0.1 kg wrist with its centre of mass 0.7 m away on a UR5).
///
/// Whether real bodies reproduce the estimate at all is measured by the misfit
/// ‖R S (β(θ) − β̂)‖² / σ², about χ² with r degrees of freedom when the estimate is a real arm
/// plus noise: far above (ChainConsistentFit::fits_estimate), the estimate is no arm's, as when
/// the model lacks a term the data have, and the bodies are not a description of the arm.
///
/// F is quadratic and the set is convex (linear matrix inequalities J_i(θ) ⪰ 0), so the problem
/// is convex with one answer: it is solved by an interior-point method (Newton on
/// t F − Σ log det J_i, t growing tenfold, each centre found to a Newton decrement of 1e-6 of
/// the barrier's size) to within tolerance · RSS of the optimum. The log-Cholesky numbers give
/// it a start strictly inside.

#include <sid/config.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid {

/// @brief Options of consistent_chain_parameters.
struct ChainConsistencyOptions {
  /// σ_p, > 0: how well the prior is known, as a standard deviation relative to each link's
  /// scale (see the file comment); sets γ = κ / ((N − r) σ_p²) when prior_weight is 0.
  double prior_std = 1.0;
  /// γ, >= 0, relative to the least-squares fit's residual sum of squares; 0: from prior_std and
  /// the identification.
  double prior_weight = 0.0;
  /// Newton steps in all, >= 1: a guard against a loop, not a stopping rule (the problem is
  /// convex). An estimate far from every real arm (every mass negated) takes 500–700 steps,
  /// depending on the machine's rounding.
  int max_iterations = 2000;
  /// The answer's cost is within tolerance times the least-squares RSS of the optimum.
  double tolerance = 1e-7;
};

/// @brief What consistent_chain_parameters found.
struct ChainConsistentFit {
  /// Every parameter of the model: ten per link (each a real body), then the drive terms (rotor
  /// inertias and friction levels positive).
  Eigen::VectorXd theta;
  Eigen::VectorXd beta;  ///< the base parameters they give
  /// The relative residual ‖τ − Yθ‖ / ‖τ‖ over the identification's equations, and the
  /// least-squares fit's beside it: how much worse a real body fits.
  double relative_residual = 0.0;
  double least_squares_relative_residual = 0.0;
  int iterations = 0;
  /// The interior point reached tolerance within max_iterations; when false, theta is the last
  /// iterate (every link a real body, but not the optimum) and is not to be used as a result.
  bool converged = false;
  double prior_weight = 0.0;  ///< the γ used, relative to the least-squares RSS
  /// κ, from the identification's HAC standard deviations (1 without them)
  double correlation_inflation = 1.0;
  /// How far β is from the least-squares estimate in the estimate's own uncertainty:
  /// ‖R S (β − β̂)‖² (N − r) / (κ RSS), about χ² with r degrees of freedom when the estimate is a
  /// real arm plus noise (less, as the prior pulls only where the data say little).
  double misfit = 0.0;
  /// r + 3 √(2 r): about the largest misfit noise alone gives.
  double misfit_limit = 0.0;
  /// misfit ≤ misfit_limit: real bodies reproduce the estimate within its uncertainty. When
  /// false, no set of real bodies near it fits the data as well: the model lacks something
  /// the data have (a drive term), and theta is not a description of the arm.
  bool fits_estimate = false;
  /// Per link: why the prior's parameters are not a real body ("" when they are); such a link
  /// starts from the nearest one that is.
  std::vector<std::string> prior_inconsistency;
};

/// @brief The link parameters of a pseudo-inertia's log-Cholesky numbers
/// [α, d1, d2, d3, s12, s23, s13, t1, t2, t3].
SID_INLINE LinkParameters<double> link_parameters_from_log_cholesky(
    const Eigen::Ref<const Eigen::Matrix<double, 10, 1>>& xi);

/// @brief The log-Cholesky numbers of a link whose pseudo-inertia is positive definite; one that
/// is not (a massless or flat CAD link) is first moved inside by the smallest multiple of the
/// identity that makes it so (1e-6 of its trace, at least 1e-9).
SID_INLINE Eigen::Matrix<double, 10, 1> log_cholesky_from_link_parameters(
    const LinkParameters<double>& phi);

/// @brief Physically consistent parameters for an identification of model (see the file comment).
/// @param prior the model's full parameter vector to stay near where the data say nothing (e.g.
///        the URDF's CAD values, drive terms 0); empty: every link 1 kg at its origin with
///        0.01 kg m² about each axis.
/// @throws std::invalid_argument if the identification failed or does not belong to model, the
///         prior has the wrong size or is not finite, or the options are invalid (prior_std not
///         > 0, prior_weight < 0, max_iterations < 1, tolerance not > 0).
SID_INLINE ChainConsistentFit consistent_chain_parameters(
    const ChainModel& model, const ChainIdentification& identification,
    const Eigen::VectorXd& prior = {}, const ChainConsistencyOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/chain_consistency-inl.hpp>
#endif
