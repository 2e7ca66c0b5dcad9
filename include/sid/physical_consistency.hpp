#pragma once
/// @file
/// @brief Physical consistency of an identified arm model: check_physical says whether the mass
/// matrix D(theta, q) is positive definite at every q2 and whether the parameters that cannot be
/// negative (gravity moments, friction levels, armature) are not; nearest_physical returns the
/// least-squares estimate closest to the data among the parameters that pass.
///
/// Why it matters: least squares alone can return a D that is indefinite at some posture (the arm
/// would then "accelerate against the applied torque") or a negative friction that feeds energy
/// in; a simulation or a controller built on such a model diverges. Both checks only use the
/// model's mass matrix, which is linear in theta:
///   D(theta, q) = sum_k theta_k A_k(q),  A_k(q) = mass_matrix(e_k, q),
/// so "D positive definite on a grid of q2" is a set of 2 x 2 linear matrix inequalities and
/// nearest_physical is a convex problem (a quadratic cost, LMIs and bounds) with a unique answer.
///
/// The grid: q2 = -pi + 2 pi g / grid_size, g = 0..grid_size-1, at q1 = 0. The arm's D depends on
/// q2 only, through cos q2 (and sin q2 with angle_offset_q2), so the grid covers every posture;
/// with an even grid_size it holds q2 = 0 and q2 = -pi, where the arm's det D = theta1 theta2 -
/// theta3^2 cos^2 q2 is smallest, and the grid check is then exact for the arm.

#include <sid/config.hpp>
#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief What physical consistency means for a model.
struct PhysicalConstraints {
  /// Names of the parameters that must be >= 0. Names the model does not have are ignored, so one
  /// list can serve models with and without a given effect. std::nullopt (the default) selects
  /// default_physical_constraints(model)'s list; an empty list bounds nothing.
  std::optional<std::vector<std::string>> nonnegative;
  /// Number of q2 grid points on [-pi, pi) at which D must be positive definite, >= 1.
  Eigen::Index grid_size = 360;
};

/// @brief The constraints physics imposes whatever the data: theta4, theta5 (m lc products: the
/// gravity moments; negative would put the centre of mass behind the joint of a link hanging
/// down, which the convention q = 0 downward excludes), theta6, theta7 (viscous friction
/// dissipates) and every parameter named "*.Fc" (Coulomb level) or "*.Ia" (rotor inertia).
/// Stribeck's "Fs_minus_Fc", offsets and springs may have either sign and are left free.
SID_INLINE PhysicalConstraints default_physical_constraints(const Model<double>& model);

/// @brief Result of check_physical.
struct PhysicalCheck {
  /// min_eigenvalue > 0: D(theta, q) positive definite at every grid point.
  bool mass_matrix_positive_definite = false;
  double min_eigenvalue = 0.0;     ///< smallest eigenvalue of D over the grid [kg m^2]
  double min_eigenvalue_q2 = 0.0;  ///< q2 of that grid point [rad]
  /// Parameters that must be >= 0 but are negative, in theta order, and their values.
  std::vector<std::string> negative_parameters;
  std::vector<double> negative_values;

  bool plausible() const noexcept {
    return mass_matrix_positive_definite && negative_parameters.empty();
  }
};

/// @brief Options of nearest_physical.
struct NearestPhysicalOptions {
  /// The answer satisfies D(theta, q2_g) >= margin * s_D * I with s_D the largest |eigenvalue| of
  /// D(theta_hat, q2_g) over the grid (0 if that vanishes) [-], >= 0. A margin keeps the answer
  /// strictly inside (D invertible, check_physical agreeing despite rounding); 1e-9 moves the
  /// answer by an amount far below any estimate's standard deviation.
  double margin = 1e-9;
  /// Stop when the duality-gap bound nu / t (nu = 2 grid_size + number of bounds) is at most
  /// tolerance * ||X theta - y||^2 [-], > 0: the cost is then optimal to this relative accuracy.
  double tolerance = 1e-10;
  /// Newton steps over both phases (finding a start, then the fit), >= 1.
  int max_iterations = 500;
};

/// @brief Result of nearest_physical.
struct [[nodiscard]] ConsistentEstimate {
  Eigen::VectorXd theta;                ///< the constrained estimate
  Eigen::VectorXd theta_unconstrained;  ///< ordinary least squares, theta_hat
  /// false: theta_hat already satisfied the constraints and theta == theta_hat exactly.
  bool changed = false;
  /// ||X theta - y||^2 - ||X theta_hat - y||^2 >= 0, computed as ||R (theta - theta_hat)||^2
  /// (R from the QR of the column-scaled X) so that it is accurate however small.
  double cost_increase = 0.0;
  /// Bounded parameters the fit holds at zero, in theta order. Those that do not enter D are set
  /// exactly to 0; those in D too, unless that would break D's margin (then they keep the
  /// barrier's tiny positive value).
  std::vector<std::string> active_bounds;
  /// The mass-matrix constraint binds: min_eigenvalue is within 1e-6 s_D of margin_absolute.
  bool mass_matrix_active = false;
  double min_eigenvalue = 0.0;     ///< smallest eigenvalue of D(theta, q2) over the grid [kg m^2]
  double min_eigenvalue_q2 = 0.0;  ///< where it occurs [rad]
  double margin_absolute = 0.0;    ///< margin * s_D [kg m^2]
  int iterations = 0;              ///< Newton steps over both phases
  /// The duality-gap bound met options.tolerance. If false (iteration limit), theta still
  /// satisfies every constraint but may not be the closest such estimate.
  bool converged = false;
};

