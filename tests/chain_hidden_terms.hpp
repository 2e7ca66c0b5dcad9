#pragma once
// Data of a six-axis arm (the TX40's URDF) with drive terms hidden from its nominal model, for the
// chain diagnosis's tests and bench: rigid bodies, viscous friction 0.5 and a rotor of 0.01 on
// every joint, plus what is hidden; 10 s (by default) at 500 Hz of a random Fourier excitation
// within ±1.2 rad of zero (joint 2: by default), σq = 1e-4 rad, σ_τ = 0.1 N m.

#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/urdf.hpp>

#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid_test {

inline const sid::UrdfChain& tx40_arm() {
  static const sid::UrdfChain arm = [] {
    std::ifstream in(std::string(SID_TEST_DATA_DIR) + "/staubli_tx40/tx40_mdh_modified.urdf");
    std::stringstream text;
    text << in.rdbuf();
    return sid::chain_from_urdf(text.str(), "base_link", "tool0");
  }();
  return arm;
}

/// Viscous friction on every joint and a rotor on every joint but `without_rotor` (0-based; -1:
/// none left out): what a diagnosis starts from.
inline sid::ChainModel tx40_nominal(int without_rotor = -1) {
  const sid::Transmission direct(6);
  std::vector<sid::DriveTerm> terms = sid::drive_terms({sid::DriveTermKind::Viscous}, direct);
  for (int j = 0; j < 6; ++j)
    if (j != without_rotor) terms.push_back({sid::DriveTermKind::Armature, j, false});
  return sid::ChainModel(tx40_arm().chain, tx40_arm().joint_names, terms, direct, 0.05);
}

/// A hidden drive term and its value; an armature is added to the joint's rotor of 0.01. With
/// angle_offset, an offset of joint term.index's measured angle instead: measured q = q - value.
struct HiddenTerm {
  sid::DriveTerm term;
  double value = 0.0;
  bool angle_offset = false;
};

/// The noise-free experiment behind tx40_hidden_term_run: the true arm, its parameters, the
/// tracked run, and the generator the measurement noise is drawn from next.
struct Tx40Experiment {
  sid::ChainModel truth;
  Eigen::VectorXd theta;
  sid::ChainExperimentResult run;
  Eigen::VectorXd angle_offset;  ///< per joint: measured q = q - angle_offset
  std::mt19937_64 rng;
};

/// joint2_range: the excitation's reach on joint 2 [rad]; over ±1.2 rad a spring there is not
/// separable from gravity, over ±2 rad it is.
inline Tx40Experiment tx40_hidden_term_experiment(const std::vector<HiddenTerm>& hidden,
                                                  unsigned seed, double duration = 10.0,
                                                  double joint2_range = 1.2) {
  const sid::Transmission direct(6);
  std::vector<sid::DriveTerm> terms =
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature}, direct);
  Eigen::VectorXd drives(12);
  for (int j = 0; j < 6; ++j) drives.segment<2>(2 * j) << 0.5, 0.01;
  std::vector<double> extra;
  Eigen::VectorXd angle_offset = Eigen::VectorXd::Zero(6);
  for (const HiddenTerm& h : hidden) {
    if (h.angle_offset) {
      angle_offset[h.term.index] = h.value;
      continue;
    }
    if (h.term.kind == sid::DriveTermKind::Armature && !h.term.on_motor) {
      drives[2 * h.term.index + 1] += h.value;
      continue;
    }
    terms.push_back(h.term);
    extra.push_back(h.value);
  }
  sid::ChainModel truth(tx40_arm().chain, tx40_arm().joint_names, terms, direct, 0.05);
  Eigen::VectorXd theta(truth.parameters());
  theta << tx40_arm().theta.head(60), drives,
      Eigen::Map<const Eigen::VectorXd>(extra.data(), static_cast<Eigen::Index>(extra.size()));
  std::mt19937_64 rng(100 + seed);
  Eigen::VectorXd range = Eigen::VectorXd::Constant(6, 1.2);
  range[1] = joint2_range;
  const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
      Eigen::VectorXd::Zero(6), 5, 0.1, range, Eigen::VectorXd::Constant(6, 2.0), rng);
  sid::ChainExperiment experiment;
  experiment.duration = duration;
  experiment.sample_time = 0.002;
  sid::ChainExperimentResult run =
      sid::simulate_chain_experiment(truth, theta, desired, experiment);
  if (!run.ok()) throw std::runtime_error("tx40_hidden_term_experiment: " + run.message);
  return {std::move(truth), std::move(theta), std::move(run), std::move(angle_offset), rng};
}

inline sid::ChainTrajectory<double> tx40_hidden_term_run(const std::vector<HiddenTerm>& hidden,
                                                         unsigned seed, double duration = 10.0,
                                                         double joint2_range = 1.2) {
  Tx40Experiment e = tx40_hidden_term_experiment(hidden, seed, duration, joint2_range);
  sid::ChainTrajectory<double> measured = e.run.trajectory();
  measured.q.rowwise() -= e.angle_offset.transpose();
  return sid::add_measurement_noise(measured, sid::MeasurementNoise<double>{1e-8, 1e-2}, e.rng);
}

}  // namespace sid_test
