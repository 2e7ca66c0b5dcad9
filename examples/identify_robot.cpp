// What sid_identify --robot does, from C++ in one library call: a URDF and a joint-side log
// (CSV with columns t, q1..qn, tau1..taun) in, the base parameters with their HAC standard
// deviations and the physically consistent links out.
//   usage: identify_robot ROBOT.urdf BASE_LINK TIP_LINK LOG.csv
#include <sid/cvode/identify_robot.hpp>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The library does no I/O: a minimal reader of a log whose columns are t, q1..qn, tau1..taun.
sid::ChainTrajectory<double> read_log(const std::string& path, int joints) {
  std::istringstream lines(read_text(path));
  std::string line;
  std::getline(lines, line);  // the header
  std::vector<std::vector<double>> rows;
  while (std::getline(lines, line)) {
    std::vector<double> row;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) row.push_back(std::stod(cell));
    if (row.size() != std::size_t(1 + 2 * joints))
      throw std::runtime_error(path + ": a row without t, q1..q" + std::to_string(joints) +
                               ", tau1..tau" + std::to_string(joints));
    rows.push_back(row);
  }
  const auto n = static_cast<Eigen::Index>(rows.size());
  sid::ChainTrajectory<double> log;
  log.t.resize(n);
  log.q.resize(n, joints);
  log.tau.resize(n, joints);
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    log.t[k] = rows[i][0];
    for (int j = 0; j < joints; ++j) {
      log.q(k, j) = rows[i][std::size_t(1 + j)];
      log.tau(k, j) = rows[i][std::size_t(1 + joints + j)];
    }
  }
  return log;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 5) {
    std::cerr << "usage: identify_robot ROBOT.urdf BASE_LINK TIP_LINK LOG.csv\n";
    return 2;
  }
  try {
    const sid::UrdfChain arm = sid::chain_from_urdf(read_text(argv[1]), argv[2], argv[3]);
    const sid::Transmission joint_side(arm.chain.joints());
    // sid_identify's default model: viscous and Coulomb friction, armature and a torque offset.
    const sid::ChainModel model(arm.chain, arm.joint_names,
                                sid::drive_terms(sid::robot_drive_term_kinds(), joint_side),
                                joint_side);
    sid::RobotIdentifyOptions options;
    options.fit.threads = 0;                               // the cutoff search on every core
    options.description = sid::description_dynamics(arm);  // where the data say little
    const sid::RobotIdentification r =
        sid::identify_robot(model, {{argv[4], read_log(argv[4], model.joints())}}, {}, options);

    const sid::ChainIdentification& id = r.identification;
    for (Eigen::Index i = 0; i < id.fit.theta.size(); ++i)
      std::printf("%-40s %12.6g +- %.3g\n", id.parameter_names[std::size_t(i)].c_str(),
                  id.fit.theta[i], id.std_dev[i]);
    std::printf("residual %.2f %% of the torque; real bodies %.2f %%%s\n",
                100.0 * id.fitted.relative_residual, 100.0 * r.consistent.relative_residual,
                sid::consistent_links_problem(r).empty() ? "" : " (not a result)");
    for (const auto& w : r.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "identify_robot: " << e.what() << "\n";
    return 1;
  }
}
