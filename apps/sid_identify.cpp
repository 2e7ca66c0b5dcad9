// sid_identify: identify the 7 dynamic parameters of the two-link arm from a CSV log of joint
// angles and torques (derivatives by raw differences, filtered differences or the smoothing
// spline, then least squares) and print the estimate with its statistics.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <sid/cvode/instrumental_variables.hpp>
#include <sid/identify.hpp>
#include <sid/identify_runs.hpp>
#include <sid/model/effects.hpp>
#include <sid/physical_consistency.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sstream>
#include <stdexcept>
#include <initializer_list>
#include <string>
#include <vector>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "csv.hpp"
#include "drive_gains_app.hpp"
#include "payload_app.hpp"
#include "runs_report.hpp"
#include "windows_app.hpp"

namespace {

constexpr const char* kName = "sid_identify";

constexpr const char* kDescription =
    "Identify the dynamic parameters of an arm from measured joint angles and torques of one or\n"
    "several runs: the paper's two-link arm (theta1..theta7), or any serial chain with --robot\n"
    "URDF/DH (its links' base parameters and per-drive friction, offset and rotor inertia).\n"
    "Each angle is smoothed by a cubic smoothing spline, velocities and accelerations are taken\n"
    "from it, tau = Z(q, qd, qdd) theta is solved by least squares, and the estimate is printed\n"
    "with its standard deviations, fit statistics, its physical plausibility and, for runs kept\n"
    "aside (--validate), how well it predicts their torques. The options below are grouped by\n"
    "the arm they apply to.\n";

constexpr const char* kFooter = R"(
Input: CSV files (one per run) with a header row and the columns t [s], q1, q2 [rad], tau1,
tau2 [N m] in any order (other columns are ignored; --columns maps other names, e.g.
--columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2); lines starting with
'#' are comments. t must be strictly increasing (the grid may be non-uniform for css); every cell
a finite number. The raw and filtered methods need uniform sampling. q1 is measured from the
downward vertical, q2 relative to link 1 (the sid_simulate convention).

Several runs (torque-cv, the default): each run is smoothed on its own time grid, and the
equations of all runs are stacked into one least-squares fit. One cutoff frequency serves all
runs and joints: the spline's penalty lambda = 1 / (h (2 pi f_c)^4), h the run's mean sampling
period, halves a sinusoid at f_c. Without --cutoff, f_c is the one (on a grid of 4 per octave
over 0.25..64 Hz) whose estimate best predicts torques it was not fitted on: each run is cut
into 5 contiguous blocks, each block is predicted by the fit of all the others, and the RMS of
those held-out residuals is minimised. Unlike gcv it needs no independent angle noise, so it
does not interpolate quantised encoder angles. Samples within 0.1 s of each end of a run
(--skip for the start) are not used: the natural spline's ends distort qdd.
  --effects ID,...   adds effect terms to the model: coulomb_jX, stribeck_jX,
                     torque_offset_jX, angle_offset_qX, armature_jX, spring_jX (X = 1, 2)
  --validate RUN     predicts the torques of a run not used in the fit (same cutoff and skips)
                     and prints the RMS error per joint (repeatable)
  --reference-theta  prints the same errors for a given parameter vector (e.g. a published
                     model), on the fitted and the validation runs
  --gear-ratio       with armature_j2: the rotor of drive 2, carried by link 1, adds
                     (gr^2+1) Ir, -gr Ir, gr^2 Ir to M11, M12, M22; with theta1 and theta2 free
                     this is exactly an armature Ia = (gr^2 + gr) Ir on joint 2, so
                     Ir = Ia / (gr^2 + gr) is reported with its standard deviation.
Uncertainty: the std column is the HAC standard deviation (Newey-West, prewhitened, per run):
residuals on smoothed measured data are correlated in time, and the least-squares std
(ls_std in the JSON) is then several times too small. With three runs or more, each run is
also left out in turn: the column std (runs) is the jackknife over those fits, and the runs
table shows how well the others' fit predicts each run (columns "left out").
The physical plausibility of the estimate is always checked: the mass matrix positive definite
for every q2 (on a 1-degree grid) and theta4..theta7, Coulomb levels and armatures >= 0. If it
fails, the nearest physically consistent estimate (least squares under those constraints) is
printed as well, labelled as such.

Methods (--method):
  raw       forward differences qd_i = (q_{i+1} - q_i)/Ts, qdd likewise (the last 2 samples
            have no qdd and are dropped)
  filtered  the same differences, then q, qd, qdd each filtered forward-backward by Butterworth
            low-pass filters (orders 3, 3, 4; cut-offs 0.05, 0.015, 0.01 of Nyquist, the paper's
            10, 3, 2 Hz at 400 Hz sampling)
  css       (default) cubic smoothing spline per joint (Reinsch); derivatives analytic. How
            much it smooths is chosen by --smoothing (below).

Smoothing of css (--smoothing):
  torque-cv     (default without --sigma-q, --S, --lambda and with --estimator ls) the cutoff
                chosen by cross-validating the torque prediction; see "Several runs" above.
  gcv           (default with --estimator wls or iv) the penalty form
                sum((g(t_i) - q_i)^2) + lambda * integral(g''^2) with lambda chosen from the
                data by minimising generalized cross-validation, so no noise level is needed;
                the residuals then estimate the angle noise: sigma_hat = sqrt(F / (n - tr A))
                [rad], with tr A the equivalent degrees of freedom of the fit. One lambda per
                joint for the whole record, chosen on the samples with t >= t_0 + 0.125 s (or
                t_0 + skip/2 if that is smaller) so the start transient does not pull it down.
  cv            the same with ordinary leave-one-out cross-validation.
  s-constraint  (default with --sigma-q or --S; the paper's choice) the smoothest g with
                sum(((g(t_i) - q_i) / dq)^2) <= S. dq = --sigma-q is the standard deviation of
                the angle noise [rad] (one value for both joints, or two comma-separated);
                S = --S, default the number of samples n. With --S alone dq = 1 (unit
                weights) and S is a sum of squared residuals [rad^2]: --S n*sigma^2 is the
                same constraint as --sigma-q sigma (n = number of samples in the file).
  lambda        the penalty form with a given --lambda V > 0 and weights 1/dq^2 (needs
                --sigma-q): SciPy's make_smoothing_spline(t, q, w=1/dq^2, lam=V). lambda = 1/p.
                --lambda alone implies --smoothing lambda.
--S goes only with s-constraint and --lambda only with lambda; gcv and cv take neither, nor
--sigma-q (they estimate the noise level themselves).

Estimator (--estimator):
  ls   (default) ordinary least squares (Householder QR of the column-scaled regressor)
  wls  Gautier's IDIM-WLS: a first least-squares fit, then each joint's equations weighted by
       1/sigma_j^2, sigma_j^2 = that joint's residual variance; the relative standard
       deviations are then Gautier's
  iv   IDIM-IV (Janot et al.): the least-squares estimate, then instrumental variables: the
       instruments are the regressor at the states of a CVODE simulation of the current
       estimate, driven by the measured torque (smoothed by GCV, so its noise does not enter
       the instruments) and restarted every 0.5 s from the estimated state; iterated until
       theta changes by < 1e-4 relative (at most 10 iterations; the count is reported). It
       removes the bias that noise in the estimated accelerations causes (theta2 about -3 %
       at sigma_q^2 = 1e-4 with --smoothing gcv). Because it does, gcv and cv then smooth
       with 0.25 x the lambda they choose: less smoothing bias, more noise, which IV removes.
       Standard deviations from sigma^2 (W^T X)^-1 W^T W (X^T W)^-1.

Window: samples with t < t_0 + --skip are not used (the start transient). Default 0.25 s
(torque-cv: 0.1 s), for the filtered method 1.7475 s (filter start-up).

Output (standard output): per parameter the estimate, its standard deviation (from the residual
variance and (X^T X)^-1), the relative standard deviation in %, the unit and, with --true, the
true value and the error 100 (estimate - true)/|true| in %; then the residual RMS per joint
[N m], the samples used, the 2-norm condition number of the column-scaled regressor, for css the
smoothing per joint (Reinsch's p, lambda = 1/p, tr A = the equivalent degrees of freedom, and
for gcv/cv the estimated angle noise sigma_hat [rad]), and any warning.
Units: theta1..theta3 [kg m^2], theta4, theta5 [kg m], theta6, theta7 [N m s/rad].

--json FILE also writes the result as JSON: names, units, theta, std, rel_std_pct,
residual_rms, condition_number, ill_conditioned, warning, method, estimator, iv_iterations
and iv_converged (null unless iv), samples_used, samples_total,
skip, smoothing_p (null unless css), sigma_q (null unless s-constraint or lambda), S (null
unless s-constraint), smoothing (null unless css): {mode, lambda, trace, sigma_hat, p,
cross_validation_skip}, each but mode a [joint 1, joint 2] array (null where not computed:
sigma_hat outside gcv/cv), and with --true also true and error_pct.

With torque-cv the JSON has: input (the files), names, units, theta, std (HAC), rel_std_pct,
ls_std, jackknife_std (null with fewer than 3 runs), residual_rms, condition_number, ill_conditioned, warning, samples_used, skip, skip_end,
smoothing {mode, cutoff_hz, chosen, folds_per_run, grid_hz, cross_validation_rms, lambda (per
run)}, runs [{file, samples_total, samples_used, lambda, residual_rms, left_out_prediction_rms
[, reference_residual_rms]}],
validation [{file, samples, residual_rms, nominal_residual_rms [, reference_residual_rms]}],
physical {plausible, mass_matrix_positive_definite, min_mass_eigenvalue, min_mass_eigenvalue_q2,
negative_parameters, consistent_theta (null when plausible), ...}, reference_theta and, with
--gear-ratio, rotor {gear_ratio, Ir, Ir_std, supported}.

Exit codes: 0 success, 2 bad input or options, or a regressor whose columns are linearly
dependent (the data do not excite every parameter; the message names the columns), 1 internal
error.

Any serial chain (--robot FILE): a URDF (the chain from --base to --tip, defaults the root
and the one end link) or a DH table (docs/serial-arms.md). Runs have columns t, q1..qn,
tau1..taun in the joint order of the description (--columns renames them, e.g.
t=time,q1=pos_1,tau1=effort_1). The model is the links' rigid-body parameters plus, per joint,
viscous friction and armature (rotor inertia), which every geared drive has, and the drive
terms --effects adds to them (default coulomb,offset; also coulomb_asymmetry, spring, stribeck
(width 0.1 rad/s)): --effects coulomb fits viscous, Coulomb and armature. --effects none fits
rigid bodies only; --no-default-effects makes --effects the whole list (e.g.
--no-default-effects --effects coulomb). The report and the JSON (drive_terms,
drive_term_parameters) list the terms fitted. A --transmission file (YAML: gear_ratios,
couplings, joint_zero; or a URDF with ros_control <transmission> elements, e.g. the robot's
own) makes the runs motor-side and adds the coupled motors' drive terms (no offset). Each
joint's smoothing cutoff is chosen by held-out torque prediction (or --cutoff F for all), the
torque goes through its joint's smoother too, and equations at rest are left out
(--rest-fraction). The report names each base parameter by the combination it stands for,
with its HAC standard deviation;
--validate RUN and --validate-fraction F report how well held-out torques are predicted, over
the fit's equations and over the log as recorded. Physically consistent links (each a real
body, near the URDF's values where the data say little: a prior toward them whose weight is
reported, set against the estimate's uncertainty with the residuals' correlation in time) are
fitted too, and --write-urdf OUT.urdf writes them, with each joint's viscous and Coulomb
friction as its <dynamics damping friction>, into a copy of the URDF, and --write-mjcf OUT.xml
into a MuJoCo model (armature and stiffness too, a motor per joint; meshes MuJoCo cannot read
are left out and listed in its first comment); when that fit does
not converge, or real bodies cannot reproduce the estimate within its uncertainty (a drive term
the data have is missing), the report says so, with the torque error the real bodies add;
both refuse them (exit 2) when the fit did not converge or they add more than 10 %
(--strict-consistency: whenever they do not reproduce the estimate), measured on the held-out
runs, else by blocked cross-validation (--consistency-folds: each span of time predicted by the
fit of the others and by its real bodies).
--estimator wls weights each joint by its residual variance; --estimator iv refines by IDIM-IV over all runs: angles smoothed by their
GCV spline, torque as measured, least squares, then instruments from simulations (0.5 s
segments from the smoothed state) of the physically consistent arm nearest to each estimate.
On a simulated TX40 with rotors (3 runs each) it predicts the true torque to 0.19 % where ls
does to 0.32 % at sigma_q = 1e-2 rad, 0.087 against 0.105 % at 1e-3 rad, and as well (0.055
against 0.054 %) at 1e-4 rad; on the real TX40 run the held-out 30 % are predicted to 6.83 %
against 6.94 %.
When the iteration does not converge, or leaves more than 1.5 times least squares' residual,
the simulated motion does not follow the measured one (the instruments are weak): the ls fit
is reported, with a warning. The JSON has joint_names, parameter_names, theta, std_dev,
residual_rms, relative_residual, their *_measured counterparts, validation [{file,
residual_rms, relative_residual, ...}] and with iv: iv_applied, iv_iterations, iv_converged,
iv_residual_ratio, iv_message, least_squares_theta, iv_fit (per run; the top-level residuals
are then the first run's), drive_terms, drive_term_parameters and physically_consistent {theta,
beta, relative_residual, converged, iterations, prior_weight, correlation_inflation}.

Drift (--robot --window 10min LOG...; --window log: each log one window, e.g. one a day):
each window is identified on its own (its cutoffs, base parameters, HAC std) and each
parameter's estimates are fitted by a line over the operating time (the logs end to end);
the report lists the windows and per parameter the slope [/h], its std (inflated by the Birge
ratio when the windows scatter more than their std allow) and 'drifts' when |slope| > 3 std
with 4 windows or more, and still so with any one window left out.
--report FILE.html plots each drive term's estimate and +-2 std over the operating time.
The JSON has windows [{source, start, end, operating_time_h, cutoff_hz, relative_residual,
theta, std_dev}] (theta in the order of parameters, null where a window regroups it) and
parameters [{name, combination, windows, mean, slope_per_hour, slope_std_dev, birge_ratio,
drifts}].

Drive gains (--robot --currents): the logs' tau columns are motor currents [A], not torques.
--payload-run LOADED.csv is a log with a load of known inertia (--known-payload m,cx,cy,cz or
m,cx,cy,cz,ixx,iyy,izz,ixy,ixz,iyz: mass [kg], centre of mass [m] and inertia about it [kg m^2]
in the frame of the --tip link, e.g. tool0, whatever fixed joints lie between it and the last
moving link; --payload-frame LINK names another link fixed to that one; a DH table: its last
link's frame) fixed to the tip; the RUN files are logs without it. The arm's base parameters
and each motor's gain K [N m/A] are fitted together (Gautier and Briot): K i = Y theta without
the load and K i = Y theta + Y_tip phi with it. Without the known load the gains' scale is not
identifiable; a motor the load's torque does not reach (a point mass on its axis) keeps its
gain free, and the tool says which. Then every run is converted to torques (K i, minus the
load's torque on LOADED.csv) and identified as above; the report and the JSON add the gains with
their HAC std (drive_gains [{joint, gain, std}], drive_gain_fit with the load and its frame).

Payload (--robot --payload-of ARM.json): the RUN files carry an unknown load; with the arm of
ARM.json held, its mass, centre of mass and inertia are identified and reported in the frame of
the --tip link (or --payload-frame's; a DH table: its last link's), the std of the centre of
mass turned into that frame with it.

Examples:
  sid_identify --robot ur5.urdf --tip tool0 --currents --known-payload 3,0.03,-0.02,0.06 \
      --payload-run loaded.csv --json fit.json unloaded.csv
  sid_identify --robot ur5.urdf --tip tool0 --payload-of fit.json --json load.json loaded.csv
  sid_identify log.csv
  sid_identify --columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2 \
      --effects coulomb_j1,coulomb_j2 --validate run3.csv run1.csv run2.csv
  sid_identify --sigma-q 1e-3 log.csv
  sid_identify --smoothing cv --json result.json log.csv
  sid_identify --method filtered --json result.json log.csv
  sid_identify --estimator iv log.csv
  sid_identify --robot arm.urdf --validate run2.csv --json fit.json run1.csv
  sid_identify --robot tx40.urdf --transmission tx40.yaml --validate-fraction 0.3 motor_log.csv
  sid_identify --robot arm.urdf --estimator iv run1.csv run2.csv
  sid_identify --robot arm.urdf --effects coulomb,stribeck run1.csv
  sid_identify --robot arm.urdf --window log --json drift.json day1.csv day2.csv day3.csv
  sid_simulate | sid_identify -
)";

const char* const kUnits[7] = {"kg m^2", "kg m^2",    "kg m^2",   "kg m",
                               "kg m",   "N m s/rad", "N m s/rad"};

struct Options {
  sid::app::ChainIdentifyAppOptions chain;
  sid::app::DriveGainAppOptions gains;  ///< --currents, --known-payload, --payload-run
  std::vector<std::string> inputs;
  std::string columns;
  std::vector<std::string> validate;
  std::optional<double> cutoff;
  std::string effects;
  std::string reference_theta;
  std::string gear_ratio;
  std::string method = "css";
  std::string sigma_q;
  std::optional<double> S;
  std::string smoothing;
  std::optional<double> lambda;
  std::optional<double> skip;
  std::string estimator = "ls";
  std::string truth;
  std::string json;
  bool force = false;
  std::string payload_of;     ///< --payload-of: the arm held while the load is identified
  std::string payload_frame;  ///< --payload-frame: the link the load's frame is (default --tip)
};

void define_options(CLI::App& cli, Options& o) {
  cli.footer(kFooter);
  cli.add_option("--robot", o.chain.robot,
                 "identify any serial chain: its URDF or DH table (see the chain section "
                 "below); the runs then have columns t, q1..qn, tau1..taun")
      ->check(CLI::ExistingFile);
  cli.add_option("--base", o.chain.base, "--robot URDF: the chain's first link (default: root)");
  cli.add_option("--tip", o.chain.tip,
                 "--robot URDF: the chain's last link (default: the one end link)");
  cli.add_option("--hold", o.chain.hold,
                 "--robot URDF: JOINT=VALUE,... holds joints off the chain (a gripper past the "
                 "tip, a head on a branch) at VALUE [rad or m] instead of 0");
  cli.add_option("--transmission", o.chain.transmission,
                 "--robot: YAML with gear_ratios, couplings and joint_zero, or a URDF with "
                 "ros_control <transmission> elements; the runs are then motor-side (angles "
                 "and torques as the drives log them)")
      ->check(CLI::ExistingFile);
  cli.add_option("--validate-fraction", o.chain.validate_fraction,
                 "--robot: fit the first 1 - F of the one run, predict its last F");
  cli.add_option("--window", o.chain.window,
                 "--robot: identify each window of the logs on its own (600, 600s, 10min, 2h, "
                 "1d; 'log': each log whole) and report each parameter's drift over the "
                 "operating time (the logs laid end to end in the order given)");
  cli.add_option("--rest-fraction", o.chain.rest_fraction,
                 "--robot: leave out joint j's equations where |qd_j| < F RMS(qd_j) "
                 "(default 0.1)");
  cli.add_option("--payload-of", o.payload_of,
                 "--robot: ARM.json (this tool's --json on logs without the load): hold that arm "
                 "and identify the ten inertial parameters of a load fixed to the chain's tip "
                 "link from the runs, which carry it (mass, centre of mass and inertia in the "
                 "--tip link's frame, e.g. tool0, or --payload-frame's, with HAC std, a real "
                 "body); --json writes them under 'payload' (its 'frame' names the link), "
                 "--write-urdf a copy of the URDF with the load as link 'payload' fixed to the "
                 "tip")
      ->check(CLI::ExistingFile);
  cli.add_option("--write-urdf", o.chain.write_urdf,
                 "--robot URDF: write a copy of it with the physically consistent link "
                 "parameters and joint friction (refuses to overwrite without --force)");
  cli.add_option("--write-mjcf", o.chain.write_mjcf,
                 "--robot URDF: write a MuJoCo model of it (MJCF) with the physically consistent "
                 "links, each joint's damping, frictionloss, armature and stiffness, the "
                 "description's shapes and a motor per joint (refuses to overwrite without "
                 "--force)");
  cli.add_option("--report", o.chain.report,
                 "--robot: write the result as one self-contained HTML page (parameters and "
                 "std, torque errors, held-out prediction, the consistent model, plots per "
                 "joint; refuses to overwrite without --force)");
  cli.add_option("--torque-delay", o.chain.torque_delay,
                 "--robot: D [s]: the logs' torque lags their angles by D (servo currents and "
                 "positions over separate paths): each torque is paired with the angles' spline "
                 "D earlier (negative: the angles lag); |D| at most --skip");
  cli.add_option("--estimate-torque-delay", o.chain.estimate_torque_delay,
                 "--robot: MAX [s]: estimate how far the torque lags the angles, within ±MAX "
                 "(at most --skip), as the delay whose fit explains the torque best (every joint "
                 "smoothed at one cutoff); report it with its standard deviation and fit with it");
  cli.add_option("--consistency-folds", o.chain.consistency_folds,
                 "--robot without held-out runs: judge the consistent links' torque error by "
                 "blocked cross-validation over N spans of time, each predicted from the others "
                 "(default 5; 0: on the fitted equations, where least squares always wins)");
  cli.add_flag("--strict-consistency", o.chain.strict_consistency,
               "--write-urdf and --write-mjcf refuse real bodies that do not reproduce the "
               "estimate within its uncertainty too (by default only those that add more than "
               "10 % to the torque error, held-out where there is a held-out run)");
  cli.add_option("--coulomb-epsilon", o.chain.coulomb_epsilon,
                 "--robot: Coulomb friction as tanh(qd / EPS) [rad/s] (default 0.01; 0: sign)");
  cli.add_flag("--currents", o.gains.currents,
               "--robot: the logs' tau columns are motor currents [A]; the drive gains [N m/A] "
               "are found from a known payload (--known-payload, --payload-run), then the arm "
               "is identified in N m; see the chain section below");
  cli.add_option("--known-payload", o.gains.known_payload,
                 "--currents: the load on the tip link in --payload-run, m,cx,cy,cz or "
                 "m,cx,cy,cz,ixx,iyy,izz,ixy,ixz,iyz: mass [kg], centre of mass [m] and inertia "
                 "about it [kg m^2] in the --tip link's frame, e.g. tool0, or --payload-frame's "
                 "(default inertia 0: a point mass)");
  cli.add_option("--payload-frame", o.payload_frame,
                 "--payload-of, --known-payload: LINK, the URDF link whose frame the load is "
                 "reported or given in (default: the --tip link); any link fixed to the "
                 "chain's last moving link, that link included. A DH table has only its last "
                 "link's frame");
  cli.add_option("--payload-run", o.gains.payload_run,
                 "--currents: LOADED.csv, the log with the known payload (the RUN files are "
                 "logs without it)")
      ->check(CLI::ExistingFile);
  cli.add_option("RUN", o.inputs,
                 "input CSV file(s), one per measured run ('-' reads standard input); several runs "
                 "are fitted together")
      ->required();
  cli.add_option("--columns", o.columns,
                 "map sid's columns to the file's names, e.g. "
                 "t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2");
  cli.add_option("--validate", o.validate,
                 "a run not used in the fit: report how well the estimate predicts its torques "
                 "(repeatable)")
      ->allow_extra_args(false);
  cli.add_option(
      "--cutoff", o.cutoff,
      "torque-cv: smooth at this cutoff [Hz] instead of choosing it by cross-validation");
  cli.add_option("--effects", o.effects,
                 "effect terms added to the model, comma-separated. Two-link (torque-cv): ids "
                 "such as coulomb_j1,coulomb_j2,torque_offset_j1,armature_j2. --robot: drive "
                 "term kinds added on every joint to viscous friction and armature, which are "
                 "always fitted (default coulomb,offset; also coulomb_asymmetry, spring, "
                 "stribeck); none: rigid bodies only");
  cli.add_flag("--no-default-effects", o.chain.no_default_effects,
               "--robot: fit only the drive terms --effects names (viscous and armature too only "
               "when listed)");
  cli.add_option("--reference-theta", o.reference_theta,
                 "torque-cv: a reference parameter vector (one value per model parameter, "
                 "comma-separated): its torque prediction errors are shown beside the estimate's");
  cli.add_option("--gear-ratio", o.gear_ratio,
                 "torque-cv with armature_j2: gear ratios gr1,gr2 (or one for both); reports the "
                 "rotor inertia of drive 2 carried by link 1, Ir = Ia / (gr2^2 + gr2)");
  cli.add_option("-m,--method", o.method, "derivative method: raw, filtered or css")
      ->capture_default_str();
  cli.add_option("--sigma-q", o.sigma_q,
                 "css: standard deviation dq of the angle noise [rad], one value or two "
                 "(joint 1,joint 2); selects --smoothing s-constraint unless a mode is given");
  cli.add_option("--S", o.S,
                 "css s-constraint: sum(((g - q)/dq)^2) <= S, S >= 0 (default: number of "
                 "samples)");
  cli.add_option("--smoothing", o.smoothing,
                 "css: torque-cv, s-constraint, gcv, cv or lambda (default: s-constraint with "
                 "--sigma-q or --S, lambda with --lambda, gcv with --estimator wls or iv, "
                 "otherwise torque-cv)");
  cli.add_option("--lambda", o.lambda,
                 "css lambda mode: penalty weight lambda > 0 with weights 1/dq^2 (needs "
                 "--sigma-q)");
  cli.add_option("--skip", o.skip,
                 "drop samples with t < t_0 + SKIP [s] (default 0.25; filtered: 1.7475)");
  cli.add_option("--true", o.truth,
                 "true theta1..theta7, comma-separated: adds the true value and the error in %");
  cli.add_option("--estimator", o.estimator, "ls (default), wls or iv; see below");
  cli.add_option("--json", o.json, "also write the result as JSON to FILE ('-': standard output)");
  cli.add_flag("--force", o.force, "overwrite the --json file if it exists");
  const auto group = [&](const std::string& name, std::initializer_list<const char*> options) {
    for (const char* option : options) cli.get_option(option)->group(name);
  };
  group("Every arm", {"--columns", "--validate", "--cutoff", "--effects", "--skip", "--estimator",
                      "--json", "--force"});
  group("Any serial chain (--robot)", {"--robot",
                                       "--base",
                                       "--tip",
                                       "--hold",
                                       "--transmission",
                                       "--validate-fraction",
                                       "--rest-fraction",
                                       "--no-default-effects",
                                       "--coulomb-epsilon",
                                       "--write-urdf",
                                       "--write-mjcf",
                                       "--report",
                                       "--torque-delay",
                                       "--consistency-folds",
                                       "--strict-consistency",
                                       "--payload-of",
                                       "--payload-frame",
                                       "--currents",
                                       "--known-payload",
                                       "--payload-run"});
  group("The paper's two-link arm (without --robot)",
        {"--method", "--smoothing", "--sigma-q", "--S", "--lambda", "--true", "--reference-theta",
         "--gear-ratio"});
}

std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

std::string fixed(const char* format, double v) {
  if (std::isnan(v)) return "n/a";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

sid::IdentifyOptions finish_window(const Options& o, sid::IdentifyOptions options);

sid::IdentifyOptions make_options(const Options& o) {
  using sid::app::require;
  sid::IdentifyOptions options;
  try {
    options.method = sid::parse_derivative_method(o.method);
  } catch (const std::invalid_argument&) {
    throw sid::app::InputError("--method: unknown method '" + o.method +
                               "' (expected raw, filtered or css)");
  }
  const bool css = options.method == sid::DerivativeMethod::SmoothingSpline;
  if (o.S) {
    require(std::isfinite(*o.S) && *o.S >= 0.0,
            "--S must be a finite number >= 0, got " + short_number(*o.S));
    options.S = *o.S;
  }
  if (o.lambda)
    require(std::isfinite(*o.lambda) && *o.lambda > 0.0,
            "--lambda must be a finite number > 0, got " + short_number(*o.lambda));
  if (!o.sigma_q.empty()) {
    const std::vector<double> s = sid::app::parse_doubles(o.sigma_q, "--sigma-q");
    require(s.size() == 1 || s.size() == 2,
            "--sigma-q needs 1 value or 2 (joint 1,joint 2), got " + std::to_string(s.size()));
    for (std::size_t j = 0; j < s.size(); ++j)
      require(s[j] > 0.0, "--sigma-q must be > 0 [rad], got " + short_number(s[j]) +
                              (s.size() == 2 ? " (joint " + std::to_string(j + 1) + ")" : ""));
    options.sigma_q = sid::Vector2<double>(s.front(), s.back());
  }
  // The smoothing mode: given, or implied by the other options.
  sid::SmoothingMode mode = sid::SmoothingMode::Gcv;
  if (!o.smoothing.empty()) {
    try {
      mode = sid::parse_smoothing_mode(o.smoothing);
    } catch (const std::invalid_argument&) {
      throw sid::app::InputError("--smoothing: unknown mode '" + o.smoothing +
                                 "' (expected torque-cv, s-constraint, gcv, cv or lambda)");
    }
  } else if (o.lambda) {
    mode = sid::SmoothingMode::Lambda;
  } else if (o.S || !o.sigma_q.empty()) {
    mode = sid::SmoothingMode::SConstraint;
  }
  options.smoothing = mode;
  if (!css) {
    if (o.S || !o.sigma_q.empty() || !o.smoothing.empty() || o.lambda)
      std::cerr << kName
                << ": note: --sigma-q, --S, --smoothing and --lambda only apply to --method "
                   "css; ignored for "
                << o.method << "\n";
    return finish_window(o, options);
  }
  const std::string name = sid::smoothing_mode_name(mode);
  switch (mode) {
    case sid::SmoothingMode::SConstraint:
      require(!o.lambda,
              "--lambda does not apply to --smoothing s-constraint (use --S, or "
              "--smoothing lambda)");
      require(o.S || !o.sigma_q.empty(),
              "--smoothing s-constraint needs --sigma-q V: the standard deviation of the angle "
              "noise [rad] (or --S V to give the constraint directly, with unit weights); "
              "without either use --smoothing gcv");
      if (o.sigma_q.empty()) options.sigma_q = sid::Vector2<double>::Ones();
      break;
    case sid::SmoothingMode::Gcv:
    case sid::SmoothingMode::Cv:
      require(!o.S, "--S does not apply to --smoothing " + name +
                        " (it chooses lambda from the data); use --smoothing s-constraint");
      require(!o.lambda, "--lambda does not apply to --smoothing " + name +
                             " (it chooses lambda from the data); use --smoothing lambda");
      require(o.sigma_q.empty(),
              "--sigma-q does not apply to --smoothing " + name +
                  " (it estimates the noise level from the data); use --smoothing "
                  "s-constraint or lambda");
      break;
    case sid::SmoothingMode::Lambda:
      require(o.lambda.has_value(),
              "--smoothing lambda needs --lambda V (the penalty weight, > 0)");
      require(!o.S, "--S does not apply to --smoothing lambda (use --smoothing s-constraint)");
      require(!o.sigma_q.empty(),
              "--smoothing lambda needs --sigma-q V: the weights are 1/sigma_q^2 [rad^-2]");
      options.lambda = *o.lambda;
      break;
  }
  return finish_window(o, options);
}

// The window options (--skip), last step of make_options.
sid::IdentifyOptions finish_window(const Options& o, sid::IdentifyOptions options) {
  using sid::app::require;
  if (o.skip) {
    require(std::isfinite(*o.skip) && *o.skip >= 0.0,
            "--skip must be a finite number >= 0 [s], got " + short_number(*o.skip));
    options.skip = *o.skip;
    options.filtered_skip = *o.skip;
    // GCV/CV fit from t_0 + cross_validation_skip: keep that inside the window, with room for
    // the end effect of the natural spline.
    options.cross_validation_skip = std::min(options.cross_validation_skip, 0.5 * *o.skip);
  }
  return options;
}

// [joint 1, joint 2] with null for NaN (and for infinity: JSON has neither).
nlohmann::json json_pair(const sid::Vector2<double>& v) {
  nlohmann::json out = nlohmann::json::array();
  for (int k = 0; k < 2; ++k)
    out.push_back(std::isfinite(v[k]) ? nlohmann::json(v[k]) : nlohmann::json(nullptr));
  return out;
}

// tr A of the s-constraint and lambda fits, which the pipeline does not compute: the sum of
// the leverages of the penalty form at the p found, on the same grid and weights (O(n)).
void fill_trace(const sid::Trajectory<double>& data, const sid::IdentifyOptions& options,
                sid::SmoothingReport& report) {
  if (options.method != sid::DerivativeMethod::SmoothingSpline) return;
  if (options.smoothing != sid::SmoothingMode::SConstraint &&
      options.smoothing != sid::SmoothingMode::Lambda)
    return;
  const sid::SmoothingSpline<double> spline(data.t);
  const auto n = static_cast<double>(data.size());
  for (int j = 0; j < 2; ++j) {
    if (!std::isnan(report.trace[j])) continue;
    const double p = report.p[j];
    if (p == 0.0) {
      report.trace[j] = 2.0;  // the straight line
    } else if (std::isinf(p)) {
      report.trace[j] = n;  // interpolation
    } else if (p > 0.0) {
      try {
        const Eigen::VectorXd dq = Eigen::VectorXd::Constant(data.size(), options.sigma_q[j]);
        report.trace[j] = spline.hat_diagonal(dq, p).sum();
      } catch (const std::exception&) {
        // leave NaN ("n/a"): the report is still useful without it
      }
    }
  }
}

// The least-squares warning without its "sid::least_squares: warning: " prefix.
std::string warning_text(const std::string& message) {
  const std::string marker = "warning: ";
  const auto at = message.find(marker);
  return at == std::string::npos ? message : message.substr(at + marker.size());
}

// What the IV step did (iterations < 0: not run).
struct IvOutcome {
  int iterations = -1;
  bool converged = false;
};

struct Report {
  std::string text;
  nlohmann::json json;
};

Report make_report(const sid::IdentifyOptions& options, const sid::app::CsvTable& table,
                   const sid::Identification& id,
                   const std::optional<sid::TwoLinkParameters<double>>& truth,
                   const std::string& estimator, const IvOutcome& iv, double t_start) {
  const auto& fit = id.fit;
  const std::string input = table.source == "-" ? "<stdin>" : table.source;
  const std::vector<std::string> names = sid::two_link_parameter_names();
  const bool css = options.method == sid::DerivativeMethod::SmoothingSpline;
  const double skip = options.method == sid::DerivativeMethod::FilteredDifference
                          ? options.filtered_skip
                          : options.skip;
  Eigen::VectorXd error_pct;
  if (truth) {
    error_pct.resize(static_cast<Eigen::Index>(names.size()));
    for (Eigen::Index k = 0; k < error_pct.size(); ++k)
      error_pct[k] = (*truth)[k] != 0.0
                         ? 100.0 * (fit.theta[k] - (*truth)[k]) / std::abs((*truth)[k])
                         : std::nan("");
  }

  std::ostringstream out;
  out << kName << ": " << input << ", method " << sid::method_name(options.method) << ", "
      << id.samples_used() << " of " << table.rows()
      << " samples used (t >= " << short_number(id.kinematics.t[0]) << " s), estimator "
      << estimator;
  if (iv.iterations >= 0)
    out << " (" << iv.iterations << (iv.iterations == 1 ? " iteration, " : " iterations, ")
        << (iv.converged ? "converged" : "not converged") << ")";
  out << "\n\n";
  char line[256];
  std::snprintf(line, sizeof line, "%-9s %15s %12s %11s  %-10s", "parameter", "estimate", "std",
                "rel.std %", "unit");
  out << line;
  if (truth) {
    std::snprintf(line, sizeof line, " %15s %10s", "true", "error %");
    out << line;
  }
  out << "\n";
  for (int k = 0; k < 7; ++k) {
    std::snprintf(line, sizeof line, "%-9s %15s %12s %11s  %-10s",
                  names[static_cast<std::size_t>(k)].c_str(), fixed("%.8g", fit.theta[k]).c_str(),
                  fixed("%.3g", fit.std_dev[k]).c_str(),
                  fixed("%.4f", fit.relative_std_dev[k]).c_str(), kUnits[k]);
    out << line;
    if (truth) {
      std::snprintf(line, sizeof line, " %15s %10s", fixed("%.8g", (*truth)[k]).c_str(),
                    fixed("%+.4f", error_pct[k]).c_str());
      out << line;
    }
    out << "\n";
  }
  out << "\nresidual RMS [N m]: joint 1 " << short_number(fit.residual_rms[0]) << ", joint 2 "
      << short_number(fit.residual_rms[1]) << "\n";
  out << "samples used: " << id.samples_used() << " (" << 2 * id.samples_used()
      << " equations; skip " << short_number(skip) << " s)\n";
  out << "condition number (column-scaled regressor): " << short_number(fit.condition_number)
      << "\n";
  const sid::SmoothingReport& sm = id.smoothing;
  const bool cross_validated =
      options.smoothing == sid::SmoothingMode::Gcv || options.smoothing == sid::SmoothingMode::Cv;
  if (css) {
    out << "smoothing (css): " << sid::smoothing_mode_name(options.smoothing);
    switch (options.smoothing) {
      case sid::SmoothingMode::SConstraint:
        out << " (sigma_q = " << short_number(options.sigma_q[0]) << ", "
            << short_number(options.sigma_q[1])
            << " rad; S = " << short_number(options.S.value_or(static_cast<double>(table.rows())))
            << ")";
        break;
      case sid::SmoothingMode::Gcv:
      case sid::SmoothingMode::Cv:
        out << " (lambda chosen by "
            << (options.smoothing == sid::SmoothingMode::Gcv ? "generalized" : "leave-one-out")
            << " cross-validation on t >= " << short_number(t_start + options.cross_validation_skip)
            << " s)";
        break;
      case sid::SmoothingMode::Lambda:
        out << " (lambda = " << short_number(options.lambda)
            << ", sigma_q = " << short_number(options.sigma_q[0]) << ", "
            << short_number(options.sigma_q[1]) << " rad)";
        break;
    }
    out << "\n";
    std::snprintf(line, sizeof line, "  %-7s %13s %13s %13s", "joint", "p", "lambda", "tr A (dof)");
    out << line << (cross_validated ? "  sigma_hat [rad]" : "") << "\n";
    for (int jt = 0; jt < 2; ++jt) {
      std::snprintf(line, sizeof line, "  %-7d %13s %13s %13s", jt + 1,
                    fixed("%.6g", sm.p[jt]).c_str(), fixed("%.6g", sm.lambda[jt]).c_str(),
                    fixed("%.2f", sm.trace[jt]).c_str());
      out << line;
      if (cross_validated) {
        std::snprintf(line, sizeof line, "  %15s", fixed("%.4g", sm.sigma[jt]).c_str());
        out << line;
      }
      out << "\n";
    }
  }
  if (fit.ill_conditioned) out << "warning: " << warning_text(fit.message) << "\n";

  nlohmann::json j;
  j["input"] = input;
  j["method"] = sid::method_name(options.method);
  j["estimator"] = estimator;
  j["iv_iterations"] = iv.iterations >= 0 ? nlohmann::json(iv.iterations) : nlohmann::json(nullptr);
  j["iv_converged"] = iv.iterations >= 0 ? nlohmann::json(iv.converged) : nlohmann::json(nullptr);
  j["names"] = names;
  j["units"] = std::vector<std::string>(std::begin(kUnits), std::end(kUnits));
  j["theta"] = sid::app::to_json_array(fit.theta);
  j["std"] = sid::app::to_json_array(fit.std_dev);
  j["rel_std_pct"] = sid::app::to_json_array(fit.relative_std_dev);
  j["residual_rms"] = sid::app::to_json_array(fit.residual_rms);
  j["condition_number"] = fit.condition_number;
  j["ill_conditioned"] = fit.ill_conditioned;
  j["warning"] =
      fit.ill_conditioned ? nlohmann::json(warning_text(fit.message)) : nlohmann::json(nullptr);
  j["samples_used"] = id.samples_used();
  j["samples_total"] = table.rows();
  j["skip"] = skip;
  j["t_first_used"] = id.kinematics.t[0];
  j["smoothing_p"] = css ? sid::app::to_json_array(id.smoothing_p) : nlohmann::json(nullptr);
  const bool weighted = css && !cross_validated;
  const bool constrained = css && options.smoothing == sid::SmoothingMode::SConstraint;
  j["sigma_q"] = weighted ? sid::app::to_json_array(options.sigma_q) : nlohmann::json(nullptr);
  j["S"] = constrained ? nlohmann::json(options.S.value_or(static_cast<double>(table.rows())))
                       : nlohmann::json(nullptr);
  if (css) {
    nlohmann::json s;
    s["mode"] = sid::smoothing_mode_name(options.smoothing);
    s["lambda"] = json_pair(sm.lambda);
    s["trace"] = json_pair(sm.trace);
    s["sigma_hat"] = json_pair(sm.sigma);
    s["p"] = json_pair(sm.p);
    s["cross_validation_skip"] =
        cross_validated ? nlohmann::json(options.cross_validation_skip) : nlohmann::json(nullptr);
    j["smoothing"] = s;
  } else {
    j["smoothing"] = nullptr;
  }
  if (truth) {
    j["true"] = sid::app::to_json_array(*truth);
    j["error_pct"] = sid::app::to_json_array(error_pct);
  }
  return {out.str(), j};
}

// torque-cv is the default where the user gave nothing that asks for another smoothing: the
// estimators wls and iv were tuned with gcv, and the difference methods do not smooth.
bool uses_torque_cv(const Options& o) {
  if (o.smoothing == "torque-cv" || o.cutoff) return true;
  if (!o.smoothing.empty()) return false;
  return o.method == "css" && o.estimator == "ls" && o.sigma_q.empty() && !o.S && !o.lambda;
}

sid::Model<double> runs_model(const Options& o) {
  sid::Model<double> model = sid::two_link_arm_model<double>(sid::kPaperGravity);
  if (o.effects.empty()) return model;
  for (const sid::Effect effect : sid::app::parse_effect_list(o.effects, "--effects"))
    model.add(sid::effect_term(effect));
  return model;
}

sid::RunsIdentifyOptions runs_options(const Options& o) {
  using sid::app::require;
  require(o.method == "css",
          "--smoothing torque-cv smooths with the spline: it needs --method css");
  require(o.estimator == "ls",
          "--smoothing torque-cv supports --estimator ls only (wls and iv use gcv)");
  require(o.sigma_q.empty() && !o.S && !o.lambda,
          "--sigma-q, --S and --lambda do not apply to --smoothing torque-cv (it chooses the "
          "smoothing by how well it predicts torques)");
  require(o.truth.empty(),
          "--true applies to the single-run smoothing modes; with torque-cv use "
          "--reference-theta");
  sid::RunsIdentifyOptions options;
  if (o.skip) {
    require(std::isfinite(*o.skip) && *o.skip >= 0.0,
            "--skip must be a finite number >= 0 [s], got " + short_number(*o.skip));
    options.skip = *o.skip;
  }
  if (o.cutoff) {
    require(std::isfinite(*o.cutoff) && *o.cutoff > 0.0,
            "--cutoff must be a finite number > 0 [Hz], got " + short_number(*o.cutoff));
    options.cutoff_hz = *o.cutoff;
  }
  return options;
}

int identify_from_runs(const Options& o) {
  using sid::app::require;
  sid::app::RunsReportInput in;
  in.program = kName;
  in.options = runs_options(o);
  in.model = runs_model(o);
  if (!o.reference_theta.empty()) {
    const std::vector<double> v =
        sid::app::parse_doubles(o.reference_theta, "--reference-theta",
                                static_cast<std::size_t>(in.model.num_parameters()));
    in.reference_theta = Eigen::Map<const Eigen::VectorXd>(v.data(), in.model.num_parameters());
  }
  if (!o.gear_ratio.empty()) {
    const std::vector<double> g = sid::app::parse_doubles(o.gear_ratio, "--gear-ratio");
    require(g.size() == 1 || g.size() == 2,
            "--gear-ratio needs 1 value or 2 (gr1,gr2), got " + std::to_string(g.size()));
    for (double v : g) require(v > 0.0, "--gear-ratio must be > 0, got " + short_number(v));
    require(
        in.model.has_term(sid::kRotorCoupling.id()),
        "--gear-ratio needs armature_j2 in --effects: the rotor of drive 2 enters the fit as an "
        "armature on joint 2");
    in.gear_ratio = g.back();
  }
  const sid::app::TrajectoryColumns columns =
      o.columns.empty() ? sid::app::TrajectoryColumns{}
                        : sid::app::parse_trajectory_columns(o.columns, "--columns");
  sid::app::require_stdin_at_most_once(o.inputs, o.validate);
  if (!o.json.empty()) sid::app::ensure_writable(o.json, o.force);

  in.runs = sid::app::read_runs(o.inputs, columns);
  std::vector<sid::Trajectory<double>> data;
  for (const auto& run : in.runs) data.push_back(run.data);
  const std::vector<sid::app::RunFile> held_out = sid::app::read_runs(o.validate, columns);
  try {
    in.id = sid::identify_runs(data, in.model, in.options);
  } catch (const std::invalid_argument& e) {
    throw sid::app::InputError(e.what());
  }
  if (!in.id.fit.ok())
    throw sid::app::InputError("the parameters cannot be identified from these runs: " +
                               in.id.fit.message);
  const Eigen::VectorXd& theta = in.id.fit.theta;
  in.physical = sid::check_physical(in.model, theta, sid::default_physical_constraints(in.model));
  if (!in.physical.plausible()) {
    const sid::StackedRegression<double> all = sid::stack_runs(in.model, in.id.kinematics);
    try {
      in.consistent = sid::nearest_physical(in.model, all.X, all.y,
                                            sid::default_physical_constraints(in.model));
    } catch (const std::invalid_argument& e) {
      std::cerr << kName << ": warning: no physically consistent estimate: " << e.what() << "\n";
    }
  }
  for (const auto& run : held_out) {
    sid::app::ValidationRow row{run.file, {}, std::nullopt};
    try {
      row.prediction = sid::predict_torque(run.data, in.model, theta, in.id.cutoff_hz, in.options);
      if (in.reference_theta)
        row.reference = sid::predict_torque(run.data, in.model, *in.reference_theta,
                                            in.id.cutoff_hz, in.options);
    } catch (const std::invalid_argument& e) {
      throw sid::app::InputError(run.file + ": " + e.what());
    }
    in.validation.push_back(row);
  }
  if (in.reference_theta)
    for (const auto& run : data)
      in.reference_on_fitted.push_back(
          sid::predict_torque(run, in.model, *in.reference_theta, in.id.cutoff_hz, in.options));
  const sid::app::RunsReport report = sid::app::make_runs_report(in);
  (o.json == "-" ? std::cerr : std::cout) << report.text << std::flush;
  if (!o.json.empty()) sid::app::write_json(o.json, report.json);
  return sid::app::kExitOk;
}

int identify(Options o) {
  using sid::app::require;
  if (!o.chain.robot.empty()) {
    require(o.method == "css" && o.sigma_q.empty() && !o.S && o.smoothing.empty() && !o.lambda &&
                o.truth.empty() && o.reference_theta.empty() && o.gear_ratio.empty(),
            "with --robot the smoothing is chosen per joint by held-out torque prediction; "
            "--method, --sigma-q, --S, --smoothing, --lambda, --true, --reference-theta "
            "and --gear-ratio apply to the two-link arm");
    o.chain.inputs = o.inputs;
    o.chain.columns = o.columns;
    o.chain.validate = o.validate;
    if (o.cutoff) o.chain.cutoff = std::to_string(*o.cutoff);
    o.chain.effects = o.effects;
    o.chain.skip = o.skip;
    o.chain.estimator = o.estimator;
    o.chain.json = o.json;
    o.chain.force = o.force;
    require(!o.gains.any() || o.payload_of.empty(),
            "--currents and --payload-of are two uses: the gains from a known load, or an "
            "unknown load on a fitted arm; give one");
    require(o.payload_frame.empty() || !o.payload_of.empty() || !o.gains.known_payload.empty(),
            "--payload-frame goes with --known-payload or --payload-of (the frame of the load)");
    require((o.chain.write_mjcf.empty() && o.chain.report.empty()) || o.payload_of.empty(),
            "--write-mjcf and --report do not go with --payload-of: --write-urdf writes the arm "
            "with its load");
    o.gains.payload_frame = o.payload_frame;
    if (!o.chain.window.empty()) {
      require(!o.gains.any() && o.payload_of.empty(),
              "--window identifies the arm per window; --currents and --payload-of do not go "
              "with it");
      return sid::app::identify_robot_windows(o.chain, kName);
    }
    if (o.gains.any()) return sid::app::identify_robot_currents(o.chain, o.gains, kName);
    if (!o.payload_of.empty())
      return sid::app::identify_payload_robot(o.chain, o.payload_of, o.payload_frame, kName);
    return sid::app::identify_robot(o.chain, kName);
  }
  require(o.chain.base.empty() && o.chain.tip.empty() && o.chain.hold.empty() &&
              o.chain.transmission.empty() && !o.chain.validate_fraction &&
              !o.chain.rest_fraction && !o.chain.coulomb_epsilon && o.chain.write_urdf.empty() &&
              o.chain.write_mjcf.empty() && o.chain.report.empty() && !o.chain.no_default_effects &&
              !o.chain.strict_consistency && !o.chain.consistency_folds && !o.chain.torque_delay &&
              !o.chain.estimate_torque_delay && o.chain.window.empty(),
          "--base, --tip, --hold, --transmission, --validate-fraction, --window, --rest-fraction, "
          "--coulomb-epsilon, --write-urdf, --write-mjcf, --report, --strict-consistency, "
          "--consistency-folds, --torque-delay, --estimate-torque-delay and "
          "--no-default-effects need --robot");
  require(o.payload_of.empty(), "--payload-of needs --robot (the description of the arm)");
  require(o.payload_frame.empty(), "--payload-frame needs --robot (a URDF naming the link)");
  require(!o.gains.any(), "--currents, --known-payload and --payload-run need --robot");
  if (uses_torque_cv(o)) return identify_from_runs(o);
  require(o.inputs.size() == 1,
          "several runs are fitted together only with --smoothing torque-cv "
          "(the default for --method css without --sigma-q, --S, --lambda)");
  require(
      o.validate.empty() && o.effects.empty() && o.reference_theta.empty() && o.gear_ratio.empty(),
      "--validate, --effects, --reference-theta and --gear-ratio apply to --smoothing torque-cv");
  sid::IdentifyOptions options = make_options(o);
  require(o.estimator == "ls" || o.estimator == "wls" || o.estimator == "iv",
          "--estimator: unknown estimator '" + o.estimator + "' (expected ls, wls or iv)");
  options.weighted = o.estimator == "wls";
  if (o.estimator == "iv")
    options.cross_validation_lambda_scale = sid::kInstrumentalVariableLambdaScale;
  std::optional<sid::TwoLinkParameters<double>> truth;
  if (!o.truth.empty()) {
    const std::vector<double> v = sid::app::parse_doubles(o.truth, "--true", 7);
    truth = Eigen::Map<const sid::TwoLinkParameters<double>>(v.data());
  }
  if (!o.json.empty()) sid::app::ensure_writable(o.json, o.force);

  const sid::app::CsvTable table = sid::app::read_csv(o.inputs.front());
  const sid::Trajectory<double> data = sid::app::trajectory_from_table(
      table, o.columns.empty() ? sid::app::TrajectoryColumns{}
                               : sid::app::parse_trajectory_columns(o.columns, "--columns"));
  require(data.size() >= 3, table.source + ": identification needs at least 3 data rows, got " +
                                std::to_string(data.size()));
  sid::Identification id;
  try {
    id = sid::identify(data, options);
  } catch (const std::invalid_argument& e) {
    throw sid::app::InputError(table.source + ": " + e.what());
  }
  fill_trace(data, options, id.smoothing);
  if (!id.fit.ok())
    throw sid::app::InputError(table.source +
                               ": the parameters cannot be identified from these "
                               "data: " +
                               id.fit.message);

  IvOutcome iv;
  if (o.estimator == "iv") {
    const sid::InstrumentalVariableResult refined =
        sid::refine_instrumental_variables(id.kinematics, id.fit);
    if (!refined.ok())
      throw sid::app::InputError(table.source +
                                 ": the instrumental-variable step failed: " + refined.message);
    id.fit = refined.fit;
    iv.iterations = refined.iterations;
    iv.converged = refined.converged;
    if (!refined.converged) std::cerr << kName << ": warning: " << refined.message << "\n";
  }
  const Report report = make_report(options, table, id, truth, o.estimator, iv, data.t[0]);
  // With the JSON on standard output the table goes to standard error, so each stays parseable.
  (o.json == "-" ? std::cerr : std::cout) << report.text << std::flush;
  if (id.fit.ill_conditioned && o.json != "-")
    std::cerr << kName << ": warning: " << warning_text(id.fit.message) << "\n";
  if (!o.json.empty()) sid::app::write_json(o.json, report.json);
  return sid::app::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] { return identify(options); });
}
