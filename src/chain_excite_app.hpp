#pragma once
/// @file
/// @brief sid_excite: the excitation of a robot description's chain designed for
/// identification (sid::design_excitation), and the file its Fourier coefficients are written
/// to and sid_simulate --robot --trajectory reads.

#include <sid/fourier_trajectory.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace sid::app {

/// @brief The options of sid_excite.
struct ChainExciteOptions {
  std::string robot, base, tip, hold;
  /// The drives' transmission (YAML or URDF, as sid_identify --robot takes it): the model
  /// then has the drive terms of each coupled motor too. Empty: each joint its own motor.
  std::string transmission;
  int harmonics = 5;
  double base_frequency = 0.1;   ///< [Hz]
  double q_range = 1.0;          ///< largest |q - q0| [rad or m], and 90 % of the <limit>
  double qd_max = 1.5;           ///< largest |qd| [rad/s or m/s], and 90 % of the <limit>
  double qdd_max = 10.0;         ///< largest |qdd| [rad/s^2 or m/s^2]
  double torque_fraction = 0.8;  ///< of each <limit effort>
  double rate = 20.0;            ///< grid points per second over one period [Hz]
  int max_evaluations = 300;
  std::string algorithm = "slsqp";  ///< slsqp or mma
  std::uint64_t seed = 1;
  /// Candidate ids of sid_diagnose --robot (e.g. spring_j2,offset_j2, angle_offset_q2,
  /// stribeck_j3:0.2 for a width other than 0.1 rad/s) whose columns join the conditioned
  /// regressor: an excitation on which they are told apart. Empty: the base regressor alone.
  std::string separate;
  bool random_only = false;  ///< report (and write) the random excitation only
  std::string output;        ///< the coefficients file; empty: not written
  bool force = false;
};

/// @brief An excitation as sid_excite designs it, with its report.
struct ChainExcitation {
  sid::FourierTrajectory trajectory;     ///< the designed one (the random one with random_only)
  double condition_number = 0.0;         ///< of the scaled base regressor along trajectory
  double random_condition_number = 0.0;  ///< the random start's
  std::string report;                    ///< the text sid_excite prints
  std::vector<std::string> comments;     ///< the coefficients file's header lines
};

/// @brief Designs the excitation of options (output and force are not used).
/// @throws InputError naming the option or file at fault.
ChainExcitation design_robot_excitation(const ChainExciteOptions& options, const char* app_name);

/// @brief Designs the excitation, prints the comparison with the random one and writes the
/// file. @return the exit code; bad input throws InputError.
int excite_robot(const ChainExciteOptions& options, const char* app_name);

/// @brief Writes a Fourier trajectory as CSV: one row per joint, columns
/// joint,base_frequency,q0,a1..aH,b1..bH (17 significant digits, so it reads back exactly);
/// comments become '#' lines first.
void write_fourier_trajectory(const std::string& path, const sid::FourierTrajectory& trajectory,
                              const std::vector<std::string>& comments);

/// @brief Reads the file write_fourier_trajectory writes.
/// @throws InputError naming the file and the problem (a missing column, a joint count other
///         than joints, joints out of order, base frequencies that differ, a bad coefficient).
sid::FourierTrajectory read_fourier_trajectory(const std::string& path, int joints);

}  // namespace sid::app
