#pragma once
/// @file
/// @brief Inline sine and cosine of one angle for the fixed-size arm fast paths.
///
/// glibc's sincos costs about 11 ns per call, two per sample, which alone would exceed the 50 us
/// budget for stacking the paper's 4001-sample regressor. This branch-light inline version (Cody-
/// Waite reduction to [-pi/4, pi/4] + the Cephes minimax polynomials, Moshier 1989) is within
/// 2 ulp of glibc there and lets the compiler pipeline consecutive samples. Outside |x| <= 1e6 rad
/// (or for NaN/inf) and for every Scalar other than double it defers to std::sin/std::cos.

#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace sid::detail {

template <typename Scalar>
struct SinCos {
  Scalar sin;
  Scalar cos;
};

inline SinCos<double> sincos_reduced(double x) noexcept {
  // pi/2 split into three parts; the first two have trailing zero bits so k * part is exact for
  // |k| < 2^29 (Cephes sin.c, DP1..DP3 doubled).
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kPio2Part1 = 1.57079625129699707031;
  constexpr double kPio2Part2 = 7.54978941586159635335e-8;
  constexpr double kPio2Part3 = 5.39030285815811905290e-15;
  // Adding and subtracting 1.5 * 2^52 rounds to the nearest integer without a libm call.
  constexpr double kRoundMagic = 6755399441055744.0;
  const double k = (x * kTwoOverPi + kRoundMagic) - kRoundMagic;
  const double r = ((x - k * kPio2Part1) - k * kPio2Part2) - k * kPio2Part3;
  const double z = r * r;
  // Cephes sincof / coscof: minimax on [-pi/4, pi/4].
  const double s =
      r + r * z *
              (-1.66666666666666307295e-1 +
               z * (8.33333333332211858878e-3 +
                    z * (-1.98412698295895385996e-4 +
                         z * (2.75573136213857245213e-6 +
                              z * (-2.50507477628578072866e-8 + z * 1.58962301576546568060e-10)))));
  const double c =
      1.0 - 0.5 * z +
      z * z *
          (4.16666666666665929218e-2 +
           z * (-1.38888888888730564116e-3 +
                z * (2.48015872888517045348e-5 +
                     z * (-2.75573141792967388112e-7 +
                          z * (2.08757008419747316778e-9 + z * -1.13585365213876817300e-11)))));
  const auto quadrant = static_cast<std::int64_t>(k) & 3;
  const double sin_abs = (quadrant & 1) ? c : s;
  const double cos_abs = (quadrant & 1) ? s : c;
  return {(quadrant & 2) ? -sin_abs : sin_abs, ((quadrant + 1) & 2) ? -cos_abs : cos_abs};
}

/// @brief sin and cos of x[0..n-1] into s, c without branches, so that the compiler vectorizes
/// the loop (quadrant logic on the bits of the rounded multiple of pi/2 instead of selects).
/// @pre |x[i]| <= 1e6 and finite (callers check and fall back to std::sin/std::cos otherwise).
inline void sincos_batch(const double* x, double* s, double* c, long n) noexcept {
  constexpr double kTwoOverPi = 0.63661977236758134308;
  constexpr double kPio2Part1 = 1.57079625129699707031;
  constexpr double kPio2Part2 = 7.54978941586159635335e-8;
  constexpr double kPio2Part3 = 5.39030285815811905290e-15;
  constexpr double kRoundMagic = 6755399441055744.0;
  for (long i = 0; i < n; ++i) {
    const double shifted = x[i] * kTwoOverPi + kRoundMagic;
    const double k = shifted - kRoundMagic;
    const double r = ((x[i] - k * kPio2Part1) - k * kPio2Part2) - k * kPio2Part3;
    const double z = r * r;
    const double sr =
        r +
        r * z *
            (-1.66666666666666307295e-1 +
             z * (8.33333333332211858878e-3 +
                  z * (-1.98412698295895385996e-4 +
                       z * (2.75573136213857245213e-6 +
                            z * (-2.50507477628578072866e-8 + z * 1.58962301576546568060e-10)))));
    const double cr =
        1.0 - 0.5 * z +
        z * z *
            (4.16666666666665929218e-2 +
             z * (-1.38888888888730564116e-3 +
                  z * (2.48015872888517045348e-5 +
                       z * (-2.75573141792967388112e-7 +
                            z * (2.08757008419747316778e-9 + z * -1.13585365213876817300e-11)))));
    // The low mantissa bits of shifted hold k (two's complement), so k mod 4 is bits & 3.
    std::uint64_t kb, sb, cb;
    std::memcpy(&kb, &shifted, sizeof kb);
    std::memcpy(&sb, &sr, sizeof sb);
    std::memcpy(&cb, &cr, sizeof cb);
    const std::uint64_t swap = std::uint64_t(0) - (kb & 1);  // all ones in odd quadrants
    const std::uint64_t sin_bits = ((cb & swap) | (sb & ~swap)) ^ ((kb & 2) << 62);
    const std::uint64_t cos_bits = ((sb & swap) | (cb & ~swap)) ^ (((kb + 1) & 2) << 62);
    std::memcpy(&s[i], &sin_bits, sizeof sin_bits);
    std::memcpy(&c[i], &cos_bits, sizeof cos_bits);
  }
}

/// Largest |x| [rad] for which the inline paths are used; the reduction stays exact well beyond.
inline constexpr double kFastSinCosLimit = 1e6;

/// @brief sin(x) and cos(x); fast inline path for double, std functions otherwise.
template <typename Scalar>
SinCos<Scalar> sincos(const Scalar& x) noexcept {
  using std::cos;
  using std::sin;
  if constexpr (std::is_same_v<Scalar, double>) {
    if (std::fabs(x) <= kFastSinCosLimit) return sincos_reduced(x);
  }
  return {sin(x), cos(x)};
}

}  // namespace sid::detail
