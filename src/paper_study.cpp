#include "paper_study.hpp"

#include <sid/cvode/chain_instrumental_variables.hpp>
#include <sid/cvode/experiment.hpp>
#include <sid/cvode/instrumental_variables.hpp>
#include <sid/model/two_link_arm.hpp>

#include "app.hpp"
#include "csv.hpp"
#include "montecarlo_report.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid::app {
namespace {

std::string short_number(double v) { return format_number("%.6g", v); }

}  // namespace

std::vector<sid::StudyMethod> parse_study_methods(const std::string& text) {
  constexpr const char* kExpected = "raw, filtered, css, css_gcv, css_wls, css_iv, css_tcv, oracle";
  std::vector<sid::StudyMethod> methods;
  for (const auto& name : parse_name_list(text, "--methods", "method name", "methods", kExpected)) {
    try {
      methods.push_back(sid::parse_study_method(name));
    } catch (const std::invalid_argument&) {
      throw InputError(
          "--methods: unknown method '" + name +
          "' (expected raw, filtered, css, css_gcv, css_wls, css_iv, css_tcv or oracle)");
    }
  }
  return methods;
}

sid::MonteCarloOptions paper_study_options(const PaperStudyOptions& o) {
  sid::MonteCarloOptions study;
  require(o.runs >= 2,
          "--runs must be >= 2 (a sample variance needs two runs), got " + std::to_string(o.runs));
  require(o.runs <= 1000000, "--runs must be <= 1000000, got " + std::to_string(o.runs));
  study.runs = o.runs;
  study.sigma_q2_levels = parse_doubles(o.levels, "--levels");
  require(study.sigma_q2_levels.size() <= 100, "--levels: at most 100 levels");
  for (std::size_t k = 0; k < study.sigma_q2_levels.size(); ++k) {
    const double v = study.sigma_q2_levels[k];
    require(v > 0.0, "--levels: value " + std::to_string(k + 1) + " (" + short_number(v) +
                         ") must be > 0: every sigma_q2 is a variance, and CSS needs sigma_q > 0");
    for (std::size_t j = 0; j < k; ++j)
      require(level_label(study.sigma_q2_levels[j]) != level_label(v),
              "--levels: " + level_label(v) + " is given twice");
  }
  require(
      std::isfinite(o.sigma_tau2) && o.sigma_tau2 >= 0.0,
      "--sigma-tau2 must be a finite variance >= 0 [(N m)^2], got " + short_number(o.sigma_tau2));
  study.sigma_tau2 = o.sigma_tau2;
  study.methods = parse_study_methods(o.methods);
  study.refine = sid::instrumental_variable_step();
  study.seed = parse_seed(o.seed);
  require(o.threads >= 0,
          "--threads must be >= 0 (0 = all cores), got " + std::to_string(o.threads));
  study.threads = o.threads;
  return study;
}

sid::Kinematics<double> paper_study_truth(const sid::TwoLinkParameters<double>& theta) {
  auto fd = [&theta](const sid::Vector2<double>& q, const sid::Vector2<double>& qd,
                     const sid::Vector2<double>& tau) {
    return sid::two_link_forward_dynamics(theta, q, qd, tau, sid::kPaperGravity);
  };
  const sid::ExperimentResult run =
      sid::simulate_arm_experiment(fd, sid::PaperInput(), sid::ArmExperiment());
  if (!run.ok())
    throw std::runtime_error("the simulation of the true trajectory failed (" + run.flag_name +
                             "): " + run.message);
  return run.truth;
}

// The paper's filters keep their cutoffs in Hz (10, 3 and 2 Hz at 400 Hz) at any rate.
sid::ChainMonteCarloOptions chain_study_options(const PaperStudyOptions& shared,
                                                const ChainStudyOptions& o) {
  sid::ChainMonteCarloOptions chain;
  static_cast<sid::StudySettings&>(chain) = paper_study_options(shared);
  chain.refine = sid::chain_instrumental_variable_step();
  require(std::isfinite(o.duration) && o.duration > 1.0 && o.duration <= 3600.0,
          "--duration must be in (1, 3600] s (every method drops 0.25 s at each end; the "
          "filtered one 1.75 s at the start), got " +
              short_number(o.duration));
  require(std::isfinite(o.rate) && o.rate >= 50.0 && o.rate <= 100000.0,
          "--rate must be in [50, 100000] Hz, got " + short_number(o.rate));
  if (o.estimate_torque_delay) {
    const double reach = std::min(chain.identify.skip, chain.identify.skip_end);
    require(std::find(chain.methods.begin(), chain.methods.end(), sid::StudyMethod::CssTorqueCv) !=
                chain.methods.end(),
            "--estimate-torque-delay is css_tcv's: add css_tcv to --methods");
    require(std::isfinite(*o.estimate_torque_delay) && *o.estimate_torque_delay > 0.0 &&
                *o.estimate_torque_delay <= reach,
            "--estimate-torque-delay must be in (0, " + short_number(reach) + "] s, got " +
                short_number(*o.estimate_torque_delay));
    chain.estimate_torque_delay = sid::TorqueDelaySearch{*o.estimate_torque_delay};
  }
  auto& f = chain.kinematics.filters;
  const double scale = 400.0 / o.rate;
  f.q_cutoff *= scale;
  f.qd_cutoff *= scale;
  f.qdd_cutoff *= scale;
  return chain;
}

ChainStudyTruth chain_study_truth(const ChainStudyOptions& o,
                                  sid::ChainMonteCarloOptions& options) {
  ChainSimulateOptions c;
  c.robot = o.robot;
  c.base = o.base;
  c.tip = o.tip;
  c.hold = o.hold;
  c.duration = o.duration;
  c.sample_time = 1.0 / o.rate;
  c.harmonics = o.harmonics;
  c.base_frequency = o.base_frequency;
  c.q_range = o.q_range;
  c.qd_max = o.qd_max;
  c.encoder_bits = o.encoder_bits;
  c.encoder_ratio = o.encoder_ratio;
  c.torque_delay = o.torque_delay;
  std::mt19937_64 rng(options.seed);
  const RobotDescription robot = read_simulated_robot(c);
  options.sensors = logged_sensors(c, robot.chain.joints());
  try {
    (void)sid::encoder_steps(options.sensors, robot.chain, "--encoder-bits");
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  SimulatedRobot simulated = simulate_robot_truth(c, robot, rng);
  ChainStudySetup setup;
  setup.robot = o.robot;
  setup.base = o.base;
  setup.tip = o.tip;
  setup.joint_names = robot.joint_names;
  setup.samples = simulated.truth.size();
  setup.duration = o.duration;
  setup.sample_time = c.sample_time;
  setup.harmonics = o.harmonics;
  setup.base_frequency = o.base_frequency;
  setup.q_range = o.q_range;
  setup.qd_max = o.qd_max;
  setup.encoder_bits = o.encoder_bits;
  setup.encoder_ratio = o.encoder_ratio;
  return {std::move(simulated), std::move(setup)};
}

}  // namespace sid::app
