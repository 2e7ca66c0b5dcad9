#pragma once
// sid_simulate --robot: an identification experiment on any serial chain of a URDF, simulated
// with CVODE under a random Fourier excitation, written as the log sid_identify --robot reads.

#include <cstdint>
#include <string>
#include <vector>

namespace sid::app {

struct ChainSimulateOptions {
  std::string robot, base, tip, hold;
  double duration = 10.0, sample_time = 0.0025;
  double sigma_q2 = 1e-6, sigma_tau2 = 1e-2;
  std::uint64_t seed = 1;
  std::vector<std::string>
      effects;  ///< viscous_jN:V, coulomb_jN:V, armature_jN:V, torque_offset_jN:V
  int harmonics = 5;
  double base_frequency = 0.1;  ///< [Hz]
  double q_range = 1.0;         ///< largest |q - q0| per joint [rad or m]
  double qd_max = 1.5;          ///< largest |qd| per joint [rad/s or m/s]
  double coulomb_epsilon = 0.01;
  double rtol = 1e-9, atol = 1e-9;
  bool truth = false;
  std::string output = "-";
};

/// Simulates, adds noise and writes the CSV (t, q1..qn, tau1..taun; with truth the true q, qd,
/// qdd and tau too); returns the number of samples.
/// @throws InputError naming the problem (a DH table, an unknown effect, a failed simulation).
long simulate_robot(const ChainSimulateOptions& options);

}  // namespace sid::app
