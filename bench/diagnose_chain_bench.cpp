// The chain diagnosis on a simulated six-axis arm (the TX40's URDF): one drive term hidden at a
// time on each joint, for each kind the diagnosis tries, and effect-free controls, two seeds
// each. Runs once; prints what was named for every data set and the time per data set.

#include <sid/diagnose_chain.hpp>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "../tests/chain_hidden_terms.hpp"

namespace {

void BM_ChainHiddenTerms(benchmark::State& state) {
  struct Kind {
    sid::DriveTermKind kind;
    double value;
  };
  const std::vector<Kind> kinds = {{sid::DriveTermKind::Coulomb, 1.0},
                                   {sid::DriveTermKind::Offset, 0.5},
                                   {sid::DriveTermKind::Spring, 1.0},
                                   {sid::DriveTermKind::Armature, 0.05}};
  int right = 0, total = 0;
  double seconds = 0.0, worst = 0.0;
  std::string report;
  for (auto _ : state) {
    right = total = 0;
    seconds = worst = 0.0;
    report.clear();
    const auto record = [&](const std::string& hidden, const sid::ChainDiagnosis& r,
                            const std::string& expected, unsigned seed) {
      std::string named, not_separable;
      for (const auto& e : r.named) {
        char value[96];
        std::snprintf(value, sizeof value, "%s=%.4g(+-%.2g; cv %.2g %%)", e.id.c_str(), e.value,
                      e.std, 100.0 * e.cv_drop);
        named += (named.empty() ? "" : ",") + std::string(value);
      }
      for (const auto& t : r.not_named)
        if (t.reason.rfind("not separable", 0) == 0)
          not_separable += (not_separable.empty() ? "" : ",") + t.id;
      const bool ok =
          expected.empty() ? r.named.empty() : r.named.size() == 1 && r.named[0].id == expected;
      right += ok ? 1 : 0;
      ++total;
      seconds += r.seconds;
      worst = std::max(worst, r.seconds);
      char line[512];
      std::snprintf(line, sizeof line,
                    "  %-16s seed %u | %-5s | %-40s | %.2f s | not separable: %s\n", hidden.c_str(),
                    seed, ok ? "right" : "WRONG", named.empty() ? "(none)" : named.c_str(),
                    r.seconds, not_separable.empty() ? "-" : not_separable.c_str());
      report += line;
    };
    for (const unsigned seed : {1u, 2u})
      record(
          "none",
          sid::diagnose_chain(sid_test::tx40_nominal(), {sid_test::tx40_hidden_term_run({}, seed)}),
          "", seed);
    for (const Kind& k : kinds)
      for (int j = 0; j < 6; ++j)
        for (const unsigned seed : {1u, 2u}) {
          const sid::DriveTerm term{k.kind, j, false};
          const bool rotor = k.kind == sid::DriveTermKind::Armature;
          const sid::ChainModel nominal = sid_test::tx40_nominal(rotor ? j : -1);
          const sid::ChainDiagnosis r = sid::diagnose_chain(
              nominal, {sid_test::tx40_hidden_term_run({{term, k.value}}, seed)});
          record(sid::drive_term_id(term), r, sid::drive_term_id(term), seed);
        }
  }
  std::printf(
      "\nChain diagnosis, TX40 URDF, 10 s at 500 Hz, sigma_q = 1e-4 rad, sigma_tau = 0.1 N m\n%s"
      "right: %d/%d data sets; diagnose_chain() time mean %.2f s, worst %.2f s\n\n",
      report.c_str(), right, total, seconds / std::max(total, 1), worst);
  state.counters["right"] = right;
  state.counters["data_sets"] = total;
}
BENCHMARK(BM_ChainHiddenTerms)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace
