// Reinsch smoother: fixed-p fit and S-constrained fit, each including g, g', g'' at all knots.
#include <sid/smoothing_spline.hpp>

#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

namespace {

constexpr double kSigma = 1e-3;  // noise of the test signal (the paper's sigma_q2 = 1e-6)

struct Signal {
  Eigen::VectorXd t, y;
};

// A trajectory-like signal sampled at 400 Hz, like the paper's experiment, with fixed-seed noise.
Signal make_signal(Eigen::Index n) {
  std::mt19937_64 rng(2024);
  std::normal_distribution<double> noise(0.0, kSigma);
  Signal s{Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (Eigen::Index i = 0; i < n; ++i) {
    s.t[i] = 0.0025 * static_cast<double>(i);
    s.y[i] = std::sin(s.t[i]) + 0.5 * std::sin(3.1 * s.t[i]) + noise(rng);
  }
  return s;
}

void touch_derivatives(const sid::SmoothingFit<double>& fit) {
  const Eigen::VectorXd g = fit.spline.derivatives_at_knots(0);
  const Eigen::VectorXd dg = fit.spline.derivatives_at_knots(1);
  const Eigen::VectorXd d2g = fit.spline.derivatives_at_knots(2);
  benchmark::DoNotOptimize(g.data());
  benchmark::DoNotOptimize(dg.data());
  benchmark::DoNotOptimize(d2g.data());
}

void BM_SmoothingFixedP(benchmark::State& state) {
  const Signal s = make_signal(state.range(0));
  const sid::SmoothingSpline<double> spline(s.t);
  const double p = spline.fit_constrained(s.y, kSigma).p;  // a realistic p for this signal
  for (auto _ : state) touch_derivatives(spline.fit_penalized(s.y, kSigma, p));
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetComplexityN(state.range(0));
}

void BM_SmoothingConstrainedS(benchmark::State& state) {
  const Signal s = make_signal(state.range(0));
  int factorizations = 0;
  for (auto _ : state) {
    const sid::SmoothingSpline<double> spline(s.t);        // grid set-up included
    const auto fit = spline.fit_constrained(s.y, kSigma);  // S = n
    factorizations = fit.factorizations;
    touch_derivatives(fit);
  }
  state.counters["factorizations"] = factorizations;
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetComplexityN(state.range(0));
}

void BM_SmoothingGcv(benchmark::State& state) {
  const Signal s = make_signal(state.range(0));
  int evaluations = 0;
  double sigma = 0.0;
  for (auto _ : state) {
    const sid::SmoothingSpline<double> spline(s.t);
    const auto fit = spline.fit_cross_validated(s.y);  // no noise level given
    evaluations = fit.iterations;
    sigma = fit.sigma;
    touch_derivatives(fit);
  }
  state.counters["evaluations"] = evaluations;
  state.counters["sigma_hat_over_sigma"] = sigma / kSigma;
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetComplexityN(state.range(0));
}

}  // namespace

BENCHMARK(BM_SmoothingGcv)
    ->Arg(4001)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMicrosecond)
    ->Complexity(benchmark::oN);
BENCHMARK(BM_SmoothingFixedP)
    ->Arg(4001)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMicrosecond)
    ->Complexity(benchmark::oN);
BENCHMARK(BM_SmoothingConstrainedS)
    ->Arg(4001)
    ->Arg(100000)
    ->Arg(1000000)
    ->Unit(benchmark::kMicrosecond)
    ->Complexity(benchmark::oN);
