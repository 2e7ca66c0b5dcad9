#pragma once
// sid_simulate --robot: the options of sid::simulate_robot read from the command line and its
// files, the log written as sid_identify --robot reads it.

#include <sid/cvode/simulate_robot.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "robot_description.hpp"

namespace sid::app {

struct ChainSimulateOptions {
  std::string robot, base, tip, hold;
  double duration = 10.0, sample_time = 0.0025;
  double sigma_q2 = 1e-6, sigma_tau2 = 1e-2;
  std::uint64_t seed = 1;
  /// viscous_jN:V, coulomb_jN:V, armature_jN:V, spring_jN:V, stribeck_jN:Fc,Fs,vs,
  /// torque_offset_jN:V, angle_offset_qN:V
  std::vector<std::string> effects;
  int harmonics = 5;
  double base_frequency = 0.1;  ///< [Hz]
  double q_range = 1.0;         ///< largest |q - q0| per joint [rad or m]
  double qd_max = 1.5;          ///< largest |qd| per joint [rad/s or m/s]
  double coulomb_epsilon = 0.01;
  double rtol = 1e-9, atol = 1e-9;
  bool truth = false;
  std::string output = "-";
  /// A Fourier trajectory file (sid_excite -o) to track instead of the random one; then the
  /// harmonics, base frequency and ranges above are the file's.
  std::string trajectory;
  /// A CSV of t, tau1..taun to drive the arm with open loop instead (its times are the log's);
  /// the arm starts at rest at q0 (empty: the middle of each joint's <limit>).
  std::string torque;
  std::string q0;
  /// "START,END,FX,FY,FZ": the outside pushes at push_point of the tip link with force
  /// (FX, FY, FZ) [N, base frame] from START to END [s], ramping in and out over push_ramp [s].
  std::vector<std::string> pushes;
  double push_ramp = 0.02;
  std::string push_point;  ///< "X,Y,Z" [m] in the tip link's frame; empty: its origin
  /// The sensors of a cheap arm: encoder bits per turn and the encoders' gear ratio ("B" or
  /// "B1,...,Bn"; empty: not quantised, on the joint) and the torque channel's lag [s].
  std::string encoder_bits, encoder_ratio;
  double torque_delay = 0.0;
};

/// @brief The sensors of options.encoder_bits, encoder_ratio and torque_delay on n joints.
/// @throws InputError naming the option at fault.
LoggedSensors logged_sensors(const ChainSimulateOptions& options, int n);

/// @brief sid::excitation_room, its refusal naming the description's file (source).
/// @throws InputError when a joint's <limit> range is empty.
ExcitationRoom excitation_room(const RobotDescription& robot, const std::string& source,
                               double q_range, double qd_max);

/// @brief Checks the excitation's options and reads the description of options.robot.
/// @throws InputError naming the problem (options out of range, a DH table, which has no inertias).
RobotDescription read_simulated_robot(const ChainSimulateOptions& options);

/// The experiment of the options on robot (read_simulated_robot) without noise
/// (sid::simulate_robot_truth), the random excitation drawn from rng (the options' seed is not
/// used here).
/// @throws InputError naming the problem (an unknown effect, a failed simulation).
SimulatedRobot simulate_robot_truth(const ChainSimulateOptions& options,
                                    const RobotDescription& robot, std::mt19937_64& rng);

/// The simulated experiment and its log (sid::simulate_robot, the options' seed).
struct SimulatedLog {
  RobotDescription robot;
  SimulatedRobot simulated;
  ChainTrajectory<double> measured;
  std::vector<std::string> warnings;  ///< torques above <limit effort>, motion beyond <limit>
};

/// Reads the description and simulates the log.
/// @throws InputError as read_simulated_robot and simulate_robot_truth.
SimulatedLog simulate_robot_log(const ChainSimulateOptions& options);

/// Simulates, adds noise and writes the CSV (t, q1..qn, tau1..taun; with truth the true q, qd,
/// qdd and tau too); returns the number of samples.
/// @throws InputError naming the problem (a DH table, an unknown effect, a failed simulation).
long simulate_robot(const ChainSimulateOptions& options);

}  // namespace sid::app
