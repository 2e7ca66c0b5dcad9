#pragma once
// Runs for the tests of the multi-run layer: the measured runs of a real arm in
// tests/data/dfki_double_pendulum, and synthetic runs of a known model on logged-like grids.

#include <sid/model/model.hpp>
#include <sid/trajectory.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid_test {

// A measured run (time, pos_meas1, pos_meas2, tau_meas1, tau_meas2, in that order).
inline sid::Trajectory<double> load_run(const std::string& id) {
  const std::string path =
      std::string(SID_TEST_DATA_DIR) + "/dfki_double_pendulum/trajectory_" + id + ".csv";
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open " + path);
  std::string line;
  std::getline(in, line);
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    std::stringstream cells(line);
    std::string cell;
    std::vector<double> row;
    while (std::getline(cells, cell, ',')) row.push_back(std::stod(cell));
    if (row.size() != 5) throw std::runtime_error(path + ": expected 5 columns");
    rows.push_back(row);
  }
  sid::Trajectory<double> run;
  const auto n = static_cast<Eigen::Index>(rows.size());
  run.t.resize(n);
  run.q.resize(n, 2);
  run.tau.resize(n, 2);
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& r = rows[static_cast<std::size_t>(i)];
    run.t[i] = r[0];
    run.q.row(i) << r[1], r[2];
    run.tau.row(i) << r[3], r[4];
  }
  return run;
}

// A run of `model` with parameters `theta` driven along a known smooth motion: τ from the
// model's inverse dynamics, so θ is known exactly; the grid is jittered like a logged one and
// the angles, with quantum > 0, rounded like an encoder's.
inline sid::Trajectory<double> synthetic_run(const sid::Model<double>& model,
                                             const Eigen::VectorXd& theta, double phase, int n,
                                             double period, unsigned seed, double quantum = 0.0) {
  sid::Trajectory<double> run;
  run.t.resize(n);
  run.q.resize(n, 2);
  run.tau.resize(n, 2);
  unsigned state = seed;
  double t = 0.0;
  for (int i = 0; i < n; ++i) {
    state = state * 1664525u + 1013904223u;
    t += period * (0.7 + 0.6 * (state >> 8) / 16777216.0);
    const double w1 = 5.0, w2 = 7.0;
    sid::Vector2<double> q(0.8 * std::sin(w1 * t + phase), 0.6 * std::cos(w2 * t + phase));
    const sid::Vector2<double> qd(0.8 * w1 * std::cos(w1 * t + phase),
                                  -0.6 * w2 * std::sin(w2 * t + phase));
    const sid::Vector2<double> qdd(-0.8 * w1 * w1 * std::sin(w1 * t + phase),
                                   -0.6 * w2 * w2 * std::cos(w2 * t + phase));
    run.tau.row(i) = model.inverse_dynamics(theta, q, qd, qdd).transpose();
    if (quantum > 0.0) q = (q / quantum).array().round().matrix() * quantum;
    run.t[i] = t;
    run.q.row(i) = q.transpose();
  }
  return run;
}

}  // namespace sid_test
