#pragma once
/// @file
/// @brief A robot's identification experiment simulated from its description, as
/// `sid_simulate --robot` and the chain Monte Carlo study make it: the description's links and
/// joints' <dynamics>, drive terms and sensor faults added on top, tracking a random Fourier
/// excitation within the joints' limits (or a given one), or driven open loop by a given torque,
/// optionally pushed at the tool; then the log its sensors record.

#include <sid/config.hpp>
#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/logged_sensors.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/robot_description.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

/// @brief What a simulated arm may have beyond its description.
enum class RobotEffectKind {
  Viscous,       ///< viscous friction Fv [N m s/rad], added to the joint's <dynamics damping>
  Coulomb,       ///< Coulomb friction Fc [N m], added to its <dynamics friction>
  Armature,      ///< rotor inertia Ia [kg m^2]
  Spring,        ///< a joint spring k [N m/rad]
  Stribeck,      ///< a Stribeck curve: Coulomb level Fc, static level Fs, width vs
  TorqueOffset,  ///< the torque sensor's bias b [N m], added to the logged torque
  AngleOffset,   ///< the encoder's offset delta [rad], subtracted from the logged angle
};

/// @brief One effect on one joint (sid_simulate's --effect viscous_j2:0.3, stribeck_j1:Fc,Fs,vs,
/// angle_offset_q3:0.01).
struct RobotEffect {
  RobotEffectKind kind = RobotEffectKind::Viscous;
  int joint = 0;       ///< 0-based
  double value = 0.0;  ///< Fv, Fc, Ia, k, b or delta; for a Stribeck curve its Coulomb level
  double stribeck_static = 0.0;    ///< Stribeck only: Fs > Fc [N m]
  double stribeck_velocity = 0.0;  ///< Stribeck only: vs > 0 [rad/s]
};

/// @brief A force the outside applies at a point of the tip link from start to end [s], ramped
/// in and out.
struct ToolPush {
  double start = 0.0, end = 0.0;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< [N], base frame
};

/// @brief The pushes of a simulated run.
struct ToolPushes {
  std::vector<ToolPush> pushes;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< where, in the tip link's frame [m]
  double ramp = 0.02;  ///< the time a push takes to come and go [s]; end - start >= 2 ramp
};

/// @brief A random Fourier excitation about the middle of each joint's limits
/// (sid::excitation_room, sid::random_fourier_trajectory).
struct RandomRobotExcitation {
  int harmonics = 5;            ///< 1..50
  double base_frequency = 0.1;  ///< [Hz]
  double q_range = 1.0;         ///< largest |q - q0| per joint [rad or m]
  double qd_max = 1.5;          ///< largest |qd| per joint [rad/s or m/s]
};

/// @brief An open-loop run under a given torque, from rest.
struct DrivingTorque {
  Eigen::VectorXd t;    ///< the log's times [s], increasing
  Eigen::MatrixXd tau;  ///< one row per time, one column per joint [N m or N]
  Eigen::VectorXd q0;   ///< the angles it starts from; empty: the middle of each joint's <limit>
};

/// @brief Settings of simulate_robot().
struct RobotSimulationOptions {
  std::vector<RobotEffect> effects;  ///< one per kind and joint at most
  double coulomb_epsilon = 0.01;     ///< eps of tanh(qd / eps) [rad/s]
  /// The excitation tracked, unless `trajectory` or `torque` is given.
  RandomRobotExcitation random;
  std::optional<FourierTrajectory> trajectory;  ///< a trajectory to track instead
  std::optional<DrivingTorque> torque;          ///< or a torque to drive the arm with
  ToolPushes pushes;                            ///< the outside's, tracked runs only
  double duration = 10.0;                       ///< of a tracked run [s]
  double sample_time = 0.0025;  ///< of a tracked run [s]; a driven run has the torque's times
  SimulatorOptions simulator = SimulatorOptions{1e-9, 1e-9};
  MeasurementNoise<double> noise{1e-6, 1e-2};  ///< the sensors' (angle, torque) variances
  /// Encoders that round the noisy angles, a torque channel behind the angles'.
  LoggedSensors sensors;
};

