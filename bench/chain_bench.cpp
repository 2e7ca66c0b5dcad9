// Timing of a six-joint arm's regressor (Newton-Euler in the parameters), its forward dynamics
// (articulated bodies against the mass-matrix route), of stacking the
// 10 s excitation at 1 kHz, the size of a typical identification experiment, of the whole
// identification of such a run (drive terms, cutoff search, HAC, physically consistent links),
// and of the diagnosis of a simulated 20 s TX40 log with hidden drive terms.

#include <sid/base_parameters.hpp>
#include <sid/chain_consistency.hpp>
#include <sid/cvode/chain_experiment.hpp>
#include <sid/diagnose_chain.hpp>
#include <sid/excitation_design.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/articulated_body.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/link_inertia.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/urdf.hpp>

#include <benchmark/benchmark.h>

#include <Eigen/Core>

#include <fstream>
#include <memory>
#include <random>
#include <stdexcept>
#include <sstream>
#include <string>
#include <vector>

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

/// A plausible body on every link (forward dynamics needs a positive-definite mass matrix).
Eigen::VectorXd plausible_theta(int joints) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(sid::chain_parameter_count(joints));
  for (int i = 0; i < joints; ++i) {
    sid::LinkInertia<double> body;
    body.mass = 6.0 - 0.8 * i;
    body.com = sid::Vector3<double>(0.05, 0.02 * i, 0.1);
    body.inertia_com = sid::Vector3<double>(0.05, 0.04, 0.03).asDiagonal();
    theta.segment<sid::kLinkParameters>(sid::kLinkParameters * i) = sid::standard_parameters(body);
  }
  return theta;
}

// Forward dynamics, O(n) (articulated bodies) against O(n^3) (n + 2 inverse dynamics, Cholesky).
template <bool kArticulated>
void BM_SixJointForwardDynamics(benchmark::State& state) {
  const auto chain = puma560();
  const Eigen::VectorXd theta = plausible_theta(6);
  const Eigen::MatrixXd q = random_samples(kNumStates, kPi, 1).transpose(),
                        qd = random_samples(kNumStates, 2, 2).transpose(),
                        tau = random_samples(kNumStates, 20, 3).transpose();
  Eigen::Index i = 0;
  for (auto _ : state) {
    if constexpr (kArticulated)
      benchmark::DoNotOptimize(
          sid::chain_forward_dynamics_aba(chain, theta, q.col(i), qd.col(i), tau.col(i)));
    else
      benchmark::DoNotOptimize(
          sid::chain_forward_dynamics(chain, theta, q.col(i), qd.col(i), tau.col(i)));
    i = (i + 1) % kNumStates;
  }
}
BENCHMARK_TEMPLATE(BM_SixJointForwardDynamics, true)->Name("BM_SixJointForwardDynamicsAba");
BENCHMARK_TEMPLATE(BM_SixJointForwardDynamics, false)->Name("BM_SixJointForwardDynamicsCubic");

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

/// The PUMA 560 with viscous and Coulomb friction, offsets and armature per joint, and a 10 s
/// run at 1 kHz whose torques are exact plus 0.05 N m of noise: three harmonics per joint.
struct SixJointRun {
  sid::ChainModel model{puma560(),
                        {},
                        sid::drive_terms(sid::default_drive_term_kinds(), sid::Transmission(6)),
                        sid::Transmission(6)};
  sid::ChainTrajectory<double> run;

  SixJointRun() {
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0.1, 1.0);
    for (int i = 0; i < 6; ++i) {
      theta[10 * i] = 10.0 * u(rng) / (i + 1);  // m
      theta.segment<3>(10 * i + 1) = 0.1 * theta[10 * i] * sid::Vector3<double>(u(rng), 0, u(rng));
      theta[10 * i + 4] = theta[10 * i + 6] = theta[10 * i + 9] = 0.1 * theta[10 * i];
    }
    for (Eigen::Index k = 60; k < theta.size(); ++k) theta[k] = u(rng);
    std::normal_distribution<double> noise(0.0, 0.05);
    constexpr Eigen::Index kSamples = 10000;
    run.t.resize(kSamples);
    run.q.resize(kSamples, 6);
    run.tau.resize(kSamples, 6);
    Eigen::MatrixXd y(6, model.parameters());
    Eigen::VectorXd q(6), qd(6), qdd(6);
    for (Eigen::Index k = 0; k < kSamples; ++k) {
      const double t = 1e-3 * static_cast<double>(k);
      for (int j = 0; j < 6; ++j) {
        q[j] = qd[j] = qdd[j] = 0.0;
        for (int h = 1; h <= 3; ++h) {
          const double w = 2.0 * kPi * 0.2 * (1.0 + 0.25 * j) * h, a = 0.6 / h;
          q[j] += a * std::sin(w * t + j + h);
          qd[j] += a * w * std::cos(w * t + j + h);
          qdd[j] -= a * w * w * std::sin(w * t + j + h);
        }
      }
      model.regressor(q, qd, qdd, y);
      run.t[k] = t;
      run.q.row(k) = q.transpose();
      run.tau.row(k) = (y * theta).transpose();
      for (int j = 0; j < 6; ++j) run.tau(k, j) += noise(rng);
    }
  }
};

void BM_SixJointModelRegressor(benchmark::State& state) {
  const SixJointRun arm;
  const Eigen::MatrixXd q = random_samples(kNumStates, kPi, 1).transpose(),
                        qd = random_samples(kNumStates, 2, 2).transpose(),
                        qdd = random_samples(kNumStates, 5, 3).transpose();
  Eigen::MatrixXd y(6, arm.model.parameters());
  Eigen::Index i = 0;
  for (auto _ : state) {
    arm.model.regressor(q.col(i), qd.col(i), qdd.col(i), y);
    benchmark::DoNotOptimize(y.data());
    i = (i + 1) % kNumStates;
  }
}
BENCHMARK(BM_SixJointModelRegressor);

