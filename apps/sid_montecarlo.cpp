// sid_montecarlo: the paper's Monte Carlo study (section 3.1). Simulates the true trajectory of
// the two-link arm once, then for every noise level and run adds measurement noise, estimates
// the parameters by each method and reports sample means and variances beside the paper's.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <optional>
#include <random>
#include <sid/cvode/experiment.hpp>
#include <sid/cvode/chain_instrumental_variables.hpp>
#include <sid/cvode/instrumental_variables.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/study/chain_montecarlo.hpp>
#include <sid/study/montecarlo.hpp>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "app.hpp"
#include "chain_montecarlo_report.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"
#include "montecarlo_report.hpp"
#include "paper_study.hpp"
#include "plot.hpp"
#include "progress_bar.hpp"

namespace {

constexpr const char* kName = "sid_montecarlo";

constexpr const char* kDescription =
    "The Monte Carlo study of the paper (Dolinsky & Celikovsky, section 3.1): identify the 7\n"
    "parameters of the simulated two-link arm from noisy joint angles and torques, many times per\n"
    "noise level, by each method, and report sample means and variances beside the paper's\n"
    "tables 2-7.\n";

constexpr const char* kFooter = R"(
The experiment: the arm starts at rest at q = 0 and is driven open loop by u1 = 6 sin t,
u2 = 4 cos t [N m] for T = 10 s; the true trajectory is simulated once with CVODE and sampled
every Ts = 0.0025 s (4001 samples). Each run adds independent Gaussian noise to it: variance
sigma_q2 [rad^2] on both joint angles and sigma_tau2 [(N m)^2] on both torques. The true
parameters are the paper's, corrected as in docs/paper-reproduction.md:
  theta = 0.034015193438, 0.003064135808, 0.0045320492, 0.13291456, 0.01694224, 0.6189, 0.6189

Methods (how q-dot and q-double-dot are estimated from the noisy angles; then least squares):
  raw       forward differences qd_i = (q_{i+1} - q_i) / Ts, qdd likewise from qd
  filtered  the same differences, then q, qd, qdd each filtered forward-backward by the paper's
            Butterworth low-pass filters (q: order 3, 10 Hz; qd: order 3, 3 Hz; qdd: order 4,
            2 Hz); drops t < 1.7475 s (the filters' start-up)
  css       Reinsch cubic smoothing spline with dq = sigma_q and S = n, derivatives analytic
  css_gcv   the same spline with lambda chosen by generalized cross-validation: it is not told
            sigma_q (not in the paper)
  css_wls   css_gcv's kinematics, then weighted least squares with per-joint torque noise
            variances estimated from a first fit (Gautier's IDIM-WLS; not in the paper)
  css_iv    the spline with 0.25 x the GCV lambda (less smoothing bias, more noise), least
            squares, then instrumental variables (IDIM-IV): instruments from CVODE simulations
            of the current estimate driven by the GCV-smoothed measured torque, restarted every
            0.5 s from the smoothed state, iterated until theta changes by < 1e-4 relative (at
            most 10 times; not in the paper)
  css_tcv   the spline at the cutoff frequency whose least-squares fit best predicts held-out
            torques (5 contiguous blocks, 4 cutoffs per octave over 0.25..64 Hz): it is not
            told sigma_q; sid_identify's default on measured data (not in the paper)
  oracle    the exact q, qd, qdd with the noisy torques: the floor no estimator beats on average
            (not in the paper)
Every method drops t < 0.25 s (the start transient).

Reproducibility: a run's noise depends only on (seed, level index, run index), so the numbers
printed and written are the same for any --threads. The seed is printed; the default is fixed.

Output (standard output): the settings, then per noise level the paper's layout: sample means
(true value | each method, "ours / paper" for raw, filtered and css where the paper has the
level), sample variances likewise ("~" marks the paper's order-of-magnitude-only entries), bias
and standard deviation in % of the true value, and the ranking of the methods by RMS relative
error (sqrt of the mean over runs and parameters of ((theta-hat - theta) / theta)^2) with the
worst |bias|. Last line: the wall time. A progress bar is drawn on standard error when it is a
terminal and the study takes more than a second (not with --quiet).

Files (existing files are never overwritten without --force):
  --json FILE    {"runs", "seed", "true_theta", "levels": [{"sigma_q2", "methods": {"raw":
                 {"mean", "var", "bias_pct", "std_pct", "rms_rel_error_pct", ...}, ...}}],
                 "wall_seconds", ...}; NaN becomes null. '-' writes the JSON to standard output
                 instead of the tables.
  --csv-dir DIR  every theta-hat of every run: estimates.csv (level,method,run,theta1..theta7)
                 and one METHOD_LEVEL.csv (run,theta1..theta7) per level and method; nan marks
                 a failed run
  --plots DIR    fig2_qdd1.png, fig3_qdd2.png: the paper's Fig. 2 and 3, the exact, CSS and
                 filtered accelerations of run 0 at sigma_q2 = 1e-6 (the noise of that run of
                 the study when 1e-6 is a level, else of the default study), the filtered
                 method's clipped start marked; fig2_qdd1_detail.png, fig3_qdd2_detail.png: the
                 same from t = 0.25 s (the start transient no longer sets the scale);
                 theta1.png .. theta7.png: box plots of the
                 estimates by method and level with the true value. Each PNG comes with its
                 data (.dat) and gnuplot script (.gp); without gnuplot those are still written
                 (install it with: sudo apt-get install gnuplot-nox).

Any serial chain (--robot FILE.urdf [--base LINK] [--tip LINK] [--hold JOINT=VALUE,...]): the
same study on the chain of a URDF, as sid_simulate --robot simulates it: the description's
links, its <dynamics> damping and friction, no rotor inertia; a random Fourier excitation drawn
from --seed (--harmonics, --base-frequency, --q-range, --qd-max, about the middle of each
joint's <limit> and within 90 % of its limits) tracked by computed torque for --duration s,
sampled at --rate Hz. Each run adds the noise of the levels to q and tau; each method
estimates the kinematics as above (filters at the same cutoffs in Hz; every method drops
t < 0.25 s and the last 0.25 s) and fits the base parameters of the chain's model (the links'
ten parameters each, viscous and Coulomb friction and armature per joint: the base parameters
are the combinations the data can tell apart, as sid_identify --robot names them) by least
squares; css_tcv is sid_identify --robot's own pipeline on the run (cutoffs chosen by held-out
torque prediction, torques filtered alike, equations at rest left out); css_iv takes its
instruments from simulations of the physically consistent arm nearest to each estimate, at
GCV's own lambda, and a run where that iteration does not converge or leaves more than 1.5 times
the first fit's residual keeps the first (css_gcv) fit, counted as declined. --encoder-bits,
--encoder-ratio and --torque-delay log each run through a cheap arm's sensors, as
sid_simulate does: the methods smooth with dq^2 = sigma_q2 + step^2 / 12, the oracle takes
the torque without the delay; --estimate-torque-delay MAX has css_tcv estimate the delay on
every run and fit paired at it (the delays found are in the report and the JSON). The
report gives, per level and method, the median and largest |bias| and
std over the base parameters in % of each true value (parameters whose true value is 0 have
none), the RMS relative error, and how the estimate predicts the true torque at the true
motion (100 |tau - Y beta-hat| / |tau|, mean and largest over the runs). --json FILE writes
it with every base parameter's mean, variance, bias and std; --csv-dir every estimate
(beta1..betaP, the comments naming each combination); --plots DIR torque_error.png (every
run's torque prediction error by method and level, log scale), qdd_j1.png .. qdd_jn.png (exact,
CSS and filtered accelerations of run 0 at sigma_q2 = 1e-6, as Fig. 2 and 3) and beta1.png ..
betaP.png (box plots of each base parameter's estimates with its true value).

Exit codes: 0 success, 2 bad options or unwritable outputs (message on standard error),
1 internal error.

Examples:
  sid_montecarlo
  sid_montecarlo --runs 100 --levels 1e-6 --methods css,oracle --json study.json
  sid_montecarlo --runs 10 --plots figures --csv-dir estimates --threads 4
  sid_montecarlo --robot tests/data/urdf/real/ur5_robot.urdf --tip tool0 --runs 30 \
      --methods raw,filtered,css,css_gcv,css_tcv,oracle --json ur5_study.json
)";

struct Options {
  int runs = 30;
  std::string levels = "1e-8,1e-6,1e-4";
  double sigma_tau2 = 1e-2;
  std::string methods = "raw,filtered,css,oracle";
  std::string seed = std::to_string(sid::MonteCarloOptions().seed);
  int threads = 0;
  std::string json;
  std::string csv_dir;
  std::string plots;
  bool quiet = false;
  bool force = false;
  // --robot: the same study on any chain of a URDF
  std::string robot, base, tip, hold;
  int harmonics = 5;
  double base_frequency = 0.1, q_range = 1.0, qd_max = 1.5;
  double duration = 10.0, rate = 400.0;
  std::string encoder_bits, encoder_ratio;
  double torque_delay = 0.0;
  std::optional<double> estimate_torque_delay;
  std::vector<const CLI::Option*> chain_only;  ///< the options that need --robot
};

void define_options(CLI::App& cli, Options& o) {
  cli.footer(kFooter);
  cli.add_option("--runs", o.runs, "number of runs (noisy data sets) per noise level N >= 2")
      ->capture_default_str();
  cli.add_option("--levels", o.levels,
                 "angle noise variances sigma_q2 > 0 [rad^2], comma-separated")
      ->capture_default_str();
  cli.add_option("--sigma-tau2", o.sigma_tau2, "torque noise variance >= 0 [(N m)^2]")
      ->capture_default_str();
  cli.add_option("--methods", o.methods,
                 "methods to compare, comma-separated, any subset and order of raw, filtered, "
                 "css, css_gcv, css_wls, css_iv, css_tcv, oracle")
      ->capture_default_str();
  cli.add_option("--seed", o.seed, "seed of the noise, an integer 0 .. 2^64 - 1")
      ->capture_default_str();
  cli.add_option("--threads", o.threads,
                 "worker threads K >= 0 (0 = all cores); the results do not depend on it")
      ->capture_default_str();
  cli.add_option("--json", o.json, "write the summary as JSON to FILE ('-' = standard output)");
  cli.add_option("--csv-dir", o.csv_dir, "write every estimate of every run as CSV into DIR");
  cli.add_option("--plots", o.plots, "draw the figures (PNG via gnuplot) into DIR");
  cli.add_flag("-q,--quiet", o.quiet, "no progress bar and no notes on standard error");
  cli.add_flag("--force", o.force, "overwrite existing output files");
  cli.add_option("--robot", o.robot,
                 "the study on the chain of this URDF instead of the paper's two-link arm");
  o.chain_only = {
      cli.add_option("--base", o.base, "--robot: the chain's first link (default: the root)"),
      cli.add_option("--tip", o.tip, "--robot: the chain's last link (default: the one end link)"),
      cli.add_option("--hold", o.hold, "--robot: JOINT=VALUE,... for joints off the chain"),
      cli.add_option("--harmonics", o.harmonics, "--robot: harmonics of the Fourier excitation")
          ->capture_default_str(),
      cli.add_option("--base-frequency", o.base_frequency,
                     "--robot: the excitation's base frequency [Hz] (its period is 1 / f)")
          ->capture_default_str(),
      cli.add_option("--q-range", o.q_range,
                     "--robot: largest |q_j - q0_j| [rad or m], q0 the middle of its <limit>")
          ->capture_default_str(),
      cli.add_option("--qd-max", o.qd_max, "--robot: largest |qd_j| [rad/s or m/s]")
          ->capture_default_str(),
      cli.add_option("--duration", o.duration, "--robot: duration of the experiment [s]")
          ->capture_default_str(),
      cli.add_option("--rate", o.rate, "--robot: sampling rate of the experiment [Hz], >= 50")
          ->capture_default_str(),
      cli.add_option("--encoder-bits", o.encoder_bits,
                     "--robot: B or B1,...,Bn: the logged angles rounded to encoders of B bits "
                     "per turn (as sid_simulate)"),
      cli.add_option(
          "--encoder-ratio", o.encoder_ratio,
          "--robot: R or R1,...,Rn: turns of each encoder per joint turn (on the motor)"),
      cli.add_option("--torque-delay", o.torque_delay,
                     "--robot: the torque logged this long behind the angles [s]")
          ->capture_default_str(),
      cli.add_option("--estimate-torque-delay", o.estimate_torque_delay,
                     "--robot: css_tcv estimates the torque's delay within +-MAX [s] and fits "
                     "paired at it (as sid_identify --robot --estimate-torque-delay)")};
}

sid::MonteCarloOptions study_options(const Options& o) {
  return sid::app::paper_study_options(
      {o.runs, o.levels, o.sigma_tau2, o.methods, o.seed, o.threads});
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

/// Says what the figures came to: how many were written, or once how to draw them.
void report_plots(const Options& o, const std::vector<sid::app::PlotResult>& plots) {
  bool all_rendered = true;
  for (const auto& p : plots) all_rendered = all_rendered && p.rendered;
  if (!all_rendered) {
    // The messages of all plots are alike.
    int not_drawn = 0;
    for (const auto& p : plots)
      if (!p.rendered && not_drawn++ == 0) std::cerr << kName << ": " << p.message << "\n";
    if (not_drawn > 1)
      std::cerr << kName << ": the same holds for the other " << not_drawn - 1
                << " figures; to draw them all: cd '" << o.plots
                << "' && for f in *.gp; do gnuplot \"$f\"; done\n";
  } else if (!o.quiet) {
    std::cerr << kName << ": wrote " << plots.size()
              << " figures (PNG, data and gnuplot script) into " << o.plots << "\n";
  }
}

sid::app::ChainStudyOptions chain_options(const Options& o) {
  return {o.robot,        o.base,
          o.tip,          o.hold,
          o.harmonics,    o.base_frequency,
          o.q_range,      o.qd_max,
          o.duration,     o.rate,
          o.encoder_bits, o.encoder_ratio,
          o.torque_delay, o.estimate_torque_delay};
}

sid::ChainMonteCarloOptions chain_study_options(const Options& o) {
  return sid::app::chain_study_options(
      {o.runs, o.levels, o.sigma_tau2, o.methods, o.seed, o.threads}, chain_options(o));
}

int chain_study(const Options& o) {
  sid::ChainMonteCarloOptions checked = chain_study_options(o);
  const bool json_to_stdout = o.json == "-";
  if (!o.json.empty()) for_option("--json", [&] { sid::app::ensure_writable(o.json, o.force); });
  if (!o.csv_dir.empty())
    for_option("--csv-dir", [&] {
      sid::app::ensure_output_directory(o.csv_dir, sid::app::montecarlo_csv_files(checked),
                                        o.force);
    });
  // Sets checked.sensors, which need the chain's joints.
  const sid::app::ChainStudyTruth truth = sid::app::chain_study_truth(chain_options(o), checked);
  const sid::SimulatedRobot& sim = truth.simulated;
  const sid::app::ChainStudySetup& setup = truth.setup;
  if (!o.plots.empty())
    for_option("--plots", [&] {
      // The figures' names depend on the chain: one per joint and per base parameter.
      const Eigen::Index parameters =
          sid::chain_base_parameters(sim.model, checked.identify).rank();
      sid::app::ensure_output_directory(
          o.plots, sid::app::chain_montecarlo_plot_files(sim.model.joints(), parameters), o.force);
    });
  if (!json_to_stdout) std::cout << sid::app::chain_montecarlo_header(checked, setup) << std::flush;

  sid::ChainMonteCarloOptions options = checked;
  sid::app::ProgressBar bar(kName, "runs", !o.quiet && sid::app::stderr_is_terminal());
  options.progress = [&bar](int done, int total) { bar.update(done, total); };
  sid::ChainMonteCarloResult result;
  try {
    result = sid::run_chain_monte_carlo(sim.model, sim.theta, sim.truth, options);
  } catch (...) {
    bar.finish();
    throw;
  }
  bar.finish();
  if (!json_to_stdout)
    std::cout << sid::app::chain_montecarlo_tables(result) << "\n"
              << sid::app::chain_montecarlo_wall_line(result) << std::flush;
  if (!o.json.empty()) {
    sid::app::write_json(o.json, sid::app::chain_montecarlo_json(result, options, setup));
    if (!o.quiet && !json_to_stdout) std::cerr << kName << ": wrote " << o.json << "\n";
  }
  if (!o.csv_dir.empty()) {
    sid::app::write_chain_montecarlo_csv(o.csv_dir, result);
    if (!o.quiet)
      std::cerr << kName << ": wrote the estimates of every run into " << o.csv_dir << "\n";
  }
  if (!o.plots.empty())
    report_plots(o, sid::app::write_chain_montecarlo_plots(o.plots, sim.truth, result, options,
                                                           setup.joint_names));
  return sid::app::kExitOk;
}

int study(const Options& o) {
  if (!o.robot.empty()) return chain_study(o);
  for (const CLI::Option* option : o.chain_only)
    sid::app::require(option->count() == 0,
                      option->get_name() + " is an option of --robot (the study of a chain)");
  // Check every option and output path before any work, so a typo fails fast.
  sid::MonteCarloOptions options = study_options(o);
  const bool json_to_stdout = o.json == "-";
  if (!o.json.empty()) for_option("--json", [&] { sid::app::ensure_writable(o.json, o.force); });
  if (!o.csv_dir.empty())
    for_option("--csv-dir", [&] {
      sid::app::ensure_output_directory(o.csv_dir, sid::app::montecarlo_csv_files(options),
                                        o.force);
    });
  if (!o.plots.empty())
    for_option("--plots", [&] {
      sid::app::ensure_output_directory(o.plots, sid::app::montecarlo_plot_files(), o.force);
    });

  const sid::Kinematics<double> truth = sid::app::paper_study_truth(options.theta);
  if (!json_to_stdout)
    std::cout << sid::app::montecarlo_header(options, truth.size()) << std::flush;

  sid::app::ProgressBar bar(kName, "runs", !o.quiet && sid::app::stderr_is_terminal());
  options.progress = [&bar](int done, int total) { bar.update(done, total); };
  sid::MonteCarloResult result;
  try {
    result = sid::run_monte_carlo(truth, options);
  } catch (...) {
    bar.finish();
    throw;
  }
  bar.finish();

  if (!json_to_stdout)
    std::cout << sid::app::montecarlo_tables(result) << "\n"
              << sid::app::montecarlo_wall_line(result) << std::flush;

  if (!o.json.empty()) {
    sid::app::write_json(o.json, sid::app::montecarlo_json(result, options, truth.size()));
    if (!o.quiet && !json_to_stdout) std::cerr << kName << ": wrote " << o.json << "\n";
  }
  if (!o.csv_dir.empty()) {
    sid::app::write_montecarlo_csv(o.csv_dir, result);
    if (!o.quiet)
      std::cerr << kName << ": wrote the estimates of every run into " << o.csv_dir << "\n";
  }
  if (!o.plots.empty())
    report_plots(o, sid::app::write_montecarlo_plots(o.plots, truth, result, options));
  return sid::app::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return study(options); });
}
