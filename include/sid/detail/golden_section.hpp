#pragma once
// The minimum of a function of one variable within a bracket, by golden-section search.

#include <cmath>

namespace sid::detail {

/// The middle of the last bracket around a minimum of f in [left, right], narrowed by the golden
/// ratio until it is at most `tolerance` wide. f is taken to have one minimum in the bracket (a
/// coarse scan finds it first).
template <typename F>
double golden_section_minimum(const F& f, double left, double right, double tolerance) {
  const double ratio = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = right - ratio * (right - left), x2 = left + ratio * (right - left);
  double f1 = f(x1), f2 = f(x2);
  while (right - left > tolerance) {
    if (f1 < f2) {
      right = x2;
      x2 = x1;
      f2 = f1;
      x1 = right - ratio * (right - left);
      f1 = f(x1);
    } else {
      left = x1;
      x1 = x2;
      f1 = f2;
      x2 = left + ratio * (right - left);
      f2 = f(x2);
    }
  }
  return 0.5 * (left + right);
}

}  // namespace sid::detail
