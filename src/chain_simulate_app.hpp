#pragma once
// sid_simulate --robot: an identification experiment on any serial chain of a URDF, simulated
// with CVODE under a random Fourier excitation or a given torque, written as the log
// sid_identify --robot reads.

#include <sid/model/chain_model.hpp>
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
};

/// @brief Where an excitation of the robot may go: q0 about the middle of each joint's <limit>,
/// |q - q0| at most q_range and 90 % of its half width, |qd| at most qd_max and 90 % of its
/// velocity limit (q_range and qd_max alone where the URDF gives no limit).
struct ExcitationRoom {
  Eigen::VectorXd q0, q_range, qd_max;
};

/// @throws InputError when a joint's <limit> range is empty (source names the file).
ExcitationRoom excitation_room(const RobotDescription& robot, const std::string& source,
                               double q_range, double qd_max);

/// The experiment before any noise: the description, the model simulated (viscous, Coulomb and
/// armature terms on every joint, springs and Stribeck terms where asked), its true parameters,
/// the sensor faults of the effects (torque offsets added to the sensed torque, angle offsets
/// subtracted from the sensed angle; not part of the model) and the true samples.
struct SimulatedRobot {
  RobotDescription robot;
  ChainModel model;
  Eigen::VectorXd theta;
  Eigen::VectorXd torque_offset;
  Eigen::VectorXd angle_offset;
  ChainKinematics<double> truth;
  Eigen::MatrixXd external;  ///< the pushes' joint torques per sample; empty without pushes
};

/// Reads the description and simulates it under the random Fourier excitation drawn from rng
/// (the options' seed is not used here), the trajectory file or the torque file. Noise, columns
/// and output are ignored.
/// @throws InputError naming the problem (a DH table, an unknown effect, a failed simulation).
SimulatedRobot simulate_robot_truth(const ChainSimulateOptions& options, std::mt19937_64& rng);

/// The simulated experiment and its log: the sensors' faults and noise added to the truth.
struct SimulatedLog {
  SimulatedRobot simulated;
  ChainTrajectory<double> measured;
  std::vector<std::string> warnings;  ///< torques above <limit effort>, motion beyond <limit>
};

/// Simulates and adds the sensors' faults and noise (the options' seed drives both).
/// @throws InputError as simulate_robot_truth.
SimulatedLog simulate_robot_log(const ChainSimulateOptions& options);

/// Simulates, adds noise and writes the CSV (t, q1..qn, tau1..taun; with truth the true q, qd,
/// qdd and tau too); returns the number of samples.
/// @throws InputError naming the problem (a DH table, an unknown effect, a failed simulation).
long simulate_robot(const ChainSimulateOptions& options);

}  // namespace sid::app
