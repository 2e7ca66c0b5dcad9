// sid_diagnose: find where the identified two-link arm model and measured data disagree, name
// the missing physical effect from sid's effect library, add it and show the gap shrink.

// First: shows that the header compiles on its own (tests/CMakeLists.txt counts on it).
#include <sid/diagnose.hpp>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sid/cvode/diagnose.hpp>
#include <sid/diagnose_runs.hpp>
#include <sid/model/effects.hpp>
#include <string>
#include <vector>

#include "app.hpp"
#include "chain_diagnose_app.hpp"
#include "csv.hpp"
#include "diagnose_report.hpp"
#include "plot.hpp"
#include "runs_diagnose_report.hpp"

namespace {

constexpr const char* kName = "sid_diagnose";

constexpr const char* kDescription =
    "Diagnose a two-link arm log: identify the paper's 7-parameter model, find where it and the\n"
    "data disagree (torque residual against the noise floor, free simulation against the\n"
    "measured angles), name the missing physical effect (friction, sensor offsets, rotor inertia,\n"
    "springs), refit with it and report the gap before and after. With --robot, the same for\n"
    "any serial chain: which drive terms (friction, offsets, rotors, springs) its logs support.\n";

constexpr const char* kFooter = R"(
Measured runs (two files or more, or --measured): the runs are diagnosed together, as they are.
  1. Each run is smoothed on its own time grid (which may be non-uniform) at one cutoff
     frequency, chosen by how well the nominal model then predicts torques it was not fitted
     on (as sid_identify does); the equations of all runs are stacked.
  2. The floor per run and joint is the torque's content above the cutoff: no model on the
     smoothed angles can explain it.
  3. Forward selection: an effect is named only if its HAC Wald test rejects (Holm, 1 %) AND
     it lowers the torque error of held-out runs (each run predicted by the fit of the
     others; with fewer than 3 runs, contiguous blocks) by more than 0.5 % in mean square,
     AND its values are physical. Significance alone is not enough on measured logs: a term
     that absorbs one run's model error is significant but predicts the other runs worse.
  4. Reported: the named and rejected effects with their values, whether the rotor of drive
     2 carried by link 1 is supported (--gear-ratio turns its armature into Ir), what no
     effect explains (the residual's excess over the floor), the final model with its
     physical plausibility, each run's free simulation in one line (its error, or where and
     why it became unstable), and the runs given with --validate.
  Options of the single-log diagnosis that do not apply: --reference-theta, --plots,
  --rest-velocity, --window.

Any serial chain (--robot FILE, a URDF or DH table, as sid_identify --robot takes it): the
  logs (t, q1..qn, tau1..taun; motor-side with --transmission) are smoothed per joint at the
  cutoff of a GCV spline of its angles (white angle noise, as simulated logs have) or, for
  measured logs (--measured, two files or more, or angles GCV leaves unsmoothed: quantised
  encoder angles), at the cutoffs sid_identify --robot chooses, by held-out torque prediction
  of the nominal model with Coulomb friction and torque offsets; then the nominal model (rigid
  bodies and --drives) is fitted. Then every drive term kind of --candidates (default coulomb, offset, armature,
  spring, viscous, stribeck: a Stribeck curve at widths 0.03, 0.1 and 0.3 rad/s, the best
  fitting one tested and, once named, its width fitted) on every joint and coupled motor where the model lacks it, and an
  offset of every joint's measured angle (angle_offset, true q = measured q + delta, through
  the nominal fit's torque linearised in that angle; where the link parameters absorb it, as
  on a first joint about a vertical axis or the last joint, it is not separable), is tested
  against the residual: named only if its HAC Wald test rejects (Holm, 1 %), BIC and the blocked
  cross-validation error drop, its value is physical, and it changes the torque prediction by
  at least --negligible-size of the joint's torque noise (otherwise: significant but
  negligible). Reported: per joint the noise, the residual before and after and what no tried
  term explains; the named terms with values and HAC standard deviations; why each other one
  was not named; with a URDF, each model's free simulation (1 s segments from the smoothed
  state) and, per joint, how far the final one stays from the motion against what an exact
  model does on this arm and log: six replicates of the log that the final model explains
  exactly (its torque along the smoothed motion, with the log's own angle and torque noise),
  each fitted, made consistent and simulated alike; a joint beyond 2x the largest replicate's
  error moves in a way the final model does not explain.

Input: CSV files with a header row and the columns t [s], q1, q2 [rad], tau1, tau2 [N m] in
any order (other columns are ignored; what sid_simulate writes; --columns maps other names, e.g.
--columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2); '#' lines are
comments. t must be strictly increasing, every cell a finite number.

Single log (one file): the single-log diagnosis smooths with GCV and takes its noise floors from GCV, which assume
independent noise: right for simulated logs, far too small on quantised encoder angles and
drive-estimated torques. Diagnose measured logs as measured runs (above).

What it does:
  1. Identifies theta1..theta7 by the cubic smoothing spline (lambda by GCV, no noise level
     needed), dropping t < t_0 + 0.25 s and the last 0.05 s.
  2. Estimates the torque noise floor per joint (sigma of a GCV smoothing spline of tau) and
     the kinematic floor (the torque error the angle noise leaves through the smoothed qd, qdd,
     by Monte Carlo), flags windows (--window s) whose torque residual RMS exceeds both. Where a joint rests (|qd| <
     --rest-velocity) its friction is static and unknown: its equations there and 20 ms
     around are left out of the fits, tests and residual figures.
  3. Simulates the identified model open loop, driven by the measured torque and restarted
     from the smoothed state every --segment s, and flags windows whose angle error exceeds
     6x what the torque noise alone does (calibrated by simulating that noise).
  4. Tests each candidate effect against the residual by forward selection (HAC Wald test
     with Holm correction, BIC drop, blocked cross-validation, physical admissibility), adds
     the one that passes best, repeats until none passes, and refits.

Effects (--candidates, default all):
  coulomb_j1, coulomb_j2              Fc tanh(qd_j / eps), Fc > 0 [N m]; eps = --coulomb-epsilon
  stribeck_j1, stribeck_j2            (Fc + (Fs - Fc) exp(-(qd_j/vs)^2)) tanh(qd_j / eps)
  torque_offset_j1, torque_offset_j2  measured tau_j = applied tau_j + b [N m]; a constant load
                                      looks the same
  angle_offset_q1, angle_offset_q2    true q_j = measured q_j + delta [rad]; for q1 a tilt of the
                                      base in the plane of motion looks the same
  armature_j1, armature_j2            rotor inertia Ia [kg m^2] added to D11 / D22; on joint 1
                                      it equals theta1's column: reported as not separable and,
                                      with --reference-theta, as theta1 drift
  spring_j1, spring_j2                k q_j, k > 0 [N m/rad]

Output (standard output): the noise floor; the nominal fit; where the model and the data
disagree per joint (residual RMS, excess over the floor, flagged windows, free-simulation
error); each named effect in words with estimate +- std; the candidates that are not separable
or not named (with the smallest value that would have been detected); the before/after table
per joint; with --reference-theta the parameters that drifted (|z| > 3).

Files (existing files are never overwritten without --force):
  --json FILE   {"effects": [{"id", "name", "estimate", "std", ...}], "not_separable",
                "not_named", "noise_floor", "nominal": {"theta", "std", "residual_rms",
                "excess_rms", "sim_error_rms", "windows", "sim_windows", ...}, "final": {...},
                "drift", "simulation", "seconds"}; '-' writes it to standard output instead of
                the report (which then goes to standard error).
  --plots DIR   residual_j1.png, residual_j2.png (torque residual before/after over time),
                friction_j1.png, friction_j2.png (mean residual against joint velocity: the
                friction curve the model lacks), sim_q1.png, sim_q2.png (measured angle and the
                free simulations before/after), sim_error_q1.png, sim_error_q2.png (measured -
                simulated angle before/after, with the band the torque noise alone explains);
                each with its .dat and gnuplot .gp script.

Exit codes: 0 success, 2 bad input or options (message on standard error), 1 internal error.

Examples:
  sid_diagnose run1.csv run2.csv run3.csv --validate run4.csv --gear-ratio 6 \
      --columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2
  sid_simulate --effect coulomb_j2:0.2 -o log.csv && sid_diagnose log.csv
  sid_diagnose log.csv --json diagnosis.json --plots figures
  sid_diagnose log.csv --candidates coulomb_j1,coulomb_j2 --coulomb-epsilon 0.02
  sid_diagnose --robot arm.urdf --transmission drives.yaml motor_log.csv --json diagnosis.json
  sid_diagnose log.csv --reference-theta 0.0340,0.00306,0.00453,0.1329,0.01694,0.6189,0.6189
)";

