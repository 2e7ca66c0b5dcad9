#pragma once
// Simulated arms with drive terms hidden from their nominal models, for the chain diagnosis's
// tests and bench. The TX40 (its URDF): rigid bodies, viscous friction 0.5 and a rotor of 0.01 on
// every joint, plus what is hidden; 10 s (by default) at 500 Hz of a random Fourier excitation
// within ±1.2 rad of zero (joint 2: by default), σq = 1e-4 rad, σ_τ = 0.1 N m. A UR5 and a Panda
// (their public URDFs) as a user would log them: viscous friction only, 20 s at 500 Hz of a
// five-harmonic Fourier excitation (base 0.1 Hz), σq = 1e-4 rad, σ_τ 1 % of each joint's RMS.
// Three arms the diagnosis was never tuned on (a Kinova Jaco 2, a Baxter's left arm and a Unitree
// G1's left arm, from their public URDFs) as a real arm logs: 1 kHz, the angles quantised by a
// 16-bit encoder (no other angle noise), σ_τ 2 % of each joint's RMS.

#include <sid/cvode/chain_experiment.hpp>
#include <sid/fourier_trajectory.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/urdf.hpp>

#include <cmath>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid_test {

inline sid::UrdfChain urdf_arm(const std::string& file, const std::string& base,
                               const std::string& tip) {
  std::ifstream in(std::string(SID_TEST_DATA_DIR) + "/" + file);
  if (!in) throw std::runtime_error("cannot read " + file);
  std::stringstream text;
  text << in.rdbuf();
  return sid::chain_from_urdf(text.str(), base, tip);
}

/// An arm of the hidden-term suite: its description, the true drives (on every joint), the
/// excitation's centre and reach, and the measurement noise.
struct SuiteArm {
  std::string name;
  sid::UrdfChain arm;
  Eigen::VectorXd viscous, rotor;
  Eigen::VectorXd center, range;
  double qd_max = 2.0;
  double duration = 10.0;
  double torque_noise = 0.1;  ///< σ_τ [N m], or with relative_noise each joint's share of its RMS
  bool relative_noise = false;
  double sample_time = 0.002;  ///< [s]
  /// > 0: the measured angles are the true ones rounded to this step [rad] (an encoder's
  /// resolution), with no other angle noise; 0: σq = 1e-4 rad of white noise.
  double angle_step = 0.0;

  int joints() const { return arm.chain.joints(); }
};

inline const sid::UrdfChain& tx40_arm() {
  static const sid::UrdfChain arm =
      urdf_arm("staubli_tx40/tx40_mdh_modified.urdf", "base_link", "tool0");
  return arm;
}

/// joint2_range: the excitation's reach on joint 2 [rad]; over ±1.2 rad a spring there is not
/// separable from gravity, over ±2 rad it is.
inline SuiteArm tx40_suite_arm(double duration = 10.0, double joint2_range = 1.2) {
  SuiteArm a{"TX40",
             tx40_arm(),
             Eigen::VectorXd::Constant(6, 0.5),
             Eigen::VectorXd::Constant(6, 0.01),
             Eigen::VectorXd::Zero(6),
             Eigen::VectorXd::Constant(6, 1.2)};
  a.range[1] = joint2_range;
  a.duration = duration;
  return a;
}

inline SuiteArm ur5_suite_arm() {
  SuiteArm a{"UR5",
             urdf_arm("urdf/real/ur5_robot.urdf", "base_link", "tool0"),
             Eigen::VectorXd::Constant(6, 0.5),
             Eigen::VectorXd::Zero(6),
             Eigen::VectorXd::Zero(6),
             Eigen::VectorXd::Constant(6, 1.2)};
  a.duration = 20.0;
  a.torque_noise = 0.01;
  a.relative_noise = true;
  return a;
}

