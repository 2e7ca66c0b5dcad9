#pragma once
/// @file
/// @brief Base parameters: the largest set of regressor columns that a regression can tell
/// apart, and how every other column regroups onto them.
///
/// A serial arm's regressor has columns that are zero (a parameter that never moves a joint) or
/// combinations of others (first moments and inertias that act only together). With
/// W[:, dependent] = W[:, independent] K, the data determine only
/// beta = theta[independent] + K theta[dependent], and W theta = W[:, independent] beta.

#include <Eigen/Core>
#include <Eigen/Householder>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

template <typename Scalar>
struct BaseParameters {
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

  std::vector<Eigen::Index> independent;  ///< columns kept, ascending
  std::vector<Eigen::Index> dependent;    ///< columns regrouped onto them, ascending
  Matrix K;                               ///< independent.size() x dependent.size()

  /// The smallest kept column's distance from the columns before it over the largest dropped
  /// one's (unit-norm columns; set by base_parameters_in_order, NaN otherwise): how clearly the
  /// rank was decided. Infinite when no column was dropped for being a combination.
  Scalar rank_gap = std::numeric_limits<Scalar>::quiet_NaN();

  Eigen::Index rank() const noexcept { return static_cast<Eigen::Index>(independent.size()); }

  /// @brief beta = theta[independent] + K theta[dependent].
  /// @throws std::invalid_argument if theta does not have one entry per column.
  Vector beta(const Eigen::Ref<const Vector>& theta) const {
    const auto columns = static_cast<Eigen::Index>(independent.size() + dependent.size());
    if (theta.size() != columns)
      throw std::invalid_argument("sid::BaseParameters::beta: theta has " +
                                  std::to_string(theta.size()) + " entries for " +
                                  std::to_string(columns) + " columns");
    return theta(independent) + K * theta(dependent);
  }

  /// @brief W[:, independent], the regressor of beta.
  /// @throws std::invalid_argument if w does not have one column per parameter.
  Matrix base_regressor(const Eigen::Ref<const Matrix>& w) const {
    const auto columns = static_cast<Eigen::Index>(independent.size() + dependent.size());
    if (w.cols() != columns)
      throw std::invalid_argument("sid::BaseParameters::base_regressor: W has " +
                                  std::to_string(w.cols()) + " columns, expected " +
                                  std::to_string(columns));
    return w(Eigen::all, independent);
  }
};

namespace detail {

template <typename Scalar>
void check_base_regressor(
    const char* who,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>& w) {
  if (w.rows() == 0 || w.cols() == 0)
    throw std::invalid_argument(std::string(who) + ": W is empty");
  if (!w.allFinite())
    throw std::invalid_argument(std::string(who) + ": W holds a value that is not finite");
}

/// K with W[:, dependent] = W[:, independent] K, from a QR of the given (ascending, distinct)
/// independent columns. `verified`: the caller found each of them farther than the tolerance
/// from the span of the columns before it. A pivoted QR's last pivot can still fall below the
/// tolerance (taking the largest residual first leaves the smallest for last; among three unit
/// columns by up to √2), and such columns are independent all the same: K then comes from the
/// unpivoted QR, whose diagonal is the caller's distances.
template <typename Scalar>
BaseParameters<Scalar> regroup(
    const char* who,
    const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>& w,
    std::vector<Eigen::Index> independent, Scalar relative_tolerance, bool verified = false) {
  BaseParameters<Scalar> base;
  for (Eigen::Index j = 0, at = 0; j < w.cols(); ++j) {
    if (at < static_cast<Eigen::Index>(independent.size()) &&
        independent[static_cast<std::size_t>(at)] == j)
      ++at;
    else
      base.dependent.push_back(j);
  }
  base.independent = std::move(independent);
  const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> wi = w(Eigen::all, base.independent);
  Eigen::ColPivHouseholderQR<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> qr(wi);
  qr.setThreshold(relative_tolerance);
  if (qr.rank() < wi.cols() && verified) {
    base.K = Eigen::HouseholderQR<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>>(wi).solve(
        w(Eigen::all, base.dependent));
    return base;
  }
  if (qr.rank() < wi.cols())
    throw std::invalid_argument(std::string(who) +
                                ": the independent columns are themselves "
                                "dependent (rank " +
                                std::to_string(qr.rank()) + " of " + std::to_string(wi.cols()) +
                                ")");
  base.K = base.dependent.empty()
               ? Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>(wi.cols(), 0)
               : Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>(
                     qr.solve(w(Eigen::all, base.dependent)));
  return base;
}

/// The base parameters a QR with column pivoting chose: W P = Q [R11 R12], so the kept
/// columns' K is R11^-1 R12, put into ascending column order.
template <typename Qr>
BaseParameters<typename Qr::Scalar> base_from_pivoted_qr(const Qr& qr) {
  using Scalar = typename Qr::Scalar;
  const Eigen::Index r = qr.rank(), p = qr.cols();
  const auto& pivots = qr.colsPermutation().indices();
  const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> k_pivoted =
      qr.matrixR().topLeftCorner(r, r).template triangularView<Eigen::Upper>().solve(
          qr.matrixR().topRightCorner(r, p - r));
  // Pivot positions in the order of the columns they hold.
  const auto by_column = [&](Eigen::Index begin, Eigen::Index end) {
    std::vector<Eigen::Index> at(static_cast<std::size_t>(end - begin));
    for (Eigen::Index k = begin; k < end; ++k) at[static_cast<std::size_t>(k - begin)] = k;
    std::sort(at.begin(), at.end(),
              [&](Eigen::Index a, Eigen::Index b) { return pivots[a] < pivots[b]; });
    return at;
  };
  const std::vector<Eigen::Index> kept = by_column(0, r), regrouped = by_column(r, p);
  BaseParameters<Scalar> base;
  for (const Eigen::Index k : kept) base.independent.push_back(pivots[k]);
  for (const Eigen::Index k : regrouped) base.dependent.push_back(pivots[k]);
  base.K.resize(r, p - r);
  for (Eigen::Index a = 0; a < r; ++a)
    for (Eigen::Index b = 0; b < p - r; ++b)
      base.K(a, b) =
          k_pivoted(kept[static_cast<std::size_t>(a)], regrouped[static_cast<std::size_t>(b)] - r);
  return base;
}

}  // namespace detail

