// Built against an installed sid through find_package(sid): smooths a line and checks it.
#include <sid/smoothing_spline.hpp>

#include <cmath>
#include <cstdio>

int main() {
  const Eigen::VectorXd t = Eigen::VectorXd::LinSpaced(20, 0.0, 1.0);
  const Eigen::VectorXd y = (1.0 + 2.0 * t.array()).matrix();
  const auto fit = sid::SmoothingSpline<double>(t).fit_constrained(y, 0.1);
  const double slope = fit.spline.derivative(0.5, 1);
  std::printf("slope %.12f\n", slope);
  return std::abs(slope - 2.0) < 1e-9 ? 0 : 1;
}
