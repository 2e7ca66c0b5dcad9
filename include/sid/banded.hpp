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
/// @tparam Bandwidth number of sub-diagonals (>= 1), fixed at compile time so the inner loops
/// unroll.
template <typename Scalar, int Bandwidth>
class BandedLDLT {
  static_assert(std::is_floating_point<Scalar>::value,
                "BandedLDLT needs a real floating-point Scalar");
  static_assert(Bandwidth >= 1, "BandedLDLT needs at least one sub-diagonal");

 public:
  using Band = Eigen::Matrix<Scalar, Bandwidth + 1, Eigen::Dynamic>;
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1>;

  BandedLDLT() = default;

  /// @brief Storage for an n×n matrix, its band zeroed; fill it with band() and call factorize().
  explicit BandedLDLT(Eigen::Index n) { resize(n); }

  void resize(Eigen::Index n) {
    if (n < 0)
      throw std::invalid_argument("sid::BandedLDLT: size must be >= 0, got " + std::to_string(n));
    band_.setZero(Bandwidth + 1, n);  // no reallocation when n is unchanged
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
    // Raw column-major band: entry (k, j) at b[j * kRows + k]. Loops over k have compile-time
    // bounds, so for the pentadiagonal case the compiler emits straight-line code per row.
    const Eigen::Index n = size();
    Scalar* b = band_.data();
    if constexpr (Bandwidth == 2) return factorize_pentadiagonal();
    for (Eigen::Index j = 0; j < n; ++j) {
      Scalar* col = b + j * kRows;
      // D(j) = A(j,j) − Σ_k L(j, j−k)² D(j−k)
      Scalar d = col[0];
      for (int k = 1; k <= Bandwidth; ++k) {
        if (j < k) break;
        const Scalar* prev = b + (j - k) * kRows;
        d -= prev[k] * prev[k] * prev[0];
      }
      using std::isfinite;
      if (!(d > Scalar(0)) || !isfinite(d)) {
        factorized_ = false;
        return false;
      }
      col[0] = d;
      const Scalar inv_d = Scalar(1) / d;
      // L(j+r, j) = (A(j+r, j) − Σ_{c<j} L(j+r, c) L(j, c) D(c)) / D(j); column c = j+r−k.
      for (int r = 1; r <= Bandwidth; ++r) {
        if (j + r >= n) break;
        Scalar a = col[r];
        for (int k = r + 1; k <= Bandwidth; ++k) {
          const Eigen::Index c = j + r - k;
          if (c < 0) break;
          const Scalar* cc = b + c * kRows;
          a -= cc[k] * cc[k - r] * cc[0];
        }
        col[r] = a * inv_d;
      }
    }
    factorized_ = true;
    return true;
  }

  bool factorized() const { return factorized_; }

  /// @brief Solves A x = b in place (x overwrites b). @pre factorize() returned true.
  template <typename Derived>
  void solve_in_place(Eigen::MatrixBase<Derived>& x) const {
    static_assert(Derived::InnerStrideAtCompileTime == 1,
                  "solve_in_place needs contiguous columns");
    if (!factorized_)
      throw std::logic_error("sid::BandedLDLT::solve_in_place: matrix is not factorized");
    if (x.rows() != size())
      throw std::invalid_argument("sid::BandedLDLT::solve_in_place: right-hand side has " +
                                  std::to_string(x.rows()) + " rows, matrix has " +
                                  std::to_string(size()));
    const Eigen::Index n = size();
    const Scalar* b = band_.data();
    for (Eigen::Index col = 0; col < x.cols(); ++col) {
      Scalar* v = &x(0, col);  // Vector-like storage: unit inner stride is required below
      if constexpr (Bandwidth == 2) {
        solve_pentadiagonal(v);
        continue;
      }
      for (Eigen::Index i = 0; i < n; ++i) {  // L z = b, then w = z / D
        Scalar s = v[i];
        for (int k = 1; k <= Bandwidth; ++k) {
          if (i < k) break;
          s -= b[(i - k) * kRows + k] * v[i - k];
        }
        v[i] = s;
      }
      for (Eigen::Index i = 0; i < n; ++i) v[i] /= b[i * kRows];
      for (Eigen::Index i = n - 2; i >= 0; --i) {  // Lᵀ x = w
        Scalar s = v[i];
        for (int r = 1; r <= Bandwidth; ++r) {
          if (i + r >= n) break;
          s -= b[i * kRows + r] * v[i + r];
        }
        v[i] = s;
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
  static constexpr int kRows = Bandwidth + 1;

  // The pentadiagonal case (the Reinsch system) as straight-line code with the previous rows
  // held in registers: no per-row branches, about half the time of the general loops.
  bool factorize_pentadiagonal() noexcept {
    // With eₖ = L(·, k) D(k) (the numerators before the division), D(j+1) = A − L e − L e needs
    // only one division on the dependency chain from D(j) to D(j+1).
    const Eigen::Index n = size();
    Scalar* b = band_.data();
    Scalar l_j_1(0), e_j_1(0);        // L(j, j-1), L(j, j-1) D(j-1)
    Scalar l_j_2(0), e_j_2(0);        // L(j, j-2), L(j, j-2) D(j-2)
    Scalar l_next_1(0), e_next_1(0);  // L(j+1, j-1), L(j+1, j-1) D(j-1)
    using std::isfinite;
    for (Eigen::Index j = 0; j < n; ++j) {
      Scalar* col = b + j * kRows;
      const Scalar d = col[0] - l_j_1 * e_j_1 - l_j_2 * e_j_2;
      if (!(d > Scalar(0)) || !isfinite(d)) {
        factorized_ = false;
        return false;
      }
      const Scalar e1 = col[1] - l_next_1 * e_j_1;  // L(j+1, j) D(j)
      const Scalar e2 = col[2];                     // L(j+2, j) D(j)
      const Scalar l1 = e1 / d, l2 = e2 / d;
      col[0] = d;
      col[1] = j + 1 < n ? l1 : Scalar(0);
      col[2] = j + 2 < n ? l2 : Scalar(0);
      l_j_2 = l_next_1;
      e_j_2 = e_next_1;
      l_j_1 = l1;
      e_j_1 = e1;
      l_next_1 = l2;
      e_next_1 = e2;
    }
    factorized_ = true;
    return true;
  }

  void solve_pentadiagonal(Scalar* v) const noexcept {
    const Eigen::Index n = size();
    const Scalar* b = band_.data();
    Scalar z_prev2(0), z_prev1(0);
    for (Eigen::Index i = 0; i < n;
         ++i) {  // L z = b; L(i, i-1) = b[(i-1)*3+1], L(i, i-2) = b[(i-2)*3+2]
      const Scalar l1 = i >= 1 ? b[(i - 1) * kRows + 1] : Scalar(0);
      const Scalar l2 = i >= 2 ? b[(i - 2) * kRows + 2] : Scalar(0);
      const Scalar z = v[i] - l1 * z_prev1 - l2 * z_prev2;
      v[i] = z;
      z_prev2 = z_prev1;
      z_prev1 = z;
    }
    Scalar x_next2(0), x_next1(0);
    for (Eigen::Index i = n - 1; i >= 0; --i) {  // Lᵀ x = z / D
      const Scalar* col = b + i * kRows;
      const Scalar x = v[i] / col[0] - col[1] * x_next1 - col[2] * x_next2;
      v[i] = x;
      x_next2 = x_next1;
      x_next1 = x;
    }
  }

  Band band_;
  bool factorized_ = false;
};

}  // namespace sid
