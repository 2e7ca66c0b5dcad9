// sid_simulate: simulate the paper's open-loop experiment on the two-link arm with CVODE and write
// the measured (noisy) joint angles and torques as CSV, optionally with the true signals. Effects
// the paper's model leaves out (friction, sensor offsets, ...) can be hidden in the data, so that
// a diagnosis can be tested against a known answer.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <system_error>
#include <iostream>
#include <random>
#include <sid/cvode/experiment.hpp>
#include <sid/measurement_noise.hpp>
#include <sid/model/effects.hpp>
#include <sid/model/two_link_arm.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "app.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"

namespace {

constexpr const char* kName = "sid_simulate";

constexpr const char* kDescription =
    "Simulate the open-loop experiment of the paper (two-link arm, u1 = 6 sin t, u2 = 4 cos t)\n"
    "and write the measured joint angles and torques (true values + Gaussian noise) as CSV.\n"
    "--excitation multisine changes the input; --effect hides a physical effect in the data.\n";

constexpr const char* kFooter = R"(
The arm: D(q) qdd + C(q, qd) qd + G(q) + diag(theta6, theta7) qd = tau, with
  D = [[th1 + th2 + 2 th3 cos q2, th2 + th3 cos q2], [th2 + th3 cos q2, th2]],
  G = [th4 g sin q1 + th5 g sin(q1 + q2), th5 g sin(q1 + q2)], g = 9.81 m/s^2;
q1 [rad] from the downward vertical, q2 [rad] relative to link 1. The input torque is
tau1 = 6 sin t, tau2 = 4 cos t [N m] (--excitation paper, the default) or
tau1 = 5 sin 1.3t + 2 sin 3.1t, tau2 = 3 cos 0.7t + 1.5 sin 2.3t [N m] (--excitation multisine);
the arm starts at rest at q = 0. Samples are taken at t_k = k Ts [s], k = 0 .. round(T / Ts)
(T = 10, Ts = 0.0025 give 4001 samples).

Parameters (default: the paper's, corrected as in docs/paper-reproduction.md):
  --theta t1,...,t7   theta1..theta3 [kg m^2], theta4, theta5 [kg m], theta6, theta7 [N m s/rad]
                      default 0.034015193438,0.003064135808,0.0045320492,0.13291456,
                              0.01694224,0.6189,0.6189
  --physical l1,lc1,lc2,m1,m2,I1,I2,mu1,mu2
                      link 1 length, centre-of-mass distances [m], masses [kg], inertias about
                      the centres of mass [kg m^2], viscous friction [N m s/rad]; converted by
                      theta1 = m1 lc1^2 + I1 + m2 l1^2, theta2 = m2 lc2^2 + I2, theta3 = m2 l1 lc2,
                      theta4 = m1 lc1 + m2 l1, theta5 = m2 lc2, theta6 = mu1, theta7 = mu2.
The mass matrix D(q) must be positive definite for every q (theta2 > 0 and
theta1 theta2 > theta3^2); other values are refused.

Noise (independent, zero mean, Gaussian, the same variance on both joints):
  --sigma-q2 V    variance of the angle noise [rad^2]      (default 1e-6; 0 = exact angles)
  --sigma-tau2 V  variance of the torque noise [(N m)^2]   (default 1e-2; 0 = exact torques)
  --seed N        seed of std::mt19937_64 (default 1). The same seed and options give the same
                  file, byte for byte (with this build's standard library). The seed is printed
                  to standard error and recorded in the file's comment lines.

Output (standard output unless --output), 17 significant digits, '#' comment lines first
(settings: seed, variances, theta, tolerances), then the header:
  t,q1,q2,tau1,tau2                         time [s], measured angles [rad], torques [N m]
  with --truth also q1_true,q2_true,qd1,qd2,qdd1,qdd2,tau1_true,tau2_true
                                            true angles [rad], velocities [rad/s],
                                            accelerations [rad/s^2] and torques [N m]
The file is what sid_identify reads.

Any chain (--robot FILE.urdf [--base LINK] [--tip LINK] [--hold JOINT=VALUE,...]): the URDF's
links and <dynamics> damping and friction, every joint tracking a random Fourier series
(--harmonics, --base-frequency; about the middle of the joint's <limit>, scaled so that
|q_j - q0_j| <= --q-range and |qd_j| <= --qd-max and within 90 % of the <limit>s, drawn
from --seed) under computed torque with a PD correction. Effects on a chain: viscous_jN:fv,
coulomb_jN:Fc (tanh, --coulomb-epsilon), stribeck_jN:Fc,Fs,vs (as for two joints),
armature_jN:Ia (a rotor; needed where a link has no inertia about its own axis), spring_jN:k
(k q), torque_offset_jN:b (a torque sensor bias) and angle_offset_qN:d (measured q = q - d).
--trajectory FILE tracks the Fourier series sid_excite wrote instead of the random one.
--torque FILE drives the arm open loop with the torque of a CSV (columns t, tau1..taun; linear
between its rows, which are the log's times) from rest at --q0 (default: the middle of each
<limit>); nothing holds it there, so the torque must (a warning names a joint that leaves its
<limit>). Output: t,q1..qn,tau1..taun (with --truth also q1_true.., qd1.., qdd1..,
tau1_true..), the log sid_identify --robot reads.

Exit codes: 0 success, 2 bad options or a failed simulation (message on standard error),
1 internal error.

Examples:
  sid_simulate -o run.csv
  sid_simulate --sigma-q2 1e-8 --seed 7 --truth -o run7.csv
  sid_simulate --effect coulomb_j2:0.1 --effect angle_offset_q1:0.05 --excitation multisine
  sid_simulate --effect stribeck_j1:0.1,0.3,0.2 --truth -o stribeck.csv
  sid_simulate --robot arm.urdf --effect coulomb_j3:0.4 --Ts 0.001 -o arm.csv
  sid_simulate --robot arm.urdf --torque torque.csv --q0 0,0.5,-0.3 -o driven.csv
  sid_simulate --sigma-q2 0 --sigma-tau2 0 --physical 0.2675,0.0398,0.0392,0.4347,0.4322,0.0024,0.0024,0.6189,0.6189
)";

struct Options {
  double T = 10.0;
  double Ts = 0.0025;
  double sigma_q2 = 1e-6;
  double sigma_tau2 = 1e-2;
  std::string seed = "1";
  std::string theta;
  std::string physical;
  std::string output = "-";
  bool force = false;
  bool truth = false;
  bool quiet = false;
  std::vector<std::string> effects;
  std::string excitation = "paper";
  double coulomb_epsilon = 0.01;
  double rtol = 1e-10;
  double atol = 1e-10;
  // --robot: any chain of a URDF under a random Fourier excitation
  std::string robot, base, tip, hold;
  int harmonics = 5;
  double base_frequency = 0.1;
  double q_range = 1.0;
  double qd_max = 1.5;
  std::string trajectory;
  std::string torque, q0;
  std::vector<std::string> pushes;
  double push_ramp = 0.02;
  std::string push_point;
  std::string encoder_bits, encoder_ratio;
  double torque_delay = 0.0;
};

// The effect list of --help, written from the library so that it cannot fall out of step.
std::string effects_help() {
  std::string text = R"(
Effects (--effect ID:VALUES, repeatable, each ID at most once). Each is a torque added to the left
side of the equation above, or a fault of a sensor:
  coulomb_jX        Fc tanh(qd_j / eps): Coulomb friction; Fc > 0 [N m]; eps = --coulomb-epsilon
                    (default 0.01 rad/s: 99.5 % of Fc at |qd| = 3 eps)
  stribeck_jX       (Fc + (Fs - Fc) exp(-(qd_j / vs)^2)) tanh(qd_j / eps): VALUES Fc,Fs,vs with
                    0 < Fc < Fs [N m] and vs > 0 [rad/s], e.g. stribeck_j1:0.1,0.3,0.2
  torque_offset_jX  sensor bias b [N m], any sign: measured tau_j = applied tau_j + b
                    (looks exactly like a constant load torque)
  angle_offset_qX   sensor offset delta [rad], |delta| < pi/2: true q_j = measured q_j + delta,
                    i.e. measured q_j = true q_j - delta (on q1 it looks exactly like a base tilt)
  armature_jX       rotor inertia Ia > 0 [kg m^2] added to D_jj (on joint 1 it is theta1's own
                    term, so it cannot be told apart from a larger theta1)
  spring_jX         k q_j, joint stiffness k > 0 [N m/rad]
X is 1 or 2. Every id with its values:
)";
  for (const sid::Effect effect : sid::all_effects()) {
    const auto names = sid::effect_value_names(effect);
    const auto units = sid::effect_value_units(effect);
    std::string values;
    for (std::size_t i = 0; i < names.size(); ++i)
      values += (i ? "," : "") + names[i] + " [" + units[i] + "]";
    std::string line = "  " + effect.id() + ":" + values;
    line.resize(std::max<std::size_t>(line.size() + 2, 44), ' ');
    const std::string name = sid::effect_name(effect);
    text += line.size() + name.size() <= 100 ? line + name + "\n" : line + "\n      " + name + "\n";
  }
  text += "--truth writes the true angles and the applied torques, without the sensor offsets.\n";
  return text;
}

void define_options(CLI::App& cli, Options& o) {
  cli.footer(std::string(kFooter) + effects_help());
  cli.add_option("--T", o.T, "duration of the experiment T [s], > Ts")->capture_default_str();
  cli.add_option("--Ts", o.Ts, "sampling period Ts [s], > 0")->capture_default_str();
  cli.add_option("--sigma-q2", o.sigma_q2, "variance of the angle noise [rad^2], >= 0")
      ->capture_default_str();
  cli.add_option("--sigma-tau2", o.sigma_tau2, "variance of the torque noise [(N m)^2], >= 0")
      ->capture_default_str();
  cli.add_option("--seed", o.seed,
                 "seed of the noise generator (std::mt19937_64), an integer 0 .. 2^64 - 1")
      ->capture_default_str();
  auto* theta = cli.add_option("--theta", o.theta,
                               "the 7 base parameters theta1..theta7, comma-separated "
                               "(default: the paper's)");
  auto* physical = cli.add_option("--physical", o.physical,
                                  "physical parameters l1,lc1,lc2,m1,m2,I1,I2,mu1,mu2 "
                                  "(instead of --theta)");
  theta->excludes(physical);
  cli.add_option("--effect", o.effects,
                 "hide an effect, ID:VALUES e.g. coulomb_j2:0.1 (repeatable; ids below)");
  cli.add_option("--excitation", o.excitation,
                 "input torque: paper (6 sin t, 4 cos t) or multisine [N m]")
      ->capture_default_str();
  cli.add_option("--coulomb-epsilon", o.coulomb_epsilon,
                 "eps of tanh(qd / eps) in Coulomb and Stribeck friction [rad/s], > 0")
      ->capture_default_str();
  cli.add_flag("--truth", o.truth,
               "also write the true q, qd, qdd and tau (columns q1_true, ..., tau2_true)");
  cli.add_option("-o,--output", o.output, "output CSV file ('-' is standard output)")
      ->capture_default_str();
  cli.add_flag("--force", o.force, "overwrite the output file if it exists");
  cli.add_flag("-q,--quiet", o.quiet, "do not print the seed and summary to standard error");
  cli.add_option("--rtol", o.rtol, "CVODE relative tolerance, > 0")->capture_default_str();
  cli.add_option("--atol", o.atol, "CVODE absolute tolerance [rad, rad/s], > 0")
      ->capture_default_str();
  auto* robot = cli.add_option("--robot", o.robot,
                               "simulate the chain of this URDF instead (see 'Any chain' below)")
                    ->check(CLI::ExistingFile);
  robot->excludes(theta)->excludes(physical);
  cli.add_option("--base", o.base, "--robot: the chain's first link (default: the root)");
  cli.add_option("--tip", o.tip, "--robot: the chain's last link (default: the one end link)");
  cli.add_option("--hold", o.hold, "--robot: JOINT=VALUE,... for joints off the chain");
  cli.add_option("--harmonics", o.harmonics, "--robot: harmonics of the Fourier excitation")
      ->capture_default_str();
  cli.add_option("--base-frequency", o.base_frequency,
                 "--robot: the excitation's base frequency [Hz] (its period is 1 / f)")
      ->capture_default_str();
  cli.add_option("--q-range", o.q_range,
                 "--robot: largest |q_j - q0_j| [rad or m], q0 the middle of its <limit>")
      ->capture_default_str();
  cli.add_option("--qd-max", o.qd_max, "--robot: largest |qd_j| [rad/s or m/s]")
      ->capture_default_str();
  cli.add_option("--trajectory", o.trajectory,
                 "--robot: track this Fourier trajectory (sid_excite -o) instead of a random one")
      ->check(CLI::ExistingFile);
  auto* torque = cli.add_option("--torque", o.torque,
                                "--robot: drive the arm open loop with this CSV's torque "
                                "(t,tau1..taun) instead of tracking an excitation")
                     ->check(CLI::ExistingFile);
  cli.add_option("--q0", o.q0,
                 "--robot --torque: the angles to start from at rest, comma-separated "
                 "(default: the middle of each joint's <limit>)");
  torque->excludes("--trajectory");
  cli.add_option("--push", o.pushes,
                 "--robot: START,END,FX,FY,FZ [s, N]: the outside pushes at the tool with this "
                 "force (base frame) from START to END; repeat for several pushes. The log's "
                 "torque is the drives' only (sid_external finds the push); --truth adds "
                 "tau1_ext..")
      ->excludes("--torque");
  cli.add_option("--push-ramp", o.push_ramp,
                 "--robot --push: the time a push takes to come and go [s] (default 0.02)");
  cli.add_option("--push-point", o.push_point,
                 "--robot --push: X,Y,Z [m]: where on the tip link the push acts, in its frame "
                 "(default its origin)");
  cli.add_option("--encoder-bits", o.encoder_bits,
                 "--robot: B or B1,...,Bn: the encoders' bits per turn; the logged angles are "
                 "rounded to 2 pi / (2^B R) (12 bits on the joint: 1.5e-3 rad, a hobby servo's)");
  cli.add_option("--encoder-ratio", o.encoder_ratio,
                 "--robot --encoder-bits: R or R1,...,Rn: turns of each encoder per turn of its "
                 "joint (the gear ratio of an encoder on the motor; default 1)");
  cli.add_option("--torque-delay", o.torque_delay,
                 "--robot: D [s]: the torque channel lags the angles by D (the torque logged at "
                 "t is the drives' at t - D; negative: the angles lag)");
}

std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

// Exact (shortest round-trip text) for the file's comments, short (6 digits) for messages.
std::string join_numbers(const Eigen::VectorXd& v, bool exact = false) {
  std::string out;
  for (Eigen::Index i = 0; i < v.size(); ++i)
    out += (i ? "," : "") + (exact ? sid::app::shortest_number(v[i]) : short_number(v[i]));
  return out;
}

// CVODE's messages end with a period; ours continue after them.
std::string without_final_period(std::string text) {
  while (!text.empty() && (text.back() == '.' || text.back() == ' ' || text.back() == '\n'))
    text.pop_back();
  return text;
}

sid::TwoLinkParameters<double> choose_theta(const Options& o) {
  using sid::app::require;
  if (!o.theta.empty()) {
    const std::vector<double> v = sid::app::parse_doubles(o.theta, "--theta", 7);
    return Eigen::Map<const sid::TwoLinkParameters<double>>(v.data());
  }
  if (!o.physical.empty()) {
    const std::vector<double> v = sid::app::parse_doubles(o.physical, "--physical", 9);
    const char* names[] = {"l1", "lc1", "lc2", "m1", "m2", "I1", "I2", "mu1", "mu2"};
    for (int k : {0, 3, 4})
      require(v[static_cast<std::size_t>(k)] > 0.0,
              std::string("--physical: ") + names[k] + " must be > 0, got " +
                  short_number(v[static_cast<std::size_t>(k)]));
    for (int k : {5, 6})
      require(v[static_cast<std::size_t>(k)] >= 0.0,
              std::string("--physical: ") + names[k] + " must be >= 0, got " +
                  short_number(v[static_cast<std::size_t>(k)]));
    const sid::TwoLinkPhysical<double> p{v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8]};
    return sid::two_link_parameters(p);
  }
  return sid::paper_arm_parameters();
}