struct Options {
  std::vector<std::string> inputs;
  std::vector<std::string> validate;
  bool measured = false;
  std::optional<double> gear_ratio;
  std::string reference;
  std::string columns;
  std::string json;
  std::string report;  ///< --robot: the diagnosis as one HTML page
  std::string plots;
  std::string candidates;
  std::optional<double> coulomb_epsilon;
  double segment = 1.0;
  double window = 0.5;
  double rest_velocity = sid::DiagnoseOptions{}.rest_velocity;
  std::optional<double> negligible_size;
  bool force = false;
  // Any serial chain
  std::string robot, base, tip, hold, transmission, drives, cutoff;
  std::optional<double> rest_fraction;
};

void define_options(CLI::App& cli, Options& o) {
  cli.footer(kFooter);
  cli.add_option("DATA", o.inputs, "input CSV file(s), one per run ('-' reads standard input)")
      ->required();
  cli.add_flag("--measured", o.measured,
               "diagnose as measured runs (torque-cv smoothing, held-out prediction) even for one "
               "file; implied by two files or more");
  cli.add_option("--validate", o.validate,
                 "measured runs: predict the torques of this run, not used in the fit "
                 "(repeatable)")
      ->allow_extra_args(false);
  cli.add_option("--gear-ratio", o.gear_ratio,
                 "measured runs: gear ratio of drive 2, to report its rotor inertia Ir, > 0");
  cli.add_option("--columns", o.columns,
                 "map sid's columns to the file's names, e.g. "
                 "t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2");
  cli.add_option("--reference-theta", o.reference,
                 "theta1..theta7 of a reference identification, comma-separated: report drift");
  cli.add_option("--json", o.json,
                 "also write the diagnosis as JSON to FILE ('-': standard output)");
  cli.add_option("--plots", o.plots, "draw the figures (PNG via gnuplot) into DIR");
  cli.add_option("--report", o.report,
                 "--robot: write the diagnosis as one self-contained HTML page (the residual "
                 "against the noise per joint, the named effects and their tests, what was not "
                 "named and why, the free simulations; refuses to overwrite without --force)");
  cli.add_option("--candidates", o.candidates, "effect ids to try, comma-separated (default: all)");
  cli.add_option("--coulomb-epsilon", o.coulomb_epsilon,
                 "eps of the Coulomb term tanh(qd/eps) [rad/s], > 0 (default 0.01)");
  cli.add_option("--rest-velocity", o.rest_velocity,
                 "a joint with |qd| below V [rad/s] is at rest: its equations there (and 20 ms "
                 "around) are left out, static friction being unknown; 0 keeps all, >= 0")
      ->capture_default_str();
  cli.add_option("--segment", o.segment,
                 "free simulation: restart from the smoothed state every S seconds, > 0")
      ->capture_default_str();
  cli.add_option("--window", o.window, "length of the windows compared with the noise [s], > 0")
      ->capture_default_str();
  cli.add_option("--negligible-size", o.negligible_size,
                 "practical size below which a significant effect is not named, in [0, 1): its "
                 "change of the torque prediction over the residual RMS (default 0.075), with "
                 "--robot over the torque noise");
  cli.add_flag("--force", o.force, "overwrite existing output files");
  cli.add_option("--robot", o.robot,
                 "any serial chain: its URDF or DH table; the logs have t, q1..qn, tau1..taun "
                 "(see Any serial chain below)");
  cli.add_option("--base", o.base, "--robot URDF: the chain's first link (default: root)");
  cli.add_option("--tip", o.tip, "--robot URDF: the chain's last link (default: the one end link)");
  cli.add_option("--hold", o.hold, "--robot URDF: JOINT=VALUE,... holds joints off the chain");
  cli.add_option("--transmission", o.transmission,
                 "--robot: YAML or URDF transmission; the logs are then motor-side");
  cli.add_option("--drives", o.drives,
                 "--robot: the nominal model's drive terms on every joint (default: "
                 "viscous,armature; none for rigid bodies alone)");
  cli.add_option("--cutoff", o.cutoff,
                 "--robot: smoothing cutoff [Hz], one or one per joint (default: per joint from "
                 "GCV of its angles, or by held-out torque prediction as sid_identify --robot for "
                 "measured logs: --measured, two files or more, or angles GCV leaves unsmoothed)");
  cli.add_option("--rest-fraction", o.rest_fraction,
                 "--robot: leave out joint j's equations where |qd_j| < F RMS(qd_j) (default 0.1)");
}

