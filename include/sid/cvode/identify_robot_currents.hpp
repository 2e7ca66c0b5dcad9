#pragma once
/// @file
/// @brief The identification of a chain from logs of motor currents, as `sid_identify --robot
/// --currents` makes it: the drive gains (current to torque) from a run that carries a load of
/// known inertia on the tip link and runs without it (sid/drive_gains.hpp), then the arm from
/// every run converted to torques by those gains, the load's torque taken off the loaded one
/// (sid::identify_robot).

#include <sid/config.hpp>
#include <sid/cvode/identify_robot.hpp>
#include <sid/drive_gains.hpp>
#include <sid/model/link_inertia.hpp>

#include <string>
#include <vector>

namespace sid {

/// @brief Options of identify_robot_currents().
struct RobotCurrentsOptions {
  /// The arm's identification; its fit.cutoff_hz, when given, are the gains' cutoffs too.
  RobotIdentifyOptions identify;
  /// A gain whose HAC std exceeds this share of it is said to be poorly determined (a warning):
  /// the load barely reaches that motor, or the loaded run barely moves it.
  double poor_gain = 0.05;
};

/// @brief What identify_robot_currents() found.
struct RobotCurrentsIdentification {
  DriveGainIdentification gains;
  /// The arm from the converted runs, in N m. Its warnings include poorly determined gains.
  RobotIdentification arm;
  /// When the cutoffs were chosen: the one the first fit of the gains used [Hz] (the geometric
  /// middle of the search range), before the choice on the runs it converted; else NaN.
  double first_cutoff_hz = 0.0;
};

/// @brief Finds the drive gains and then the arm.
/// @param loaded_run the run with the load on the tip link (joint-side angles, currents [A] as
///        its torques)
/// @param runs the runs without it (at least one: with the loaded run alone the load merges
///        with the tip link and the gains' scale is not identifiable)
/// @param payload the load in the frame of the chain's last moving link
/// @param held_out runs without the load, predicted with the estimate after their conversion
/// @throws std::invalid_argument naming what is wrong (the gain fit's, the identification's).
SID_INLINE RobotCurrentsIdentification identify_robot_currents(
    const ChainModel& model, const NamedChainRun& loaded_run,
    const std::vector<NamedChainRun>& runs, const LinkInertia<double>& payload,
    const std::vector<NamedChainRun>& held_out = {}, const RobotCurrentsOptions& options = {});

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/cvode/identify_robot_currents-inl.hpp>
#endif
