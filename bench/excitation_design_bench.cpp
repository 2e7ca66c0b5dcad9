// Timing of one evaluation of the excitation design's objective and constraints on the TX40
// (6 joints, 84 model parameters, 58 base parameters; 5 harmonics over a 200-point period):
// without gradient (what a line search asks for) and with it (the regressor's differences in
// q, qd and qdd at every grid point).

#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/urdf.hpp>

#include <benchmark/benchmark.h>

#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>

namespace {

struct Tx40Problem {
  sid::ChainModel model;
  Eigen::VectorXd theta;
  std::unique_ptr<sid::detail::ExcitationProblem> problem;  // refers to model
  Eigen::VectorXd x;
};

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

Tx40Problem& tx40() {
  static Tx40Problem* p = [] {
    sid::UrdfChain arm = sid::chain_from_urdf(
        read_text(SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
    const int n = arm.chain.joints();
    const sid::Transmission direct(n);
    sid::ChainModel model(arm.chain, arm.joint_names,
                          sid::drive_terms(sid::default_drive_term_kinds(), direct), direct);
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
    theta.head(model.rigid_body_parameters()) = arm.theta.head(model.rigid_body_parameters());
    sid::ExcitationLimits limits{
        Eigen::VectorXd::Constant(n, 1.0), Eigen::VectorXd::Constant(n, 1.5),
        Eigen::VectorXd::Constant(n, 10.0), Eigen::VectorXd::Constant(n, 100.0)};
    const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(n);
    const sid::ExcitationDesignOptions options;
    std::mt19937_64 rng(1);
    const sid::FourierTrajectory start =
        sid::random_excitation(model, theta, q0, limits, options, rng);
    auto* made = new Tx40Problem{std::move(model), theta, nullptr, {}};
    made->problem = std::make_unique<sid::detail::ExcitationProblem>(
        made->model, theta, sid::chain_base_parameters(made->model).independent, q0, limits,
        options);
    made->x = made->problem->variables_of(start);
    return made;
  }();
  return *p;
}

void run(benchmark::State& state, bool gradient) {
  Tx40Problem& p = tx40();
  Eigen::VectorXd x = p.x;
  for (auto _ : state) {
    x[0] += 1e-12;  // a new point each time: the problem keeps the last one
    p.problem->evaluate(x.data(), gradient);
    benchmark::DoNotOptimize(p.problem->objective());
  }
}

void BM_ExcitationObjectiveTx40(benchmark::State& state) { run(state, false); }
void BM_ExcitationObjectiveAndGradientTx40(benchmark::State& state) { run(state, true); }

BENCHMARK(BM_ExcitationObjectiveTx40)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExcitationObjectiveAndGradientTx40)->Unit(benchmark::kMillisecond);

}  // namespace
