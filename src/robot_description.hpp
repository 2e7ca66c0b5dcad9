#pragma once
/// @file
/// @brief Robot descriptions and transmissions read from files for the apps: a URDF or a DH
/// table gives the chain and its joint names, a YAML file or a URDF's <transmission> elements the
/// drives' gear ratios and coupling.

#include <sid/model/robot_description.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/transmission.hpp>
#include <sid/model/urdf.hpp>
#include <sid/trajectory.hpp>

#include "csv.hpp"

#include <map>
#include <string>
#include <vector>

namespace sid::app {

/// @brief Reads a URDF (a file whose first element is <robot>) or a DH table (see
/// docs/serial-arms.md). base and tip name the URDF links the chain runs between; empty: the
/// description's root, and its one leaf (an error naming the leaves when there are several).
/// @throws InputError naming the file and the problem.
/// @param held the values [rad or m] at which joints off the chain (branches, bodies past the
///        tip) are held, by joint name; the others are held at 0.
RobotDescription read_robot_description(const std::string& path, const std::string& base,
                                        const std::string& tip,
                                        const std::map<std::string, double>& held = {});

/// @brief The pose of `link` in the frame of the chain's last moving link (link_names.back()):
/// the fixed joints from that link out to it composed, the identity for the link itself. A load
/// fixed to the arm's end is identified in that link's frame and given, or reported, in a
/// flange's (tool0), which a vendor's data sheet uses.
/// @param option names the option in the messages (e.g. "--payload-frame").
/// @throws InputError for a DH table (its frames are the links'), a link the URDF does not have,
///         one that is not below the last moving link, or one with a moving joint between them.
sid::FramePose<double> fixed_link_pose(const RobotDescription& robot, const std::string& link,
                                       const std::string& option);

/// @brief The link whose frame a load fixed to the arm's end is given or reported in: `frame` if
/// given, else the URDF's tip link (robot.tip, a flange where vendors give a load's centre of
/// mass); "" for a DH table, whose load is in its last link's frame.
/// @throws InputError (naming `option`) for a frame given with a DH table.
std::string payload_frame_name(const RobotDescription& robot, const std::string& frame,
                               const std::string& option);

/// @brief Parses "joint=value,joint=value" (the held joints of --hold).
/// @throws InputError on a missing '=', an empty name, a value that is not a finite number or a
///         joint given twice; option names the option in the message.
std::map<std::string, double> parse_held_joints(const std::string& text, const std::string& option);

/// @brief Reads a transmission file (see docs/serial-arms.md): YAML with gear_ratios (one per
/// joint), optional couplings [{motor, joint, ratio}] with joints named or numbered from 1,
/// optional joint_zero [rad]; or XML (text starting with '<', or a .urdf or .xml file, e.g. the
/// robot's own URDF) whose ros_control / ros2_control <transmission> elements give them
/// (sid::transmission_from_urdf).
/// @throws InputError naming the file and the key or element.
sid::Transmission read_transmission(const std::string& path,
                                    const std::vector<std::string>& joint_names);

/// @brief The column names of a chain log: "t", "q1".."qn", "tau1".."taun" unless a map
/// "t=time,q1=pos_1,...,tau7=effort_7" (any subset, any order) renames some.
/// @throws InputError on a key that is not one of those, a key given twice, a missing '=' or an
///         empty name; option names the option in the message.
std::vector<std::string> chain_columns(const std::string& map, int joints,
                                       const std::string& option);

/// @brief A chain log from a table with the columns named by chain_columns (any order; other
/// columns ignored).
/// @throws InputError on a missing column or time that is not strictly increasing.
sid::ChainTrajectory<double> chain_trajectory_from_table(const CsvTable& table, int joints,
                                                         const std::vector<std::string>& names);

}  // namespace sid::app
