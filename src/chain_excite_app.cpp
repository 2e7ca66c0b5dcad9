#include "chain_excite_app.hpp"

#include <sid/excitation_design.hpp>
#include <sid/excite_robot.hpp>
#include <sid/model/chain_model.hpp>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iostream>
#include <limits>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

constexpr const char* kSeparateForm =
    "KIND_jN or KIND_mN (KIND coulomb, coulomb_asymmetry, offset, armature, spring, viscous or "
    "stribeck, stribeck_jN:VS for a width other than 0.1 rad/s) or angle_offset_qN, N from 1, "
    "as sid_diagnose --robot names them";

/// The 1-based number after `prefix` in `text` (digits only), or 0.
int number_after(const std::string& text, std::size_t prefix) {
  if (text.size() <= prefix || text.size() > prefix + 6) return 0;
  for (std::size_t i = prefix; i < text.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return 0;
  return std::stoi(text.substr(prefix));
}

std::vector<sid::ExcitationCandidate> parse_separate(const std::string& text, int joints,
                                                     const sid::Transmission& transmission) {
  std::vector<sid::ExcitationCandidate> out;
  const std::vector<std::string> ids =
      parse_name_list(text, "--separate", "candidate id", "candidate ids", kSeparateForm);
  const std::vector<int> motors = transmission.coupled_motors();
  const sid::DriveTermKind kinds[] = {
      sid::DriveTermKind::Viscous,          sid::DriveTermKind::Coulomb,
      sid::DriveTermKind::CoulombAsymmetry, sid::DriveTermKind::Offset,
      sid::DriveTermKind::Armature,         sid::DriveTermKind::Spring,
      sid::DriveTermKind::Stribeck};
  for (const std::string& given : ids) {
    sid::ExcitationCandidate c;
    const std::string bad = "--separate: '" + given + "' is not a candidate id: " + kSeparateForm;
    std::string id = given;
    double width = sid::DriveTerm{}.velocity;
    const std::size_t colon = given.find(':');
    if (colon != std::string::npos) {
      id = given.substr(0, colon);
      require(id.rfind("stribeck_", 0) == 0,
              "--separate: '" + given + "': only a Stribeck candidate takes a width (:VS)");
      const std::vector<double> v = parse_doubles(given.substr(colon + 1), "--separate " + id, 1);
      require(v[0] > 0.0, "--separate: '" + given + "': the width must be > 0 [rad/s]");
      width = v[0];
    }
    int number = 0;
    if (id.rfind("angle_offset_q", 0) == 0) {
      c.angle_offset = true;
      number = number_after(id, std::string("angle_offset_q").size());
      require(number >= 1, bad);
    } else {
      const std::size_t cut = id.find_last_of('_');
      require(cut != std::string::npos && cut + 1 < id.size(), bad);
      const std::string keyword = id.substr(0, cut);
      const char where = id[cut + 1];
      const auto kind = std::find_if(std::begin(kinds), std::end(kinds),
                                     [&](auto k) { return keyword == sid::drive_term_keyword(k); });
      number = number_after(id, cut + 2);
      require(kind != std::end(kinds) && (where == 'j' || where == 'm') && number >= 1, bad);
      c.term = {*kind, number - 1, where == 'm', width};
    }
    c.term.index = number - 1;
    c.id = colon == std::string::npos ? id : given;
    if (c.term.on_motor) {
      std::string list;
      for (const int m : motors) list += (list.empty() ? "" : ", ") + std::to_string(m + 1);
      require(std::find(motors.begin(), motors.end(), c.term.index) != motors.end(),
              "--separate: '" + given + "': motor " + std::to_string(number) +
                  " is not one the transmission couples to several joints (" +
                  (list.empty() ? "none is" : "coupled: " + list) + ")");
      require(
          c.term.kind != sid::DriveTermKind::Offset,
          "--separate: '" + given + "': a motor has no offset of its own (its joints' hold it)");
    } else {
      require(number <= joints,
              "--separate: '" + given + "': the chain has " + std::to_string(joints) + " joints");
    }
    for (const sid::ExcitationCandidate& other : out)
      require(other.id != c.id, "--separate: '" + given + "' is given twice");
    out.push_back(c);
  }
  return out;
}

std::string use_text(const sid::ExcitationUse& use) {
  return "largest share of the limits: q " + number("%.3f", use.q.maxCoeff()) + ", qd " +
         number("%.3f", use.qd.maxCoeff()) + ", qdd " + number("%.3f", use.qdd.maxCoeff()) +
         ", tau " + number("%.3f", use.tau.maxCoeff());
}

std::string shares_text(const std::vector<sid::ExcitationCandidate>& separate,
                        const Eigen::VectorXd& shares) {
  std::string text;
  for (std::size_t i = 0; i < separate.size(); ++i)
    text += (text.empty() ? "" : ", ") + separate[i].id + " " +
            number("%.3g", shares[static_cast<Eigen::Index>(i)]);
  return text;
}

/// What sid_excite prints: the problem, the random start, the design, and whether the
/// candidates are told apart.
std::string excitation_report(const ChainExciteOptions& o, const sid::RobotExcitation& e,
                              const std::vector<sid::ExcitationCandidate>& separate, int samples) {
  const std::size_t offsets = e.angle_offsets.size();
  std::ostringstream out;
  out << "robot " << o.robot << ": " << e.model.joints() << " joints, " << e.columns.size()
      << " base parameters of " << e.model.parameters()
      << (offsets == 0 ? std::string()
                       : " and " + std::to_string(offsets) + " angle-offset column" +
                             (offsets > 1 ? "s" : ""))
      << "; " << o.harmonics << " harmonics of " << shortest_number(o.base_frequency) << " Hz, "
      << samples << " grid points per period\n"
      << "random excitation (seed " << o.seed << "): condition number "
      << number("%.4g", e.random.condition_number) << "; " << use_text(e.random.use) << "\n";
  const std::string shares_line = "  1 - R^2 of each --separate column given all the others: ";
  if (!separate.empty())
    out << shares_line << shares_text(separate, e.random.separate_shares) << "\n";
  if (!e.design) return out.str();
  const sid::ExcitationAssessment& designed = *e.designed;
  out << "designed excitation: condition number " << number("%.4g", designed.condition_number)
      << " (" << number("%.3g", e.random.condition_number / designed.condition_number)
      << " times smaller); exp(objective) " << number("%.4g", std::exp(e.design->objective))
      << " (random " << number("%.4g", std::exp(e.design->start_objective)) << "); "
      << use_text(designed.use) << "\n"
      << "  " << e.design->evaluations << " evaluations (" << o.algorithm << ", "
      << e.design->stop_reason << ") in " << number("%.3g", e.design_seconds) << " s\n";
  if (separate.empty()) return out.str();
  out << shares_line << shares_text(separate, designed.separate_shares) << "\n";
  std::string weak;
  for (std::size_t i = 0; i < separate.size(); ++i)
    if (designed.separate_shares[static_cast<Eigen::Index>(i)] < e.separable_share)
      weak += (weak.empty() ? "" : ", ") + separate[i].id;
  out << (weak.empty() ? "  each above " + number("%.3g", e.separable_share) +
                             ": sid_diagnose --robot can test them on a run of this excitation"
                       : "  still below " + number("%.3g", e.separable_share) + " (" + weak +
                             "): on a run of this excitation sid_diagnose --robot will likely "
                             "call them not separable; give the motion more room (a wider "
                             "--q-range, --qd-max, more --harmonics)")
      << "\n";
  return out.str();
}

/// The coefficients file's header: the chain, the trajectory's formula, where it came from and
/// the limits it keeps.
std::vector<std::string> excitation_comments(const ChainExciteOptions& o,
                                             const RobotDescription& robot,
                                             const sid::RobotExcitation& e, const char* app_name) {
  const std::string seed = std::to_string(o.seed);
  std::string origin = "the random excitation from seed " + seed + ", condition number " +
                       number("%.6g", e.random.condition_number);
  if (e.design) {
    origin = "designed from the random excitation of seed " + seed + ": condition number " +
             number("%.6g", e.designed->condition_number) + " (random " +
             number("%.6g", e.random.condition_number) + ")";
    if (!o.separate.empty()) origin += "; separating " + o.separate;
  }
  std::string joint_list;
  for (const auto& name : robot.joint_names) joint_list += (joint_list.empty() ? "" : ",") + name;
  return {std::string(app_name) + " --robot " + o.robot + ": " +
              std::to_string(robot.chain.joints()) + " joints (" + joint_list + ")" +
              (o.transmission.empty() ? "" : ", the coupled motors of " + o.transmission),
          "q_j(t) = q0_j + sum_l a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t), w = 2 pi f; "
          "at rest at t = k / f",
          origin,
          "limits: |q - q0| <= min(" + shortest_number(o.q_range) +
              ", 90 % of <limit>), |qd| <= min(" + shortest_number(o.qd_max) +
              ", 90 % of <limit>), |qdd| <= " + shortest_number(o.qdd_max) +
              ", |tau| <= " + shortest_number(o.torque_fraction) + " <limit effort>"};
}

}  // namespace

