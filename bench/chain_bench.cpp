// Timing of a six-joint arm's regressor (Newton-Euler in the parameters) and of stacking the
// 10 s excitation at 1 kHz, the size of a typical identification experiment.

#include <sid/base_parameters.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>

#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <random>

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kNumStates = 1024;  // cycled through so the branch predictor sees varied angles

sid::SerialChain<double> puma560() {
  return sid::SerialChain<double>(sid::DhConvention::Standard, {{0.0, kPi / 2, 0.0, 0.0},
                                                                {0.4318, 0.0, 0.0, 0.0},
                                                                {0.0203, -kPi / 2, 0.15005, 0.0},
                                                                {0.0, kPi / 2, 0.4318, 0.0},
                                                                {0.0, -kPi / 2, 0.0, 0.0},
                                                                {0.0, 0.0, 0.0, 0.0}});
}

Eigen::MatrixXd random_samples(Eigen::Index rows, double bound, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-bound, bound);
  Eigen::MatrixXd m(rows, 6);
  for (auto& v : m.reshaped()) v = u(rng);
  return m;
}

void BM_SixJointRegressor(benchmark::State& state) {
  const auto chain = puma560();
  // States as columns, so that each is contiguous as a control loop's vectors are.
  const Eigen::MatrixXd q = random_samples(kNumStates, kPi, 1).transpose(),
                        qd = random_samples(kNumStates, 2, 2).transpose(),
                        qdd = random_samples(kNumStates, 5, 3).transpose();
  Eigen::MatrixXd y(6, sid::chain_parameter_count(6));
  Eigen::Index i = 0;
  for (auto _ : state) {
    sid::chain_regressor(chain, q.col(i), qd.col(i), qdd.col(i), y);
    benchmark::DoNotOptimize(y.data());
    i = (i + 1) % kNumStates;
  }
}
BENCHMARK(BM_SixJointRegressor);

void BM_SixJointStack10sAt1kHz(benchmark::State& state) {
  const auto chain = puma560();
  constexpr Eigen::Index kSamples = 10000;
  const Eigen::MatrixXd q = random_samples(kSamples, kPi, 1), qd = random_samples(kSamples, 2, 2),
                        qdd = random_samples(kSamples, 5, 3), tau = random_samples(kSamples, 50, 4);
  for (auto _ : state)
    benchmark::DoNotOptimize(sid::stack_chain_regression(chain, q, qd, qdd, tau));
  state.SetItemsProcessed(state.iterations() * kSamples);
}
BENCHMARK(BM_SixJointStack10sAt1kHz)->Unit(benchmark::kMillisecond);

void BM_SixJointBaseParameters(benchmark::State& state) {
  const auto chain = puma560();
  constexpr Eigen::Index kSamples = 300;
  const Eigen::MatrixXd q = random_samples(kSamples, kPi, 1), qd = random_samples(kSamples, 2, 2),
                        qdd = random_samples(kSamples, 5, 3);
  const Eigen::MatrixXd w =
      sid::stack_chain_regression(chain, q, qd, qdd, Eigen::MatrixXd::Zero(kSamples, 6)).X;
  for (auto _ : state) benchmark::DoNotOptimize(sid::base_parameters(w).rank());
}
BENCHMARK(BM_SixJointBaseParameters)->Unit(benchmark::kMillisecond);

}  // namespace
