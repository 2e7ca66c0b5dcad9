#include "chain_simulate_app.hpp"

#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/chain_jacobian.hpp>
#include <sid/model/chain_model.hpp>

#include "app.hpp"
#include "chain_excite_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <functional>
#include <iostream>
#include <random>
#include <string>
#include <vector>

namespace sid::app {

namespace {

/// One push of --push: a force at the tool, ramped in and out.
struct Push {
  double start = 0.0, end = 0.0;
  Eigen::Vector3d force;
};

/// The outside's joint torques of o.pushes (empty function without any).
std::function<ChainModel::Vector(double, const ChainModel::Vector&)> pushes_torque(
    const ChainSimulateOptions& o, const SerialChain<double>& chain) {
  if (o.pushes.empty()) return {};
  require(o.torque.empty(), "--push applies to the tracked excitation, not to --torque");
  require(o.push_ramp > 0.0 && std::isfinite(o.push_ramp), "--push-ramp must be > 0 s");
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  if (!o.push_point.empty()) {
    const std::vector<double> p = parse_doubles(o.push_point, "--push-point");
    require(p.size() == 3, "--push-point takes X,Y,Z [m] in the tip link's frame");
    point << p[0], p[1], p[2];
  }
  std::vector<Push> pushes;
  for (const std::string& text : o.pushes) {
    const std::vector<double> v = parse_doubles(text, "--push");
    require(v.size() == 5, "--push takes START,END,FX,FY,FZ [s, N], not '" + text + "'");
    require(v[1] - v[0] >= 2.0 * o.push_ramp,
            "--push '" + text + "': END - START must be at least twice the ramp (" +
                shortest_number(o.push_ramp) + " s)");
    pushes.push_back({v[0], v[1], Eigen::Vector3d(v[2], v[3], v[4])});
  }
  const double ramp = o.push_ramp;
  return [pushes, point, ramp, chain](double t, const ChainModel::Vector& q) {
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    for (const Push& p : pushes) {
      const double rise = std::clamp((t - p.start) / ramp, 0.0, 1.0),
                   fall = std::clamp((p.end - t) / ramp, 0.0, 1.0);
      force += std::min(rise, fall) * p.force;
    }
    if (force.isZero()) return ChainModel::Vector(ChainModel::Vector::Zero(q.size()));
    return ChainModel::Vector(sid::chain_point_force_torque<double>(chain, q, point, force));
  };
}

std::string joined(const Eigen::RowVectorXd& values) {
  std::string text;
  for (Eigen::Index j = 0; j < values.size(); ++j)
    text += (j ? "," : "") + shortest_number(values[j]);
  return text;
}

struct ChainEffect {
  /// viscous, coulomb, armature, spring, stribeck, torque_offset (a sensor bias) or
  /// angle_offset (an encoder offset)
  std::string kind;
  int joint = 0;  ///< 0-based
  std::vector<double> values;
};

ChainEffect parse_chain_effect(const std::string& text, int joints) {
  const std::string who = "--effect '" + text + "': ";
  const std::string form = "expected KIND_jN:VALUE (angle_offset_qN:VALUE), e.g. coulomb_j3:0.4";
  const auto colon = text.find(':');
  require(colon != std::string::npos, who + form);
  const std::string id = text.substr(0, colon), value = text.substr(colon + 1);
  const bool angle = id.rfind("angle_offset_q", 0) == 0;
  const auto mark = angle ? std::string("angle_offset").size() : id.rfind("_j");
  require(mark != std::string::npos, who + form);
  ChainEffect e;
  e.kind = id.substr(0, mark);
  require(e.kind == "viscous" || e.kind == "coulomb" || e.kind == "armature" ||
              e.kind == "spring" || e.kind == "stribeck" || e.kind == "torque_offset" ||
              e.kind == "angle_offset",
          who + "unknown kind '" + e.kind +
              "'; on a chain: viscous, coulomb, armature, spring, stribeck, torque_offset, "
              "angle_offset");
  const std::string number = id.substr(mark + 2);
  int joint = 0;
  const auto parsed = std::from_chars(number.data(), number.data() + number.size(), joint);
  require(!number.empty() && parsed.ec == std::errc() &&
              parsed.ptr == number.data() + number.size() && joint >= 1 && joint <= joints,
          who + "the joint must be 1.." + std::to_string(joints) + ", got '" + number + "'");
  e.joint = joint - 1;
  if (e.kind == "stribeck") {
    e.values = parse_doubles(value, "--effect " + id, 3);
    require(e.values[0] > 0.0 && e.values[1] > e.values[0] && e.values[2] > 0.0,
            who + "stribeck takes Fc,Fs,vs with 0 < Fc < Fs [N m] and vs > 0 [rad/s]");
    return e;
  }
  e.values = parse_doubles(value, "--effect " + id, 1);
  require(e.kind == "torque_offset" || e.kind == "angle_offset" || e.values[0] > 0.0,
          who + e.kind + " must be > 0, got " + shortest_number(e.values[0]));
  return e;
}

/// Refuses a chain with a joint that moves no inertia at q: its acceleration is undefined.
void require_inertia_on_every_joint(const std::string& source, const ChainModel& model,
                                    const Eigen::VectorXd& theta, const ChainModel::Vector& q) {
  const Eigen::VectorXd inertia = model.model().mass_matrix(theta, q).diagonal();
  Eigen::Index least = 0;
  const double smallest = inertia.minCoeff(&least);
  require(smallest > 0.0,
          source +
              ": a joint of the chain moves no inertia (a link with none about its axis); add "
              "a rotor, e.g. --effect armature_j" +
              std::to_string(least + 1) + ":0.01");
}

/// The run of sid_simulate --robot --torque: open loop from rest at q0, at the file's times.
SimulatedRobot driven_by_torque(const ChainSimulateOptions& o, const RobotDescription& robot,
                                const ChainModel& model, const Eigen::VectorXd& theta,
                                const Eigen::VectorXd& torque_offset,
                                const Eigen::VectorXd& angle_offset) {
  require(o.trajectory.empty(), "--torque and --trajectory are two inputs; give one");
  const int n = model.joints();
  const CsvTable table = read_csv(o.torque);
  require(table.rows() >= 2, o.torque + ": needs at least 2 rows of t,tau1..tau" +
                                 std::to_string(n) + ", got " + std::to_string(table.rows()));
  require_strictly_increasing(table, "t");
  Eigen::MatrixXd tau(table.rows(), n);
  for (int j = 0; j < n; ++j) tau.col(j) = table.column("tau" + std::to_string(j + 1));
  Eigen::VectorXd x0 = Eigen::VectorXd::Zero(2 * n);
  if (o.q0.empty()) {
    x0.head(n) = excitation_room(robot, o.robot, o.q_range, o.qd_max).q0;
  } else {
    const std::vector<double> q0 = parse_doubles(o.q0, "--q0", static_cast<std::size_t>(n));
    x0.head(n) = Eigen::Map<const Eigen::VectorXd>(q0.data(), n);
  }
  require_inertia_on_every_joint(o.robot, model, theta, x0.head(n));
  SimulatorOptions simulator;
  simulator.rtol = o.rtol;
  simulator.atol = o.atol;
  const ChainExperimentResult run =
      simulate_chain_torque(model, theta, table.column("t"), tau, x0, simulator);
  require(run.ok(), "the simulation under the torque of " + o.torque + " stopped at t = " +
                        shortest_number(run.truth.t.size() > 0 ? run.truth.t[run.truth.size() - 1]
                                                               : table.column("t")[0]) +
                        " s (" + run.message +
                        "); the torque does not hold the arm (gravity?) or spins it away");
  return SimulatedRobot{robot, model, theta, torque_offset, angle_offset, run.truth, {}};
}

}  // namespace

ExcitationRoom excitation_room(const RobotDescription& robot, const std::string& source,
                               double q_range, double qd_max) {
  const int n = robot.chain.joints();
  ExcitationRoom room{Eigen::VectorXd::Zero(n), Eigen::VectorXd::Constant(n, q_range),
                      Eigen::VectorXd::Constant(n, qd_max)};
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const UrdfJointLimits& limit = robot.limits[static_cast<std::size_t>(j)];
    if (std::isfinite(limit.lower) && std::isfinite(limit.upper)) {
      require(limit.upper > limit.lower, source + ": joint '" + robot.joint_names[j] +
                                             "' has an empty <limit> range; cannot move it");
      room.q0[j] = 0.5 * (limit.lower + limit.upper);
      room.q_range[j] = std::min(room.q_range[j], 0.45 * (limit.upper - limit.lower));
    }
    if (std::isfinite(limit.velocity) && limit.velocity > 0.0)
      room.qd_max[j] = std::min(room.qd_max[j], 0.9 * limit.velocity);
  }
  return room;
}