namespace detail {

/// Barrier stages (tenfold weight each) before giving up: 60 decades is far beyond what double
/// precision can use, so reaching it means Newton stalled, not slow progress.
inline constexpr int kMaxBarrierStages = 60;

inline double physical_grid_q2(Eigen::Index g, Eigen::Index grid_size) noexcept {
  constexpr double pi = 3.14159265358979323846;
  return -pi + 2.0 * pi * static_cast<double>(g) / static_cast<double>(grid_size);
}

/// Rows 3g, 3g+1, 3g+2 hold the entries (1,1), (1,2), (2,2) of A_k(q2_g) in column k, so that
/// (basis * theta) stacks D(theta, q2_g). Column j of D is Z(q, 0, e_j) theta - Z(q, 0, 0) theta
/// (model/dynamics.hpp), so three regressor evaluations give every A_k at a grid point instead of
/// 3 p calls of mass_matrix. The off-diagonal is the mean of (1,2) and (2,1), which agree for any
/// term derived from a Lagrangian; symmetrising makes "positive definite" well defined otherwise.
SID_INLINE Eigen::MatrixXd mass_matrix_basis(const Model<double>& model, Eigen::Index grid_size);

inline double min_eigenvalue_2x2(double a11, double a12, double a22) noexcept {
  return 0.5 * (a11 + a22) - std::hypot(0.5 * (a11 - a22), a12);
}

inline double max_abs_eigenvalue_2x2(double a11, double a12, double a22) noexcept {
  return std::abs(0.5 * (a11 + a22)) + std::hypot(0.5 * (a11 - a22), a12);
}

struct GridMinimum {
  double value = std::numeric_limits<double>::infinity();
  Eigen::Index index = 0;
};

/// Smallest eigenvalue over the grid of the stacked matrices d (3 grid_size entries).
SID_INLINE GridMinimum grid_min_eigenvalue(const Eigen::Ref<const Eigen::VectorXd>& d);

/// Indices (in theta order) of the parameters c bounds at zero.
SID_INLINE std::vector<Eigen::Index> bounded_indices(const Model<double>& model,
                                                     const PhysicalConstraints& c);

SID_INLINE void check_grid_size(const char* who, const PhysicalConstraints& c);

/// Phase 1 (Boyd & Vandenberghe sec. 11.4.1): a point where D(phi) is positive definite at every
/// grid point and phi_k > 0 on the bounded indices, or an exception if none exists.
/// The feasible set is a cone (D is homogeneous in phi), so the problem is normalised: minimise
/// s over |phi_j| <= 1 subject to D_g(phi) / a_max + s I >= 0 and phi_k + s >= 0; (phi, s) =
/// (0, 1) is strictly feasible, and any iterate with s < 0 is an interior point of the cone.
/// The optimal s* < 0 iff the cone has an interior; it is declared empty once the bound
/// s - nu / t on s* exceeds -2 delta, i.e. the cone is thinner than delta in these units.
SID_INLINE Eigen::VectorXd physical_interior_point(const Eigen::MatrixXd& basis,
                                                   const std::vector<Eigen::Index>& bounded,
                                                   int& iterations, int max_iterations);

}  // namespace detail

/// @brief Is theta physically plausible: D(theta, q) positive definite at every grid q2 (q1 = 0,
/// see the file comment) and no parameter of c's list negative.
/// @param theta [model.num_parameters()], finite.
/// @throws std::invalid_argument on a wrongly sized or non-finite theta, or c.grid_size < 1.
SID_INLINE PhysicalCheck check_physical(const Model<double>& model,
                                        const Eigen::Ref<const Eigen::VectorXd>& theta,
                                        const PhysicalConstraints& c = {});

/// @brief The least-squares estimate closest to the data among the physically plausible ones:
///   minimise ||X theta - y||^2 subject to D(theta, q2_g) >= margin_absolute I on the grid and
///   theta_k >= 0 for c's parameters.
///
/// A convex problem (D linear in theta), solved as follows. X is column-scaled (its columns may
/// differ by 1e3 in norm) and QR-factorised, so ||X theta - y||^2 = ||R (phi - phi_hat)||^2 + RSS
/// with phi the scaled theta: O(m p^2) once, after which nothing depends on m. If theta_hat
/// meets the constraints it is returned unchanged. Otherwise a phase 1 finds an interior point
/// phi_f, the fit starts from phi_hat + c phi_f (c from Weyl's inequality, so every constraint
/// holds strictly), and a log-barrier Newton method (Boyd & Vandenberghe, ch. 11) follows the
/// central path, the barrier weight falling tenfold per stage, until the duality-gap bound meets
/// options.tolerance. Each Newton step costs O(grid_size p_D^2 + p^3), p_D the parameters in D.
/// @param X regressor (m x p, m > p, p = model.num_parameters(), full column rank), finite.
/// @param y measured torques (m), finite.
/// @throws std::invalid_argument ("sid::nearest_physical: ...") on wrong sizes, non-finite
///         values, a rank-deficient X, invalid options or c.grid_size, or when no parameter values
///         satisfy the constraints strictly (e.g. a model without inertia terms).
SID_INLINE ConsistentEstimate nearest_physical(const Model<double>& model,
                                               const Eigen::Ref<const Eigen::MatrixXd>& X,
                                               const Eigen::Ref<const Eigen::VectorXd>& y,
                                               const PhysicalConstraints& c = {},
                                               const NearestPhysicalOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/physical_consistency-inl.hpp>
#endif
