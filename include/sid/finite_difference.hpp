#pragma once
/// @file
/// @brief First and second derivatives of uniformly sampled signals by finite differences,
/// column-wise on n x k matrices (the paper's "raw" method, eq. 47-48, and central differences).

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace sid {

/// @brief Derivative estimates of an n x k signal and the samples they belong to.
///
/// first.row(r) estimates x'(t_i) at sample i = first_begin + r, second.row(r) estimates x''(t_i)
/// at sample i = second_begin + r. Which samples exist depends on the scheme:
/// | scheme  | first: samples      | second: samples     | both: [begin(), end()) |
/// |---------|---------------------|---------------------|------------------------|
/// | forward | 0 .. n-2 (n-1 rows) | 0 .. n-3 (n-2 rows) | [0, n-2)               |
/// | central | 1 .. n-2 (n-2 rows) | 1 .. n-2 (n-2 rows) | [1, n-1)               |
/// Class invariant: first.cols() == second.cols() == k.
template <typename Scalar>
struct FiniteDifferences {
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> first;   ///< x' [unit/s]
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> second;  ///< x'' [unit/s^2]
  Eigen::Index first_begin = 0;                                  ///< sample index of first.row(0)
  Eigen::Index second_begin = 0;                                 ///< sample index of second.row(0)

  /// First sample at which both derivatives exist.
  Eigen::Index begin() const { return std::max(first_begin, second_begin); }
  /// One past the last sample at which both derivatives exist.
  Eigen::Index end() const {
    return std::min(first_begin + first.rows(), second_begin + second.rows());
  }
  /// Rows of `first` for the samples [begin(), end()).
  auto first_common() const { return first.middleRows(begin() - first_begin, end() - begin()); }
  /// Rows of `second` for the samples [begin(), end()).
  auto second_common() const { return second.middleRows(begin() - second_begin, end() - begin()); }
};

namespace detail {

template <typename Derived>
void check_differences_input(const char* who, const Eigen::MatrixBase<Derived>& x,
                             typename Derived::Scalar ts) {
  const std::string prefix = std::string(who) + ": ";
  if (x.rows() < 3)
    throw std::invalid_argument(prefix + "x must have at least 3 rows (samples), got " +
                                std::to_string(x.rows()));
  if (x.cols() < 1) throw std::invalid_argument(prefix + "x must have at least 1 column");
  using std::isfinite;
  if (!(ts > typename Derived::Scalar(0)) || !isfinite(ts)) {
    std::ostringstream value;
    value << ts;
    throw std::invalid_argument(prefix + "ts must be positive and finite, got " + value.str());
  }
  if (!x.allFinite()) throw std::invalid_argument(prefix + "x must be finite");
}

}  // namespace detail

/// @brief Forward differences (paper eq. 47-48): x'_i = (x_{i+1} - x_i) / Ts for i = 0..n-2,
/// x''_i = (x'_{i+1} - x'_i) / Ts = (x_{i+2} - 2 x_{i+1} + x_i) / Ts^2 for i = 0..n-3.
///
/// Both are first-order accurate at sample i: x'_i has error Ts x''/2 + O(Ts^2), and x''_i is the
/// centred second difference at i+1, so it lags by one sample (error Ts x''' + O(Ts^2)).
/// @param[in] x n x k samples, one column per signal, uniformly spaced.
/// @param[in] ts sampling period Ts [s] > 0.
/// @throws std::invalid_argument if n < 3, ts <= 0 or not finite, or x not finite.
template <typename Derived>
FiniteDifferences<typename Derived::Scalar> forward_differences(const Eigen::MatrixBase<Derived>& x,
                                                                typename Derived::Scalar ts) {
  detail::check_differences_input("sid::forward_differences", x, ts);
  const Eigen::Index n = x.rows();
  FiniteDifferences<typename Derived::Scalar> d;
  d.first = (x.bottomRows(n - 1) - x.topRows(n - 1)) / ts;
  d.second = (d.first.bottomRows(n - 2) - d.first.topRows(n - 2)) / ts;
  d.first_begin = 0;
  d.second_begin = 0;
  return d;
}

/// @brief Central differences at the interior samples i = 1..n-2:
/// x'_i = (x_{i+1} - x_{i-1}) / (2 Ts), x''_i = (x_{i+1} - 2 x_i + x_{i-1}) / Ts^2.
///
/// Second-order accurate: x'_i has error Ts^2 x'''/6 (exact for quadratics), x''_i has error
/// Ts^2 x''''/12 (exact for cubics).
/// @param[in] x n x k samples, one column per signal, uniformly spaced.
/// @param[in] ts sampling period Ts [s] > 0.
/// @throws std::invalid_argument if n < 3, ts <= 0 or not finite, or x not finite.
template <typename Derived>
FiniteDifferences<typename Derived::Scalar> central_differences(const Eigen::MatrixBase<Derived>& x,
                                                                typename Derived::Scalar ts) {
  using Scalar = typename Derived::Scalar;
  detail::check_differences_input("sid::central_differences", x, ts);
  const Eigen::Index n = x.rows();
  FiniteDifferences<Scalar> d;
  d.first = (x.bottomRows(n - 2) - x.topRows(n - 2)) / (Scalar(2) * ts);
  d.second =
      (x.bottomRows(n - 2) - Scalar(2) * x.middleRows(1, n - 2) + x.topRows(n - 2)) / (ts * ts);
  d.first_begin = 1;
  d.second_begin = 1;
  return d;
}

}  // namespace sid
