// Finite differences and Butterworth filtering on the paper's signal size: 4001 samples x 2 joints.

#include <sid/butterworth.hpp>
#include <sid/finite_difference.hpp>

#include <benchmark/benchmark.h>

namespace {

constexpr Eigen::Index kSamples = 4001;
constexpr double kTs = 0.0025;

Eigen::MatrixXd joint_angles(Eigen::Index n) {
  const Eigen::ArrayXd t = Eigen::ArrayXd::LinSpaced(n, 0.0, kTs * static_cast<double>(n - 1));
  Eigen::MatrixXd q(n, 2);
  q.col(0) = (0.8 * (1.3 * t).sin() + 0.01 * (170.0 * t).sin()).matrix();
  q.col(1) = (0.5 * (0.9 * t).cos() + 0.01 * (210.0 * t).cos()).matrix();
  return q;
}

void BM_ForwardDifferences(benchmark::State& state) {
  const Eigen::MatrixXd q = joint_angles(kSamples);
  for (auto _ : state) {
    auto d = sid::forward_differences(q, kTs);
    benchmark::DoNotOptimize(d.second.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples * 2);
}
BENCHMARK(BM_ForwardDifferences)->Unit(benchmark::kMicrosecond);

void BM_CentralDifferences(benchmark::State& state) {
  const Eigen::MatrixXd q = joint_angles(kSamples);
  for (auto _ : state) {
    auto d = sid::central_differences(q, kTs);
    benchmark::DoNotOptimize(d.second.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples * 2);
}
BENCHMARK(BM_CentralDifferences)->Unit(benchmark::kMicrosecond);

void BM_ButterworthDesign(benchmark::State& state) {
  for (auto _ : state) {
    auto tf = sid::butterworth_lowpass(4, 0.01);
    benchmark::DoNotOptimize(tf.a.data());
  }
}
BENCHMARK(BM_ButterworthDesign);

// The paper's three filters: q (3, 0.05), qd (3, 0.015), qdd (4, 0.01); arg = order, Wn * 1000.
void BM_Filtfilt(benchmark::State& state) {
  const Eigen::MatrixXd q = joint_angles(kSamples);
  const auto tf = sid::butterworth_lowpass(static_cast<int>(state.range(0)),
                                           static_cast<double>(state.range(1)) / 1000.0);
  for (auto _ : state) {
    auto y = sid::filtfilt(tf, q);
    benchmark::DoNotOptimize(y.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples * 2);
}
BENCHMARK(BM_Filtfilt)->Args({3, 50})->Args({3, 15})->Args({4, 10})->Unit(benchmark::kMicrosecond);

void BM_Lfilter(benchmark::State& state) {
  const Eigen::MatrixXd q = joint_angles(kSamples);
  const auto tf = sid::butterworth_lowpass(4, 0.01);
  for (auto _ : state) {
    auto y = sid::lfilter(tf.b, tf.a, q);
    benchmark::DoNotOptimize(y.data());
  }
  state.SetItemsProcessed(state.iterations() * kSamples * 2);
}
BENCHMARK(BM_Lfilter)->Unit(benchmark::kMicrosecond);

}  // namespace