void write_fourier_trajectory(const std::string& path, const sid::FourierTrajectory& f,
                              const std::vector<std::string>& comments) {
  const int n = f.joints(), h = f.harmonics();
  std::vector<std::string> names{"joint", "base_frequency", "q0"};
  std::vector<Eigen::VectorXd> columns{Eigen::VectorXd::LinSpaced(n, 1.0, n),
                                       Eigen::VectorXd::Constant(n, f.base_frequency), f.q0};
  for (const char* stem : {"a", "b"})
    for (int l = 1; l <= h; ++l) {
      names.push_back(stem + std::to_string(l));
      columns.push_back(std::string(stem) == "a" ? f.a.col(l - 1) : f.b.col(l - 1));
    }
  write_csv(path, names, columns, comments);
}

sid::FourierTrajectory read_fourier_trajectory(const std::string& path, int joints) {
  const CsvTable table = read_csv(path);
  require(table.rows() == joints, table.source +
                                      ": a Fourier trajectory file has one row per "
                                      "joint; the chain has " +
                                      std::to_string(joints) + ", the file " +
                                      std::to_string(table.rows()));
  int h = 0;
  while (table.has("a" + std::to_string(h + 1)) && table.has("b" + std::to_string(h + 1))) ++h;
  require(h >= 1, table.source +
                      ": no columns a1 and b1 (expected joint,base_frequency,q0,"
                      "a1..aH,b1..bH as sid_excite writes)");
  require(!table.has("a" + std::to_string(h + 1)) && !table.has("b" + std::to_string(h + 1)),
          table.source + ": the columns a" + std::to_string(h + 1) + " and b" +
              std::to_string(h + 1) + " do not both exist");
  const Eigen::VectorXd& joint = table.column("joint");
  const Eigen::VectorXd& frequency = table.column("base_frequency");
  for (Eigen::Index r = 0; r < table.rows(); ++r) {
    require(joint[r] == static_cast<double>(r + 1),
            table.where(r) + ": joint must be " + std::to_string(r + 1) + " (rows in joint order)");
    require(frequency[r] == frequency[0] && frequency[r] > 0.0,
            table.where(r) + ": base_frequency must be > 0 and the same on every row");
  }
  sid::FourierTrajectory f;
  f.base_frequency = frequency[0];
  f.q0 = table.column("q0");
  f.a.resize(joints, h);
  f.b.resize(joints, h);
  for (int l = 1; l <= h; ++l) {
    f.a.col(l - 1) = table.column("a" + std::to_string(l));
    f.b.col(l - 1) = table.column("b" + std::to_string(l));
  }
  try {
    f.validate("Fourier trajectory");
  } catch (const std::invalid_argument& e) {
    throw InputError(table.source + ": " + e.what());
  }
  return f;
}

