#pragma once
/// @file
/// @brief sid_identify --robot --currents: logs of motor currents, one run with a known payload
/// on the tip link: the drive gains (sid/drive_gains.hpp), then the usual chain identification
/// of the runs converted to torques, with the gains in its report and JSON.

#include <sid/drive_gains.hpp>
#include <sid/model/link_inertia.hpp>

#include "chain_identify_app.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace sid::app {

/// @brief The options of sid_identify that make its --robot logs currents.
struct DriveGainAppOptions {
  bool currents = false;      ///< --currents: the tau columns are motor currents [A]
  std::string known_payload;  ///< --known-payload m,cx,cy,cz[,ixx,iyy,izz,ixy,ixz,iyz]
  std::string payload_run;    ///< --payload-run: the log with the payload on the tip link
  /// --payload-frame: the link whose frame --known-payload is given in, fixed to the chain's
  /// last moving link (empty: the --tip link; a DH table: its last link's frame).
  std::string payload_frame;
  bool any() const { return currents || !known_payload.empty() || !payload_run.empty(); }
};

/// @brief The load of --known-payload: mass [kg], centre of mass [m] and, optionally, inertia
/// about it [kg m^2] (ixx, iyy, izz, ixy, ixz, iyz; default 0, a point mass), in the frame it is
/// given in (DriveGainAppOptions::payload_frame).
/// @throws InputError naming --known-payload: a count other than 4 or 10, a value that is not
///         a number, or a load that is no real body.
sid::LinkInertia<double> parse_known_payload(const std::string& text);

/// @brief The checks of the option combination (before any file is read).
/// @throws InputError: --known-payload or --payload-run without --currents, --currents without
///         either (the gains' scale needs the known load) or without --robot.
void check_drive_gain_options(const ChainIdentifyAppOptions& chain, const DriveGainAppOptions& o);

/// @brief The gains and the identification of the converted runs.
struct DriveGainResult {
  sid::DriveGainIdentification gains;
  ChainIdentifyResult identified;  ///< its text and json include the gains
};

/// @brief Finds the gains from chain.inputs (without the payload) and o.payload_run (with it),
/// converts every run (and chain.validate's) to joint torques, subtracts the payload's torque
/// from the loaded run and identifies the arm as sid_identify --robot does.
/// @throws InputError naming what is wrong.
DriveGainResult identify_with_drive_gains(const ChainIdentifyAppOptions& chain,
                                          const DriveGainAppOptions& o);

/// @brief sid_identify --robot --currents: prints the report (and writes --json, --write-urdf).
/// @return the exit code; bad input throws InputError.
int identify_robot_currents(const ChainIdentifyAppOptions& chain, const DriveGainAppOptions& o,
                            const char* app_name);

}  // namespace sid::app
