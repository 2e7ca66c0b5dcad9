// Benchmarks of the CVODE simulator on the paper's experiment (10 s, 4001 samples).
// Run: simulator_bench --benchmark_repetitions=3 --benchmark_report_aggregates_only=true
// "max" is the slowest repetition's mean; worst_ms the slowest single run of all iterations.

#include <sid/cvode/experiment.hpp>

#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

namespace {

// The paper's arm, written out (independent of include/sid/model/), 2x2 solve by Cramer's rule.
struct PaperArm {
  double th[7] = {0.034015193438, 0.003064135808, 0.0045320492, 0.13291456,
                  0.01694224,     0.6189,         0.6189};
  double g = 9.81;
  Eigen::Vector2d operator()(const Eigen::Vector2d& q, const Eigen::Vector2d& qd,
                             const Eigen::Vector2d& tau) const {
    const double c2 = std::cos(q[1]);
    const double s2 = std::sin(q[1]);
    const double s12 = std::sin(q[0] + q[1]);
    const double d11 = th[0] + th[1] + 2.0 * th[2] * c2;
    const double d12 = th[1] + th[2] * c2;
    const double d22 = th[1];
    const double b1 = tau[0] + th[2] * s2 * (2.0 * qd[0] * qd[1] + qd[1] * qd[1]) - th[5] * qd[0] -
                      th[3] * g * std::sin(q[0]) - th[4] * g * s12;
    const double b2 = tau[1] - th[2] * s2 * qd[0] * qd[0] - th[6] * qd[1] - th[4] * g * s12;
    const double det = d11 * d22 - d12 * d12;
    return Eigen::Vector2d((d22 * b1 - d12 * b2) / det, (d11 * b2 - d12 * b1) / det);
  }
};

void run_experiment(benchmark::State& state, sid::IntegrationMethod method, double tolerance) {
  sid::ArmExperiment experiment;
  experiment.simulator.method = method;
  experiment.simulator.rtol = experiment.simulator.atol = tolerance;
  const PaperArm arm;
  double worst = 0.0;
  sid::SimulationStatistics stats;
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    const sid::ExperimentResult run =
        sid::simulate_arm_experiment(arm, sid::PaperInput(), experiment);
    benchmark::DoNotOptimize(run.truth.q.data());
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    worst = std::max(worst, elapsed);
    if (!run.ok()) {
      state.SkipWithError(run.message.c_str());
      return;
    }
    stats = run.statistics;
  }
  state.counters["steps"] = static_cast<double>(stats.steps);
  state.counters["rhs"] = static_cast<double>(stats.rhs_evaluations);
  state.counters["jac"] = static_cast<double>(stats.jacobian_evaluations);
  state.counters["worst_ms"] = worst * 1e3;
}

double max_of(const std::vector<double>& v) { return *std::max_element(v.begin(), v.end()); }

void BM_PaperExperimentAdamsNewton(benchmark::State& state) {
  run_experiment(state, sid::IntegrationMethod::AdamsNewton, 1e-10);
}
void BM_PaperExperimentBdf(benchmark::State& state) {
  run_experiment(state, sid::IntegrationMethod::Bdf, 1e-10);
}
void BM_PaperExperimentAdamsFixedPoint(benchmark::State& state) {
  run_experiment(state, sid::IntegrationMethod::AdamsFixedPoint, 1e-10);
}
void BM_PaperExperimentAdamsNewtonTight(benchmark::State& state) {
  run_experiment(state, sid::IntegrationMethod::AdamsNewton, 1e-12);
}

}  // namespace

BENCHMARK(BM_PaperExperimentAdamsNewton)
    ->Unit(benchmark::kMillisecond)
    ->ComputeStatistics("max", max_of);
BENCHMARK(BM_PaperExperimentBdf)->Unit(benchmark::kMillisecond)->ComputeStatistics("max", max_of);
BENCHMARK(BM_PaperExperimentAdamsFixedPoint)
    ->Unit(benchmark::kMillisecond)
    ->ComputeStatistics("max", max_of);
BENCHMARK(BM_PaperExperimentAdamsNewtonTight)
    ->Unit(benchmark::kMillisecond)
    ->ComputeStatistics("max", max_of);
