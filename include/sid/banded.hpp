#pragma once
/// @file
/// @brief Symmetric positive-definite banded matrices: LDLᵀ factorization and solve in
/// O(n·bw²) time and O(n·bw) memory, without pivoting (none is needed for SPD matrices).

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace sid {

/// @brief LDLᵀ factorization of a symmetric positive-definite matrix with `Bandwidth`
/// sub-diagonals (2 for the pentadiagonal Reinsch system).
///
/// The matrix is given by its lower band, column by column: `band(k, j)` = A(j + k, j) for
/// k = 0..Bandwidth (entries that would fall outside the matrix are ignored). The factor is
/// stored in the same layout: `band(0, j)` = D(j) and `band(k, j)` = L(j + k, j), which is what
/// the Hutchinson–de Hoog recurrence for the central band of A⁻¹ needs.
///
/// Class invariant: after a successful factorize(), every D(j) is finite and > 0.
/// @tparam Scalar a real floating-point type.
/// @tparam Bandwidth number of sub-diagonals (>= 1), fixed at compile time so the inner loops unroll.
template <typename Scalar, int Bandwidth>
class BandedLDLT {
  static_assert(std::is_floating_point<Scalar>::value, "BandedLDLT needs a real floating-point Scalar");
  static_assert(Bandwidth >= 1, "BandedLDLT needs at least one sub-diagonal");

 public:
  using Band = Eigen::Matrix<Scalar, Bandwidth + 1, Eigen::Dynamic>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

  BandedLDLT() = default;

  /// @brief Storage for an n×n matrix, its band zeroed; fill it with band() and call factorize().
  explicit BandedLDLT(Eigen::Index n) { resize(n); }

  void resize(Eigen::Index n) {
    if (n < 0) throw std::invalid_argument("sid::BandedLDLT: size must be >= 0, got " + std::to_string(n));
    band_.setZero(Bandwidth + 1, n);
    factorized_ = false;
  }

  Eigen::Index size() const { return band_.cols(); }

  /// @brief The lower band of A before factorize(), of the factor after.
  Band& band() {
    factorized_ = false;
    return band_;
  }
  const Band& band() const { return band_; }

  /// @brief Factorizes in place.
  /// @return false if a pivot is not positive and finite (A not numerically SPD); the band
  /// then holds a partial factor and solve() must not be called.
  [[nodiscard]] bool factorize() noexcept {
    const Eigen::Index n = size();
    for (Eigen::Index j = 0; j < n; ++j) {
      // D(j) = A(j,j) - sum_c L(j,c)^2 D(c)
      Scalar d = band_(0, j);
      for (Eigen::Index c = std::max<Eigen::Index>(0, j - Bandwidth); c < j; ++c) {
        const Scalar l = band_(j - c, c);
        d -= l * l * band_(0, c);
      }
      using std::isfinite;
      if (!(d > Scalar(0)) || !isfinite(d)) {
        factorized_ = false;
        return false;
      }
      band_(0, j) = d;
      const Scalar inv_d = Scalar(1) / d;
      // L(i,j) = (A(i,j) - sum_c L(i,c) L(j,c) D(c)) / D(j), i = j+1..j+Bandwidth
      for (int r = 1; r <= Bandwidth && j + r < n; ++r) {
        const Eigen::Index i = j + r;
        Scalar a = band_(r, j);
        for (Eigen::Index c = std::max<Eigen::Index>(0, i - Bandwidth); c < j; ++c)
          a -= band_(i - c, c) * band_(j - c, c) * band_(0, c);
        band_(r, j) = a * inv_d;
      }
    }
    factorized_ = true;
    return true;
  }

  bool factorized() const { return factorized_; }

  /// @brief Solves A x = b in place (x overwrites b). @pre factorize() returned true.
  template <typename Derived>
  void solve_in_place(Eigen::MatrixBase<Derived>& x) const {
    if (!factorized_) throw std::logic_error("sid::BandedLDLT::solve_in_place: matrix is not factorized");
    if (x.rows() != size())
      throw std::invalid_argument("sid::BandedLDLT::solve_in_place: right-hand side has " +
                                  std::to_string(x.rows()) + " rows, matrix has " +
                                  std::to_string(size()));
    const Eigen::Index n = size();
    for (Eigen::Index col = 0; col < x.cols(); ++col) {
      for (Eigen::Index i = 1; i < n; ++i) {  // L z = b
        Scalar s = x(i, col);
        for (Eigen::Index c = std::max<Eigen::Index>(0, i - Bandwidth); c < i; ++c)
          s -= band_(i - c, c) * x(c, col);
        x(i, col) = s;
      }
      for (Eigen::Index i = 0; i < n; ++i) x(i, col) /= band_(0, i);  // D w = z
      for (Eigen::Index i = n - 2; i >= 0; --i) {                     // Lᵀ x = w
        Scalar s = x(i, col);
        for (Eigen::Index r = 1; r <= Bandwidth && i + r < n; ++r) s -= band_(r, i) * x(i + r, col);
        x(i, col) = s;
      }
    }
  }

  /// @brief Returns A⁻¹ b. @pre factorize() returned true.
  Vector solve(const Eigen::Ref<const Vector>& b) const {
    Vector x = b;
    solve_in_place(x);
    return x;
  }

 private:
  Band band_;
  bool factorized_ = false;
};

}  // namespace sid
