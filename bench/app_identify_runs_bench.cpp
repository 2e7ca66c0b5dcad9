// Identification and diagnosis from measured runs: the six DFKI double-pendulum runs in tests/data
// (29 k samples on non-uniform grids), read with the apps' CSV reader.

#include <sid/identify_runs.hpp>
#include <sid/diagnose_runs.hpp>

#include <benchmark/benchmark.h>

#include <sid/model/two_link_arm.hpp>
#include <string>
#include <vector>

#include "csv.hpp"

namespace {

const std::vector<sid::Trajectory<double>>& real_runs() {
  static const std::vector<sid::Trajectory<double>> runs = [] {
    sid::app::TrajectoryColumns columns;
    columns.t = "time";
    columns.q1 = "pos_meas1";
    columns.q2 = "pos_meas2";
    columns.tau1 = "tau_meas1";
    columns.tau2 = "tau_meas2";
    std::vector<sid::Trajectory<double>> out;
    for (const char* id : {"00", "01", "02", "03", "05", "12"})
      out.push_back(sid::app::trajectory_from_table(
          sid::app::read_csv(std::string(SID_TEST_DATA_DIR) + "/dfki_double_pendulum/trajectory_" +
                             id + ".csv"),
          columns));
    return out;
  }();
  return runs;
}

// One run's spline at one cutoff, both joints, derivatives at every sample.
void BM_KinematicsAtCutoff(benchmark::State& state) {
  const sid::Trajectory<double>& run = real_runs().front();
  for (auto _ : state) {
    const auto k = sid::kinematics_at_cutoff(run, 4.76);
    benchmark::DoNotOptimize(k.qdd.data());
  }
  state.SetItemsProcessed(state.iterations() * run.size());
}

// The whole identification of the six runs: 33 cutoffs cross-validated, then the QR fit.
// Argument: threads of the cutoff search.
void BM_IdentifySixRealRuns(benchmark::State& state) {
  const sid::Model<double> model = sid::two_link_arm_model<double>(sid::kPaperGravity);
  sid::RunsIdentifyOptions options;
  options.threads = static_cast<int>(state.range(0));
  Eigen::Index samples = 0;
  for (const auto& r : real_runs()) samples += r.size();
  for (auto _ : state) {
    const auto id = sid::identify_runs(real_runs(), model, options);
    benchmark::DoNotOptimize(id.fit.theta.data());
  }
  state.SetItemsProcessed(state.iterations() * samples);
  state.counters["runs"] = static_cast<double>(real_runs().size());
}

// The diagnosis of the six runs together (torque domain: cutoff, forward selection with each
// run held out in turn, final fit, rotor coupling test); the apps add one free simulation per run.
// Argument: threads of the cutoff search.
void BM_DiagnoseSixRealRuns(benchmark::State& state) {
  sid::RunsDiagnoseOptions options;
  options.identify.threads = static_cast<int>(state.range(0));
  Eigen::Index samples = 0;
  for (const auto& r : real_runs()) samples += r.size();
  for (auto _ : state) {
    const auto d = sid::diagnose_runs(real_runs(), options);
    benchmark::DoNotOptimize(d.final.fit.theta.data());
  }
  state.SetItemsProcessed(state.iterations() * samples);
}

}  // namespace

BENCHMARK(BM_DiagnoseSixRealRuns)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_KinematicsAtCutoff)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_IdentifySixRealRuns)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