void check_options(const Options& o) {
  using sid::app::require;
  require(std::isfinite(o.Ts) && o.Ts > 0.0,
          "--Ts must be a finite number > 0 [s], got " + short_number(o.Ts));
  require(std::isfinite(o.T) && o.T > o.Ts, "--T must be a finite number greater than --Ts (" +
                                                short_number(o.Ts) + " s), got " +
                                                short_number(o.T));
  require(o.T / o.Ts <= 1e8,
          "--T / --Ts = " + short_number(o.T / o.Ts) + " samples is too many (at most 1e8)");
  require(std::isfinite(o.sigma_q2) && o.sigma_q2 >= 0.0,
          "--sigma-q2 must be a finite variance >= 0 [rad^2], got " + short_number(o.sigma_q2));
  require(
      std::isfinite(o.sigma_tau2) && o.sigma_tau2 >= 0.0,
      "--sigma-tau2 must be a finite variance >= 0 [(N m)^2], got " + short_number(o.sigma_tau2));
  require(std::isfinite(o.rtol) && o.rtol > 0.0,
          "--rtol must be a finite number > 0, got " + short_number(o.rtol));
  require(std::isfinite(o.atol) && o.atol > 0.0,
          "--atol must be a finite number > 0, got " + short_number(o.atol));
  require(o.excitation == "paper" || o.excitation == "multisine",
          "--excitation must be paper or multisine, got '" + o.excitation + "'");
  require(std::isfinite(o.coulomb_epsilon) && o.coulomb_epsilon > 0.0,
          "--coulomb-epsilon must be a finite number > 0 [rad/s], got " +
              short_number(o.coulomb_epsilon));
}

