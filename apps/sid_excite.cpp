// sid_excite: the excitation of a robot's chain designed for identification: the Fourier
// coefficients that make the base regressor well conditioned within the joints' limits,
// starting and ending at rest, compared with a random excitation within the same limits.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <system_error>

#include "app.hpp"
#include "chain_excite_app.hpp"

namespace {

constexpr const char* kName = "sid_excite";

constexpr const char* kDescription =
    "Design the excitation of a robot's chain for identification: the coefficients of a Fourier\n"
    "trajectory that make the base regressor well conditioned within position, velocity,\n"
    "acceleration and torque limits, at rest at the start and the end of each period.\n";

constexpr const char* kFooter = R"(
The trajectory (per joint j, w = 2 pi f, H = --harmonics):
  q_j(t) = q0_j + sum_{l=1..H} a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t),
q0_j the middle of the joint's <limit>. The first harmonic is chosen so that qd_j = qdd_j = 0 at
t = 0 and so at every multiple of the period 1 / f: a run of whole periods starts and ends at rest.

Limits: |q_j - q0_j| <= --q-range and 90 % of the <limit>'s half range, |qd_j| <= --qd-max and
90 % of its velocity, |qdd_j| <= --qdd-max, |tau_j| <= --torque-fraction x its effort, tau from
the inverse dynamics with the URDF's links and <dynamics> (joints without an effort: no torque
limit). They hold on the grid of --rate points per second over a period, tightened so that q, qd
and qdd hold between the points too; the report checks all four on a grid four times finer.

Objective: the base regressor W_b (the model sid_identify --robot fits: the links, viscous and
Coulomb friction, offset and rotor per joint, and per coupled motor with --transmission) over
one period; the design minimizes the mean
variance inflation factor of its columns, which bounds the condition number of W_b with unit
columns (the one sid_identify reports and the one printed here). NLopt (SLSQP by default) runs
from the random excitation of --seed, within --max-evaluations; the result depends on the options
and the seed only.

Separating look-alikes (--separate ID,...): where sid_diagnose --robot names a term with a caveat
that a candidate it cannot separate on the logged motion may stand behind it, give the two ids
(KIND_jN or KIND_mN, KIND coulomb, coulomb_asymmetry, offset, armature, spring, viscous or
stribeck (stribeck_jN:VS for a width other than 0.1 rad/s); angle_offset_qN for an encoder offset).
Drive terms the model lacks join it, and an encoder offset joins W_b as the torque's slope in that
joint's angle at the description's parameters, d(Y theta)/dq_j, the column sid_diagnose tests it
by. The report gives each candidate's 1 - R^2 given all the other columns on the random and on the
designed excitation: sid_diagnose calls a candidate not separable below 0.005 (given its nominal
model, whose columns are fewer). What no motion separates is refused with the reason (a rotor
about a vertical first axis, the last joint's encoder offset). Where the limits leave too little
room (a spring against gravity within +-1 rad) the report says so: widen --q-range.

Output (-o FILE): CSV, one row per joint, joint,base_frequency,q0,a1..aH,b1..bH, '#' comment
lines first. sid_simulate --robot URDF --trajectory FILE simulates it; --T a multiple of 1 / f
(10 s at 0.1 Hz) ends at rest.

Exit codes: 0 success, 2 bad options or input (message on standard error), 1 internal error.

Examples:
  sid_excite --robot arm.urdf -o excitation.csv
  sid_excite --robot arm.urdf --random --seed 3
  sid_excite --robot tx40.urdf --transmission drives.yaml -o excitation.csv
  sid_excite --robot tx40.urdf --separate spring_j2,offset_j2 --q-range 2 -o separate.csv
  sid_simulate --robot arm.urdf --trajectory excitation.csv --T 10 -o run.csv
)";

struct Options {
  sid::app::ChainExciteOptions excite;
  std::string seed = "1";
};

void define_options(CLI::App& cli, Options& options) {
  sid::app::ChainExciteOptions& o = options.excite;
  cli.footer(kFooter);
  cli.add_option("--robot", o.robot, "the robot description (URDF)")
      ->required()
      ->check(CLI::ExistingFile);
  cli.add_option("--base", o.base, "the chain's first link (default: the root)");
  cli.add_option("--tip", o.tip, "the chain's last link (default: the one end link)");
  cli.add_option("--hold", o.hold, "JOINT=VALUE,... for joints off the chain");
  cli.add_option("--transmission", o.transmission,
                 "the drives' transmission (YAML or URDF, as sid_identify --robot): the "
                 "coupled motors' friction and rotors join the regressor")
      ->check(CLI::ExistingFile);
  cli.add_option("--harmonics", o.harmonics, "harmonics H of the Fourier series, 2..50")
      ->capture_default_str();
  cli.add_option("--base-frequency", o.base_frequency, "f [Hz]; the period is 1 / f")
      ->capture_default_str();
  cli.add_option("--q-range", o.q_range, "largest |q_j - q0_j| [rad or m]")->capture_default_str();
  cli.add_option("--qd-max", o.qd_max, "largest |qd_j| [rad/s or m/s]")->capture_default_str();
  cli.add_option("--qdd-max", o.qdd_max, "largest |qdd_j| [rad/s^2 or m/s^2]")
      ->capture_default_str();
  cli.add_option("--torque-fraction", o.torque_fraction,
                 "largest |tau_j| as a fraction of its <limit effort>, in (0, 1]")
      ->capture_default_str();
  cli.add_option("--rate", o.rate,
                 "grid points per second over one period, for the objective and the limits [Hz]")
      ->capture_default_str();
  cli.add_option("--max-evaluations", o.max_evaluations, "NLopt's budget of evaluations")
      ->capture_default_str();
  cli.add_option("--algorithm", o.algorithm, "slsqp or mma (NLopt)")->capture_default_str();
  cli.add_option("--seed", options.seed,
                 "seed of std::mt19937_64 for the random excitation the design starts from")
      ->capture_default_str();
  cli.add_option("--separate", o.separate,
                 "candidate ids of sid_diagnose --robot (e.g. spring_j2,offset_j2 or "
                 "angle_offset_q2) whose columns join the conditioned regressor");
  cli.add_flag("--random", o.random_only,
               "only the random excitation: its condition number (and -o writes it)");
  cli.add_option("-o,--output", o.output, "write the coefficients to this CSV file ('-': stdout)");
  cli.add_flag("--force", o.force, "overwrite the output file if it exists");
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  return sid::app::run_app(
      kName, kDescription, argc, argv, [&](CLI::App& cli) { define_options(cli, options); },
      [&] {
        options.excite.seed = sid::app::parse_seed(options.seed);
        return sid::app::excite_robot(options.excite, kName);
      });
}
