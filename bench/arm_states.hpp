#pragma once
// Bench-only: what the dynamics benches share: a URDF's text and random joint states, one per
// column, drawn once and cycled so that no call sees the same angles twice.

#include <Eigen/Core>

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>

namespace sid_bench {

constexpr Eigen::Index kNumStates = 1024;

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

/// kNumStates states of `joints` values uniform in [-bound, bound], one per column (contiguous,
/// as a control loop's are).
inline Eigen::MatrixXd random_states(int joints, double bound, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-bound, bound);
  Eigen::MatrixXd m(joints, kNumStates);
  for (auto& v : m.reshaped()) v = u(rng);
  return m;
}

}  // namespace sid_bench