// The library's message without its "sid::parse_effect: " prefix, after the option's name.
std::vector<sid::EffectSpec> parse_effects(const std::vector<std::string>& texts) {
  std::vector<sid::EffectSpec> specs;
  for (const auto& text : texts) {
    try {
      specs.push_back(sid::parse_effect(text));
    } catch (const std::invalid_argument& e) {
      std::string message = e.what();
      const std::string prefix = "sid::parse_effect: ";
      if (message.rfind(prefix, 0) == 0) message.erase(0, prefix.size());
      throw sid::app::InputError("--effect '" + text + "': " + message);
    }
    for (std::size_t k = 0; k + 1 < specs.size(); ++k)
      sid::app::require(specs[k].effect != specs.back().effect,
                        "--effect " + specs.back().effect.id() + " is given more than once");
  }
  return specs;
}

// "coulomb_j2:0.1", exact enough to be read back by --effect.
std::string spec_text(const sid::EffectSpec& spec) {
  std::string text = spec.effect.id() + ":";
  for (std::size_t i = 0; i < spec.values.size(); ++i)
    text += (i ? "," : "") + sid::app::shortest_number(spec.values[i]);
  return text;
}

std::string spec_description(const sid::EffectSpec& spec) {
  const auto names = sid::effect_value_names(spec.effect);
  const auto units = sid::effect_value_units(spec.effect);
  std::string text = "effect " + spec.effect.id() + ": " + sid::effect_name(spec.effect);
  for (std::size_t i = 0; i < names.size(); ++i)
    text += (i ? ", " : "; ") + names[i] + " = " + sid::app::shortest_number(spec.values[i]) + " " +
            units[i];
  return text;
}