std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

// Runs check and prefixes the option's name to its InputError ("--json: refusing to ...").
template <typename Check>
void for_option(const std::string& option, const Check& check) {
  try {
    check();
  } catch (const sid::app::InputError& e) {
    throw sid::app::InputError(option + ": " + e.what());
  }
}

sid::app::TrajectoryColumns columns_of(const Options& o) {
  return o.columns.empty() ? sid::app::TrajectoryColumns{}
                           : sid::app::parse_trajectory_columns(o.columns, "--columns");
}

int diagnose_measured_runs(const Options& o) {
  using sid::app::require;
  require(o.reference.empty() && o.plots.empty() && !o.negligible_size &&
              o.rest_velocity == sid::DiagnoseOptions{}.rest_velocity && o.window == 0.5,
          "--reference-theta, --plots, --negligible-size, --rest-velocity and --window apply to "
          "the diagnosis of a single log, "
          "not of measured runs");
  sid::app::RunsDiagnoseReportInput in;
  if (!o.candidates.empty())
    in.options.candidates = sid::app::parse_effect_list(o.candidates, "--candidates");
  if (o.coulomb_epsilon) {
    require(std::isfinite(*o.coulomb_epsilon) && *o.coulomb_epsilon > 0.0,
            "--coulomb-epsilon must be a finite number > 0 [rad/s], got " +
                short_number(*o.coulomb_epsilon));
    in.options.effects.coulomb_epsilon = *o.coulomb_epsilon;
  }
  require(std::isfinite(o.segment) && o.segment > 0.0,
          "--segment must be a finite number > 0 [s], got " + short_number(o.segment));
  in.segment = o.segment;
  if (o.gear_ratio) {
    require(std::isfinite(*o.gear_ratio) && *o.gear_ratio > 0.0,
            "--gear-ratio must be a finite number > 0, got " + short_number(*o.gear_ratio));
    in.gear_ratio = o.gear_ratio;
  }
  sid::app::require_stdin_at_most_once(o.inputs, o.validate);
  if (!o.json.empty()) for_option("--json", [&] { sid::app::ensure_writable(o.json, o.force); });

  const sid::app::TrajectoryColumns columns = columns_of(o);
  in.runs = sid::app::read_runs(o.inputs, columns);
  std::vector<sid::Trajectory<double>> data;
  for (const auto& run : in.runs) data.push_back(run.data);
  const std::vector<sid::app::RunFile> held_out = sid::app::read_runs(o.validate, columns);
  try {
    in.diagnosis = sid::diagnose_runs(data, in.options);
  } catch (const std::invalid_argument& e) {
    throw sid::app::InputError(e.what());
  }
  const sid::RunsDiagnosis& d = in.diagnosis;
  if (!d.final.fit.ok())
    throw sid::app::InputError("the final model cannot be identified from these runs: " +
                               d.final.fit.message);
  const auto constraints = sid::default_physical_constraints(d.final_model);
  in.physical = sid::check_physical(d.final_model, d.final.fit.theta, constraints);
  if (!in.physical.plausible()) {
    const sid::StackedRegression<double> all = sid::stack_runs(d.final_model, d.final.kinematics);
    try {
      in.consistent = sid::nearest_physical(d.final_model, all.X, all.y, constraints);
    } catch (const std::invalid_argument& e) {
      std::cerr << kName << ": warning: no physically consistent estimate: " << e.what() << "\n";
    }
  }
  sid::FreeSimulationOptions simulation;
  simulation.segment = o.segment;
  simulation.simulator.rtol = simulation.simulator.atol =
      sid::SimulationCheckOptions{}.checked_tolerance;
  for (const auto& k : d.final.kinematics)
    in.simulations.push_back(sid::free_simulation(d.final_model, d.final.fit.theta, k, simulation));
  sid::RunsIdentifyOptions fitted = in.options.identify;
  fitted.cutoff_hz = d.cutoff_hz;
  for (const auto& run : held_out) {
    try {
      in.validation.push_back(
          {run.file,
           sid::predict_torque(run.data, d.final_model, d.final.fit.theta, d.cutoff_hz, fitted),
           sid::predict_torque(run.data, d.nominal_model, d.nominal.fit.theta, d.cutoff_hz,
                               fitted)});
    } catch (const std::invalid_argument& e) {
      throw sid::app::InputError(run.file + ": " + e.what());
    }
  }
  const sid::app::RunsReport report = sid::app::make_runs_diagnose_report(in);
  (o.json == "-" ? std::cerr : std::cout) << report.text << std::flush;
  if (!o.json.empty()) sid::app::write_json(o.json, report.json);
  return sid::app::kExitOk;
}

