// sid::ArmDynamics against Pinocchio on the same arms, the same random states, in the same run:
// inverse dynamics (Pinocchio's rnea), gravity (computeGeneralizedGravity) and the mass matrix
// (crba). Built only where CMake finds Pinocchio (bench/CMakeLists.txt); CI never does.
//
// Both read the same URDF with the same chain: the UR5 and the TX40 whole (base_link..tool0),
// the Panda from panda_link0 with its fingers locked at 0 (buildReducedModel), as
// sid::chain_from_urdf holds them. Before timing anything the program checks, on every state,
// that sid's rigid-body torques, gravity and mass matrix are Pinocchio's to kTolerance, and
// aborts otherwise.
//
// What each side computes. Pinocchio's rnea has the links and, if set, the rotors' inertia
// (Model::armature), but no friction and no offsets. So sid is timed twice: rigid bodies only
// (sid::drive_terms({}, ...)), the same arithmetic as rnea, and with the default drive terms
// (viscous and Coulomb friction, offset, armature: a tanh per joint more). Pinocchio is also timed
// twice: its templates compiled here with sid's flags (arguments that are column blocks), and the
// wheel's own compiled instantiation (arguments that are Eigen::Ref<const VectorXd>, what its
// extern templates name). crba fills M's upper triangle only; sid's mass_matrix fills both.

#include <sid/arm_dynamics.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/transmission.hpp>
#include <sid/model/urdf.hpp>

#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/joint-configuration.hpp>
#include <pinocchio/algorithm/model.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody/data.hpp>
#include <pinocchio/multibody/model.hpp>
#include <pinocchio/parsers/urdf.hpp>

#include <benchmark/benchmark.h>

#include "../arm_states.hpp"

#include <Eigen/Core>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

using sid_bench::kNumStates;
using sid_bench::random_states;
using sid_bench::read_text;

constexpr double kPi = 3.14159265358979323846;
// Both evaluate the same recursions in double: round-off is ~1e-13 of torques up to ~100 N m.
constexpr double kTolerance = 1e-9;

sid::ChainModel chain_model(const sid::UrdfChain& urdf,
                            const std::vector<sid::DriveTermKind>& kinds) {
  const sid::Transmission direct(urdf.chain.joints());
  return sid::ChainModel(urdf.chain, urdf.joint_names, sid::drive_terms(kinds, direct), direct);
}

/// One arm as both libraries see it, with its states (q for Pinocchio: a continuous joint's
/// configuration is (cos, sin)).
struct Arm {
  std::string name;
  sid::UrdfChain urdf;
  sid::ChainModel rigid_model, driven_model;
  Eigen::VectorXd rigid_theta, driven_theta;
  std::unique_ptr<sid::ArmDynamics> rigid, driven;
  pinocchio::Model pin;
  Eigen::MatrixXd q, qd, qdd, q_pin;

