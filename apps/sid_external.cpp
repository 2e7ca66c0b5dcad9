// sid_external: the torque the outside applies to an identified arm, and its contacts, from a
// log of the arm's angles and drive torques.

#include <CLI/CLI.hpp>
#include <string>

#include "app.hpp"
#include "external_app.hpp"

namespace {

constexpr const char* kName = "sid_external";

constexpr const char* kDescription =
    "The torque the outside applies at each joint of an identified arm, and the contacts it\n"
    "makes, from a log of its angles and drive torques: tau_ext with\n"
    "M(q) qdd + c(q, qd) + g(q) + drive terms = tau_motor + tau_ext.\n";

constexpr const char* kFooter = R"(
The arm: --model ARM.json, written by sid_identify --robot FILE --json ARM.json on logs
without contact, with the same --robot, --base, --tip and --transmission. Its physically
consistent parameters are used (each link a real body).

Methods:
  observer (default)  the generalized-momentum observer: p = M(q) qd,
                      r = K (p - p(0) - integral of (tau + r - beta) dt), beta = g + friction
                      - C^T qd; r follows tau_ext through a first-order lag of rate K [1/s]
                      (--gain; default 300 /s, at most half the sampling rate and no
                      faster than the rates: 2 pi x their slowest cutoff). No
                      acceleration, so no differentiated encoder noise. The same observer is
                      the library's sid::MomentumObserver, for a real-time loop. Offline, the
                      whole log at hand, the same lag run backwards in time then cancels the
                      observer's delay (a zero-phase filter of rate K).
  residual            ID(q, qd, qdd) - tau with the spline's accelerations: no lag, more noise.
Rates come from a smoothing spline of the angles at the cutoff GCV chooses for each joint (as
much of the motion as the angle noise lets through), or, when the log is a measured one (angles
on a grid, encoder counts, or that GCV leaves unsmoothed: GCV takes their error for motion), at
the fit's cutoffs scaled by the half octave (1/2 to 4) at which the model best predicts this
log's torque; --cutoff HZ or --cutoff fit chooses. The torque is taken as logged.

Contacts: a joint is in contact where |tau_ext| exceeds --threshold times the fit's residual RMS
on its own logs (as recorded): the model's own error sets what counts as a contact; where this
estimate's robust spread (1.4826 MAD) is larger, as with coarse encoders, it does. Excursions
shorter than --min-duration are left out; contacts closer than --merge-gap are one; none is
looked for within --skip of the log's ends. An excursion beyond a joint's effort limit (the
URDF's <limit effort>) is no contact but the model's failure: it is listed apart, with a warning.

Outputs: the report on standard output; -o EXT.csv: t,tau_ext1..taun,contact; --json: the
thresholds, the gain, contacts [{start, end, joints, peak}] and beyond_effort_limit; --plots DIR: one plot per joint
(gnuplot; without it the data and scripts are written).

Exit codes: 0 success, 2 bad options or input (message on standard error), 1 internal error.

Examples:
  sid_identify --robot ur5.urdf --json arm.json run1.csv run2.csv
  sid_external --robot ur5.urdf --model arm.json -o ext.csv --json contacts.json log.csv
  sid_external --robot ur5.urdf --model arm.json --method residual --plots ext_plots log.csv
)";

void define_options(CLI::App& cli, sid::app::ExternalOptions& o) {
  cli.footer(kFooter);
  cli.add_option("--robot", o.chain.robot, "the robot description (URDF or DH table)")
      ->required()
      ->check(CLI::ExistingFile);
  cli.add_option("--base", o.chain.base, "URDF: the chain's first link (default: the root)");
  cli.add_option("--tip", o.chain.tip, "URDF: the chain's last link (default: the one end link)");
  cli.add_option("--hold", o.chain.hold, "URDF: JOINT=VALUE,... for joints off the chain");
  cli.add_option("--transmission", o.chain.transmission,
                 "the drives' transmission (as sid_identify): the log is motor-side")
      ->check(CLI::ExistingFile);
  cli.add_option("--model", o.model, "ARM.json: sid_identify --robot --json of the arm")
      ->required()
      ->check(CLI::ExistingFile);
  cli.add_option("--columns", o.chain.columns,
                 "t=NAME,q1=NAME,...,tau1=NAME: the log's column names if not t,q1..,tau1..");
  cli.add_option("--method", o.method, "observer or residual")->capture_default_str();
  cli.add_option("--gain", o.gain,
                 "the observer's rate K [1/s] (default 300, at most half the sampling rate and "
                 "2 pi x the slowest rate cutoff)");
  cli.add_option(
      "--cutoff", o.cutoff,
      "smooth the angles at this cutoff before taking rates [Hz], one or one per joint, or "
      "'fit' for the fit's (default: GCV's; for a measured log, the fit's scaled to this log)");
  cli.add_option("--threshold", o.threshold_factor,
                 "contact where |tau_ext| > this times the fit's residual RMS")
      ->capture_default_str();
  cli.add_option("--min-duration", o.min_duration, "shortest contact [s]")->capture_default_str();
  cli.add_option("--skip", o.skip,
                 "look for no contact this long at each end of the log, where the spline's "
                 "rates are least sure [s]")
      ->capture_default_str();
  cli.add_option("--merge-gap", o.merge_gap, "contacts closer than this are one [s]")
      ->capture_default_str();
  cli.add_option("-o,--output", o.output, "write t,tau_ext1..n,contact to this CSV ('-': stdout)");
  cli.add_option("--json", o.json, "write the contacts and thresholds as JSON ('-': stdout)");
  cli.add_option("--plots", o.plots, "write one plot per joint into this directory");
  cli.add_flag("--force", o.force, "overwrite output files that exist");
  cli.add_option("RUN", o.chain.inputs, "the log: t,q1..qn,tau1..taun (CSV)")
      ->required()
      ->check(CLI::ExistingFile);
}

}  // namespace

int main(int argc, char** argv) {
  sid::app::ExternalOptions options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return sid::app::run_external(options, kName); });
}
