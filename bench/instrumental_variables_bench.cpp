// The IDIM-IV step on one data set of the study (σq² = 1e-4): what css_iv adds per run.
// Run: instrumental_variables_bench --benchmark_repetitions=3
// --benchmark_report_aggregates_only=true
// And sid_identify --robot's two estimators against the truth on a simulated six-axis arm
// (--benchmark_filter=ChainIvAgainstLeastSquares; runs once and prints the table).

#include <sid/cvode/chain_experiment.hpp>
#include <sid/cvode/chain_instrumental_variables.hpp>
#include <sid/cvode/experiment.hpp>
#include <sid/cvode/instrumental_variables.hpp>
#include <sid/identify_chain.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/study/montecarlo.hpp>

#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <string>

#include "../tests/chain_hidden_terms.hpp"

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

// The TX40's URDF with viscous friction 0.5 and a rotor of 0.01 on every joint, 10 s at 500 Hz of
// a random Fourier excitation (seeds 1-3), σ_τ = 0.1 N m, at three angle noise levels: the true
// torque's prediction error 100 |Y β̂ - τ| / |τ| at the true motion, for identify_chain (least
// squares at cutoffs chosen by held-out torque prediction) and identify_chain_iv.
void BM_ChainIvAgainstLeastSquares(benchmark::State& state) {
  const sid::ChainModel model = sid_test::tx40_hidden_term_experiment({}, 1, 0.1).truth;
  const sid::BaseParameters<double> base = sid::chain_base_parameters(model);
  std::string table;
  double iv_seconds = 0.0;
  int iv_runs = 0;
  for (auto _ : state) {
    table.clear();
    for (const double sigma_q2 : {1e-8, 1e-6, 1e-4}) {
      double ls_sum = 0.0, iv_sum = 0.0, ls_worst = 0.0, iv_worst = 0.0;
      int used = 0, runs = 0;
      for (const unsigned seed : {1u, 2u, 3u}) {
        sid_test::Tx40Experiment e = sid_test::tx40_hidden_term_experiment({}, seed);
        const sid::ChainExperimentResult& run = e.run;
        std::mt19937_64& rng = e.rng;
        const sid::ChainTrajectory<double> noisy = sid::add_measurement_noise(
            run.trajectory(), sid::MeasurementNoise<double>{sigma_q2, 1e-2}, rng);
        const auto truth = sid::detail::window_rows(run.truth, 0.25, 9.75);
        const sid::ChainRegression exact = sid::chain_regression(
            model, base.independent, truth, sid::chain_regression_samples(truth.t, 100.0));
        const auto error = [&](const Eigen::VectorXd& beta) {
          return 100.0 * (exact.x * beta - exact.y).norm() / exact.y.norm();
        };
        const sid::ChainIdentification ls = sid::identify_chain(model, {noisy});
        if (ls.base.independent != base.independent) {
          state.SkipWithError("the run leaves base parameters undetermined");
          return;
        }
        const auto start = std::chrono::steady_clock::now();
        const sid::ChainIvIdentification iv = sid::identify_chain_iv(model, base, {noisy});
        iv_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        ++iv_runs;
        const double e_ls = error(ls.fit.theta), e_iv = error(iv.iv.fit.theta);
        ls_sum += e_ls;
        ls_worst = std::max(ls_worst, e_ls);
        ++runs;
        if (iv.iv.converged) {
          iv_sum += e_iv;
          iv_worst = std::max(iv_worst, e_iv);
          ++used;
        }
      }
      char line[256];
      std::snprintf(line, sizeof line,
                    "  sigma_q2 %-6g | ls mean %.3f %%, worst %.3f %% | iv mean %.3f %%, worst "
                    "%.3f %% (%d/%d converged)\n",
                    sigma_q2, ls_sum / runs, ls_worst, used ? iv_sum / used : 0.0, iv_worst, used,
                    runs);
      table += line;
    }
  }
  std::printf(
      "\nTrue torque's prediction error, TX40 with rotors, 10 s at 500 Hz, sigma_tau = 0.1 N m, "
      "seeds 1-3\n%sidentify_chain_iv: %.2f s per run\n\n",
      table.c_str(), iv_seconds / std::max(iv_runs, 1));
}
BENCHMARK(BM_ChainIvAgainstLeastSquares)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