  Arm(std::string name_in, const std::string& file, const std::string& base, const std::string& tip,
      const std::vector<std::string>& locked)
      : name(std::move(name_in)),
        urdf(sid::chain_from_urdf(read_text(SID_TEST_DATA_DIR "/" + file), base, tip)),
        rigid_model(chain_model(urdf, {})),
        driven_model(chain_model(urdf, sid::default_drive_term_kinds())),
        rigid_theta(urdf.theta.head(rigid_model.rigid_body_parameters())),
        driven_theta(driven_model.parameters()) {
    const int n = urdf.chain.joints();
    driven_theta.head(driven_model.rigid_body_parameters()) = rigid_theta;
    Eigen::Index column = driven_model.rigid_body_parameters();
    for (const sid::DriveTerm& t : driven_model.terms()) {  // as bench/arm_dynamics_bench.cpp
      const double effort = urdf.joints[static_cast<std::size_t>(t.index)].limit.effort;
      const double scale = std::isfinite(effort) ? effort : 50.0;
      const double factor = t.kind == sid::DriveTermKind::Viscous    ? 0.02
                            : t.kind == sid::DriveTermKind::Coulomb  ? 0.05
                            : t.kind == sid::DriveTermKind::Offset   ? 0.01
                            : t.kind == sid::DriveTermKind::Armature ? 0.002
                                                                     : 0.0;
      driven_theta[column++] = factor * scale;
    }
    rigid = std::make_unique<sid::ArmDynamics>(rigid_model, rigid_theta);
    driven = std::make_unique<sid::ArmDynamics>(driven_model, driven_theta);

    pinocchio::Model full;
    pinocchio::urdf::buildModel(SID_TEST_DATA_DIR "/" + file, full);
    std::vector<pinocchio::JointIndex> lock;
    for (const std::string& joint : locked) lock.push_back(full.getJointId(joint));
    pin = lock.empty() ? full : pinocchio::buildReducedModel(full, lock, pinocchio::neutral(full));
    if (pin.nv != n)
      fail("Pinocchio has " + std::to_string(pin.nv) + " joints, sid " + std::to_string(n));
    for (int j = 0; j < n; ++j)
      if (pin.names[static_cast<std::size_t>(j + 1)] !=
          urdf.joint_names[static_cast<std::size_t>(j)])
        fail("joint " + std::to_string(j + 1) + " is " +
             pin.names[static_cast<std::size_t>(j + 1)] + " in Pinocchio, " +
             urdf.joint_names[static_cast<std::size_t>(j)] + " in sid");

    q = random_states(n, kPi, 1);
    qd = random_states(n, 2.0, 2);
    qdd = random_states(n, 5.0, 3);
    q_pin.resize(pin.nq, kNumStates);
    for (Eigen::Index s = 0; s < kNumStates; ++s)
      for (int j = 0; j < n; ++j) {
        const auto& joint = pin.joints[static_cast<std::size_t>(j + 1)];
        if (joint.nq() == 2) {  // a continuous joint (JointModelRUB*)
          q_pin(joint.idx_q(), s) = std::cos(q(j, s));
          q_pin(joint.idx_q() + 1, s) = std::sin(q(j, s));
        } else {
          q_pin(joint.idx_q(), s) = q(j, s);
        }
      }
  }

  [[noreturn]] void fail(const std::string& why) const {
    std::fprintf(stderr, "pinocchio_comparison_bench: %s: %s\n", name.c_str(), why.c_str());
    std::abort();
  }

  /// sid's rigid-body torques, gravity and mass matrix against Pinocchio's on every state.
  void check() const {
    pinocchio::Data data(pin);
    const int n = rigid->joints();
    sid::ArmDynamics::Vector tau(n), g(n);
    sid::ArmDynamics::Matrix m(n, n);
    double worst_tau = 0.0, worst_g = 0.0, worst_m = 0.0;
    for (Eigen::Index s = 0; s < kNumStates; ++s) {
      rigid->inverse_dynamics(q.col(s), qd.col(s), qdd.col(s), tau);
      pinocchio::rnea(pin, data, q_pin.col(s), qd.col(s), qdd.col(s));
      worst_tau = std::max(worst_tau, (tau - data.tau).cwiseAbs().maxCoeff());
      rigid->gravity(q.col(s), g);
      pinocchio::computeGeneralizedGravity(pin, data, q_pin.col(s));
      worst_g = std::max(worst_g, (g - data.g).cwiseAbs().maxCoeff());
      rigid->mass_matrix(q.col(s), m);
      pinocchio::crba(pin, data, q_pin.col(s));
      const Eigen::MatrixXd upper = data.M.triangularView<Eigen::Upper>();
      worst_m = std::max(
          worst_m,
          (Eigen::MatrixXd(m.triangularView<Eigen::Upper>()) - upper).cwiseAbs().maxCoeff());
    }
    std::printf(
        "%-6s %d joints: max |tau - rnea| %.1e N m, |g - g_pin| %.1e N m, |M - crba| %.1e\n",
        name.c_str(), n, worst_tau, worst_g, worst_m);
    if (!(worst_tau < kTolerance && worst_g < kTolerance && worst_m < kTolerance))
      fail("sid and Pinocchio disagree beyond " + std::to_string(kTolerance));
  }
};

std::vector<std::unique_ptr<Arm>>& arms() {
  static std::vector<std::unique_ptr<Arm>> all;
  return all;
}

const Arm& arm(int i) { return *arms()[static_cast<std::size_t>(i)]; }