ChainExcitation design_robot_excitation(const ChainExciteOptions& o, const char* app_name) {
  require(o.harmonics >= 2 && o.harmonics <= 50,
          "--harmonics must be 2..50 (the first harmonic is spent on starting at rest)");
  const auto positive = [](double v, const std::string& option, const std::string& unit) {
    require(std::isfinite(v) && v > 0.0,
            option + " must be a finite number > 0" + unit + ", got " + shortest_number(v));
  };
  positive(o.base_frequency, "--base-frequency", " [Hz]");
  positive(o.q_range, "--q-range", "");
  positive(o.qd_max, "--qd-max", "");
  positive(o.qdd_max, "--qdd-max", "");
  positive(o.rate, "--rate", " [Hz]");
  require(std::isfinite(o.torque_fraction) && o.torque_fraction > 0.0 && o.torque_fraction <= 1.0,
          "--torque-fraction must be in (0, 1], got " + shortest_number(o.torque_fraction));
  require(o.max_evaluations >= 1 && o.max_evaluations <= 100000,
          "--max-evaluations must be 1..100000");
  require(o.algorithm == "slsqp" || o.algorithm == "mma",
          "--algorithm must be slsqp or mma, got '" + o.algorithm + "'");
  const double samples = std::round(o.rate / o.base_frequency);
  require(samples >= 8.0 * o.harmonics && samples <= 1e5,
          "--rate / --base-frequency = " + shortest_number(samples) +
              " grid points per period; needs 8 x --harmonics (" + std::to_string(8 * o.harmonics) +
              ") to 100000");

  const RobotDescription robot =
      read_robot_description(o.robot, o.base, o.tip, parse_held_joints(o.hold, "--hold"));
  require(robot.link_parameters.size() > 0,
          o.robot + ": a DH table has no link inertias to compute torques with; give a URDF");
  const int n = robot.chain.joints();
  // The model sid_identify --robot fits to the arm's log (with the transmission's coupled motors);
  // torques from the description's links and <dynamics> damping and friction.
  const sid::Transmission transmission = o.transmission.empty()
                                             ? sid::Transmission(n)
                                             : read_transmission(o.transmission, robot.joint_names);
  const sid::ChainModel nominal(robot.chain, robot.joint_names,
                                sid::drive_terms(sid::default_drive_term_kinds(), transmission),
                                transmission);
  sid::RobotExcitationOptions options;
  if (!o.separate.empty()) options.separate = parse_separate(o.separate, n, transmission);
  options.design.harmonics = o.harmonics;
  options.design.base_frequency = o.base_frequency;
  options.design.samples = static_cast<int>(samples);
  options.design.max_evaluations = o.max_evaluations;
  options.design.algorithm =
      o.algorithm == "mma" ? sid::ExcitationAlgorithm::Mma : sid::ExcitationAlgorithm::Slsqp;
  options.seed = o.seed;
  options.random_only = o.random_only;

  const ExcitationRoom room = excitation_room(robot, o.robot, o.q_range, o.qd_max);
  sid::ExcitationLimits limits{
      room.q_range, room.qd_max, Eigen::VectorXd::Constant(n, o.qdd_max),
      Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity())};
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const double effort = robot.limits[static_cast<std::size_t>(j)].effort;
    if (std::isfinite(effort) && effort > 0.0) limits.tau_max[j] = o.torque_fraction * effort;
  }
  const sid::RobotExcitation e = [&] {
    try {
      return sid::excite_robot(nominal, description_dynamics(robot), room.q0, limits, options);
    } catch (const sid::InseparableCandidate& error) {
      throw InputError(std::string("--separate: ") + error.what());
    } catch (const std::invalid_argument& error) {
      throw InputError(o.robot + ": " + error.what());
    }
  }();
  ChainExcitation result;
  result.trajectory = e.chosen().trajectory;
  result.condition_number = e.chosen().condition_number;
  result.random_condition_number = e.random.condition_number;
  result.report = excitation_report(o, e, options.separate, options.design.samples);
  result.comments = excitation_comments(o, robot, e, app_name);
  return result;
}

int excite_robot(const ChainExciteOptions& o, const char* app_name) {
  if (!o.output.empty()) ensure_writable(o.output, o.force);
  const ChainExcitation e = design_robot_excitation(o, app_name);
  // The report goes where the coefficients do not.
  (o.output == "-" ? std::cerr : std::cout) << e.report << std::flush;
  if (!o.output.empty()) {
    write_fourier_trajectory(o.output, e.trajectory, e.comments);
    if (o.output != "-") std::cerr << app_name << ": coefficients written to " << o.output << "\n";
  }
  return kExitOk;
}

}  // namespace sid::app
