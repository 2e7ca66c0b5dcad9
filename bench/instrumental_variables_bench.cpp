// The IDIM-IV step on one data set of the study (σq² = 1e-4): what css_iv adds per run.
// Run: instrumental_variables_bench --benchmark_repetitions=3
// --benchmark_report_aggregates_only=true

#include <sid/cvode/experiment.hpp>
#include <sid/cvode/instrumental_variables.hpp>
#include <sid/study/montecarlo.hpp>

#include <benchmark/benchmark.h>

#include <stdexcept>

namespace {

struct Case {
  sid::Kinematics<double> kept;
  sid::LeastSquaresResult<double> first;
};

const Case& study_case() {
  static const Case c = [] {
    const auto theta = sid::paper_arm_parameters<double>();
    const auto run =
        sid::simulate_arm_experiment([&](const auto& q, const auto& qd, const auto& tau) {
          return sid::two_link_forward_dynamics(theta, q, qd, tau);
        });
    if (!run.ok()) throw std::runtime_error(run.message);
    auto rng = sid::run_generator(20240601, 2, 0);
    const auto measured =
        sid::add_measurement_noise(run.truth, sid::MeasurementNoise<double>{1e-4, 1e-2}, rng);
    const sid::IdentifyOptions base;
    Case out;
    out.kept = sid::window(
        sid::study_kinematics(sid::StudyMethod::CssIv, run.truth, measured, 1e-4, base), 0.25);
    out.first = sid::fit_two_link(out.kept, sid::kPaperGravity);
    return out;
  }();
  return c;
}

void BM_InstrumentalVariableStep(benchmark::State& state) {
  const Case& c = study_case();
  int iterations = 0;
  for (auto _ : state) {
    const auto iv = sid::refine_instrumental_variables(c.kept, c.first);
    if (!iv.ok()) state.SkipWithError(iv.message.c_str());
    iterations = iv.iterations;
    benchmark::DoNotOptimize(iv.fit.theta.data());
  }
  state.counters["iv_iterations"] = iterations;
}
BENCHMARK(BM_InstrumentalVariableStep)->Unit(benchmark::kMillisecond);

}  // namespace