SimulatedRobot simulate_robot_truth(const ChainSimulateOptions& o, std::mt19937_64& rng) {
  require(o.harmonics >= 1 && o.harmonics <= 50, "--harmonics must be 1..50");
  require(std::isfinite(o.base_frequency) && o.base_frequency > 0.0,
          "--base-frequency must be a finite number > 0 [Hz]");
  require(std::isfinite(o.q_range) && o.q_range > 0.0, "--q-range must be a finite number > 0");
  require(std::isfinite(o.qd_max) && o.qd_max > 0.0, "--qd-max must be a finite number > 0");
  const RobotDescription robot =
      read_robot_description(o.robot, o.base, o.tip, parse_held_joints(o.hold, "--hold"));
  require(robot.link_parameters.size() > 0,
          o.robot + ": a DH table has no link inertias to simulate with; give a URDF");
  const int n = robot.chain.joints();
  std::vector<ChainEffect> effects;
  for (const std::string& text : o.effects) {
    effects.push_back(parse_chain_effect(text, n));
    for (std::size_t k = 0; k + 1 < effects.size(); ++k)
      require(effects[k].kind != effects.back().kind || effects[k].joint != effects.back().joint,
              "--effect '" + text + "' is given more than once");
  }

  const Transmission direct(n);
  // Springs only when asked: the model (and the theta it returns) is otherwise what it was.
  const bool springs = std::any_of(effects.begin(), effects.end(),
                                   [](const ChainEffect& e) { return e.kind == "spring"; });
  std::vector<DriveTermKind> kinds = {DriveTermKind::Viscous, DriveTermKind::Coulomb,
                                      DriveTermKind::Armature};
  if (springs) kinds.push_back(DriveTermKind::Spring);
  const auto per_joint = static_cast<Eigen::Index>(kinds.size());
  // A Stribeck curve is the joint's Coulomb level plus a term of its own width after the others.
  std::vector<DriveTerm> terms = drive_terms(kinds, direct);
  std::vector<double> stribeck_excess;
  for (const ChainEffect& e : effects)
    if (e.kind == "stribeck") {
      terms.push_back({DriveTermKind::Stribeck, e.joint, false, e.values[2]});
      stribeck_excess.push_back(e.values[1] - e.values[0]);
    }
  const ChainModel model(robot.chain, robot.joint_names, terms, direct, o.coulomb_epsilon);
  // theta: the URDF's links, its <dynamics> damping and friction, then the effects on top.
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
  theta.head(model.rigid_body_parameters()) = robot.link_parameters;
  Eigen::VectorXd torque_offset = Eigen::VectorXd::Zero(n), angle_offset = torque_offset;
  const Eigen::Index drives = model.rigid_body_parameters();
  for (int j = 0; j < n; ++j) {
    theta[drives + per_joint * j] = robot.damping[j];
    theta[drives + per_joint * j + 1] = robot.friction[j];
  }
  theta.tail(static_cast<Eigen::Index>(stribeck_excess.size())) = Eigen::Map<const Eigen::VectorXd>(
      stribeck_excess.data(), static_cast<Eigen::Index>(stribeck_excess.size()));
  for (const ChainEffect& e : effects) {
    if (e.kind == "torque_offset" || e.kind == "angle_offset") {
      (e.kind == "torque_offset" ? torque_offset : angle_offset)[e.joint] = e.values[0];
      continue;
    }
    const int slot = e.kind == "viscous"                           ? 0
                     : e.kind == "coulomb" || e.kind == "stribeck" ? 1
                     : e.kind == "armature"                        ? 2
                                                                   : 3;
    theta[drives + per_joint * e.joint + slot] += e.values[0];
  }

  if (!o.torque.empty())
    return driven_by_torque(o, robot, model, theta, torque_offset, angle_offset);
  FourierTrajectory desired;
  if (o.trajectory.empty()) {
    const ExcitationRoom room = excitation_room(robot, o.robot, o.q_range, o.qd_max);
    desired = random_fourier_trajectory(room.q0, o.harmonics, o.base_frequency, room.q_range,
                                        room.qd_max, rng);
  } else {
    desired = read_fourier_trajectory(o.trajectory, n);
  }
  ChainExperiment experiment;
  experiment.external_torque = pushes_torque(o, robot.chain);
  experiment.duration = o.duration;
  experiment.sample_time = o.sample_time;
  experiment.simulator.rtol = o.rtol;
  experiment.simulator.atol = o.atol;
  {
    ChainModel::Vector q(n), qd(n), qdd(n);
    desired.evaluate(0.0, q, qd, qdd);
    require_inertia_on_every_joint(o.robot, model, theta, q);
  }
  const ChainExperimentResult run = simulate_chain_experiment(model, theta, desired, experiment);
  require(run.ok(), std::string("the simulation failed (") + to_string(run.status) +
                        "): " + run.message +
                        "; check the description's inertias or the tolerances --rtol/--atol");

  return SimulatedRobot{robot, model, theta, torque_offset, angle_offset, run.truth, run.external};
}