/// @brief The base parameters of a stacked regressor W (rows: equations, columns: parameters),
/// chosen by a QR with column pivoting: a column is independent while its pivot exceeds
/// relative_tolerance times the largest.
/// @param w a regressor that excites the arm richly (many random samples): what these samples
///        do not move is taken as never identifiable.
/// @throws std::invalid_argument if W is empty or not finite, the tolerance is not in (0, 1),
///         or every column is zero.
template <typename Derived>
BaseParameters<typename Derived::Scalar> base_parameters(
    const Eigen::MatrixBase<Derived>& w_in,
    typename Derived::Scalar relative_tolerance = typename Derived::Scalar(1e-8)) {
  using Scalar = typename Derived::Scalar;
  const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> w(w_in);
  const char* who = "sid::base_parameters";
  detail::check_base_regressor<Scalar>(who, w);
  if (!(relative_tolerance > Scalar(0) && relative_tolerance < Scalar(1)))
    throw std::invalid_argument(std::string(who) + ": the relative tolerance must be in (0, 1)");
  Eigen::ColPivHouseholderQR<Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> qr(w);
  qr.setThreshold(relative_tolerance);
  if (qr.rank() == 0) throw std::invalid_argument(std::string(who) + ": every column of W is zero");
  return detail::base_from_pivoted_qr(qr);
}

/// @brief The regrouping onto given independent columns (e.g. a published base set).
/// @throws std::invalid_argument if W is empty or not finite, an index is out of range or
///         repeated, or the given columns are not independent.
template <typename Derived>
BaseParameters<typename Derived::Scalar> base_parameters(
    const Eigen::MatrixBase<Derived>& w_in, std::vector<Eigen::Index> independent,
    typename Derived::Scalar relative_tolerance = typename Derived::Scalar(1e-8)) {
  using Scalar = typename Derived::Scalar;
  const Eigen::Ref<const Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>> w(w_in);
  const char* who = "sid::base_parameters";
  detail::check_base_regressor<Scalar>(who, w);
  std::vector<Eigen::Index> sorted = independent;
  std::sort(sorted.begin(), sorted.end());
  if (sorted.empty())
    throw std::invalid_argument(std::string(who) + ": no independent columns given");
  if (sorted.front() < 0 || sorted.back() >= w.cols())
    throw std::invalid_argument(std::string(who) + ": an independent column is outside 0.." +
                                std::to_string(w.cols() - 1));
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end())
    throw std::invalid_argument(std::string(who) + ": an independent column is given twice");
  return detail::regroup<Scalar>(who, w, std::move(sorted), relative_tolerance);
}