/// Seven joints, centred within the joint limits of its URDF.
inline SuiteArm panda_suite_arm() {
  Eigen::VectorXd center(7), range(7);
  center << 0.0, 0.0, 0.0, -1.57, 0.0, 1.87, 0.0;
  range << 1.2, 1.0, 1.2, 1.2, 1.2, 1.2, 1.2;
  SuiteArm a{"Panda",
             urdf_arm("urdf/real/panda.urdf", "panda_link0", "panda_link8"),
             Eigen::VectorXd::Constant(7, 0.5),
             Eigen::VectorXd::Zero(7),
             center,
             range};
  a.duration = 20.0;
  a.torque_noise = 0.01;
  a.relative_noise = true;
  return a;
}

/// An arm logged as a real one: 20 s at 1 kHz, angles from a 16-bit encoder, σ_τ 2 % of each
/// joint's RMS, viscous friction 0.5 (a tenth of it on a light arm), no rotor.
inline SuiteArm real_logged_arm(std::string name, sid::UrdfChain arm, Eigen::VectorXd center,
                                Eigen::VectorXd range, double viscous = 0.5) {
  const auto n = static_cast<Eigen::Index>(center.size());
  SuiteArm a{std::move(name),          std::move(arm),    Eigen::VectorXd::Constant(n, viscous),
             Eigen::VectorXd::Zero(n), std::move(center), std::move(range)};
  a.duration = 20.0;
  a.torque_noise = 0.02;
  a.relative_noise = true;
  a.sample_time = 0.001;
  a.angle_step = 2.0 * 3.14159265358979323846 / 65536.0;
  return a;
}

/// A Kinova Jaco 2 (six joints), centred within its joint limits.
inline SuiteArm kinova_suite_arm() {
  Eigen::VectorXd center(6), range(6);
  center << 0.0, 3.14, 3.14, 0.0, 3.14, 0.0;
  range << 1.2, 1.0, 1.2, 1.2, 1.2, 1.2;
  return real_logged_arm("Kinova Jaco 2",
                         urdf_arm("urdf/real/kinova.urdf", "base", "j2s6s200_end_effector"), center,
                         range);
}

/// A Baxter's left arm (seven joints) to its hand, centred within its joint limits.
inline SuiteArm baxter_suite_arm() {
  Eigen::VectorXd center(7), range(7);
  center << 0.0, -0.55, 0.0, 1.28, 0.0, 0.26, 0.0;
  range << 1.2, 1.0, 1.2, 1.0, 1.2, 1.2, 1.2;
  return real_logged_arm("Baxter left arm",
                         urdf_arm("urdf/real/baxter.urdf", "left_arm_mount", "left_hand_link"),
                         center, range);
}

/// A Unitree G1's left arm (seven joints, 2 kg in all) from its torso: a light arm.
inline SuiteArm g1_arm_suite_arm() {
  Eigen::VectorXd center(7), range(7);
  center << 0.0, 0.3, 0.0, 0.5, 0.0, 0.0, 0.0;
  range << 1.2, 1.0, 1.2, 1.0, 1.2, 1.2, 1.2;
  return real_logged_arm(
      "G1 left arm",
      urdf_arm("urdf/real/g1_29dof_rev_1_0.urdf", "torso_link", "left_wrist_yaw_link"), center,
      range, 0.05);
}

/// Viscous friction on every joint and a rotor on every joint but `without_rotor` (0-based; -1:
/// none left out): what a diagnosis starts from (sid_diagnose --robot's default terms).
inline sid::ChainModel suite_nominal(const SuiteArm& a, int without_rotor = -1) {
  const sid::Transmission direct(a.joints());
  std::vector<sid::DriveTerm> terms = sid::drive_terms({sid::DriveTermKind::Viscous}, direct);
  for (int j = 0; j < a.joints(); ++j)
    if (j != without_rotor) terms.push_back({sid::DriveTermKind::Armature, j, false});
  return sid::ChainModel(a.arm.chain, a.arm.joint_names, terms, direct, 0.05);
}

inline sid::ChainModel tx40_nominal(int without_rotor = -1) {
  return suite_nominal(tx40_suite_arm(), without_rotor);
}

/// A hidden drive term and its value; an armature is added to the joint's rotor. With
/// angle_offset, an offset of joint term.index's measured angle instead: measured q = q - value.
struct HiddenTerm {
  sid::DriveTerm term;
  double value = 0.0;
  bool angle_offset = false;
};

