#include "chain_simulate_app.hpp"

#include <sid/cvode/simulate_robot.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/measurement_noise.hpp>

#include "app.hpp"
#include "chain_excite_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

namespace sid::app {

namespace {

std::string joined(const Eigen::RowVectorXd& values) {
  std::string text;
  for (Eigen::Index j = 0; j < values.size(); ++j)
    text += (j ? "," : "") + shortest_number(values[j]);
  return text;
}

/// The kinds of --effect, by their ids' stems.
const std::pair<const char*, RobotEffectKind> kEffectStems[] = {
    {"viscous", RobotEffectKind::Viscous},         {"coulomb", RobotEffectKind::Coulomb},
    {"armature", RobotEffectKind::Armature},       {"spring", RobotEffectKind::Spring},
    {"stribeck", RobotEffectKind::Stribeck},       {"torque_offset", RobotEffectKind::TorqueOffset},
    {"angle_offset", RobotEffectKind::AngleOffset}};

/// Parses --effect KIND_jN:VALUE (angle_offset_qN:VALUE, stribeck_jN:Fc,Fs,vs).
RobotEffect parse_robot_effect(const std::string& text, int joints) {
  const std::string who = "--effect '" + text + "': ";
  const std::string form = "expected KIND_jN:VALUE (angle_offset_qN:VALUE), e.g. coulomb_j3:0.4";
  const auto colon = text.find(':');
  require(colon != std::string::npos, who + form);
  const std::string id = text.substr(0, colon), value = text.substr(colon + 1);
  const bool angle = id.rfind("angle_offset_q", 0) == 0;
  const auto mark = angle ? std::string("angle_offset").size() : id.rfind("_j");
  require(mark != std::string::npos, who + form);
  const std::string kind = id.substr(0, mark);
  const auto stem = std::find_if(std::begin(kEffectStems), std::end(kEffectStems),
                                 [&](const auto& s) { return kind == s.first; });
  require(stem != std::end(kEffectStems),
          who + "unknown kind '" + kind +
              "'; on a chain: viscous, coulomb, armature, spring, stribeck, torque_offset, "
              "angle_offset");
  const std::string number = id.substr(mark + 2);
  int joint = 0;
  const auto parsed = std::from_chars(number.data(), number.data() + number.size(), joint);
  require(!number.empty() && parsed.ec == std::errc() &&
              parsed.ptr == number.data() + number.size() && joint >= 1 && joint <= joints,
          who + "the joint must be 1.." + std::to_string(joints) + ", got '" + number + "'");
  RobotEffect e;
  e.kind = stem->second;
  e.joint = joint - 1;
  if (e.kind == RobotEffectKind::Stribeck) {
    const std::vector<double> v = parse_doubles(value, "--effect " + id, 3);
    require(v[0] > 0.0 && v[1] > v[0] && v[2] > 0.0,
            who + "stribeck takes Fc,Fs,vs with 0 < Fc < Fs [N m] and vs > 0 [rad/s]");
    e.value = v[0];
    e.stribeck_static = v[1];
    e.stribeck_velocity = v[2];
    return e;
  }
  e.value = parse_doubles(value, "--effect " + id, 1)[0];
  require(e.kind == RobotEffectKind::TorqueOffset || e.kind == RobotEffectKind::AngleOffset ||
              e.value > 0.0,
          who + kind + " must be > 0, got " + shortest_number(e.value));
  return e;
}

std::vector<RobotEffect> parse_robot_effects(const std::vector<std::string>& texts, int joints) {
  std::vector<RobotEffect> effects;
  for (const std::string& text : texts) {
    effects.push_back(parse_robot_effect(text, joints));
    for (std::size_t k = 0; k + 1 < effects.size(); ++k)
      require(effects[k].kind != effects.back().kind || effects[k].joint != effects.back().joint,
              "--effect '" + text + "' is given more than once");
  }
  return effects;
}

/// --push START,END,FX,FY,FZ (repeated), --push-ramp and --push-point.
ToolPushes parse_pushes(const ChainSimulateOptions& o) {
  ToolPushes pushes;
  if (o.pushes.empty()) return pushes;
  require(o.torque.empty(), "--push applies to the tracked excitation, not to --torque");
  require(o.push_ramp > 0.0 && std::isfinite(o.push_ramp), "--push-ramp must be > 0 s");
  pushes.ramp = o.push_ramp;
  if (!o.push_point.empty()) {
    const std::vector<double> p = parse_doubles(o.push_point, "--push-point");
    require(p.size() == 3, "--push-point takes X,Y,Z [m] in the tip link's frame");
    pushes.point << p[0], p[1], p[2];
  }
  for (const std::string& text : o.pushes) {
    const std::vector<double> v = parse_doubles(text, "--push");
    require(v.size() == 5, "--push takes START,END,FX,FY,FZ [s, N], not '" + text + "'");
    require(v[1] - v[0] >= 2.0 * o.push_ramp,
            "--push '" + text + "': END - START must be at least twice the ramp (" +
                shortest_number(o.push_ramp) + " s)");
    pushes.pushes.push_back({v[0], v[1], Eigen::Vector3d(v[2], v[3], v[4])});
  }
  return pushes;
}

/// --torque's file and --q0.
DrivingTorque read_driving_torque(const ChainSimulateOptions& o, int n) {
  require(o.trajectory.empty(), "--torque and --trajectory are two inputs; give one");
  const CsvTable table = read_csv(o.torque);
  require(table.rows() >= 2, o.torque + ": needs at least 2 rows of t,tau1..tau" +
                                 std::to_string(n) + ", got " + std::to_string(table.rows()));
  require_strictly_increasing(table, "t");
  DrivingTorque torque;
  torque.t = table.column("t");
  torque.tau.resize(table.rows(), n);
  for (int j = 0; j < n; ++j) torque.tau.col(j) = table.column("tau" + std::to_string(j + 1));
  if (!o.q0.empty()) {
    const std::vector<double> q0 = parse_doubles(o.q0, "--q0", static_cast<std::size_t>(n));
    torque.q0 = Eigen::Map<const Eigen::VectorXd>(q0.data(), n);
  }
  return torque;
}

/// A per-joint option's values: one for every joint or one per joint.
std::vector<double> per_joint_values(const std::string& text, const std::string& option, int n) {
  if (text.empty()) return {};
  std::vector<double> v = parse_doubles(text, option);
  require(v.size() == 1 || v.size() == static_cast<std::size_t>(n),
          option + ": give one value or one per joint (" + std::to_string(n) + "), not " +
              std::to_string(v.size()));
  return v;
}

/// --encoder-bits: whole numbers of bits per turn, 1..52.
std::vector<int> encoder_bits(const std::string& text, int n) {
  std::vector<int> bits;
  for (const double b : per_joint_values(text, "--encoder-bits", n)) {
    require(b >= 1.0 && b <= 52.0 && b == std::floor(b),
            "--encoder-bits: bits per turn are whole numbers 1..52, not " + shortest_number(b));
    bits.push_back(static_cast<int>(b));
  }
  return bits;
}

}  // namespace

LoggedSensors logged_sensors(const ChainSimulateOptions& o, int n) {
  LoggedSensors sensors;
  sensors.encoder_bits = encoder_bits(o.encoder_bits, n);
  sensors.encoder_ratio = per_joint_values(o.encoder_ratio, "--encoder-ratio", n);
  for (const double r : sensors.encoder_ratio)
    require(r > 0.0, "--encoder-ratio: turns of the encoder per turn of the joint must be > 0");
  require(o.encoder_ratio.empty() || !o.encoder_bits.empty(),
          "--encoder-ratio needs --encoder-bits");
  require(std::isfinite(o.torque_delay), "--torque-delay must be finite [s]");
  sensors.torque_delay = o.torque_delay;
  return sensors;
}

namespace {

/// The library's settings of the run the options describe on robot.
RobotSimulationOptions robot_simulation_options(const ChainSimulateOptions& o,
                                                const RobotDescription& robot) {
  const int n = robot.chain.joints();
  RobotSimulationOptions s;
  s.effects = parse_robot_effects(o.effects, n);
  s.coulomb_epsilon = o.coulomb_epsilon;
  s.random = {o.harmonics, o.base_frequency, o.q_range, o.qd_max};
  if (!o.torque.empty()) s.torque = read_driving_torque(o, n);
  if (!o.trajectory.empty()) s.trajectory = read_fourier_trajectory(o.trajectory, n);
  s.pushes = parse_pushes(o);
  s.duration = o.duration;
  s.sample_time = o.sample_time;
  s.simulator.rtol = o.rtol;
  s.simulator.atol = o.atol;
  s.noise = MeasurementNoise<double>{o.sigma_q2, o.sigma_tau2};
  s.sensors = logged_sensors(o, n);
  return s;
}

/// What a joint beyond its <limit> is told.
std::string beyond_limit_warning(const RobotDescription& robot, const JointLimitExcess& e) {
  const std::string joint = "joint '" + robot.joint_names[static_cast<std::size_t>(e.joint)] + "'";
  const UrdfJointLimits& limit = robot.limits[static_cast<std::size_t>(e.joint)];
  if (e.effort)
    return joint + " needs up to " + shortest_number(e.peak_effort) +
           " N m, above its <limit effort> of " + shortest_number(limit.effort) +
           "; lower --qd-max or --q-range";
  return joint + " moves over [" + shortest_number(e.low) + ", " + shortest_number(e.high) +
         "], beyond its <limit> of [" + shortest_number(limit.lower) + ", " +
         shortest_number(limit.upper) + "]";
}

/// Runs a simulation, its refusals said in the options' words.
template <typename Simulation>
auto in_options_words(const ChainSimulateOptions& o, const Simulation& simulation) {
  try {
    return simulation();
  } catch (const JointWithoutInertia& e) {
    throw InputError(o.robot +
                     ": a joint of the chain moves no inertia (a link with none about its axis); "
                     "add a rotor, e.g. --effect armature_j" +
                     std::to_string(e.joint + 1) + ":0.01");
  } catch (const RobotSimulationFailed& e) {
    if (!o.torque.empty())
      throw InputError("the simulation under the torque of " + o.torque +
                       " stopped at t = " + shortest_number(e.stopped_at) + " s (" + e.message +
                       "); the torque does not hold the arm (gravity?) or spins it away");
    throw InputError(std::string(e.what()) +
                     "; check the description's inertias or the tolerances --rtol/--atol");
  } catch (const std::invalid_argument& e) {
    throw InputError(o.robot + ": " + e.what());
  }
}

}  // namespace

ExcitationRoom excitation_room(const RobotDescription& robot, const std::string& source,
                               double q_range, double qd_max) {
  try {
    return sid::excitation_room(robot, q_range, qd_max);
  } catch (const std::invalid_argument& e) {
    throw InputError(source + ": " + e.what());
  }
}

RobotDescription read_simulated_robot(const ChainSimulateOptions& o) {
  require(o.harmonics >= 1 && o.harmonics <= 50, "--harmonics must be 1..50");
  require(std::isfinite(o.base_frequency) && o.base_frequency > 0.0,
          "--base-frequency must be a finite number > 0 [Hz]");
  require(std::isfinite(o.q_range) && o.q_range > 0.0, "--q-range must be a finite number > 0");
  require(std::isfinite(o.qd_max) && o.qd_max > 0.0, "--qd-max must be a finite number > 0");
  RobotDescription robot =
      read_robot_description(o.robot, o.base, o.tip, parse_held_joints(o.hold, "--hold"));
  require(robot.link_parameters.size() > 0,
          o.robot + ": a DH table has no link inertias to simulate with; give a URDF");
  return robot;
}

SimulatedRobot simulate_robot_truth(const ChainSimulateOptions& o, const RobotDescription& robot,
                                    std::mt19937_64& rng) {
  const RobotSimulationOptions options = robot_simulation_options(o, robot);
  return in_options_words(o, [&] { return sid::simulate_robot_truth(robot, options, rng); });
}

SimulatedLog simulate_robot_log(const ChainSimulateOptions& o) {
  RobotDescription robot = read_simulated_robot(o);
  const RobotSimulationOptions options = robot_simulation_options(o, robot);
  sid::SimulatedRobotLog log =
      in_options_words(o, [&] { return sid::simulate_robot(robot, options, o.seed); });
  std::vector<std::string> warnings;
  for (const JointLimitExcess& e : log.beyond_limits)
    warnings.push_back(beyond_limit_warning(robot, e));
  return {std::move(robot), std::move(log.simulated), std::move(log.measured), std::move(warnings)};
}

long simulate_robot(const ChainSimulateOptions& o) {
  const SimulatedLog log = simulate_robot_log(o);
  for (const auto& w : log.warnings) std::cerr << "sid_simulate: warning: " << w << "\n";
  const SimulatedRobot& simulated = log.simulated;
  const RobotDescription& robot = log.robot;
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
          shortest_number(o.sigma_q2) + ", sigma_tau2 = " + shortest_number(o.sigma_tau2) +
          (o.encoder_bits.empty() ? std::string()
                                  : ", encoder bits per turn = " + o.encoder_bits +
                                        (o.encoder_ratio.empty() ? std::string(" (on the joints)")
                                                                 : " at " + o.encoder_ratio +
                                                                       " turns per joint turn")) +
          (o.torque_delay == 0.0
               ? std::string()
               : ", torque logged " + shortest_number(o.torque_delay) + " s behind the angles"),
      "drive terms = " + (parameters.empty() ? std::string("none") : parameters) +
          " (coulomb_epsilon = " + shortest_number(o.coulomb_epsilon) + ")",
      "effects = " + (effect_list.empty() ? std::string("none") : effect_list)};
  write_csv(o.output, names, columns, comments);
  return static_cast<long>(measured.size());
}

}  // namespace sid::app
