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
#include <sid/model/effects.hpp>
#include <string>
#include <vector>

#include "app.hpp"
#include "csv.hpp"
#include "diagnose_report.hpp"
#include "plot.hpp"

namespace {

constexpr const char* kName = "sid_diagnose";

constexpr const char* kDescription =
    "Diagnose a two-link arm log: identify the paper's 7-parameter model, find where it and the\n"
    "data disagree (torque residual against the noise floor, free simulation against the\n"
    "measured angles), name the missing physical effect (friction, sensor offsets, rotor inertia,\n"
    "springs), refit with it and report the gap before and after.\n";

constexpr const char* kFooter = R"(
Input: a CSV file with a header row and the columns t [s], q1, q2 [rad], tau1, tau2 [N m] in
any order (other columns are ignored; what sid_simulate writes; --columns maps other names, e.g.
--columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2); '#' lines are
comments. t must be strictly increasing, every cell a finite number.
Measured logs: the diagnosis smooths with GCV and takes its noise floors from GCV, which
assume independent noise; on quantised encoder angles and drive-estimated torques both are far
too small, so every window is flagged and the named effects are not reliable. Identify such
logs with sid_identify (several runs, torque-cv smoothing, --effects, --validate).

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
  sid_simulate --effect coulomb_j2:0.2 -o log.csv && sid_diagnose log.csv
  sid_diagnose log.csv --json diagnosis.json --plots figures
  sid_diagnose log.csv --candidates coulomb_j1,coulomb_j2 --coulomb-epsilon 0.02
  sid_diagnose log.csv --reference-theta 0.0340,0.00306,0.00453,0.1329,0.01694,0.6189,0.6189
)";

struct Options {
  std::string input;
  std::string reference;
  std::string columns;
  std::string json;
  std::string plots;
  std::string candidates;
  std::optional<double> coulomb_epsilon;
  double segment = 1.0;
  double window = 0.5;
  double rest_velocity = sid::DiagnoseOptions{}.rest_velocity;
  bool force = false;
};

void define_options(CLI::App& cli, Options& o) {
  cli.footer(kFooter);
  cli.add_option("DATA", o.input, "input CSV file ('-' reads standard input)")->required();
  cli.add_option("--columns", o.columns,
                 "map sid's columns to the file's names, e.g. "
                 "t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2");
  cli.add_option("--reference-theta", o.reference,
                 "theta1..theta7 of a reference identification, comma-separated: report drift");
  cli.add_option("--json", o.json,
                 "also write the diagnosis as JSON to FILE ('-': standard output)");
  cli.add_option("--plots", o.plots, "draw the figures (PNG via gnuplot) into DIR");
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
  cli.add_flag("--force", o.force, "overwrite existing output files");
}

std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

std::vector<std::string> parse_candidates(const std::string& text) {
  const std::vector<std::string> ids =
      sid::app::parse_name_list(text, "--candidates", "effect id", "effect ids");
  for (const auto& id : ids)
    if (!sid::is_effect_id(id)) {
      std::string valid;
      for (const auto& v : sid::effect_ids()) valid += (valid.empty() ? "" : ", ") + v;
      throw sid::app::InputError("--candidates: unknown effect '" + id + "' (expected " + valid +
                                 ")");
    }
  return ids;
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

int diagnose(const Options& o) {
  using sid::app::require;
  sid::DiagnoseOptions options;
  if (!o.reference.empty()) {
    const std::vector<double> v = sid::app::parse_doubles(o.reference, "--reference-theta", 7);
    options.reference_theta = Eigen::Map<const Eigen::VectorXd>(v.data(), 7);
  }
  if (!o.candidates.empty()) options.candidates = parse_candidates(o.candidates);
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
  require(std::isfinite(o.rest_velocity) && o.rest_velocity >= 0.0,
          "--rest-velocity must be a finite number >= 0 [rad/s], got " +
              short_number(o.rest_velocity));
  options.rest_velocity = o.rest_velocity;
  sid::FreeSimulationOptions simulation;
  simulation.segment = o.segment;
  const sid::SimulationCheckOptions check;

  if (!o.json.empty()) for_option("--json", [&] { sid::app::ensure_writable(o.json, o.force); });
  if (!o.plots.empty())
    for_option("--plots", [&] {
      sid::app::ensure_output_directory(o.plots, sid::app::diagnose_plot_files(), o.force);
    });

  const sid::app::CsvTable table = sid::app::read_csv(o.input);
  const sid::Trajectory<double> data = sid::app::trajectory_from_table(
      table, o.columns.empty() ? sid::app::TrajectoryColumns{}
                               : sid::app::parse_trajectory_columns(o.columns, "--columns"));
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