SimulatedLog simulate_robot_log(const ChainSimulateOptions& o) {
  std::mt19937_64 rng(o.seed);
  SimulatedRobot simulated = simulate_robot_truth(o, rng);
  const RobotDescription& robot = simulated.robot;
  const int n = simulated.model.joints();
  std::vector<std::string> warnings;
  // The excitation is scaled to the position and rate limits; the torque it takes is known only
  // now. A run beyond a drive's <limit effort> is still written (the user may want it), but said.
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const double effort = robot.limits[static_cast<std::size_t>(j)].effort;
    const double peak = simulated.truth.tau.col(j).cwiseAbs().maxCoeff();
    if (std::isfinite(effort) && effort > 0.0 && peak > effort)
      warnings.push_back("joint '" + robot.joint_names[j] + "' needs up to " +
                         shortest_number(peak) + " N m, above its <limit effort> of " +
                         shortest_number(effort) + "; lower --qd-max or --q-range");
  }
  // A given torque takes the arm wherever it goes; a Fourier excitation stays inside.
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const UrdfJointLimits& limit = robot.limits[static_cast<std::size_t>(j)];
    const double low = simulated.truth.q.col(j).minCoeff(),
                 high = simulated.truth.q.col(j).maxCoeff();
    if ((std::isfinite(limit.lower) && low < limit.lower) ||
        (std::isfinite(limit.upper) && high > limit.upper))
      warnings.push_back("joint '" + robot.joint_names[j] + "' moves over [" +
                         shortest_number(low) + ", " + shortest_number(high) +
                         "], beyond its <limit> of [" + shortest_number(limit.lower) + ", " +
                         shortest_number(limit.upper) + "]");
  }
  ChainTrajectory<double> sensed{simulated.truth.t, simulated.truth.q, simulated.truth.tau};
  // The sensors' faults: a torque bias b adds to the torque, an encoder offset d is subtracted
  // from the angle (the two-link arm's convention).
  for (int j = 0; j < n; ++j) {
    sensed.tau.col(j).array() += simulated.torque_offset[j];
    sensed.q.col(j).array() -= simulated.angle_offset[j];
  }
  ChainTrajectory<double> measured =
      add_measurement_noise(sensed, MeasurementNoise<double>{o.sigma_q2, o.sigma_tau2}, rng);
  return {std::move(simulated), std::move(measured), std::move(warnings)};
}

