#pragma once
// The definitions of <sid/cvode/simulate_robot.hpp>: included by it in header-only mode,
// compiled once into sid::cvode_compiled otherwise.

#include <sid/cvode/simulate_robot.hpp>

#include <sid/model/chain_jacobian.hpp>

#include <algorithm>
#include <cmath>
#include <utility>

namespace sid {

namespace detail {

inline void require_simulable(bool ok, const std::string& what) {
  if (!ok) throw std::invalid_argument("sid::simulate_robot: " + what);
}

/// The effect's value must suit its kind: drive terms > 0, a Stribeck curve 0 < Fc < Fs, vs > 0.
inline void check_robot_effect(const RobotEffect& e, int joints) {
  require_simulable(e.joint >= 0 && e.joint < joints,
                    "an effect on joint " + std::to_string(e.joint + 1) + " of a chain of " +
                        std::to_string(joints));
  require_simulable(std::isfinite(e.value), "an effect's value is not finite");
  if (e.kind == RobotEffectKind::Stribeck)
    require_simulable(e.value > 0.0 && e.stribeck_static > e.value && e.stribeck_velocity > 0.0,
                      "a Stribeck curve needs 0 < Fc < Fs and vs > 0");
  else if (e.kind != RobotEffectKind::TorqueOffset && e.kind != RobotEffectKind::AngleOffset)
    require_simulable(e.value > 0.0, "a drive term's value must be > 0");
}

inline void check_robot_effects(const std::vector<RobotEffect>& effects, int joints) {
  for (std::size_t k = 0; k < effects.size(); ++k) {
    check_robot_effect(effects[k], joints);
    for (std::size_t i = 0; i < k; ++i)
      require_simulable(
          effects[i].kind != effects[k].kind || effects[i].joint != effects[k].joint,
          "an effect is given twice on joint " + std::to_string(effects[k].joint + 1));
  }
}

/// Refuses a chain with a joint that moves no inertia at q.
inline void require_inertia_on_every_joint(const ChainModel& model, const Eigen::VectorXd& theta,
                                           const ChainModel::Vector& q) {
  const Eigen::VectorXd inertia = model.model().mass_matrix(theta, q).diagonal();
  Eigen::Index least = 0;
  if (!(inertia.minCoeff(&least) > 0.0)) throw JointWithoutInertia(static_cast<int>(least));
}

inline void check_robot_simulation_options(const RobotSimulationOptions& o) {
  const RandomRobotExcitation& r = o.random;
  require_simulable(r.harmonics >= 1 && r.harmonics <= 50, "harmonics must be 1..50");
  require_simulable(std::isfinite(r.base_frequency) && r.base_frequency > 0.0,
                    "the base frequency must be finite and > 0 [Hz]");
  require_simulable(
      std::isfinite(r.q_range) && r.q_range > 0.0 && std::isfinite(r.qd_max) && r.qd_max > 0.0,
      "q_range and qd_max must be finite and > 0");
  require_simulable(!(o.trajectory && o.torque), "a trajectory and a torque are two inputs");
  require_simulable(!(o.torque && !o.pushes.pushes.empty()),
                    "pushes apply to a tracked excitation, not to a driving torque");
}

/// The run under a given torque: open loop from rest at q0, at the torque's times.
inline SimulatedRobot driven_robot(SimulatedRobot arm, const RobotDescription& robot,
                                   const RobotSimulationOptions& o) {
  const DrivingTorque& torque = *o.torque;
  const int n = arm.model.joints();
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(2 * n);
  if (torque.q0.size() == 0) {
    x0.head(n) = excitation_room(robot, o.random.q_range, o.random.qd_max).q0;
  } else {
    require_simulable(torque.q0.size() == n, "q0 needs one angle per joint");
    x0.head(n) = torque.q0;
  }
  require_inertia_on_every_joint(arm.model, arm.theta, x0.head(n));
  const ChainExperimentResult run =
      simulate_chain_torque(arm.model, arm.theta, torque.t, torque.tau, x0, o.simulator);
  if (!run.ok())
    throw RobotSimulationFailed(run.status, run.message,
                                run.truth.t.size() > 0 ? run.truth.t[run.truth.size() - 1]
                                : torque.t.size() > 0  ? torque.t[0]
                                                       : 0.0);
  arm.truth = run.truth;
  return arm;
}

/// The run tracking a Fourier excitation (drawn from rng unless given), pushed or not.
inline SimulatedRobot tracking_robot(SimulatedRobot arm, const RobotDescription& robot,
                                     const RobotSimulationOptions& o, std::mt19937_64& rng) {
  const int n = arm.model.joints();
  FourierTrajectory desired;
  if (o.trajectory) {
    desired = *o.trajectory;
  } else {
    const ExcitationRoom room = excitation_room(robot, o.random.q_range, o.random.qd_max);
    desired = random_fourier_trajectory(room.q0, o.random.harmonics, o.random.base_frequency,
                                        room.q_range, room.qd_max, rng);
  }
  ChainExperiment experiment;
  experiment.external_torque = tool_push_torque(robot.chain, o.pushes);
  experiment.duration = o.duration;
  experiment.sample_time = o.sample_time;
  experiment.simulator = o.simulator;
  {
    ChainModel::Vector q(n), qd(n), qdd(n);
    desired.evaluate(0.0, q, qd, qdd);
    require_inertia_on_every_joint(arm.model, arm.theta, q);
  }
  const ChainExperimentResult run =
      simulate_chain_experiment(arm.model, arm.theta, desired, experiment);
  if (!run.ok())
    throw RobotSimulationFailed(run.status, run.message,
                                run.truth.t.size() > 0 ? run.truth.t[run.truth.size() - 1] : 0.0);
  arm.truth = run.truth;
  arm.external = run.external;
  return arm;
}

/// Where the run took a joint beyond its description's <limit>.
inline std::vector<JointLimitExcess> joints_beyond_limits(const RobotDescription& robot,
                                                          const ChainKinematics<double>& truth) {
  std::vector<JointLimitExcess> beyond;
  const int n = static_cast<int>(std::min<std::size_t>(truth.tau.cols(), robot.limits.size()));
  for (int j = 0; j < n; ++j) {
    const double effort = robot.limits[static_cast<std::size_t>(j)].effort;
    const double peak = truth.tau.col(j).cwiseAbs().maxCoeff();
    if (std::isfinite(effort) && effort > 0.0 && peak > effort)
      beyond.push_back({j, true, peak, 0.0, 0.0});
  }
  for (int j = 0; j < n; ++j) {
    const UrdfJointLimits& limit = robot.limits[static_cast<std::size_t>(j)];
    const double low = truth.q.col(j).minCoeff(), high = truth.q.col(j).maxCoeff();
    if ((std::isfinite(limit.lower) && low < limit.lower) ||
        (std::isfinite(limit.upper) && high > limit.upper))
      beyond.push_back({j, false, 0.0, low, high});
  }
  return beyond;
}

}  // namespace detail

SID_INLINE SimulatedRobot simulated_robot_model(const RobotDescription& robot,
                                                const std::vector<RobotEffect>& effects,
                                                double coulomb_epsilon) {
  detail::require_simulable(robot.link_parameters.size() > 0,
                            "the description has no link inertias to simulate with (a DH table)");
  const int n = robot.chain.joints();
  detail::check_robot_effects(effects, n);
  const auto has = [&](RobotEffectKind kind) {
    return std::any_of(effects.begin(), effects.end(),
                       [kind](const RobotEffect& e) { return e.kind == kind; });
  };
  const Transmission direct(n);
  // Springs only when asked: the model (and the theta it returns) is otherwise what it was.
  std::vector<DriveTermKind> kinds = {DriveTermKind::Viscous, DriveTermKind::Coulomb,
                                      DriveTermKind::Armature};
  if (has(RobotEffectKind::Spring)) kinds.push_back(DriveTermKind::Spring);
  const auto per_joint = static_cast<Eigen::Index>(kinds.size());
  // A Stribeck curve is the joint's Coulomb level plus a term of its own width after the others.
  std::vector<DriveTerm> terms = drive_terms(kinds, direct);
  std::vector<double> stribeck_excess;
  for (const RobotEffect& e : effects)
    if (e.kind == RobotEffectKind::Stribeck) {
      terms.push_back({DriveTermKind::Stribeck, e.joint, false, e.stribeck_velocity});
      stribeck_excess.push_back(e.stribeck_static - e.value);
    }
  SimulatedRobot arm{ChainModel(robot.chain, robot.joint_names, terms, direct, coulomb_epsilon),
                     {},
                     Eigen::VectorXd::Zero(n),
                     Eigen::VectorXd::Zero(n),
                     {},
                     {}};
  // theta: the description's links, its <dynamics> damping and friction, the effects on top.
  arm.theta = Eigen::VectorXd::Zero(arm.model.parameters());
  arm.theta.head(arm.model.rigid_body_parameters()) = robot.link_parameters;
  const Eigen::Index drives = arm.model.rigid_body_parameters();
  for (int j = 0; j < n; ++j) {
    arm.theta[drives + per_joint * j] = robot.damping[j];
    arm.theta[drives + per_joint * j + 1] = robot.friction[j];
  }
  const auto excess = static_cast<Eigen::Index>(stribeck_excess.size());
  arm.theta.tail(excess) = Eigen::Map<const Eigen::VectorXd>(stribeck_excess.data(), excess);
  for (const RobotEffect& e : effects) {
    if (e.kind == RobotEffectKind::TorqueOffset || e.kind == RobotEffectKind::AngleOffset) {
      (e.kind == RobotEffectKind::TorqueOffset ? arm.torque_offset : arm.angle_offset)[e.joint] =
          e.value;
      continue;
    }
    const int slot = e.kind == RobotEffectKind::Viscous    ? 0
                     : e.kind == RobotEffectKind::Armature ? 2
                     : e.kind == RobotEffectKind::Spring   ? 3
                                                           : 1;  // Coulomb, Stribeck
    arm.theta[drives + per_joint * e.joint + slot] += e.value;
  }
  return arm;
}

SID_INLINE std::function<ChainModel::Vector(double, const ChainModel::Vector&)> tool_push_torque(
    const SerialChain<double>& chain, const ToolPushes& pushes) {
  if (pushes.pushes.empty()) return {};
  detail::require_simulable(pushes.ramp > 0.0 && std::isfinite(pushes.ramp),
                            "a push's ramp must be > 0 s");
  for (const ToolPush& p : pushes.pushes)
    detail::require_simulable(p.end - p.start >= 2.0 * pushes.ramp,
                              "a push must last at least twice its ramp");
  return [pushes, chain](double t, const ChainModel::Vector& q) {
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    for (const ToolPush& p : pushes.pushes) {
      const double rise = std::clamp((t - p.start) / pushes.ramp, 0.0, 1.0),
                   fall = std::clamp((p.end - t) / pushes.ramp, 0.0, 1.0);
      force += std::min(rise, fall) * p.force;
    }
    if (force.isZero()) return ChainModel::Vector(ChainModel::Vector::Zero(q.size()));
    return ChainModel::Vector(chain_point_force_torque<double>(chain, q, pushes.point, force));
  };
}

SID_INLINE SimulatedRobot simulate_robot_truth(const RobotDescription& robot,
                                               const RobotSimulationOptions& options,
                                               std::mt19937_64& rng) {
  detail::check_robot_simulation_options(options);
  SimulatedRobot arm = simulated_robot_model(robot, options.effects, options.coulomb_epsilon);
  if (options.torque) return detail::driven_robot(std::move(arm), robot, options);
  return detail::tracking_robot(std::move(arm), robot, options, rng);
}

SID_INLINE SimulatedRobotLog simulate_robot(const RobotDescription& robot,
                                            const RobotSimulationOptions& options,
                                            std::uint64_t seed) {
  // The sensors are checked before the simulation, not after it.
  const Eigen::VectorXd steps = encoder_steps(options.sensors, robot.chain, "sid::simulate_robot");
  std::mt19937_64 rng(seed);
  SimulatedRobot s = simulate_robot_truth(robot, options, rng);
  std::vector<JointLimitExcess> beyond = detail::joints_beyond_limits(robot, s.truth);
  ChainTrajectory<double> sensed{s.truth.t, s.truth.q, s.truth.tau};
  // The sensors' faults: a torque bias b adds to the torque, an encoder offset d is subtracted
  // from the angle (the two-link arm's convention).
  for (Eigen::Index j = 0; j < s.model.joints(); ++j) {
    sensed.tau.col(j).array() += s.torque_offset[j];
    sensed.q.col(j).array() -= s.angle_offset[j];
  }
  sensed.tau = delayed_channel(sensed.t, sensed.tau, options.sensors.torque_delay);
  ChainTrajectory<double> measured = add_measurement_noise(sensed, options.noise, rng);
  round_to_encoders(steps, measured.q);
  return {std::move(s), std::move(measured), std::move(beyond)};
}

}  // namespace sid
