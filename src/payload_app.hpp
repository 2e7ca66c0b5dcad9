#pragma once
/// @file
/// @brief sid_identify --robot --payload-of ARM.json: the load fixed to the chain's tip link,
/// identified from logs that carry it with the arm held at an earlier fit (sid::identify_payload),
/// with its text report, its JSON and the URDF with the load added.

#include <sid/payload.hpp>

#include "chain_identify_app.hpp"
#include "identified_arm.hpp"
#include "robot_description.hpp"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace sid::app {

/// @brief What identify_payload needs besides the arm and the runs.
struct PayloadReportOptions {
  std::string robot;  ///< the description's file, for the messages (sid_excite's command)
  /// The name of the frame the load is expressed in (payload.frame its pose): a URDF link fixed
  /// to the chain's last moving link; empty for a DH table, whose last link's frame it is.
  std::string frame;
  sid::PayloadOptions payload;  ///< the rows (skips, rest rule), the frame; the cutoffs the arm's
};

/// @brief identify_payload's options for the loaded chain: its rows, the load in the frame of
/// payload_frame_name(loaded.robot, frame, option) (for a DH table, its last link's).
/// @param robot the description's file, for the messages.
/// @throws InputError as payload_frame_name and sid::app::fixed_link_pose.
PayloadReportOptions payload_report_options(const LoadedChain& loaded, const std::string& robot,
                                            const std::string& frame, const std::string& option);

/// @brief The load, its report and its JSON.
struct PayloadResult {
  sid::PayloadIdentification id;
  std::string frame;
  std::string text;                   ///< what sid_identify prints
  nlohmann::json json;                ///< what --json writes: {"payload": {...}, ...}
  std::vector<std::string> warnings;  ///< said on stderr by the tool (the arm's among them)
};

/// @brief Identifies the load on arm's tip link from runs (joint-side) with arm held: what
/// sid_identify --payload-of does and the Python binding calls.
/// @throws InputError naming what is wrong: a run of another joint count, too short, or a motion
/// that does not show every parameter of the load (naming them, with the sid_excite command that
/// designs one that does).
PayloadResult identify_payload(const IdentifiedArm& arm, const std::vector<ChainRunFile>& runs,
                               const PayloadReportOptions& options = {});

/// @brief The robot's URDF with the load as a new link `payload` (or payload_2, ... if taken),
/// fixed by `payload_joint` to the chain's tip link (robot.tip), its <inertial> the load's.
/// @param phi the load's ten standard parameters in the frame of link `frame` (empty: robot.tip),
///        a link fixed to the chain's last moving link.
/// @throws InputError for a DH table, a frame not fixed to the last moving link or a load that
/// is not a real body; std::runtime_error if the text written does not read back as the
/// description plus phi on the tip link.
std::string urdf_with_payload(const RobotDescription& robot, const sid::LinkParameters<double>& phi,
                              const std::string& frame = {});

/// @brief sid_identify --robot ... --payload-of ARM.json RUN...: reads the arm and the runs,
/// prints the report, writes --json and --write-urdf.
/// @param payload_frame --payload-frame: the link whose frame the load is reported in (empty:
///        the --tip link).
/// @return the exit code; bad input throws InputError.
int identify_payload_robot(const ChainIdentifyAppOptions& options, const std::string& payload_of,
                           const std::string& payload_frame, const char* app_name);

}  // namespace sid::app
