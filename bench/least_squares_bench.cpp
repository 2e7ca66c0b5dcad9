// Least squares on regressors shaped like the paper's: 2n x 7 with joint 1's rows first.

#include <sid/least_squares.hpp>

#include <benchmark/benchmark.h>

#include <random>

namespace {

// A 2n x 7 regressor with columns of very different scale, and y = X theta + noise (fixed seed).
struct Problem {
  Eigen::MatrixXd x;
  Eigen::VectorXd y;
};

Problem make_problem(Eigen::Index rows) {
  std::mt19937_64 rng(42);
  std::normal_distribution<double> normal;
  Eigen::VectorXd scales(7);
  scales << 30.0, 40.0, 20.0, 9.81, 9.81, 5.0, 5.0;
  Problem p{Eigen::MatrixXd(rows, 7), Eigen::VectorXd(rows)};
  for (Eigen::Index j = 0; j < 7; ++j)
    for (Eigen::Index i = 0; i < rows; ++i) p.x(i, j) = scales(j) * normal(rng);
  Eigen::VectorXd theta(7);
  theta << 0.034, 0.0031, 0.0045, 0.133, 0.017, 0.62, 0.62;
  p.y = p.x * theta;
  for (auto& v : p.y) v += 0.1 * normal(rng);
  return p;
}

void BM_LeastSquares(benchmark::State& state) {
  const Problem p = make_problem(state.range(0));
  for (auto _ : state) {
    auto fit = sid::least_squares(p.x, p.y, 2);
    benchmark::DoNotOptimize(fit.theta.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
  state.SetComplexityN(state.range(0));
}
// 8002 = 2 x 4001 rows: the paper's experiment (target <= 1 ms).
BENCHMARK(BM_LeastSquares)
    ->Arg(2002)
    ->Arg(8002)
    ->Arg(32002)
    ->Unit(benchmark::kMicrosecond)
    ->Complexity(benchmark::oN);

void BM_WeightedLeastSquares(benchmark::State& state) {
  const Problem p = make_problem(state.range(0));
  Eigen::VectorXd w(p.y.size());
  w.head(w.size() / 2).setConstant(4.0);
  w.tail(w.size() / 2).setConstant(0.25);
  for (auto _ : state) {
    auto fit = sid::weighted_least_squares(p.x, p.y, w, 2);
    benchmark::DoNotOptimize(fit.theta.data());
  }
  state.SetItemsProcessed(state.iterations() * state.range(0));
}
BENCHMARK(BM_WeightedLeastSquares)->Arg(8002)->Unit(benchmark::kMicrosecond);

}  // namespace
