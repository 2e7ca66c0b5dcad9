// Timing of the arm model: closed-form fast paths against the generic sum-of-terms Model.
// Targets: arm inverse dynamics <= 50 ns per call, stacking n = 4001 samples <= 50 us.

#include <sid/model/model.hpp>
#include <sid/model/regressor.hpp>
#include <sid/model/two_link_arm.hpp>

#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <random>
#include <vector>

namespace {

constexpr int kNumStates = 1024;  // cycled through so the branch predictor sees varied angles
constexpr Eigen::Index kPaperSamples = 4001;

struct States {
  std::vector<sid::Vector2<double>> q, qd, qdd;
};

const States& random_states() {
  static const States states = [] {
    std::mt19937_64 rng(20240601);
    std::uniform_real_distribution<double> angle(-3.14, 3.14), rate(-3.0, 3.0), acc(-10.0, 10.0);
    States s;
    for (int i = 0; i < kNumStates; ++i) {
      s.q.emplace_back(angle(rng), angle(rng));
      s.qd.emplace_back(rate(rng), rate(rng));
      s.qdd.emplace_back(acc(rng), acc(rng));
    }
    return s;
  }();
  return states;
}

struct Samples {
  sid::MatrixX2<double> q, qd, qdd;
};

Samples paper_like_samples(Eigen::Index n) {
  Samples s;
  const Eigen::ArrayXd t = Eigen::ArrayXd::LinSpaced(n, 0.0, 0.0025 * double(n - 1));
  s.q.resize(n, 2);
  s.qd.resize(n, 2);
  s.qdd.resize(n, 2);
  s.q << (1.5 * t.sin()).matrix(), (0.8 * t.cos()).matrix();
  s.qd << (1.5 * t.cos()).matrix(), (-0.8 * t.sin()).matrix();
  s.qdd << (-1.5 * t.sin()).matrix(), (-0.8 * t.cos()).matrix();
  return s;
}

void BM_TwoLinkInverseDynamics(benchmark::State& state) {
  const auto& s = random_states();
  const auto theta = sid::paper_arm_parameters<double>();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sid::two_link_inverse_dynamics(theta, s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TwoLinkInverseDynamics);

void BM_TwoLinkRegressor(benchmark::State& state) {
  const auto& s = random_states();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sid::two_link_regressor(s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TwoLinkRegressor);

void BM_TwoLinkForwardDynamics(benchmark::State& state) {
  const auto& s = random_states();
  const auto theta = sid::paper_arm_parameters<double>();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(sid::two_link_forward_dynamics(theta, s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TwoLinkForwardDynamics);

void BM_ModelInverseDynamics(benchmark::State& state) {
  const auto& s = random_states();
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.inverse_dynamics(theta, s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ModelInverseDynamics);

void BM_ModelRegressor(benchmark::State& state) {
  const auto& s = random_states();
  const auto model = sid::two_link_arm_model<double>();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.regressor(s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ModelRegressor);

void BM_ModelForwardDynamics(benchmark::State& state) {
  const auto& s = random_states();
  const auto model = sid::two_link_arm_model<double>();
  const Eigen::VectorXd theta = sid::paper_arm_parameters<double>();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(model.forward_dynamics(theta, s.q[i], s.qd[i], s.qdd[i]));
    i = (i + 1) & (kNumStates - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ModelForwardDynamics);

void BM_StackTwoLinkRegressor(benchmark::State& state) {
  const Eigen::Index n = state.range(0);
  const Samples s = paper_like_samples(n);
  Eigen::MatrixXd x(2 * n, 7);
  for (auto _ : state) {
    sid::stack_two_link_regressor<double>(s.q, s.qd, s.qdd, sid::kPaperGravity, x);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * n);
  state.SetComplexityN(n);
}
BENCHMARK(BM_StackTwoLinkRegressor)->Arg(kPaperSamples)->Arg(4 * kPaperSamples);

void BM_StackModelRegressor(benchmark::State& state) {
  const Eigen::Index n = state.range(0);
  const Samples s = paper_like_samples(n);
  const auto model = sid::two_link_arm_model<double>();
  Eigen::MatrixXd x(2 * n, model.num_parameters());
  for (auto _ : state) {
    sid::stack_regressor<double>(model, s.q, s.qd, s.qdd, x);
    benchmark::DoNotOptimize(x.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations() * n);
}
BENCHMARK(BM_StackModelRegressor)->Arg(kPaperSamples);

}  // namespace
