#pragma once
/// @file
/// @brief Butterworth low-pass design (bilinear transform) and SciPy-compatible lfilter, lfilter_zi
/// and zero-phase filtfilt, column-wise on n x k signals.
///
/// Everything here reproduces scipy.signal (butter, lfilter, lfilter_zi, filtfilt with its
/// defaults) step by step, so that results agree with SciPy to rounding: the paper's "filtered"
/// method (docs/paper-reproduction.md) is specified by SciPy/MATLAB behaviour, not by a formula.

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <complex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace sid {

/// @brief Digital filter as a rational transfer function
/// H(z) = (b0 + b1 z^-1 + ... ) / (a0 + a1 z^-1 + ...).
/// Class invariant (from butterworth_lowpass): a(0) == 1 and b.size() == a.size() == order + 1.
template <typename Scalar>
struct TransferFunction {
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> b;  ///< numerator coefficients
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> a;  ///< denominator coefficients, a(0) = 1
};

/// @brief Output and final state of lfilter with given initial conditions.
template <typename Scalar>
struct FilterState {
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> y;   ///< filtered signal, n x k
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> zf;  ///< final state, (L - 1) x k
};

namespace detail {

/// A floating-point type wider than Scalar where the platform has one (for exact-ish sums).
template <typename Scalar>
struct Wider {
  using type = long double;
};
template <>
struct Wider<float> {
  using type = double;
};

template <typename Scalar>
std::string to_string_g(Scalar value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

/// Checks b and a of a filter; L = max(len a, len b). Throws naming `who` and the argument.
template <typename DerivedB, typename DerivedA>
void check_filter(const char* who, const Eigen::MatrixBase<DerivedB>& b,
                  const Eigen::MatrixBase<DerivedA>& a) {
  const std::string prefix = std::string(who) + ": ";
  if (b.size() == 0) throw std::invalid_argument(prefix + "b must not be empty");
  if (a.size() == 0) throw std::invalid_argument(prefix + "a must not be empty");
  if (!b.allFinite()) throw std::invalid_argument(prefix + "b must be finite");
  if (!a.allFinite()) throw std::invalid_argument(prefix + "a must be finite");
  if (a(0) == typename DerivedA::Scalar(0))
    throw std::invalid_argument(prefix + "a[0] must be nonzero");
}

/// b and a normalised by a[0] and zero-padded to the common length L (as scipy.signal.lfilter).
template <typename Scalar, typename DerivedB, typename DerivedA>
TransferFunction<Scalar> normalized_padded(const Eigen::MatrixBase<DerivedB>& b,
                                           const Eigen::MatrixBase<DerivedA>& a) {
  const Eigen::Index len = std::max(b.size(), a.size());
  TransferFunction<Scalar> tf;
  tf.b = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>::Zero(len);
  tf.a = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>::Zero(len);
  const Scalar a0 = a(0);
  for (Eigen::Index i = 0; i < b.size(); ++i) tf.b(i) = b(i) / a0;
  for (Eigen::Index i = 0; i < a.size(); ++i) tf.a(i) = a(i) / a0;
  return tf;
}

/// Direct form II transposed on one column, state z (length L - 1) updated in place.
/// The operation order follows SciPy's C kernel so results agree to the last bits.
template <typename Scalar, typename DerivedX, typename DerivedY, typename DerivedZ>
void lfilter_column(const TransferFunction<Scalar>& tf, const Eigen::MatrixBase<DerivedX>& x,
                    Eigen::MatrixBase<DerivedY> const& y_out,
                    Eigen::MatrixBase<DerivedZ> const& z_out) {
  auto& y = const_cast<Eigen::MatrixBase<DerivedY>&>(y_out);
  auto& z = const_cast<Eigen::MatrixBase<DerivedZ>&>(z_out);
  const Eigen::Index len = tf.b.size();
  const Scalar* b = tf.b.data();
  const Scalar* a = tf.a.data();
  for (Eigen::Index i = 0; i < x.size(); ++i) {
    const Scalar xi = x(i);
    if (len == 1) {
      y(i) = b[0] * xi;
      continue;
    }
    const Scalar yi = z(0) + b[0] * xi;
    for (Eigen::Index k = 0; k + 2 < len; ++k) z(k) = z(k + 1) + xi * b[k + 1] - yi * a[k + 1];
    z(len - 2) = xi * b[len - 1] - yi * a[len - 1];
    y(i) = yi;
  }
}

}  // namespace detail

/// @brief Butterworth low-pass filter of order N and cutoff Wn, as scipy.signal.butter(N, Wn).
///
/// Analog prototype poles p_k = -exp(i pi (2k - N + 1) / (2N)), frequency prewarped to
/// warped = 4 tan(pi Wn / 2) (SciPy's fs = 2), bilinear transform z = (4 + s) / (4 - s), all N
/// zeros at z = -1 and gain k = warped^N / prod(4 - s_k), which makes the DC gain 1 exactly in
/// exact arithmetic (to rounding in floating point).
/// @tparam Scalar a real floating-point type.
/// @param[in] order filter order N >= 1.
/// @param[in] cutoff normalised cutoff Wn in (0, 1), relative to the Nyquist frequency
///   (e.g. 10 Hz at 400 Hz sampling: Wn = 10 / 200 = 0.05).
/// @return b, a with a(0) = 1, each of length N + 1.
/// @throws std::invalid_argument if order < 1 or cutoff is outside (0, 1).
template <typename Scalar>
TransferFunction<Scalar> butterworth_lowpass(int order, Scalar cutoff) {
  static_assert(std::is_floating_point_v<Scalar>,
                "sid::butterworth_lowpass needs a real floating-point Scalar");
  using std::exp;
  using std::tan;
  using Complex = std::complex<Scalar>;
  if (order < 1)
    throw std::invalid_argument("sid::butterworth_lowpass: order must be >= 1, got " +
                                std::to_string(order));
  if (!(cutoff > Scalar(0) && cutoff < Scalar(1)))
    throw std::invalid_argument("sid::butterworth_lowpass: cutoff must be in (0, 1), got " +
                                detail::to_string_g(cutoff));
  const Scalar pi = Scalar(EIGEN_PI);
  const Scalar fs2 = Scalar(4);  // 2 * fs with SciPy's fs = 2
  const Scalar warped = fs2 * tan(pi * cutoff / Scalar(2));

  // poly(z_poles) accumulated in complex arithmetic, as numpy.poly; the imaginary parts cancel.
  Eigen::Matrix<Complex, Eigen::Dynamic, 1> a_c =
      Eigen::Matrix<Complex, Eigen::Dynamic, 1>::Zero(order + 1);
  a_c(0) = Complex(1);
  Complex denominator(1);  // prod(4 - s_k)
  for (int k = 0; k < order; ++k) {
    const Scalar m = Scalar(-order + 1 + 2 * k);
    const Complex s = -warped * exp(Complex(0, pi * m / Scalar(2 * order)));
    denominator *= fs2 - s;
    const Complex pole = (fs2 + s) / (fs2 - s);
    for (int j = k + 1; j >= 1; --j) a_c(j) -= pole * a_c(j - 1);
  }
  Scalar gain = Scalar(1);
  for (int k = 0; k < order; ++k) gain *= warped;
  gain = (Complex(gain) / denominator).real();

  TransferFunction<Scalar> tf;
  tf.a = a_c.real();
  tf.b.resize(order + 1);
  // (1 + z^-1)^N: binomial coefficients, exact in floating point for any practical N.
  Scalar binomial = Scalar(1);
  for (int j = 0; j <= order; ++j) {
    tf.b(j) = gain * binomial;
    binomial = binomial * Scalar(order - j) / Scalar(j + 1);
  }
  return tf;
}

/// @brief Steady-state initial state of lfilter for a unit step input, as
/// scipy.signal.lfilter_zi(b, a): the solution of (I - A^T) zi = b[1:] - a[1:] b[0], A the
/// companion matrix of a.
///
/// The system's condition number grows like 1 / |sum a| (3.8e3, 1.6e5, 7.1e7 for the paper's
/// three filters), so SciPy's LU solve loses up to 3.5e-10 relative accuracy. Here the explicit
/// solution zi[0] = sum(b[1:] - a[1:] b[0]) / sum(a), zi[k] = (a[0] + .. + a[k]) zi[0] -
/// sum_{j=1..k} (b[j] - a[j] b[0]) (given in SciPy's source comments) is evaluated in a wider
/// type (long double for double), in which the sums of double coefficients are exact or nearly
/// so; the result is correct to rounding where long double is wider than double (x86-64 Linux).
/// @param[in] b numerator, @param[in] a denominator with a(0) != 0 (both normalised by a(0)).
/// @return zi of length max(len a, len b) - 1.
/// @throws std::invalid_argument on empty or non-finite coefficients, a(0) == 0, or sum(a) == 0
///   (a pole at z = 1: no steady state).
template <typename DerivedB, typename DerivedA>
Eigen::Matrix<typename DerivedB::Scalar, Eigen::Dynamic, 1> lfilter_zi(
    const Eigen::MatrixBase<DerivedB>& b, const Eigen::MatrixBase<DerivedA>& a) {
  using Scalar = typename DerivedB::Scalar;
  using Wide = typename detail::Wider<Scalar>::type;
  static_assert(std::is_same_v<Scalar, typename DerivedA::Scalar>,
                "b and a must have the same Scalar");
  detail::check_filter("sid::lfilter_zi", b, a);
  const auto tf = detail::normalized_padded<Scalar>(b, a);
  const Eigen::Index n = tf.a.size() - 1;
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> zi(n);
  if (n == 0) return zi;
  const Wide b0 = Wide(tf.b(0));
  Wide sum_a = Wide(tf.a(0));
  Wide sum_rhs = Wide(0);
  for (Eigen::Index i = 1; i <= n; ++i) {
    sum_a += Wide(tf.a(i));
    sum_rhs += Wide(tf.b(i)) - Wide(tf.a(i)) * b0;
  }
  if (sum_a == Wide(0))
    throw std::invalid_argument(
        "sid::lfilter_zi: a has a pole at z = 1 (sum of a is 0), no steady state");
  const Wide z0 = sum_rhs / sum_a;
  zi(0) = Scalar(z0);
  Wide partial_a = Wide(tf.a(0));
  Wide partial_rhs = Wide(0);
  for (Eigen::Index k = 1; k < n; ++k) {
    partial_a += Wide(tf.a(k));
    partial_rhs += Wide(tf.b(k)) - Wide(tf.a(k)) * b0;
    zi(k) = Scalar(partial_a * z0 - partial_rhs);
  }
  return zi;
}

/// @brief Filters each column of x with direct form II transposed, zero initial state, as
/// scipy.signal.lfilter(b, a, x, axis=0).
/// @return y with the shape of x.
/// @throws std::invalid_argument on bad coefficients or non-finite x.
template <typename DerivedB, typename DerivedA, typename DerivedX>
Eigen::Matrix<typename DerivedX::Scalar, Eigen::Dynamic, Eigen::Dynamic> lfilter(
    const Eigen::MatrixBase<DerivedB>& b, const Eigen::MatrixBase<DerivedA>& a,
    const Eigen::MatrixBase<DerivedX>& x) {
  using Scalar = typename DerivedX::Scalar;
  detail::check_filter("sid::lfilter", b, a);
  if (!x.allFinite()) throw std::invalid_argument("sid::lfilter: x must be finite");
  const auto tf = detail::normalized_padded<Scalar>(b, a);
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> y(x.rows(), x.cols());
  Eigen::Matrix<Scalar, Eigen::Dynamic, 1> z(tf.b.size() - 1);
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    z.setZero();
    detail::lfilter_column(tf, x.col(c), y.col(c), z);
  }
  return y;
}

/// @brief lfilter with initial state zi ((L - 1) x k, one column per signal column, L =
/// max(len a, len b)); returns the output and the final state, as lfilter(b, a, x, zi=zi).
/// @throws std::invalid_argument on bad coefficients, non-finite x or zi, or a zi of wrong size.
template <typename DerivedB, typename DerivedA, typename DerivedX, typename DerivedZ>
FilterState<typename DerivedX::Scalar> lfilter(const Eigen::MatrixBase<DerivedB>& b,
                                               const Eigen::MatrixBase<DerivedA>& a,
                                               const Eigen::MatrixBase<DerivedX>& x,
                                               const Eigen::MatrixBase<DerivedZ>& zi) {
  using Scalar = typename DerivedX::Scalar;
  detail::check_filter("sid::lfilter", b, a);
  if (!x.allFinite()) throw std::invalid_argument("sid::lfilter: x must be finite");
  const auto tf = detail::normalized_padded<Scalar>(b, a);
  const Eigen::Index len = tf.b.size();
  if (zi.rows() != len - 1 || zi.cols() != x.cols())
    throw std::invalid_argument("sid::lfilter: zi must be " + std::to_string(len - 1) + " x " +
                                std::to_string(x.cols()) + ", got " + std::to_string(zi.rows()) +
                                " x " + std::to_string(zi.cols()));
  if (!zi.allFinite()) throw std::invalid_argument("sid::lfilter: zi must be finite");
  FilterState<Scalar> out;
  out.y.resize(x.rows(), x.cols());
  out.zf = zi;
  for (Eigen::Index c = 0; c < x.cols(); ++c)
    detail::lfilter_column(tf, x.col(c), out.y.col(c), out.zf.col(c));
  return out;
}

/// @brief Zero-phase forward-backward filtering of each column of x, as
/// scipy.signal.filtfilt(b, a, x, axis=0) with its defaults: odd extension by
/// padlen = 3 max(len a, len b) samples at both ends (2 x0 - x[padlen..1] before,
/// 2 x_{n-1} - x[n-2..n-1-padlen] after), forward lfilter from lfilter_zi * (first extended
/// sample), backward lfilter of the reversed output from lfilter_zi * (last forward output),
/// reverse, trim the padding.
/// @pre x.rows() > padlen (as SciPy).
/// @return y with the shape of x: the magnitude response is |H|^2 and the phase is zero.
/// @throws std::invalid_argument on bad coefficients, non-finite x, or x.rows() <= padlen.
template <typename DerivedB, typename DerivedA, typename DerivedX>
Eigen::Matrix<typename DerivedX::Scalar, Eigen::Dynamic, Eigen::Dynamic> filtfilt(
    const Eigen::MatrixBase<DerivedB>& b, const Eigen::MatrixBase<DerivedA>& a,
    const Eigen::MatrixBase<DerivedX>& x) {
  using Scalar = typename DerivedX::Scalar;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;
  static_assert(std::is_same_v<Scalar, typename DerivedB::Scalar> &&
                    std::is_same_v<Scalar, typename DerivedA::Scalar>,
                "sid::filtfilt: b, a and x must have the same Scalar");
  detail::check_filter("sid::filtfilt", b, a);
  const Eigen::Index padlen = 3 * std::max(a.size(), b.size());
  const Eigen::Index n = x.rows();
  if (n <= padlen)
    throw std::invalid_argument("sid::filtfilt: x must have more rows than padlen = " +
                                std::to_string(padlen) + ", got " + std::to_string(n));
  if (!x.allFinite()) throw std::invalid_argument("sid::filtfilt: x must be finite");
  const auto tf = detail::normalized_padded<Scalar>(b, a);
  const Vector zi = lfilter_zi(b, a);

  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> y(n, x.cols());
  const Eigen::Index n_ext = n + 2 * padlen;
  Vector ext(n_ext), forward(n_ext), backward(n_ext), z(zi.size());
  for (Eigen::Index c = 0; c < x.cols(); ++c) {
    const auto xc = x.col(c);
    const Scalar first = xc(0), last = xc(n - 1);
    for (Eigen::Index i = 0; i < padlen; ++i) ext(i) = Scalar(2) * first - xc(padlen - i);
    ext.segment(padlen, n) = xc;
    for (Eigen::Index i = 0; i < padlen; ++i)
      ext(padlen + n + i) = Scalar(2) * last - xc(n - 2 - i);

    z = zi * ext(0);
    detail::lfilter_column(tf, ext, forward, z);
    z = zi * forward(n_ext - 1);
    detail::lfilter_column(tf, forward.reverse(), backward, z);
    y.col(c) = backward.reverse().segment(padlen, n);
  }
  return y;
}

/// @brief filtfilt with the coefficients of a TransferFunction (e.g. from butterworth_lowpass).
template <typename Scalar, typename DerivedX>
Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> filtfilt(
    const TransferFunction<Scalar>& filter, const Eigen::MatrixBase<DerivedX>& x) {
  return filtfilt(filter.b, filter.a, x);
}

}  // namespace sid