void BM_SidInverseDynamicsRigid(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  sid::ArmDynamics::Vector tau(a.rigid->joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    a.rigid->inverse_dynamics(a.q.col(i), a.qd.col(i), a.qdd.col(i), tau);
    benchmark::DoNotOptimize(tau.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_SidInverseDynamicsDrives(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  sid::ArmDynamics::Vector tau(a.driven->joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    a.driven->inverse_dynamics(a.q.col(i), a.qd.col(i), a.qdd.col(i), tau);
    benchmark::DoNotOptimize(tau.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

// Column blocks: rnea's template instantiated in this file, with the flags sid's code gets.
void BM_PinocchioRnea(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  pinocchio::Data data(a.pin);
  Eigen::Index i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        pinocchio::rnea(a.pin, data, a.q_pin.col(i), a.qd.col(i), a.qdd.col(i)).data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

// Eigen::Ref arguments: the instantiation compiled into libpinocchio_default (the wheel's flags).
void BM_PinocchioRneaLibrary(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  pinocchio::Data data(a.pin);
  using Ref = Eigen::Ref<const Eigen::VectorXd>;
  Eigen::Index i = 0;
  for (auto _ : state) {
    const Ref q(a.q_pin.col(i)), qd(a.qd.col(i)), qdd(a.qdd.col(i));
    benchmark::DoNotOptimize(pinocchio::rnea(a.pin, data, q, qd, qdd).data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_SidGravity(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  sid::ArmDynamics::Vector g(a.rigid->joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    a.rigid->gravity(a.q.col(i), g);
    benchmark::DoNotOptimize(g.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_PinocchioGravity(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  pinocchio::Data data(a.pin);
  Eigen::Index i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        pinocchio::computeGeneralizedGravity(a.pin, data, a.q_pin.col(i)).data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_SidMassMatrix(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  const int n = a.rigid->joints();
  sid::ArmDynamics::Matrix m(n, n);
  Eigen::Index i = 0;
  for (auto _ : state) {
    a.rigid->mass_matrix(a.q.col(i), m);
    benchmark::DoNotOptimize(m.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_PinocchioCrba(benchmark::State& state, int which) {
  const Arm& a = arm(which);
  pinocchio::Data data(a.pin);
  Eigen::Index i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(pinocchio::crba(a.pin, data, a.q_pin.col(i)).data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

}  // namespace

int main(int argc, char** argv) {
  arms().push_back(std::make_unique<Arm>("ur5", "urdf/real/ur5_robot.urdf", "base_link", "tool0",
                                         std::vector<std::string>{}));
  arms().push_back(std::make_unique<Arm>("tx40", "ndof/tx40.urdf", "base_link", "tool0",
                                         std::vector<std::string>{}));
  arms().push_back(std::make_unique<Arm>(
      "panda", "urdf/real/panda.urdf", "panda_link0", "panda_link8",
      std::vector<std::string>{"panda_finger_joint1", "panda_finger_joint2"}));
  std::printf("Pinocchio %s\n", PINOCCHIO_VERSION);
  for (const auto& a : arms()) a->check();

  // Grouped by arm, each operation sid then Pinocchio.
  for (int i = 0; i < static_cast<int>(arms().size()); ++i) {
    const std::string& n = arms()[static_cast<std::size_t>(i)]->name;
    benchmark::RegisterBenchmark(("InverseDynamics/" + n + "/sid_rigid").c_str(),
                                 BM_SidInverseDynamicsRigid, i);
    benchmark::RegisterBenchmark(("InverseDynamics/" + n + "/sid_drives").c_str(),
                                 BM_SidInverseDynamicsDrives, i);
    benchmark::RegisterBenchmark(("InverseDynamics/" + n + "/pinocchio_rnea").c_str(),
                                 BM_PinocchioRnea, i);
    benchmark::RegisterBenchmark(("InverseDynamics/" + n + "/pinocchio_rnea_library").c_str(),
                                 BM_PinocchioRneaLibrary, i);
    benchmark::RegisterBenchmark(("Gravity/" + n + "/sid").c_str(), BM_SidGravity, i);
    benchmark::RegisterBenchmark(("Gravity/" + n + "/pinocchio").c_str(), BM_PinocchioGravity, i);
    benchmark::RegisterBenchmark(("MassMatrix/" + n + "/sid").c_str(), BM_SidMassMatrix, i);
    benchmark::RegisterBenchmark(("MassMatrix/" + n + "/pinocchio_crba").c_str(), BM_PinocchioCrba,
                                 i);
  }
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
