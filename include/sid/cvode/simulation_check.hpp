#pragma once
/// @file
/// @brief The simulations behind diagnose_with_simulation (sid/cvode/diagnose.hpp): the data
/// type alone, for reports and plots.

#include <sid/cvode/free_simulation.hpp>
#include <sid/trajectory.hpp>

#include <Eigen/Core>

namespace sid {

/// @brief The simulations behind diagnose_with_simulation, for reports and plots.
struct SimulationCheck {
  FreeSimulation nominal;  ///< the nominal model on the result's kinematics
  FreeSimulation final;    ///< the final model (a copy of nominal when nothing was named)
  /// RMS per sample that the torque noise alone gives, per joint [rad] (over the noise runs).
  MatrixX2<double> noise_rms;
  /// Overall RMS of the noise-alone error per joint [rad].
  Vector2<double> noise_error_rms = Vector2<double>::Zero();
};

}  // namespace sid