int simulate_robot(const Options& o) {
  sid::app::require(o.excitation == "paper",
                    "--excitation is the two-link arm's; with --robot the excitation is a "
                    "random Fourier series (--harmonics, --base-frequency, --q-range, --qd-max)");
  sid::app::ChainSimulateOptions c;
  c.robot = o.robot;
  c.base = o.base;
  c.tip = o.tip;
  c.hold = o.hold;
  c.duration = o.T;
  c.sample_time = o.Ts;
  c.sigma_q2 = o.sigma_q2;
  c.sigma_tau2 = o.sigma_tau2;
  c.seed = sid::app::parse_seed(o.seed);
  c.effects = o.effects;
  c.harmonics = o.harmonics;
  c.base_frequency = o.base_frequency;
  c.q_range = o.q_range;
  c.qd_max = o.qd_max;
  c.trajectory = o.trajectory;
  c.torque = o.torque;
  c.q0 = o.q0;
  c.pushes = o.pushes;
  c.push_ramp = o.push_ramp;
  c.push_point = o.push_point;
  c.encoder_bits = o.encoder_bits;
  c.encoder_ratio = o.encoder_ratio;
  c.torque_delay = o.torque_delay;
  c.coulomb_epsilon = o.coulomb_epsilon;
  c.rtol = o.rtol;
  c.atol = o.atol;
  c.truth = o.truth;
  c.output = o.output;
  sid::app::ensure_writable(o.output, o.force);
  const long samples = sid::app::simulate_robot(c);
  if (!o.quiet)
    std::cerr << kName << ": " << o.robot << ", seed " << c.seed << ", " << samples << " samples"
              << (o.output == "-" ? std::string() : " written to " + o.output) << "\n";
  return sid::app::kExitOk;
}