/// The noise-free experiment behind suite_run: the true arm, its parameters, the tracked run,
/// and the generator the measurement noise is drawn from next.
struct SuiteExperiment {
  sid::ChainModel truth;
  Eigen::VectorXd theta;
  sid::ChainExperimentResult run;
  Eigen::VectorXd angle_offset;  ///< per joint: measured q = q - angle_offset
  std::mt19937_64 rng;
};
using Tx40Experiment = SuiteExperiment;

inline SuiteExperiment suite_experiment(const SuiteArm& a, const std::vector<HiddenTerm>& hidden,
                                        unsigned seed) {
  const int n = a.joints();
  const sid::Transmission direct(n);
  std::vector<sid::DriveTerm> terms =
      sid::drive_terms({sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature}, direct);
  Eigen::VectorXd drives(2 * n);
  for (int j = 0; j < n; ++j) drives.segment<2>(2 * j) << a.viscous[j], a.rotor[j];
  std::vector<double> extra;
  Eigen::VectorXd angle_offset = Eigen::VectorXd::Zero(n);
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
  sid::ChainModel truth(a.arm.chain, a.arm.joint_names, terms, direct, 0.05);
  Eigen::VectorXd theta(truth.parameters());
  theta << a.arm.theta.head(10 * n), drives,
      Eigen::Map<const Eigen::VectorXd>(extra.data(), static_cast<Eigen::Index>(extra.size()));
  std::mt19937_64 rng(100 + seed);
  const sid::FourierTrajectory desired = sid::random_fourier_trajectory(
      a.center, 5, 0.1, a.range, Eigen::VectorXd::Constant(n, a.qd_max), rng);
  sid::ChainExperiment experiment;
  experiment.duration = a.duration;
  experiment.sample_time = a.sample_time;
  sid::ChainExperimentResult run =
      sid::simulate_chain_experiment(truth, theta, desired, experiment);
  if (!run.ok()) throw std::runtime_error("suite_experiment (" + a.name + "): " + run.message);
  return {std::move(truth), std::move(theta), std::move(run), std::move(angle_offset), rng};
}

/// The measured log: the true run with the angle offsets and the noise.
inline sid::ChainTrajectory<double> suite_run(const SuiteArm& a,
                                              const std::vector<HiddenTerm>& hidden,
                                              unsigned seed) {
  SuiteExperiment e = suite_experiment(a, hidden, seed);
  sid::ChainTrajectory<double> measured = e.run.trajectory();
  measured.q.rowwise() -= e.angle_offset.transpose();
  if (!a.relative_noise)
    return sid::add_measurement_noise(
        measured, sid::MeasurementNoise<double>{1e-8, a.torque_noise * a.torque_noise}, e.rng);
  const Eigen::RowVectorXd sigma =
      a.torque_noise *
      (measured.tau.colwise().squaredNorm() / static_cast<double>(measured.size())).cwiseSqrt();
  std::normal_distribution<double> normal(0.0, 1.0);
  for (Eigen::Index i = 0; i < measured.size(); ++i)
    for (int j = 0; j < a.joints(); ++j) {
      measured.q(i, j) = a.angle_step > 0.0
                             ? a.angle_step * std::round(measured.q(i, j) / a.angle_step)
                             : measured.q(i, j) + 1e-4 * normal(e.rng);
      measured.tau(i, j) += sigma[j] * normal(e.rng);
    }
  return measured;
}

inline Tx40Experiment tx40_hidden_term_experiment(const std::vector<HiddenTerm>& hidden,
                                                  unsigned seed, double duration = 10.0,
                                                  double joint2_range = 1.2) {
  return suite_experiment(tx40_suite_arm(duration, joint2_range), hidden, seed);
}

inline sid::ChainTrajectory<double> tx40_hidden_term_run(const std::vector<HiddenTerm>& hidden,
                                                         unsigned seed, double duration = 10.0,
                                                         double joint2_range = 1.2) {
  return suite_run(tx40_suite_arm(duration, joint2_range), hidden, seed);
}

}  // namespace sid_test