// The whole identification: base parameters, cutoff search over the grid and per joint, fit, HAC.
void BM_SixJointIdentify10sAt1kHz(benchmark::State& state) {
  const SixJointRun arm;
  for (auto _ : state)
    benchmark::DoNotOptimize(sid::identify_chain(arm.model, {arm.run}).fit.theta);
}
BENCHMARK(BM_SixJointIdentify10sAt1kHz)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_SixJointIdentifyAtAGivenCutoff(benchmark::State& state) {
  const SixJointRun arm;
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {8.0};
  for (auto _ : state)
    benchmark::DoNotOptimize(sid::identify_chain(arm.model, {arm.run}, options).fit.theta);
}
BENCHMARK(BM_SixJointIdentifyAtAGivenCutoff)->Unit(benchmark::kMillisecond);

void BM_SixJointConsistentLinks(benchmark::State& state) {
  const SixJointRun arm;
  sid::ChainIdentifyOptions options;
  options.cutoff_hz = {8.0};
  const sid::ChainIdentification id = sid::identify_chain(arm.model, {arm.run}, options);
  for (auto _ : state)
    benchmark::DoNotOptimize(sid::consistent_chain_parameters(arm.model, id).theta);
}
BENCHMARK(BM_SixJointConsistentLinks)->Unit(benchmark::kMillisecond);

}  // namespace

// The excitation design's objective on the TX40.

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

// The chain diagnosis of a 20 s log at 500 Hz (about 56 000 equations, 42 candidates and the
// angle offsets): the TX40 tracking a random Fourier excitation with a spring on joint 5 and
// Coulomb friction on joint 2 that its nominal model (links, viscous friction, rotors) lacks,
// simulated by CVODE with the noise of sid_simulate's defaults (sigma_q2 1e-8, sigma_tau2 0.01).

namespace {

struct Tx40Log {
  sid::ChainModel nominal;
  sid::ChainTrajectory<double> run;
};

const Tx40Log& tx40_log() {
  static const Tx40Log* log = [] {
    const sid::UrdfChain arm = sid::chain_from_urdf(
        read_text(SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf"), "base_link", "tool0");
    const int n = arm.chain.joints();
    const sid::Transmission direct(n);
    using Kind = sid::DriveTermKind;
    std::vector<sid::DriveTerm> terms = sid::drive_terms({Kind::Viscous, Kind::Armature}, direct);
    terms.push_back({Kind::Spring, 4, false, 0.0});
    terms.push_back({Kind::Coulomb, 1, false, 0.0});
    const sid::ChainModel truth(arm.chain, arm.joint_names, terms, direct);
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(truth.parameters());
    const Eigen::Index links = truth.rigid_body_parameters();
    theta.head(links) = arm.theta.head(links);
    for (int j = 0; j < n; ++j) {
      theta[links + 2 * j] = arm.joints[static_cast<std::size_t>(j)].damping;
      theta[links + 2 * j + 1] = 0.01;  // a rotor on every joint: some links have no inertia
    }
    theta[links + 2 * n] = 1.5;      // spring_j5 [N m/rad]
    theta[links + 2 * n + 1] = 0.5;  // coulomb_j2 [N m]
    Eigen::VectorXd q0(n);
    for (int j = 0; j < n; ++j) {
      const sid::UrdfJointLimits& limit = arm.joints[static_cast<std::size_t>(j)].limit;
      q0[j] = 0.5 * (limit.lower + limit.upper);
    }
    std::mt19937_64 rng(1);
    const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
        q0, 5, 0.1, Eigen::VectorXd::Constant(n, 1.0), Eigen::VectorXd::Constant(n, 1.5), rng);
    sid::ChainExperiment experiment;
    experiment.duration = 20.0;
    experiment.sample_time = 0.002;
    const sid::ChainExperimentResult sim =
        sid::simulate_chain_experiment(truth, theta, desired, experiment);
    if (!sim.ok()) throw std::runtime_error("chain_bench: the TX40 simulation failed");
    sid::ChainTrajectory<double> run = sim.trajectory();
    std::normal_distribution<double> angle(0.0, 1e-4), torque(0.0, 0.1);
    for (auto& v : run.q.reshaped()) v += angle(rng);
    for (auto& v : run.tau.reshaped()) v += torque(rng);
    const sid::ChainModel nominal(arm.chain, arm.joint_names,
                                  sid::drive_terms({Kind::Viscous, Kind::Armature}, direct),
                                  direct);
    return new Tx40Log{nominal, std::move(run)};
  }();
  return *log;
}

void BM_DiagnoseChainSixJoints(benchmark::State& state) {
  const Tx40Log& log = tx40_log();
  sid::ChainDiagnoseOptions options;
  options.threads = static_cast<int>(state.range(0));
  sid::ChainDiagnosis diagnosis;
  for (auto _ : state) {
    diagnosis = sid::diagnose_chain(log.nominal, {log.run}, options);
    benchmark::DoNotOptimize(diagnosis.named.data());
  }
  state.counters["equations"] = static_cast<double>(diagnosis.equations);
  state.counters["named"] = static_cast<double>(diagnosis.named.size());
}
BENCHMARK(BM_DiagnoseChainSixJoints)
    ->Arg(1)
    ->Arg(2)
    ->ArgName("threads")
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()  // the CPU column counts both threads
    ->UseRealTime();

}  // namespace