/// @brief The base parameters in the columns' own order: a column is kept when its distance
/// from the span of the columns before it exceeds relative_tolerance (columns scaled to unit
/// norm first, so units do not decide), else it regroups onto them. Earlier columns are kept
/// in preference to later ones, so ordering the columns by what should be reported (a link's
/// own parameters before the drive terms that repeat them) decides the names, and the choice
/// depends on nothing but W.
/// @param w a regressor that excites the arm richly (many random samples).
/// @throws std::invalid_argument if W is empty or not finite, the tolerance is not in (0, 1),
///         or every column is zero.
template <typename Derived>
BaseParameters<typename Derived::Scalar> base_parameters_in_order(
    const Eigen::MatrixBase<Derived>& w_in,
    typename Derived::Scalar relative_tolerance = typename Derived::Scalar(1e-8)) {
  using Scalar = typename Derived::Scalar;
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic>;
  const Eigen::Ref<const Matrix> w(w_in);
  const char* who = "sid::base_parameters_in_order";
  detail::check_base_regressor<Scalar>(who, w);
  if (!(relative_tolerance > Scalar(0) && relative_tolerance < Scalar(1)))
    throw std::invalid_argument(std::string(who) + ": the relative tolerance must be in (0, 1)");
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> norms = w.colwise().norm().transpose();
  // A column that is zero in exact arithmetic comes out as round-off of the terms that cancel
  // (e.g. 1e-14 beside columns of 100); scaled to unit norm it would look independent.
  const Scalar zero_column =
      Scalar(1e3) * std::numeric_limits<Scalar>::epsilon() * norms.maxCoeff();
  Matrix scaled = w;
  for (Eigen::Index j = 0; j < w.cols(); ++j) {
    if (norms[j] <= zero_column) norms[j] = Scalar(0);
    scaled.col(j) = norms[j] > Scalar(0)
                        ? Eigen::Matrix<Scalar, Eigen::Dynamic, 1>(w.col(j) / norms[j])
                        : Eigen::Matrix<Scalar, Eigen::Dynamic, 1>::Zero(w.rows());
  }
  // R's diagonal of an unpivoted QR: each column's distance from the span of those before it.
  const Eigen::HouseholderQR<Matrix> qr(scaled);
  std::vector<Eigen::Index> kept;
  Scalar smallest_kept = std::numeric_limits<Scalar>::infinity(), largest_dropped = Scalar(0);
  for (Eigen::Index j = 0; j < w.cols(); ++j) {
    const Scalar distance = j < qr.matrixQR().rows() ? std::abs(qr.matrixQR()(j, j)) : Scalar(0);
    if (norms[j] > Scalar(0) && distance > relative_tolerance) {
      kept.push_back(j);
      smallest_kept = std::min(smallest_kept, distance);
    } else if (norms[j] > Scalar(0)) {
      largest_dropped = std::max(largest_dropped, distance);
    }
  }
  if (kept.empty()) throw std::invalid_argument(std::string(who) + ": every column of W is zero");
  if (static_cast<Eigen::Index>(kept.size()) == w.cols()) {
    // Every column is its own base parameter: nothing to regroup, and no second factorization
    // (the data's own pass meets this case on matrices of 1e5 rows).
    BaseParameters<Scalar> base;
    base.independent = std::move(kept);
    base.K.resize(w.cols(), 0);
    base.rank_gap = std::numeric_limits<Scalar>::infinity();
    return base;
  }
  BaseParameters<Scalar> base =
      detail::regroup<Scalar>(who, scaled, std::move(kept), relative_tolerance, true);
  for (Eigen::Index a = 0; a < base.K.rows(); ++a)  // back from unit-norm columns
    for (Eigen::Index b = 0; b < base.K.cols(); ++b)
      base.K(a, b) *= norms[base.dependent[static_cast<std::size_t>(b)]] /
                      norms[base.independent[static_cast<std::size_t>(a)]];
  base.rank_gap = largest_dropped > Scalar(0) ? smallest_kept / largest_dropped
                                              : std::numeric_limits<Scalar>::infinity();
  return base;
}

/// @brief Each base parameter written as the combination it stands for, e.g.
/// "Izz_1 + Ia_1 + Iyy_2 + 0.05185*m_3 + ...": the kept column's name, then every regrouped
/// column with its coefficient (5 significant digits; coefficients below 1e-9 of the largest are
/// left out), at most max_terms terms and "+ ..." after them (0: all).
/// @throws std::invalid_argument if names does not have one entry per column.
template <typename Scalar>
std::vector<std::string> base_parameter_names(const BaseParameters<Scalar>& base,
                                              const std::vector<std::string>& names,
                                              std::size_t max_terms = 6) {
  if (names.size() != base.independent.size() + base.dependent.size())
    throw std::invalid_argument(
        "sid::base_parameter_names: " + std::to_string(names.size()) + " names for " +
        std::to_string(base.independent.size() + base.dependent.size()) + " columns");
  std::vector<std::string> out;
  const Scalar scale = base.K.size() > 0 ? base.K.cwiseAbs().maxCoeff() : Scalar(0);
  for (std::size_t a = 0; a < base.independent.size(); ++a) {
    std::ostringstream text;
    text << names[static_cast<std::size_t>(base.independent[a])];
    std::size_t terms = 1;
    for (std::size_t b = 0; b < base.dependent.size(); ++b) {
      const Scalar k = base.K(static_cast<Eigen::Index>(a), static_cast<Eigen::Index>(b));
      if (!(std::abs(k) > Scalar(1e-9) * scale)) continue;
      if (max_terms > 0 && terms == max_terms) {
        text << " + ...";
        break;
      }
      text << (k < Scalar(0) ? " - " : " + ");
      const Scalar magnitude = std::abs(k);
      if (std::abs(magnitude - Scalar(1)) > Scalar(1e-9)) {
        std::ostringstream number;
        number.precision(5);
        number << magnitude;
        text << number.str() << "*";
      }
      text << names[static_cast<std::size_t>(base.dependent[b])];
      ++terms;
    }
    out.push_back(text.str());
  }
  return out;
}

}  // namespace sid