/// @brief The experiment before any noise: the model simulated (viscous, Coulomb and armature
/// terms on every joint, springs and Stribeck terms where asked), its true parameters, the
/// sensor faults (not part of the model) and the true samples.
struct SimulatedRobot {
  ChainModel model;
  Eigen::VectorXd theta;
  Eigen::VectorXd torque_offset;  ///< per joint, added to the logged torque
  Eigen::VectorXd angle_offset;   ///< per joint, subtracted from the logged angle
  ChainKinematics<double> truth;
  Eigen::MatrixXd external;  ///< the pushes' joint torques per sample; empty without pushes
};

/// @brief A joint the run took beyond its description's <limit>: the torque it needed above
/// `effort`, or the range it moved over outside [lower, upper].
struct JointLimitExcess {
  int joint = 0;
  bool effort = false;  ///< true: peak_effort exceeds the limit; false: [low, high] does
  double peak_effort = 0.0;
  double low = 0.0, high = 0.0;
};

/// @brief The simulated experiment and the log its sensors record.
struct SimulatedRobotLog {
  SimulatedRobot simulated;
  ChainTrajectory<double> measured;  ///< the truth with the sensors' faults and noise
  /// Efforts first, then ranges, joint by joint: a Fourier excitation is scaled to the position
  /// and rate limits, the torque it takes is known only now; a given torque takes the arm
  /// wherever it goes.
  std::vector<JointLimitExcess> beyond_limits;
};

/// @brief A chain with a joint that moves no inertia at the start: its acceleration is
/// undefined. A rotor (an armature effect) on that joint gives it one.
class JointWithoutInertia : public std::invalid_argument {
 public:
  explicit JointWithoutInertia(int joint_index)
      : std::invalid_argument("joint " + std::to_string(joint_index + 1) +
                              " of the chain moves no inertia (a link with none about its axis)"),
        joint(joint_index) {}
  int joint;  ///< 0-based
};

/// @brief A simulation CVODE could not finish.
class RobotSimulationFailed : public std::runtime_error {
 public:
  RobotSimulationFailed(SimulationStatus run_status, std::string solver_message,
                        double stopped_at_time)
      : std::runtime_error(std::string("the simulation failed (") + to_string(run_status) +
                           "): " + solver_message),
        status(run_status),
        message(std::move(solver_message)),
        stopped_at(stopped_at_time) {}
  SimulationStatus status;
  std::string message;  ///< CVODE's
  double stopped_at;    ///< the last time reached [s]
};

/// @brief The model a simulation runs: the description's links, its joints' <dynamics> damping
/// and friction as viscous and Coulomb terms, an armature on every joint, springs and Stribeck
/// terms where effects ask for them, the effects' values added; the sensor faults apart.
/// @throws std::invalid_argument for a description without link inertias (a DH table), an
///         effect on a joint the chain has not, given twice, or with a value out of its range.
SID_INLINE SimulatedRobot simulated_robot_model(const RobotDescription& robot,
                                                const std::vector<RobotEffect>& effects,
                                                double coulomb_epsilon);

/// @brief The outside's joint torques of the pushes at time t and angles q; an empty function
/// without pushes.
/// @throws std::invalid_argument for a ramp that is not > 0 or a push shorter than two ramps.
SID_INLINE std::function<ChainModel::Vector(double, const ChainModel::Vector&)> tool_push_torque(
    const SerialChain<double>& chain, const ToolPushes& pushes);

/// @brief The experiment without noise: the model (simulated_robot_model) simulated under the
/// excitation of `options` (a random one drawn from rng).
/// @throws std::invalid_argument as simulated_robot_model, excitation_room and
///         random_fourier_trajectory, for settings out of range, or both a trajectory and a torque.
/// @throws JointWithoutInertia for a joint that moves no inertia at the start.
/// @throws RobotSimulationFailed when CVODE stops early.
SID_INLINE SimulatedRobot simulate_robot_truth(const RobotDescription& robot,
                                               const RobotSimulationOptions& options,
                                               std::mt19937_64& rng);

/// @brief The experiment and its log: simulate_robot_truth, then the sensors' faults, noise,
/// delay and quantisation, one generator seeded with `seed` drawing the excitation, then the
/// noise.
/// @throws as simulate_robot_truth.
SID_INLINE SimulatedRobotLog simulate_robot(const RobotDescription& robot,
                                            const RobotSimulationOptions& options,
                                            std::uint64_t seed);

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/simulate_robot-inl.hpp>
#endif