int simulate(const Options& o) {
  using sid::app::require;
  check_options(o);
  require(o.trajectory.empty() || !o.robot.empty(), "--trajectory needs --robot");
  require(o.torque.empty() || !o.robot.empty(), "--torque needs --robot");
  require(o.q0.empty() || !o.torque.empty(), "--q0 needs --torque (and --robot)");
  require((o.encoder_bits.empty() && o.encoder_ratio.empty() && o.torque_delay == 0.0) ||
              !o.robot.empty(),
          "--encoder-bits, --encoder-ratio and --torque-delay need --robot");
  if (!o.robot.empty()) return simulate_robot(o);
  const std::uint64_t seed = sid::app::parse_seed(o.seed);
  const std::vector<sid::EffectSpec> effects = parse_effects(o.effects);
  const sid::TwoLinkParameters<double> theta = choose_theta(o);
  const std::string source = !o.physical.empty() ? "--physical" : "--theta";
  require(sid::two_link_mass_matrix_positive_definite(theta),
          source +
              ": the mass matrix D(q) is not positive definite for every q (needs theta2 > 0 "
              "and theta1 theta2 > theta3^2; theta = " +
              join_numbers(theta) + ")");
  sid::app::ensure_writable(o.output, o.force);

  sid::ArmExperiment experiment;
  experiment.duration = o.T;
  experiment.sample_time = o.Ts;
  experiment.simulator.rtol = o.rtol;
  experiment.simulator.atol = o.atol;
  sid::EffectSettings settings;
  settings.coulomb_epsilon = o.coulomb_epsilon;
  const sid::EffectfulArm arm = sid::effectful_arm(theta, effects, settings);
  // Without dynamic effects the closed form is both faster and the reference the existing files
  // were made with, so their bytes do not change; effects go through the generic model.
  const bool closed_form = arm.model.num_parameters() == 7;
  auto closed_fd = [&theta](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                            const sid::Vector2<double>& tau) {
    return sid::two_link_forward_dynamics(theta, q, qd, tau, sid::kPaperGravity);
  };
  auto model_fd = [&arm](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                         const sid::Vector2<double>& tau) {
    return arm.model.forward_dynamics(arm.theta, q, qd, tau);
  };
  auto with_input = [&](const auto& input) {
    return closed_form ? sid::simulate_arm_experiment(closed_fd, input, experiment)
                       : sid::simulate_arm_experiment(model_fd, input, experiment);
  };
  const sid::ExperimentResult run = o.excitation == "multisine" ? with_input(sid::MultisineInput())
                                                                : with_input(sid::PaperInput());
  if (!run.ok()) {
    const Eigen::Index done = run.truth.size();
    const std::string where =
        done > 0 ? "after t = " + short_number(run.truth.t[done - 1]) + " s" : "at the start";
    throw sid::app::InputError(
        "the simulation failed " + where + " (" + sid::to_string(run.status) +
        (run.flag_name.empty() ? std::string() : ", " + run.flag_name) + ")" +
        (run.message.empty() ? std::string() : ": " + without_final_period(run.message)) +
        "; check the parameters (theta = " + join_numbers(theta) +
        "; negative friction makes the arm unstable) or the tolerances --rtol/--atol");
  }
  for (Eigen::Index i = 0; i < run.truth.size(); ++i)
    require(run.truth.q.row(i).allFinite() && run.truth.qd.row(i).allFinite() &&
                run.truth.qdd.row(i).allFinite(),
            "the simulation produced a non-finite state at t = " + short_number(run.truth.t[i]) +
                " s; check the parameters");

  // The sensors' faults come before their noise: measured q = true q - delta, measured tau =
  // applied tau + b (the noise draws do not depend on the effects, so a seed's noise is the same
  // with and without them).
  sid::Trajectory<double> sensed = run.trajectory();
  for (Eigen::Index j = 0; j < 2; ++j) {
    if (arm.angle_offset[j] != 0.0) sensed.q.col(j).array() -= arm.angle_offset[j];
    if (arm.torque_offset[j] != 0.0) sensed.tau.col(j).array() += arm.torque_offset[j];
  }
  std::mt19937_64 rng(seed);
  const sid::Trajectory<double> measured = sid::add_measurement_noise(
      sensed, sid::MeasurementNoise<double>{o.sigma_q2, o.sigma_tau2}, rng);

  std::vector<std::string> names{"t", "q1", "q2", "tau1", "tau2"};
  std::vector<Eigen::VectorXd> columns{measured.t, measured.q.col(0), measured.q.col(1),
                                       measured.tau.col(0), measured.tau.col(1)};
  if (o.truth) {
    const sid::Kinematics<double>& k = run.truth;
    for (const char* name :
         {"q1_true", "q2_true", "qd1", "qd2", "qdd1", "qdd2", "tau1_true", "tau2_true"})
      names.emplace_back(name);
    for (const auto* m : {&k.q, &k.qd, &k.qdd, &k.tau})
      for (Eigen::Index j = 0; j < 2; ++j) columns.emplace_back(m->col(j));
  }
  const bool paper = o.excitation == "paper";
  std::vector<std::string> comments{
      paper ? "sid_simulate: the paper's open-loop experiment, u1 = 6 sin t, u2 = 4 cos t [N m], "
              "q(0) = qd(0) = 0, g = 9.81 m/s^2"
            : "sid_simulate: open-loop experiment with the multisine input, u1 = 5 sin 1.3t + "
              "2 sin 3.1t, u2 = 3 cos 0.7t + 1.5 sin 2.3t [N m], q(0) = qd(0) = 0, g = 9.81 m/s^2",
      "T = " + sid::app::shortest_number(o.T) + " s, Ts = " + sid::app::shortest_number(o.Ts) +
          " s, samples = " + std::to_string(measured.size()),
      "seed = " + std::to_string(seed) +
          " (std::mt19937_64), sigma_q2 = " + sid::app::shortest_number(o.sigma_q2) +
          " rad^2, sigma_tau2 = " + sid::app::shortest_number(o.sigma_tau2) + " (N m)^2",
      "theta = " + join_numbers(theta, true),
      "CVODE rtol = " + sid::app::shortest_number(o.rtol) +
          ", atol = " + sid::app::shortest_number(o.atol),
      "excitation = " + o.excitation};
  std::string effect_list;
  for (const auto& spec : effects)
    effect_list += (effect_list.empty() ? "" : " ") + spec_text(spec);
  comments.push_back(
      "effects = " + (effects.empty() ? std::string("none") : effect_list) +
      (effects.empty()
           ? std::string()
           : " (coulomb_epsilon = " + sid::app::shortest_number(o.coulomb_epsilon) + " rad/s)"));
  for (const auto& spec : effects) comments.push_back(spec_description(spec));
  sid::app::write_csv(o.output, names, columns, comments);
  if (!o.quiet)
    std::cerr << kName << ": seed " << seed << ", sigma_q2 = " << short_number(o.sigma_q2)
              << " rad^2, sigma_tau2 = " << short_number(o.sigma_tau2) << " (N m)^2, "
              << measured.size() << " samples"
              << (o.output == "-" ? std::string() : " written to " + o.output) << "\n";
  return sid::app::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return simulate(options); });
}