int diagnose_robot(const Options& o) {
  using sid::app::require;
  require(o.validate.empty() && !o.gear_ratio && o.reference.empty() && o.plots.empty() &&
              o.window == 0.5 && o.rest_velocity == sid::DiagnoseOptions{}.rest_velocity,
          "--validate, --gear-ratio, --reference-theta, --plots, --window and "
          "--rest-velocity apply to two-link logs, not with --robot");
  require(o.measured ? o.cutoff.empty() : true,
          "--measured chooses the cutoffs; with --cutoff there is nothing to choose");
  sid::app::ChainDiagnoseAppOptions chain;
  chain.chain.robot = o.robot;
  chain.chain.base = o.base;
  chain.chain.tip = o.tip;
  chain.chain.hold = o.hold;
  chain.chain.transmission = o.transmission;
  chain.chain.inputs = o.inputs;
  chain.chain.columns = o.columns;
  chain.chain.cutoff = o.cutoff;
  chain.chain.effects = o.drives;
  chain.chain.rest_fraction = o.rest_fraction;
  chain.chain.coulomb_epsilon = o.coulomb_epsilon;
  chain.chain.json = o.json;
  chain.chain.report = o.report;
  chain.chain.force = o.force;
  chain.candidates = o.candidates;
  chain.negligible_size = o.negligible_size;
  chain.measured = o.measured;
  return sid::app::diagnose_robot(chain);
}

