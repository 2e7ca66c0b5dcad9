// Timing of sid::ArmDynamics, the control loop's dynamics, on three real arms read from their
// URDFs (a UR5, the TX40, a Franka Panda): inverse dynamics with the default drive terms, its
// pieces (gravity, Coriolis, the mass matrix), the generalized momentum and a momentum
// observer's update; and, for comparison, the same torque as the identification computes it,
// Y(q, qd, qdd) theta. Pinocchio's figures on the same arms: bench/pinocchio/ (built only where
// Pinocchio is installed).

#include <sid/arm_dynamics.hpp>
#include <sid/momentum_observer.hpp>

#include <sid/model/chain_model.hpp>
#include <sid/model/transmission.hpp>
#include <sid/model/urdf.hpp>

#include <benchmark/benchmark.h>

#include "arm_states.hpp"

#include <Eigen/Core>

#include <cmath>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

namespace {

using sid_bench::kNumStates;
using sid_bench::random_states;
using sid_bench::read_text;

constexpr double kPi = 3.14159265358979323846;

/// An arm with the URDF's own links and the default drive terms (viscous and Coulomb friction,
/// offset, rotor inertia), sized from each joint's effort limit the way real drives scale: a
/// stand-in for an identification's physically consistent theta.
struct Arm {
  sid::ChainModel model;
  Eigen::VectorXd theta;
  Eigen::MatrixXd q, qd, qdd, tau;
  std::unique_ptr<sid::ArmDynamics> dynamics;  // built once, as a controller builds it

  Arm(const std::string& file, const std::string& base, const std::string& tip)
      : Arm(sid::chain_from_urdf(read_text(SID_TEST_DATA_DIR "/" + file), base, tip)) {}

  explicit Arm(const sid::UrdfChain& urdf)
      : model(urdf.chain, urdf.joint_names,
              sid::drive_terms(sid::default_drive_term_kinds(),
                               sid::Transmission(urdf.chain.joints())),
              sid::Transmission(urdf.chain.joints())),
        theta(model.parameters()) {
    const int n = model.joints();
    const Eigen::Index links = model.rigid_body_parameters();
    theta.head(links) = urdf.theta.head(links);  // urdf.theta also has zero friction columns
    Eigen::Index column = links;
    for (const sid::DriveTerm& t : model.terms()) {
      const double effort = urdf.joints[static_cast<std::size_t>(t.index)].limit.effort;
      const double scale = std::isfinite(effort) ? effort : 50.0;  // [N m]
      switch (t.kind) {
        case sid::DriveTermKind::Viscous:
          theta[column] = 0.02 * scale;
          break;  // [N m s/rad]
        case sid::DriveTermKind::Coulomb:
          theta[column] = 0.05 * scale;
          break;  // [N m]
        case sid::DriveTermKind::Offset:
          theta[column] = 0.01 * scale;
          break;  // [N m]
        case sid::DriveTermKind::Armature:
          theta[column] = 0.002 * scale;
          break;  // [kg m^2]
        default:
          theta[column] = 0.0;
      }
      ++column;
    }
    q = random_states(n, kPi, 1);
    qd = random_states(n, 2.0, 2);
    qdd = random_states(n, 5.0, 3);
    tau = random_states(n, 20.0, 4);
    dynamics = std::make_unique<sid::ArmDynamics>(model, theta);
  }
};

enum class Which { Ur5, Tx40, Panda };

const Arm& arm(Which which) {
  // Built on first use, so that a --benchmark_filter run reads only the arms it times.
  switch (which) {
    case Which::Ur5: {
      static const Arm a("urdf/real/ur5_robot.urdf", "base_link", "tool0");
      return a;
    }
    case Which::Tx40: {
      static const Arm a("ndof/tx40.urdf", "base_link", "tool0");
      return a;
    }
    case Which::Panda: {
      static const Arm a("urdf/real/panda.urdf", "panda_link0", "panda_link8");  // hand held
      return a;
    }
  }
  throw std::logic_error("arm_dynamics_bench: unknown arm");
}

void BM_InverseDynamics(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::ArmDynamics::Vector tau(a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    dynamics.inverse_dynamics(a.q.col(i), a.qd.col(i), a.qdd.col(i), tau);
    benchmark::DoNotOptimize(tau.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_Gravity(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::ArmDynamics::Vector tau(a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    dynamics.gravity(a.q.col(i), tau);
    benchmark::DoNotOptimize(tau.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_Coriolis(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::ArmDynamics::Vector c(a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    dynamics.coriolis(a.q.col(i), a.qd.col(i), c);
    benchmark::DoNotOptimize(c.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_MassMatrix(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::ArmDynamics::Matrix m(a.model.joints(), a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    dynamics.mass_matrix(a.q.col(i), m);
    benchmark::DoNotOptimize(m.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_Momentum(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::ArmDynamics::Vector p(a.model.joints()), beta(a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    dynamics.momentum(a.q.col(i), a.qd.col(i), p, beta);
    benchmark::DoNotOptimize(p.data());
    benchmark::DoNotOptimize(beta.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

void BM_ObserverUpdate(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  const sid::ArmDynamics& dynamics = *a.dynamics;
  sid::MomentumObserver observer(dynamics, Eigen::VectorXd::Constant(a.model.joints(), 50.0));
  Eigen::Index i = 0;
  for (auto _ : state) {
    // Random states make a meaningless estimate but the same arithmetic as a real 1 kHz one.
    benchmark::DoNotOptimize(observer.update(a.q.col(i), a.qd.col(i), a.tau.col(i), 1e-3).data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

// The identification's route to the same torque: the full regressor, then one product.
void BM_RegressorTorque(benchmark::State& state, Which which) {
  const Arm& a = arm(which);
  Eigen::MatrixXd y(a.model.joints(), a.model.parameters());
  Eigen::VectorXd tau(a.model.joints());
  Eigen::Index i = 0;
  for (auto _ : state) {
    a.model.regressor(a.q.col(i), a.qd.col(i), a.qdd.col(i), y);
    tau.noalias() = y * a.theta;
    benchmark::DoNotOptimize(tau.data());
    benchmark::ClobberMemory();
    i = (i + 1) % kNumStates;
  }
}

#define SID_ARM_BENCHMARKS(fn)              \
  BENCHMARK_CAPTURE(fn, ur5, Which::Ur5);   \
  BENCHMARK_CAPTURE(fn, tx40, Which::Tx40); \
  BENCHMARK_CAPTURE(fn, panda, Which::Panda)

SID_ARM_BENCHMARKS(BM_InverseDynamics);
SID_ARM_BENCHMARKS(BM_Gravity);
SID_ARM_BENCHMARKS(BM_Coriolis);
SID_ARM_BENCHMARKS(BM_MassMatrix);
SID_ARM_BENCHMARKS(BM_Momentum);
SID_ARM_BENCHMARKS(BM_ObserverUpdate);
SID_ARM_BENCHMARKS(BM_RegressorTorque);

}  // namespace
