#include "chain_excite_app.hpp"

#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

std::string use_text(const sid::ExcitationUse& use) {
  return "largest share of the limits: q " + number("%.3f", use.q.maxCoeff()) + ", qd " +
         number("%.3f", use.qd.maxCoeff()) + ", qdd " + number("%.3f", use.qdd.maxCoeff()) +
         ", tau " + number("%.3f", use.tau.maxCoeff());
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

int excite_robot(const ChainExciteOptions& o, const char* app_name) {
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
  if (!o.output.empty()) ensure_writable(o.output, o.force);

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
  const sid::ChainModel model(robot.chain, robot.joint_names,
                              sid::drive_terms(sid::default_drive_term_kinds(), transmission),
                              transmission);
  const Eigen::VectorXd theta = description_prior(robot, model);
  const std::vector<Eigen::Index> columns = sid::chain_base_parameters(model).independent;

  const ExcitationRoom room = excitation_room(robot, o.robot, o.q_range, o.qd_max);
  sid::ExcitationLimits limits{
      room.q_range, room.qd_max, Eigen::VectorXd::Constant(n, o.qdd_max),
      Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity())};
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const double effort = robot.limits[static_cast<std::size_t>(j)].effort;
    if (std::isfinite(effort) && effort > 0.0) limits.tau_max[j] = o.torque_fraction * effort;
  }
  sid::ExcitationDesignOptions options;
  options.harmonics = o.harmonics;
  options.base_frequency = o.base_frequency;
  options.samples = static_cast<int>(samples);
  options.max_evaluations = o.max_evaluations;
  options.algorithm =
      o.algorithm == "mma" ? sid::ExcitationAlgorithm::Mma : sid::ExcitationAlgorithm::Slsqp;
  const Eigen::VectorXd grid = sid::excitation_grid(o.base_frequency, options.samples);
  const int check_samples = 4 * options.samples;  // between the design's grid points too

  const auto started = std::chrono::steady_clock::now();
  std::mt19937_64 rng(o.seed);
  sid::FourierTrajectory random;
  try {
    random = sid::random_excitation(model, theta, room.q0, limits, options, rng);
  } catch (const std::invalid_argument& e) {
    throw InputError(o.robot + ": " + e.what());
  }
  const double random_cond =
      sid::scaled_condition_number(sid::excitation_regressor(model, columns, random, grid));
  // The report goes where the coefficients do not.
  std::ostream& out = o.output == "-" ? std::cerr : std::cout;
  out << "robot " << o.robot << ": " << n << " joints, " << columns.size() << " base parameters of "
      << model.parameters() << "; " << o.harmonics << " harmonics of "
      << shortest_number(o.base_frequency) << " Hz, " << options.samples
      << " grid points per period\n"
      << "random excitation (seed " << o.seed << "): condition number "
      << number("%.4g", random_cond) << "; "
      << use_text(sid::excitation_use(model, theta, random, limits, check_samples)) << "\n";
  sid::FourierTrajectory result = random;
  std::string comment = "the random excitation from seed " + std::to_string(o.seed) +
                        ", condition number " + number("%.6g", random_cond);
  if (!o.random_only) {
    sid::ExcitationDesign design;
    try {
      design = sid::design_excitation(model, theta, columns, room.q0, limits, random, options);
    } catch (const std::invalid_argument& e) {
      throw InputError(o.robot + ": " + e.what());
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const double cond = sid::scaled_condition_number(
        sid::excitation_regressor(model, columns, design.trajectory, grid));
    result = design.trajectory;
    out << "designed excitation: condition number " << number("%.4g", cond) << " ("
        << number("%.3g", random_cond / cond) << " times smaller); exp(objective) "
        << number("%.4g", std::exp(design.objective)) << " (random "
        << number("%.4g", std::exp(design.start_objective)) << "); "
        << use_text(sid::excitation_use(model, theta, design.trajectory, limits, check_samples))
        << "\n"
        << "  " << design.evaluations << " evaluations (" << o.algorithm << ", "
        << design.stop_reason << ") in " << number("%.3g", seconds) << " s\n";
    comment = "designed from the random excitation of seed " + std::to_string(o.seed) +
              ": condition number " + number("%.6g", cond) + " (random " +
              number("%.6g", random_cond) + ")";
  }
  std::string joint_list;
  for (const auto& name : robot.joint_names) joint_list += (joint_list.empty() ? "" : ",") + name;
  if (!o.output.empty()) {
    write_fourier_trajectory(
        o.output, result,
        {std::string(app_name) + " --robot " + o.robot + ": " + std::to_string(n) + " joints (" +
             joint_list + ")" +
             (o.transmission.empty() ? "" : ", the coupled motors of " + o.transmission),
         "q_j(t) = q0_j + sum_l a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t), w = 2 pi f; "
         "at rest at t = k / f",
         comment,
         "limits: |q - q0| <= min(" + shortest_number(o.q_range) +
             ", 90 % of <limit>), |qd| <= min(" + shortest_number(o.qd_max) +
             ", 90 % of <limit>), |qdd| <= " + shortest_number(o.qdd_max) +
             ", |tau| <= " + shortest_number(o.torque_fraction) + " <limit effort>"});
    if (o.output != "-") std::cerr << app_name << ": coefficients written to " << o.output << "\n";
  }
  return kExitOk;
}

}  // namespace sid::app