int diagnose(const Options& o) {
  using sid::app::require;
  if (!o.robot.empty()) return diagnose_robot(o);
  require(o.base.empty() && o.tip.empty() && o.hold.empty() && o.transmission.empty() &&
              o.drives.empty() && o.cutoff.empty() && !o.rest_fraction && o.report.empty(),
          "--base, --tip, --hold, --transmission, --drives, --cutoff, --rest-fraction and "
          "--report need --robot (the paper's arm as a DH table takes them too)");
  if (o.measured || o.inputs.size() > 1) return diagnose_measured_runs(o);
  require(o.validate.empty() && !o.gear_ratio,
          "--validate and --gear-ratio apply to measured runs (two files or more, or --measured)");
  sid::DiagnoseOptions options;
  if (!o.reference.empty()) {
    const std::vector<double> v = sid::app::parse_doubles(o.reference, "--reference-theta", 7);
    options.reference_theta = Eigen::Map<const Eigen::VectorXd>(v.data(), 7);
  }
  if (!o.candidates.empty())
    options.candidates = sid::app::parse_effect_list(o.candidates, "--candidates");
  if (o.coulomb_epsilon) {
    require(std::isfinite(*o.coulomb_epsilon) && *o.coulomb_epsilon > 0.0,
            "--coulomb-epsilon must be a finite number > 0 [rad/s], got " +
                short_number(*o.coulomb_epsilon));
    options.effects.coulomb_epsilon = *o.coulomb_epsilon;
  }
  require(std::isfinite(o.segment) && o.segment > 0.0,
          "--segment must be a finite number > 0 [s], got " + short_number(o.segment));
  require(std::isfinite(o.window) && o.window > 0.0,
          "--window must be a finite number > 0 [s], got " + short_number(o.window));
  options.window_length = o.window;
  require(
      std::isfinite(o.rest_velocity) && o.rest_velocity >= 0.0,
      "--rest-velocity must be a finite number >= 0 [rad/s], got " + short_number(o.rest_velocity));
  options.rest_velocity = o.rest_velocity;
  if (o.negligible_size) {
    require(*o.negligible_size >= 0.0 && *o.negligible_size < 1.0,
            "--negligible-size must be in [0, 1), got " + short_number(*o.negligible_size));
    options.negligible_size = *o.negligible_size;
  }
  sid::FreeSimulationOptions simulation;
  simulation.segment = o.segment;
  const sid::SimulationCheckOptions check;

  if (!o.json.empty()) for_option("--json", [&] { sid::app::ensure_writable(o.json, o.force); });
  if (!o.plots.empty())
    for_option("--plots", [&] {
      sid::app::ensure_output_directory(o.plots, sid::app::diagnose_plot_files(), o.force);
    });

  const sid::app::CsvTable table = sid::app::read_csv(o.inputs.front());
  const sid::Trajectory<double> data = sid::app::trajectory_from_table(table, columns_of(o));
  const std::string input = table.source == "-" ? "<stdin>" : table.source;
  require(data.size() >= 20,
          input + ": a diagnosis needs at least 20 data rows, got " + std::to_string(data.size()));

  sid::SimulationCheck sim;
  sid::DiagnosisResult result;
  try {
    result = sid::diagnose_with_simulation(data, options, simulation, check, &sim);
  } catch (const std::invalid_argument& e) {
    throw sid::app::InputError(input + ": " + e.what());
  }

  sid::app::DiagnoseReportContext context;
  context.input = input;
  context.samples_total = data.size();
  context.segment = o.segment;
  context.window_length = o.window;
  context.noise_runs = check.noise_runs;
  context.threshold = check.threshold;
  context.has_reference = options.reference_theta.has_value();
  context.rest_velocity = options.rest_velocity;
  context.rest_margin = options.rest_margin;
  // With the JSON on standard output the report goes to standard error, so each stays parseable.
  (o.json == "-" ? std::cerr : std::cout)
      << sid::app::diagnose_report(result, sim, context) << std::flush;
  if (!o.json.empty()) sid::app::write_json(o.json, sid::app::diagnose_json(result, sim, context));
  if (!o.plots.empty()) {
    const auto plots = sid::app::write_diagnose_plots(o.plots, result, sim);
    for (const auto& p : plots)
      if (!p.rendered) {
        std::cerr << kName << ": " << p.message << "\n";
        break;
      }
  }
  return sid::app::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return diagnose(options); });
}