long simulate_robot(const ChainSimulateOptions& o) {
  const SimulatedLog log = simulate_robot_log(o);
  for (const auto& w : log.warnings) std::cerr << "sid_simulate: warning: " << w << "\n";
  const SimulatedRobot& simulated = log.simulated;
  const RobotDescription& robot = simulated.robot;
  const ChainModel& model = simulated.model;
  const Eigen::VectorXd& theta = simulated.theta;
  const int n = model.joints();
  const Eigen::Index drives = model.rigid_body_parameters();
  const ChainTrajectory<double>& measured = log.measured;

  std::vector<std::string> names{"t"};
  std::vector<Eigen::VectorXd> columns{measured.t};
  for (const char* stem : {"q", "tau"})
    for (int j = 0; j < n; ++j) {
      names.push_back(stem + std::to_string(j + 1));
      columns.push_back(std::string(stem) == "q" ? measured.q.col(j) : measured.tau.col(j));
    }
  if (o.truth) {
    const ChainKinematics<double>& k = simulated.truth;
    const std::pair<const char*, const Eigen::MatrixXd*> truth[] = {
        {"q_true", &k.q},
        {"qd", &k.qd},
        {"qdd", &k.qdd},
        {"tau_true", &k.tau},
        {"tau_ext", simulated.external.size() ? &simulated.external : nullptr}};
    for (const auto& [stem, m] : truth)
      for (int j = 0; j < n && m; ++j) {
        const std::string s = stem;
        const auto under = s.find('_');
        names.push_back(under == std::string::npos
                            ? s + std::to_string(j + 1)
                            : s.substr(0, under) + std::to_string(j + 1) + s.substr(under));
        columns.push_back(m->col(j));
      }
  }
  std::string joint_list, parameters;
  for (int j = 0; j < n; ++j) joint_list += (j ? "," : "") + robot.joint_names[j];
  for (Eigen::Index k = drives; k < theta.size(); ++k)
    if (theta[k] != 0.0)
      parameters += (parameters.empty() ? "" : " ") +
                    model.parameter_names()[static_cast<std::size_t>(k)] + "=" +
                    shortest_number(theta[k]);
  std::string effect_list;
  for (const std::string& text : o.effects) effect_list += (effect_list.empty() ? "" : " ") + text;
  const std::vector<std::string> comments{
      "sid_simulate --robot " + o.robot + ": " + std::to_string(n) + " joints (" + joint_list +
          "), the description's links, " +
          (o.torque.empty() ? "computed torque tracking a Fourier excitation"
                            : "driven open loop by a given torque"),
      !o.torque.empty() ? "excitation: the torque of " + o.torque +
                              " from rest at q0 = " + joined(simulated.truth.q.row(0))
      : !o.trajectory.empty()
          ? "excitation: the Fourier trajectory of " + o.trajectory
          : "excitation: " + std::to_string(o.harmonics) + " harmonics of " +
                shortest_number(o.base_frequency) +
                " Hz about the middle of each joint's <limit>, |q - q0| <= " +
                shortest_number(o.q_range) + ", |qd| <= " + shortest_number(o.qd_max) +
                " (and 90 % of the limits), from the seed",
      o.torque.empty()
          ? "T = " + shortest_number(o.duration) + " s, Ts = " + shortest_number(o.sample_time) +
                " s, samples = " + std::to_string(measured.size())
          : "the torque file's times, samples = " + std::to_string(measured.size()),
      "seed = " + std::to_string(o.seed) + " (std::mt19937_64), sigma_q2 = " +
          shortest_number(o.sigma_q2) + ", sigma_tau2 = " + shortest_number(o.sigma_tau2),
      "drive terms = " + (parameters.empty() ? std::string("none") : parameters) +
          " (coulomb_epsilon = " + shortest_number(o.coulomb_epsilon) + ")",
      "effects = " + (effect_list.empty() ? std::string("none") : effect_list)};
  write_csv(o.output, names, columns, comments);
  return static_cast<long>(measured.size());
}

}  // namespace sid::app
