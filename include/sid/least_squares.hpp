#pragma once
/// @file
/// @brief Linear least squares min ||X theta - y|| by Householder QR of the column-scaled
/// regressor, with the statistics an identification report needs (paper eq. 10-11).

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace sid {

/// @brief Outcome of a least-squares fit that can occur with valid input.
enum class LeastSquaresStatus {
  Success,       ///< X has full column rank; every field of the result is filled.
  RankDeficient  ///< X (column-scaled) is numerically rank deficient; see dependent_columns.
};

/// @brief Options of least_squares and weighted_least_squares.
struct LeastSquaresOptions {
  /// Set ill_conditioned (and a warning message) when the 2-norm condition number of the
  /// column-scaled X exceeds this [-].
  double condition_warning = 1e8;
  /// Singular values of the column-scaled X at or below rank_tolerance * (largest singular value)
  /// count as zero. A value <= 0 selects max(m, p) * epsilon (numpy.linalg.matrix_rank's default).
  double rank_tolerance = 0.0;
  /// Names of the columns of X (e.g. "theta1".."theta7") used in messages; empty: "0", "1", ...
  std::vector<std::string> column_names;
};

/// @brief Estimate and statistics of a (weighted) least-squares fit.
///
/// Rows of X are split into `joints` equal consecutive blocks (paper eq. 10: joint 1's rows, then
/// joint 2's); the per-joint fields refer to these blocks. With m rows, p columns and
/// m_j = m / joints rows per joint:
/// - sigma2 = RSS / (m - p); sigma2_per_joint(j) = RSS_j / (m_j - p m_j / m): the m - p degrees
///   of freedom are shared in proportion to the rows, so the per-joint denominators add up to
///   m - p and the pooled sigma2 is their RSS-weighted combination. (The exact unbiased split
///   would need the leverages of each block; for m >> p the difference is O(p / m).)
/// - covariance = sigma2 (X^T W X)^-1 (W = I unweighted), from the triangular factor R of the QR,
///   never from the normal equations.
/// - For the weighted fit, RSS is the weighted sum sum_i w_i r_i^2; `residual` and
///   `residual_rms` are always unweighted (y - X theta).
/// On RankDeficient, theta is the minimum-norm solution in scaled coordinates, rank replaces p
/// in the degrees of freedom, and covariance, std_dev and relative_std_dev are NaN.
template <typename Scalar>
struct [[nodiscard]] LeastSquaresResult {
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;

  LeastSquaresStatus status = LeastSquaresStatus::Success;
  /// Empty on a clean success; the error (naming the dependent columns) on RankDeficient; the
  /// warning when ill_conditioned.
  std::string message;
  bool ill_conditioned = false;                 ///< condition_number > options.condition_warning
  Vector theta;                                 ///< estimate, p
  Vector residual;                              ///< y - X theta, m
  Vector residual_rms;                          ///< sqrt(mean of residual^2) per joint, joints
  Scalar sigma2 = Scalar(0);                    ///< residual variance estimate RSS / (m - p)
  Vector sigma2_per_joint;                      ///< RSS_j / (m_j - p m_j / m), joints
  Matrix covariance;                            ///< sigma2 (X^T W X)^-1, p x p
  Vector std_dev;                               ///< sqrt(diag(covariance)), p
  Vector relative_std_dev;                      ///< 100 std_dev / |theta| [%] (Gautier's %sigma), p
  Scalar condition_number = Scalar(0);          ///< 2-norm condition number of the column-scaled X
  Eigen::Index rank = 0;                        ///< numerical rank of the column-scaled X
  std::vector<Eigen::Index> dependent_columns;  ///< columns in the null space (RankDeficient)
  Vector column_scale;  ///< 2-norm of each column of (weighted) X, the scaling undone on theta
  /// The triangular factor of the column-scaled (weighted) X: X S⁻¹ = Q r with S =
  /// diag(column_scale), p x p.
  Matrix r;

  bool ok() const { return status == LeastSquaresStatus::Success; }

  /// (XᵀWX)⁻¹ = S⁻¹ r⁻¹ r⁻ᵀ S⁻¹, so that covariance = sigma2 inverse_gram(): the bread of a
  /// sandwich covariance. NaN if RankDeficient.
  Matrix inverse_gram() const {
    const Eigen::Index p = r.cols();
    if (!ok()) return Matrix::Constant(p, p, std::numeric_limits<Scalar>::quiet_NaN());
    const Matrix r_inv = r.template triangularView<Eigen::Upper>().solve(Matrix::Identity(p, p));
    const Vector inv_scale = column_scale.cwiseInverse();
    return inv_scale.asDiagonal() * (r_inv * r_inv.transpose()) * inv_scale.asDiagonal();
  }
};

namespace detail {

template <typename Scalar>
std::string format_number(Scalar value) {
  std::ostringstream out;
  out.precision(3);
  out << value;
  return out.str();
}

// The solver proper takes its operands as Refs: one instantiation per Scalar, whatever
// expressions the callers pass (an instantiation per expression type cost seconds of compile
// time each).
template <typename Scalar>
using ConstMatrixRef = Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>;
template <typename Scalar>
using ConstVectorRef = Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>>;

inline std::string column_label(const std::vector<std::string>& names, Eigen::Index j) {
  return names.empty() ? std::to_string(j) : names[static_cast<std::size_t>(j)];
}

template <typename Scalar>
void check_least_squares_input(const char* who, const ConstMatrixRef<Scalar>& x,
                               const ConstVectorRef<Scalar>& y, Eigen::Index joints,
                               const LeastSquaresOptions& options) {
  const std::string prefix = std::string(who) + ": ";
  const Eigen::Index m = x.rows(), p = x.cols();
  if (p < 1) throw std::invalid_argument(prefix + "x must have at least one column");
  if (m <= p)
    throw std::invalid_argument(prefix + "x must have more rows than columns, got " +
                                std::to_string(m) + " x " + std::to_string(p));
  if (y.size() != m)
    throw std::invalid_argument(prefix + "y must have as many entries as x has rows (" +
                                std::to_string(m) + "), got " + std::to_string(y.size()));
  if (joints < 1 || m % joints != 0)
    throw std::invalid_argument(prefix + "joints must be >= 1 and divide the rows of x (" +
                                std::to_string(m) + "), got " + std::to_string(joints));
  if (!options.column_names.empty() && static_cast<Eigen::Index>(options.column_names.size()) != p)
    throw std::invalid_argument(prefix + "options.column_names must name all " + std::to_string(p) +
                                " columns of x, got " +
                                std::to_string(options.column_names.size()));
  if (!(options.condition_warning > 0.0))
    throw std::invalid_argument(prefix + "options.condition_warning must be positive");
  if (!x.allFinite()) throw std::invalid_argument(prefix + "x must be finite");
  if (!y.allFinite()) throw std::invalid_argument(prefix + "y must be finite");
}

/// (Weighted) x with unit-norm columns; their original norms go into column_scale.
template <typename Scalar>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> scaled_regressor(
    const ConstMatrixRef<Scalar>& x, const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>* root_weights,
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& column_scale) {
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  // Unit-norm columns make the condition number and the rank decision independent of the
  // parameters' units (theta1 ~ 1e-2 kg m^2 next to theta6 ~ 1 N m s).
  Matrix xs = root_weights ? Matrix(root_weights->asDiagonal() * x) : Matrix(x);
  column_scale = xs.colwise().norm().transpose();
  for (Eigen::Index j = 0; j < xs.cols(); ++j)
    if (column_scale(j) == Scalar(0)) column_scale(j) = Scalar(1);  // zero column stays zero
  xs *= column_scale.cwiseInverse().asDiagonal();
  return xs;
}

/// Q' v for the Q of qr, reflector by reflector, without forming Q.
template <typename QR, typename Vector>
void apply_q_transpose(const QR& qr, Vector& v) {
  using Scalar = typename Vector::Scalar;
  const Eigen::Index m = v.size();
  for (Eigen::Index k = 0; k < qr.matrixQR().cols(); ++k) {
    Scalar workspace;
    v.tail(m - k).applyHouseholderOnTheLeft(qr.matrixQR().col(k).tail(m - k - 1), qr.hCoeffs()(k),
                                            &workspace);
  }
}

/// Numerical rank and condition number of the scaled x from the singular values sv of R.
template <typename Scalar>
void set_rank_and_condition(const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& sv, Eigen::Index m,
                            const LeastSquaresOptions& options,
                            LeastSquaresResult<Scalar>& result) {
  const Eigen::Index p = sv.size();
  const Scalar tol = (options.rank_tolerance > 0.0
                          ? Scalar(options.rank_tolerance)
                          : Scalar(std::max(m, p)) * std::numeric_limits<Scalar>::epsilon()) *
                     sv(0);
  result.rank = 0;
  for (Eigen::Index k = 0; k < p; ++k)
    if (sv(k) > tol) ++result.rank;
  result.condition_number =
      sv(p - 1) > Scalar(0) ? sv(0) / sv(p - 1) : std::numeric_limits<Scalar>::infinity();
}

/// RankDeficient: the minimum-norm solution in scaled coordinates, and the columns that cannot
/// be identified, listed in result.dependent_columns and named in result.message.
template <typename Scalar, typename Svd, typename QtyHead>
void solve_rank_deficient(const char* who, const Svd& svd, const QtyHead& qty_head,
                          const LeastSquaresOptions& options,
                          Eigen::Matrix<Scalar, Eigen::Dynamic, 1>& theta_scaled,
                          LeastSquaresResult<Scalar>& result) {
  using std::sqrt;
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  const Eigen::Index p = theta_scaled.size();
  const auto& sv = svd.singularValues();
  result.status = LeastSquaresStatus::RankDeficient;
  const Eigen::Index k = result.rank;
  theta_scaled.setZero();
  if (k > 0)
    theta_scaled = svd.matrixV().leftCols(k) *
                   (svd.matrixU().leftCols(k).transpose() * qty_head).cwiseQuotient(sv.head(k));
  // A column is unidentifiable iff its unit vector is not orthogonal to the null space; entries
  // of an orthonormal null basis are O(1) on involved columns and O(eps / gap) elsewhere.
  const Matrix null_basis = svd.matrixV().rightCols(p - k);
  const Scalar involved = sqrt(std::numeric_limits<Scalar>::epsilon());
  for (Eigen::Index j = 0; j < p; ++j)
    if (null_basis.row(j).norm() > involved) result.dependent_columns.push_back(j);
  std::string list;
  for (std::size_t i = 0; i < result.dependent_columns.size(); ++i)
    list += (i ? ", " : "") + column_label(options.column_names, result.dependent_columns[i]);
  result.message =
      std::string(who) + ": x has rank " + std::to_string(k) + " < " + std::to_string(p) +
      " columns: " +
      (result.dependent_columns.size() == 1 ? "column " + list + " is zero"
                                            : "columns " + list + " are linearly dependent") +
      " and cannot be identified separately";
}

/// residual, sigma2 and the per-joint sigma2 and residual RMS at result.theta.
template <typename Scalar>
void set_residual_statistics(const ConstMatrixRef<Scalar>& x, const ConstVectorRef<Scalar>& y,
                             const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>* root_weights,
                             Eigen::Index joints, LeastSquaresResult<Scalar>& result) {
  using std::sqrt;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  const Eigen::Index m = x.rows();
  result.residual = y - x * result.theta;
  const Vector weighted_residual =
      root_weights ? Vector(root_weights->cwiseProduct(result.residual)) : result.residual;
  const Eigen::Index m_j = m / joints;
  result.sigma2 = weighted_residual.squaredNorm() / Scalar(m - result.rank);
  result.sigma2_per_joint.resize(joints);
  result.residual_rms.resize(joints);
  for (Eigen::Index j = 0; j < joints; ++j) {
    const Scalar dof_j = Scalar(m_j) - Scalar(result.rank) * Scalar(m_j) / Scalar(m);
    result.sigma2_per_joint(j) = weighted_residual.segment(j * m_j, m_j).squaredNorm() / dof_j;
    result.residual_rms(j) =
        sqrt(result.residual.segment(j * m_j, m_j).squaredNorm() / Scalar(m_j));
  }
}

/// Full rank: covariance, standard deviations, and the warning when x is ill conditioned.
template <typename Scalar>
void set_covariance(const char* who, const LeastSquaresOptions& options,
                    LeastSquaresResult<Scalar>& result) {
  result.covariance = result.sigma2 * result.inverse_gram();
  result.std_dev = result.covariance.diagonal().cwiseSqrt();
  result.relative_std_dev = Scalar(100) * result.std_dev.cwiseQuotient(result.theta.cwiseAbs());
  if (result.condition_number > Scalar(options.condition_warning)) {
    result.ill_conditioned = true;
    result.message = std::string(who) + ": warning: condition number " +
                     format_number(result.condition_number) + " of the column-scaled x exceeds " +
                     format_number(options.condition_warning) +
                     "; the estimate is sensitive to noise";
  }
}

/// The fit proper. root_weights: sqrt(w) for the weighted fit, nullptr for the unweighted one.
/// Allocation matters here (an 8002 x 7 copy costs page faults): the only m x p temporary is the
/// scaled regressor, which the QR then overwrites in place.
template <typename Scalar>
LeastSquaresResult<Scalar> solve_least_squares(
    const char* who, const ConstMatrixRef<Scalar>& x, const ConstVectorRef<Scalar>& y,
    const Eigen::Matrix<Scalar, Eigen::Dynamic, 1>* root_weights, Eigen::Index joints,
    const LeastSquaresOptions& options) {
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  const Eigen::Index m = x.rows(), p = x.cols();
  const Scalar nan = std::numeric_limits<Scalar>::quiet_NaN();
  LeastSquaresResult<Scalar> result;

  Matrix xs = scaled_regressor(x, root_weights, result.column_scale);
  // Plain Householder QR suffices: rank, condition number and null space all come from the SVD of
  // R, whose singular values are those of the scaled X (Q is orthogonal).
  const Eigen::HouseholderQR<Eigen::Ref<Matrix>> qr(xs);
  Vector qty = root_weights ? Vector(root_weights->cwiseProduct(y)) : Vector(y);
  apply_q_transpose(qr, qty);
  result.r = qr.matrixQR().topLeftCorner(p, p).template triangularView<Eigen::Upper>();
  const Matrix& r = result.r;
  const auto qty_head = qty.head(p);

  // R is p x p: its SVD is cheap, and square (Eigen's QR preconditioner, which costs seconds of
  // compile time per file, would never run).
  const Eigen::JacobiSVD<Matrix, Eigen::NoQRPreconditioner> svd(
      r, Eigen::ComputeFullU | Eigen::ComputeFullV);
  set_rank_and_condition(svd.singularValues(), m, options, result);

  Vector theta_scaled(p);
  if (result.rank == p)
    theta_scaled = r.template triangularView<Eigen::Upper>().solve(qty_head);
  else
    solve_rank_deficient(who, svd, qty_head, options, theta_scaled, result);
  result.theta = theta_scaled.cwiseQuotient(result.column_scale);

  set_residual_statistics(x, y, root_weights, joints, result);
  if (result.ok()) {
    set_covariance(who, options, result);
  } else {
    result.ill_conditioned = true;
    result.covariance = Matrix::Constant(p, p, nan);
    result.std_dev = Vector::Constant(p, nan);
    result.relative_std_dev = Vector::Constant(p, nan);
  }
  return result;
}

}  // namespace detail

/// @brief Ordinary least squares min ||X theta - y||_2 (paper eq. 10-11) by Householder QR of X
/// with unit-norm columns (rank and condition from the SVD of the p x p factor R); the scaling is
/// undone on theta and covariance.
/// @param[in] x regressor, m x p with m > p; rows stacked per joint (joint 1's rows first).
/// @param[in] y measurements (torques), m.
/// @param[in] joints number of equal row blocks for the per-joint statistics (1: no split).
/// @param[in] options thresholds and column names (see LeastSquaresOptions).
/// @return status Success or RankDeficient (message names the columns that cannot be
///   identified), and the statistics documented at LeastSquaresResult.
/// @throws std::invalid_argument on sizes that do not fit (m <= p, y size, joints not dividing
///   m, column_names size) or non-finite x or y.
template <typename DerivedX, typename DerivedY>
LeastSquaresResult<typename DerivedX::Scalar> least_squares(
    const Eigen::MatrixBase<DerivedX>& x, const Eigen::MatrixBase<DerivedY>& y,
    Eigen::Index joints = 1, const LeastSquaresOptions& options = {}) {
  using Scalar = typename DerivedX::Scalar;
  static_assert(std::is_same_v<Scalar, typename DerivedY::Scalar>,
                "x and y must have the same Scalar");
  const detail::ConstMatrixRef<Scalar> xr(x);
  const detail::ConstVectorRef<Scalar> yr(y);
  detail::check_least_squares_input<Scalar>("sid::least_squares", xr, yr, joints, options);
  return detail::solve_least_squares<Scalar>("sid::least_squares", xr, yr, nullptr, joints,
                                             options);
}

/// @brief Weighted least squares min sum_i w_i (y_i - x_i theta)^2, i.e. least_squares of
/// (sqrt(W) X, sqrt(W) y). With w_i = 1 / sigma_i^2 (e.g. per-joint variances from an
/// unweighted fit, Gautier's WLS) sigma2 is close to 1 and covariance / sigma2 = (X^T W X)^-1.
/// @param[in] weights row weights w_i > 0, m.
/// Other parameters, result and exceptions as least_squares; also throws on weights of wrong size,
/// non-finite or not positive.
template <typename DerivedX, typename DerivedY, typename DerivedW>
LeastSquaresResult<typename DerivedX::Scalar> weighted_least_squares(
    const Eigen::MatrixBase<DerivedX>& x, const Eigen::MatrixBase<DerivedY>& y,
    const Eigen::MatrixBase<DerivedW>& weights, Eigen::Index joints = 1,
    const LeastSquaresOptions& options = {}) {
  using Scalar = typename DerivedX::Scalar;
  static_assert(std::is_same_v<Scalar, typename DerivedY::Scalar> &&
                    std::is_same_v<Scalar, typename DerivedW::Scalar>,
                "x, y and weights must have the same Scalar");
  const char* who = "sid::weighted_least_squares";
  const detail::ConstMatrixRef<Scalar> xr(x);
  const detail::ConstVectorRef<Scalar> yr(y);
  detail::check_least_squares_input<Scalar>(who, xr, yr, joints, options);
  if (weights.size() != x.rows())
    throw std::invalid_argument(
        std::string(who) + ": weights must have as many entries as x has rows (" +
        std::to_string(x.rows()) + "), got " + std::to_string(weights.size()));
  if (!weights.allFinite() || !(weights.array() > Scalar(0)).all())
    throw std::invalid_argument(std::string(who) + ": weights must be finite and positive");
  const Eigen::Matrix<Scalar, Eigen::Dynamic, 1> root = weights.cwiseSqrt();
  return detail::solve_least_squares<Scalar>(who, xr, yr, &root, joints, options);
}

}  // namespace sid

#ifdef SID_COMPILED_LIB
// The compiled library holds the solver for double, which every fit of the library calls (see
// sid/config.hpp).
namespace sid::detail {
extern template LeastSquaresResult<double> solve_least_squares<double>(
    const char*, const ConstMatrixRef<double>&, const ConstVectorRef<double>&,
    const Eigen::Matrix<double, Eigen::Dynamic, 1>*, Eigen::Index, const LeastSquaresOptions&);
}  // namespace sid::detail
#endif
