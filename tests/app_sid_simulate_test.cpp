// Runs the sid_simulate binary as a user would and checks its CSV output against the reference
// trajectory, its reproducibility, its noise, its messages and its exit codes.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/two_link_arm.hpp>
#include <sid/model/urdf.hpp>

#include "app_test_support.hpp"
#include "chain_excite_app.hpp"
#include "csv.hpp"

namespace fs = std::filesystem;

namespace {

// CVODE at rtol = atol = 1e-10 against SciPy DOP853 at 1e-12 (tests/data/README.md).
constexpr double kAngleTol = 1e-8;     // rad
constexpr double kVelocityTol = 1e-6;  // rad/s
constexpr double kTorqueTol = 1e-14;   // N m: the same sin/cos at the same t
// N m: a torque rebuilt from the written accelerations (17 digits of values up to ~2000 rad/s^2)
// against the applied one.
constexpr double kEquationOfMotionTol = 1e-9;
// rad or N m: up to three roundings of numbers below 10 (half an ulp each, ulp(8) = 1.8e-15) in
// ((x + b) + noise) - (x + noise).
constexpr double kOffsetTol = 4e-15;

using sid_test::AppRun;

class SidSimulate : public sid_test::AppTest {
 protected:
  AppRun run(const std::string& args) const { return shell(app("sid_simulate") + " " + args); }

  // Runs args writing to file name; expects success and returns the parsed table.
  sid::app::CsvTable simulate_to(const std::string& name, const std::string& args) const {
    const AppRun r = run(args + " -q -o " + name);
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    return sid::app::read_csv(file(name));
  }

  // Expects exit code 2, nothing on stdout, no file out.csv and an error message containing what.
  void expect_input_error(const std::string& args, const std::string& what) const {
    const AppRun r = run(args + " -o out.csv");
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("sid_simulate: error: ", 0), 0u) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos)
        << args << "\nexpected: " << what << "\ngot: " << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
    EXPECT_FALSE(fs::exists(file("out.csv"))) << args << ": wrote an output despite the error";
  }
};

double max_abs_difference(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  EXPECT_EQ(a.size(), b.size());
  if (a.size() != b.size()) return std::numeric_limits<double>::infinity();
  return (a - b).cwiseAbs().maxCoeff();
}

}  // namespace

TEST(SidSimulateHelp, ExplainsEveryOptionWithUnitsAndExitsZero) {
  const std::string command = "'" SID_APP_DIR "/sid_simulate' --help";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buffer[4096];
  while (std::size_t got = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, got);
  const int status = ::pclose(pipe);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  for (const char* word :
       {"--T",        "--Ts",    "--sigma-q2", "--sigma-tau2", "--seed", "--theta",
        "--physical", "--truth", "--output",   "--force",      "--rtol", "--atol",
        "--quiet",    "rad^2",   "(N m)^2",    "[s]",          "kg m^2", "N m s/rad",
        "q1_true",    "qdd2",    "4001",       "Exit codes"})
    EXPECT_NE(out.find(word), std::string::npos) << "help does not mention " << word;
}

TEST_F(SidSimulate, NoiseFreeRunMatchesTheReferenceTrajectory) {
  const sid::app::CsvTable sim = simulate_to("sim.csv", "--sigma-q2 0 --sigma-tau2 0 --truth");
  const sid::app::CsvTable ref = sid::app::read_csv(SID_TEST_DATA_DIR "/trajectory_noise_free.csv");
  ASSERT_EQ(sim.rows(), 4001);
  ASSERT_EQ(ref.rows(), 4001);
  EXPECT_EQ(sim.names,
            (std::vector<std::string>{"t", "q1", "q2", "tau1", "tau2", "q1_true", "q2_true", "qd1",
                                      "qd2", "qdd1", "qdd2", "tau1_true", "tau2_true"}));
  EXPECT_EQ(sim.column("t"), ref.column("t"));  // t_k = k Ts exactly, as numpy.arange
  for (const char* q : {"q1", "q2"}) {
    EXPECT_LT(max_abs_difference(sim.column(q), ref.column(q)), kAngleTol) << q;
    EXPECT_LT(max_abs_difference(sim.column(std::string(q) + "_true"), ref.column(q)), kAngleTol)
        << q;
  }
  for (const char* qd : {"qd1", "qd2"})
    EXPECT_LT(max_abs_difference(sim.column(qd), ref.column(qd)), kVelocityTol) << qd;
  for (const char* tau : {"tau1", "tau2"}) {
    EXPECT_LT(max_abs_difference(sim.column(tau), ref.column(tau)), kTorqueTol) << tau;
    EXPECT_LT(max_abs_difference(sim.column(std::string(tau) + "_true"), ref.column(tau)),
              kTorqueTol)
        << tau;
  }
  // The model's acceleration at t = 0 (the corrected paper: qdd2(0) ~ 2205 rad/s^2).
  EXPECT_NEAR(sim.column("qdd2")[0], ref.column("qdd2")[0], 1e-6);
}

TEST_F(SidSimulate, CommentHeaderRecordsTheSettingsAndIsSkippedByReadCsv) {
  const AppRun r = run("--seed 17 --sigma-q2 1e-8 --T 0.1 -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_EQ(r.out.rfind("# ", 0), 0u) << r.out.substr(0, 200);
  const std::string header = r.out.substr(0, r.out.find("\nt,"));
  for (const char* word : {"seed = 17", "sigma_q2 = 1e-08", "sigma_tau2 = 0.01",
                           "theta = 0.034015193438,0.003064135808,0.0045320492,0.13291456,"
                           "0.01694224,0.6189,0.6189",
                           "Ts = 0.0025"})
    EXPECT_NE(header.find(word), std::string::npos) << "comments lack " << word << ":\n" << header;
  std::istringstream in(r.out);
  const sid::app::CsvTable table = sid::app::parse_csv(in, "stdout");
  EXPECT_EQ(table.names, (std::vector<std::string>{"t", "q1", "q2", "tau1", "tau2"}));
  EXPECT_EQ(table.rows(), 41);
}

TEST_F(SidSimulate, SameSeedGivesIdenticalBytesAndAnotherSeedDifferentNoise) {
  ASSERT_EQ(run("--seed 5 -q -o a.csv").exit_code, 0);
  ASSERT_EQ(run("--seed 5 -q -o b.csv").exit_code, 0);
  ASSERT_EQ(run("--seed 6 -q -o c.csv").exit_code, 0);
  const std::string a = read(file("a.csv")), b = read(file("b.csv")), c = read(file("c.csv"));
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  const sid::app::CsvTable ta = sid::app::read_csv(file("a.csv"));
  const sid::app::CsvTable tc = sid::app::read_csv(file("c.csv"));
  EXPECT_EQ(ta.column("t"), tc.column("t"));
  EXPECT_GT(max_abs_difference(ta.column("q1"), tc.column("q1")), 1e-4);  // sigma_q = 1e-3
}

TEST_F(SidSimulate, NoiseHasTheRequestedVariances) {
  const sid::app::CsvTable t = simulate_to("n.csv", "--sigma-q2 4e-6 --sigma-tau2 0.01 --truth");
  const auto n = static_cast<double>(t.rows());
  // Sample variance of n = 4001 Gaussian draws: relative standard error sqrt(2/n) = 2.2 %.
  const std::vector<std::pair<std::string, double>> cases{
      {"q1", 4e-6}, {"q2", 4e-6}, {"tau1", 0.01}, {"tau2", 0.01}};
  for (const auto& [name, variance] : cases) {
    const Eigen::VectorXd e = t.column(name) - t.column(name + "_true");
    const double mean = e.mean();
    const double var = (e.array() - mean).square().sum() / (n - 1.0);
    EXPECT_NEAR(var / variance, 1.0, 0.1) << name;
    EXPECT_LT(std::abs(mean), 5.0 * std::sqrt(variance / n)) << name;
  }
  EXPECT_GT(max_abs_difference(t.column("q1"), t.column("q2")), 0.0);
}

TEST_F(SidSimulate, PhysicalParametersOfThePaperGiveThePaperTrajectory) {
  const sid::app::CsvTable by_theta = simulate_to("a.csv", "--sigma-q2 0 --sigma-tau2 0");
  const sid::app::CsvTable by_physical =
      simulate_to("b.csv",
                  "--sigma-q2 0 --sigma-tau2 0 "
                  "--physical 0.2675,0.0398,0.0392,0.4347,0.4322,0.0024,0.0024,0.6189,0.6189");
  // theta from the physical values differs in the last bits, so CVODE's adaptive steps differ:
  // the two agree to the integration accuracy.
  for (const char* q : {"q1", "q2"})
    EXPECT_LT(max_abs_difference(by_theta.column(q), by_physical.column(q)), kAngleTol) << q;
}

TEST_F(SidSimulate, ThetaChangesTheTrajectory) {
  const sid::app::CsvTable paper = simulate_to("a.csv", "--sigma-q2 0 --sigma-tau2 0 --T 2");
  const sid::app::CsvTable heavier =
      simulate_to("b.csv",
                  "--sigma-q2 0 --sigma-tau2 0 --T 2 "
                  "--theta 0.05,0.003064135808,0.0045320492,0.13291456,0.01694224,0.6189,0.6189");
  EXPECT_GT(max_abs_difference(paper.column("q1"), heavier.column("q1")), 1e-3);
}

TEST_F(SidSimulate, GridHasRoundOfTOverTsPlusOneSamplesFromZero) {
  const sid::app::CsvTable t = simulate_to("g.csv", "--T 1 --Ts 0.01");
  ASSERT_EQ(t.rows(), 101);
  EXPECT_EQ(t.column("t")[0], 0.0);
  EXPECT_DOUBLE_EQ(t.column("t")[100], 1.0);
}

TEST_F(SidSimulate, WritesToStandardOutputAndReportsTheSeedUnlessQuiet) {
  const AppRun loud = run("--T 0.05 --seed 123");
  ASSERT_EQ(loud.exit_code, 0) << loud.err;
  EXPECT_NE(loud.out.find("t,q1,q2,tau1,tau2"), std::string::npos);
  EXPECT_NE(loud.err.find("seed 123"), std::string::npos) << loud.err;
  const AppRun quiet = run("--T 0.05 --seed 123 --quiet");
  ASSERT_EQ(quiet.exit_code, 0) << quiet.err;
  EXPECT_TRUE(quiet.err.empty()) << quiet.err;
  EXPECT_EQ(quiet.out, loud.out);
}

TEST_F(SidSimulate, BadOptionsExitTwoWithAMessageNamingTheOption) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--Ts 0", "--Ts"},
      {"--Ts -0.001", "--Ts"},
      {"--Ts nan", "--Ts"},
      {"--T 0.001", "--T must be"},
      {"--T 0.0025", "--T must be"},
      {"--T inf", "--T must be"},
      {"--sigma-q2 -1e-6", "--sigma-q2"},
      {"--sigma-q2 nan", "--sigma-q2"},
      {"--sigma-tau2 -0.01", "--sigma-tau2"},
      {"--sigma-tau2 inf", "--sigma-tau2"},
      {"--seed -1", "--seed"},
      {"--seed 1.5", "--seed"},
      {"--seed abc", "--seed"},
      {"--theta 1,2,3", "--theta needs 7 values, got 3"},
      {"--theta 0.03,0.003,0.004,0.13,0.017,0.6,0.6,0.1", "--theta needs 7 values, got 8"},
      {"--theta 0.03,0.003,0.004,0.13,0.017,0.6,abc", "--theta: value 7 'abc' is not a number"},
      {"--theta 0.03,0.003,nan,0.13,0.017,0.6,0.6", "--theta: value 3"},
      {"--physical 0.2675,0.0398", "--physical needs 9 values"},
      {"--physical 0.2675,0.0398,0.0392,-0.4347,0.4322,0.0024,0.0024,0.6189,0.6189",
       "--physical: m1 must be > 0"},
      {"--theta 0.034,0.003,0.0045,0.13,0.017,0.6,0.6 "
       "--physical 0.2675,0.0398,0.0392,0.4347,0.4322,0.0024,0.0024,0.6189,0.6189",
       "--theta excludes --physical"},
      {"--rtol 0", "--rtol"},
      {"--atol -1e-10", "--atol"},
      {"--no-such-option", "no-such-option"},
  };
  for (const auto& [args, what] : cases) expect_input_error(args, what);
}

TEST_F(SidSimulate, MassMatrixThatIsNotPositiveDefiniteIsRefused) {
  expect_input_error("--theta 0.001,0.003,0.0045,0.13,0.017,0.6,0.6", "positive definite");
  expect_input_error("--theta 0.034,-0.003,0.0045,0.13,0.017,0.6,0.6", "positive definite");
  expect_input_error("--theta 0,0,0,0,0,0,0", "positive definite");
}

TEST_F(SidSimulate, FailedSimulationExitsTwoWithTheReason) {
  // Strongly negative friction: the arm accelerates without bound and CVODE gives up.
  expect_input_error("--theta 0.034,0.003,0.0045,0.13,0.017,-50,0.6", "simulation failed");
  const AppRun r = run("--theta 0.034,0.003,0.0045,0.13,0.017,-50,0.6 -o out.csv");
  EXPECT_NE(r.err.find("CV_"), std::string::npos) << r.err;
}

TEST_F(SidSimulate, RefusesToOverwriteWithoutForce) {
  { std::ofstream(file("out.csv")) << "precious\n"; }
  const AppRun refused = run("--T 0.1 -o out.csv");
  EXPECT_EQ(refused.exit_code, 2) << refused.err;
  EXPECT_NE(refused.err.find("refusing to overwrite"), std::string::npos) << refused.err;
  EXPECT_EQ(read(file("out.csv")), "precious\n");
  const AppRun forced = run("--T 0.1 -o out.csv --force");
  EXPECT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_EQ(sid::app::read_csv(file("out.csv")).rows(), 41);
}

// ---- Hidden effects and the multisine excitation --------------------------------------

namespace {

Eigen::VectorXd difference(const sid::app::CsvTable& t, const std::string& a,
                           const std::string& b) {
  return t.column(a) - t.column(b);
}

// Torque of the paper's arm (no effects) at the written true state, per joint.
Eigen::MatrixX2d paper_arm_torque(const sid::app::CsvTable& t) {
  const sid::TwoLinkParameters<double> theta = sid::paper_arm_parameters();
  Eigen::MatrixX2d tau(t.rows(), 2);
  for (Eigen::Index i = 0; i < t.rows(); ++i) {
    const sid::Vector2<double> q(t.column("q1_true")[i], t.column("q2_true")[i]);
    const sid::Vector2<double> qd(t.column("qd1")[i], t.column("qd2")[i]);
    const sid::Vector2<double> qdd(t.column("qdd1")[i], t.column("qdd2")[i]);
    tau.row(i) = sid::two_link_inverse_dynamics(theta, q, qd, qdd, sid::kPaperGravity).transpose();
  }
  return tau;
}

}  // namespace

TEST(SidSimulateHelp, DocumentsEveryEffectWithItsValuesAndUnits) {
  const std::string command = "'" SID_APP_DIR "/sid_simulate' --help";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buffer[4096];
  while (std::size_t got = std::fread(buffer, 1, sizeof buffer, pipe)) out.append(buffer, got);
  ASSERT_EQ(::pclose(pipe), 0);
  for (const char* word : {"--effect",
                           "--excitation",
                           "--coulomb-epsilon",
                           "multisine",
                           "5 sin 1.3t + 2 sin 3.1t",
                           "3 cos 0.7t + 1.5 sin 2.3t",
                           "tanh(qd_j / eps)",
                           "0.01 rad/s",
                           "exp(-(qd_j / vs)^2)",
                           "coulomb_j1:Fc [N m]",
                           "coulomb_j2:Fc [N m]",
                           "stribeck_j1:Fc [N m],Fs [N m],vs [rad/s]",
                           "stribeck_j2:",
                           "torque_offset_j1:b [N m]",
                           "torque_offset_j2:",
                           "angle_offset_q1:delta [rad]",
                           "angle_offset_q2:",
                           "armature_j1:Ia [kg m^2]",
                           "armature_j2:",
                           "spring_j1:k [N m/rad]",
                           "spring_j2:",
                           "constant load",
                           "base tilt"})
    EXPECT_NE(out.find(word), std::string::npos) << "help does not mention " << word;
}

TEST_F(SidSimulate, TorqueOffsetIsMeasuredMinusAppliedTorqueAndLeavesTheMotion) {
  const sid::app::CsvTable plain =
      simulate_to("a.csv", "--sigma-q2 0 --sigma-tau2 0 --T 2 --truth");
  const sid::app::CsvTable t =
      simulate_to("b.csv",
                  "--sigma-q2 0 --sigma-tau2 0 --T 2 --truth --effect torque_offset_j1:0.07 "
                  "--effect torque_offset_j2:-0.05");
  const Eigen::VectorXd d1 = difference(t, "tau1", "tau1_true");
  const Eigen::VectorXd d2 = difference(t, "tau2", "tau2_true");
  EXPECT_LT((d1.array() - 0.07).abs().maxCoeff(), kOffsetTol);
  EXPECT_LT((d2.array() + 0.05).abs().maxCoeff(), kOffsetTol);
  // A sensor fault does not move the arm: angles and applied torques as without it.
  for (const char* c : {"q1", "q2", "q1_true", "qd2", "tau1_true", "tau2_true"})
    EXPECT_EQ(t.column(c), plain.column(c)) << c;
}

TEST_F(SidSimulate, AngleOffsetIsMinusDeltaOnTheMeasuredAngle) {
  const sid::app::CsvTable plain =
      simulate_to("a.csv", "--sigma-q2 0 --sigma-tau2 0 --T 2 --truth");
  const sid::app::CsvTable t =
      simulate_to("b.csv",
                  "--sigma-q2 0 --sigma-tau2 0 --T 2 --truth --effect angle_offset_q1:0.05 "
                  "--effect angle_offset_q2:-0.02");
  EXPECT_LT((difference(t, "q1", "q1_true").array() + 0.05).abs().maxCoeff(), kOffsetTol);
  EXPECT_LT((difference(t, "q2", "q2_true").array() - 0.02).abs().maxCoeff(), kOffsetTol);
  for (const char* c : {"q1_true", "q2_true", "tau1", "tau2"})
    EXPECT_EQ(t.column(c), plain.column(c)) << c;
}

TEST_F(SidSimulate, SensorOffsetsDoNotChangeTheNoiseOfASeed) {
  const std::string noisy = "--sigma-q2 1e-4 --sigma-tau2 0.04 --seed 3 --T 1 ";
  const sid::app::CsvTable plain = simulate_to("a.csv", noisy);
  const sid::app::CsvTable t =
      simulate_to("b.csv", noisy + "--effect torque_offset_j2:0.3 --effect angle_offset_q1:-0.1");
  EXPECT_LT(((t.column("tau2") - plain.column("tau2")).array() - 0.3).abs().maxCoeff(), kOffsetTol);
  // measured q = true q - delta, delta = -0.1.
  EXPECT_LT(((t.column("q1") - plain.column("q1")).array() - 0.1).abs().maxCoeff(), kOffsetTol);
  EXPECT_EQ(t.column("tau1"), plain.column("tau1"));
  EXPECT_EQ(t.column("q2"), plain.column("q2"));
}

TEST_F(SidSimulate, MultisineExcitationAppliesItsFormula) {
  const sid::app::CsvTable t =
      simulate_to("m.csv", "--sigma-q2 0 --sigma-tau2 0 --excitation multisine --truth");
  const sid::app::CsvTable paper = simulate_to("p.csv", "--sigma-q2 0 --sigma-tau2 0");
  const Eigen::VectorXd time = t.column("t");
  Eigen::VectorXd u1(time.size()), u2(time.size());
  for (Eigen::Index i = 0; i < time.size(); ++i) {
    u1[i] = 5.0 * std::sin(1.3 * time[i]) + 2.0 * std::sin(3.1 * time[i]);
    u2[i] = 3.0 * std::cos(0.7 * time[i]) + 1.5 * std::sin(2.3 * time[i]);
  }
  EXPECT_LT(max_abs_difference(t.column("tau1"), u1), kTorqueTol);
  EXPECT_LT(max_abs_difference(t.column("tau2"), u2), kTorqueTol);
  // The arm obeys the paper's equation of motion under it.
  const Eigen::MatrixX2d tau = paper_arm_torque(t);
  EXPECT_LT(max_abs_difference(tau.col(0), u1), kEquationOfMotionTol);
  EXPECT_LT(max_abs_difference(tau.col(1), u2), kEquationOfMotionTol);
  EXPECT_GT(max_abs_difference(t.column("q1"), paper.column("q1")), 0.1);
}

TEST_F(SidSimulate, CoulombFrictionIsTheTorqueTheRigidArmDoesNotExplain) {
  const double fc1 = 0.3, fc2 = 0.1, eps = 0.02;
  const sid::app::CsvTable t =
      simulate_to("c.csv",
                  "--sigma-q2 0 --sigma-tau2 0 --truth --effect coulomb_j1:0.3 "
                  "--effect coulomb_j2:0.1 --coulomb-epsilon 0.02");
  const Eigen::MatrixX2d rigid = paper_arm_torque(t);
  const Eigen::VectorXd qd1 = t.column("qd1"), qd2 = t.column("qd2");
  const Eigen::VectorXd f1 = fc1 * (qd1 / eps).array().tanh();
  const Eigen::VectorXd f2 = fc2 * (qd2 / eps).array().tanh();
  EXPECT_LT(max_abs_difference(t.column("tau1") - rigid.col(0), f1), kEquationOfMotionTol);
  EXPECT_LT(max_abs_difference(t.column("tau2") - rigid.col(1), f2), kEquationOfMotionTol);
  // Both signs of both velocities occur, so the test sees the whole tanh.
  EXPECT_LT(qd1.minCoeff(), -0.1);
  EXPECT_GT(qd1.maxCoeff(), 0.1);
  EXPECT_LT(qd2.minCoeff(), -0.1);
  EXPECT_GT(qd2.maxCoeff(), 0.1);
}

TEST_F(SidSimulate, StribeckArmatureAndSpringEnterTheEquationOfMotion) {
  const double fc = 0.1, fs = 0.3, vs = 0.2, eps = 0.01, ia = 0.006, k = 0.5;
  const sid::app::CsvTable t =
      simulate_to("s.csv",
                  "--sigma-q2 0 --sigma-tau2 0 --truth --excitation multisine "
                  "--effect stribeck_j1:0.1,0.3,0.2 --effect armature_j2:0.006 "
                  "--effect spring_j2:0.5");
  const Eigen::MatrixX2d rigid = paper_arm_torque(t);
  const Eigen::ArrayXd v = t.column("qd1").array();
  const Eigen::VectorXd stribeck = (fc + (fs - fc) * (-(v / vs).square()).exp()) * (v / eps).tanh();
  const Eigen::VectorXd joint2 = ia * t.column("qdd2") + k * t.column("q2_true");
  EXPECT_LT(max_abs_difference(t.column("tau1") - rigid.col(0), stribeck), kEquationOfMotionTol);
  EXPECT_LT(max_abs_difference(t.column("tau2") - rigid.col(1), joint2), kEquationOfMotionTol);
}

TEST_F(SidSimulate, CommentsRecordTheEffectsAndTheExcitation) {
  const AppRun none = run("--T 0.1 -q");
  ASSERT_EQ(none.exit_code, 0) << none.err;
  EXPECT_NE(none.out.find("# excitation = paper\n"), std::string::npos) << none.out.substr(0, 800);
  EXPECT_NE(none.out.find("# effects = none\n"), std::string::npos) << none.out.substr(0, 800);
  const AppRun r =
      run("--T 0.1 -q --excitation multisine --effect coulomb_j2:0.1 "
          "--effect stribeck_j1:0.1,0.3,0.2 --effect angle_offset_q1:0.05");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string header = r.out.substr(0, r.out.find("\nt,"));
  for (const char* word :
       {"# excitation = multisine\n",
        "# effects = coulomb_j2:0.1 stribeck_j1:0.1,0.3,0.2 angle_offset_q1:0.05 "
        "(coulomb_epsilon = 0.01 rad/s)",
        "u1 = 5 sin 1.3t + 2 sin 3.1t", "Coulomb friction on joint 2; Fc = 0.1 N m",
        "Fc = 0.1 N m, Fs = 0.3 N m, vs = 0.2 rad/s", "delta = 0.05 rad"})
    EXPECT_NE(header.find(word), std::string::npos) << "comments lack " << word << ":\n" << header;
}

TEST_F(SidSimulate, SameSeedAndEffectsGiveIdenticalBytes) {
  const std::string args =
      "--seed 9 -q --T 3 --excitation multisine --effect coulomb_j1:0.2 "
      "--effect torque_offset_j2:0.05 ";
  ASSERT_EQ(run(args + "-o a.csv").exit_code, 0);
  ASSERT_EQ(run(args + "-o b.csv").exit_code, 0);
  const std::string a = read(file("a.csv"));
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, read(file("b.csv")));
  // The default is the paper's excitation without effects, spelled out or not.
  ASSERT_EQ(run("--seed 9 -q --T 3 -o c.csv").exit_code, 0);
  ASSERT_EQ(run("--seed 9 -q --T 3 --excitation paper -o d.csv").exit_code, 0);
  EXPECT_EQ(read(file("c.csv")), read(file("d.csv")));
  EXPECT_NE(read(file("c.csv")), a);
}

TEST_F(SidSimulate, BadEffectsAndExcitationsExitTwoWithAMessage) {
  const std::vector<std::pair<std::string, std::string>> cases{
      {"--effect coulomb_j3:0.1", "unknown effect id 'coulomb_j3'"},
      {"--effect coulomb_j3:0.1", "spring_j2"},  // the message lists the valid ids
      {"--effect coulomb_j1", "has no ':'"},
      {"--effect coulomb_j1:abc", "'abc' is not a number"},
      {"--effect coulomb_j1:-0.1", "Fc must be > 0"},
      {"--effect coulomb_j1:nan", "Fc must be finite"},
      {"--effect stribeck_j1:0.1,0.3", "needs 3 values"},
      {"--effect stribeck_j1:0.3,0.2,0.2", "Fs must be > Fc"},
      {"--effect stribeck_j1:0.1,0.3,0", "vs must be > 0"},
      {"--effect armature_j2:0", "Ia must be > 0"},
      {"--effect spring_j1:-1", "k must be > 0"},
      {"--effect angle_offset_q1:2", "|delta| must be < pi/2"},
      {"--effect coulomb_j1:0.1 --effect coulomb_j1:0.2", "coulomb_j1 is given more than once"},
      {"--excitation chirp", "--excitation must be paper or multisine, got 'chirp'"},
      {"--excitation ''", "--excitation must be paper or multisine"},
      {"--coulomb-epsilon 0", "--coulomb-epsilon"},
      {"--coulomb-epsilon nan", "--coulomb-epsilon"},
  };
  for (const auto& [args, what] : cases) expect_input_error(args, what);
}

// sid_excite as a user runs it: its help, its refusals, --force, and the file it writes read
// back by sid_simulate --robot --trajectory.

namespace {

using sid_test::AppRun;

constexpr const char* kTx40 = "'" SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf'";
// The simulated arm tracks the desired trajectory to about 1e-8 rad (chain_experiment_test); at
// rest its rates are zero to the tracking error.
constexpr double kRestTol = 1e-6;
constexpr double kPi = 3.14159265358979323846;

class SidExcite : public sid_test::AppTest {
 protected:
  AppRun run(const std::string& args) const { return shell(app("sid_excite") + " " + args); }
  void refused(const std::string& args, const std::string& words) const {
    const AppRun r = run(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("sid_excite: error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(words), std::string::npos) << args << "\n" << r.err;
  }
};

TEST_F(SidExcite, HelpNamesTheOptionsAndTheFileFormat) {
  const AppRun r = run("--help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* words : {"--robot", "--torque-fraction", "--qdd-max", "--random", "--force",
                            "joint,base_frequency,q0,a1..aH,b1..bH", "--trajectory", "--separate"})
    EXPECT_NE(r.out.find(words), std::string::npos) << words;
}

TEST_F(SidExcite, RefusesBadOptionsNamingThem) {
  refused("", "--robot is required");
  refused(std::string("--robot ") + kTx40 + " --harmonics 1", "--harmonics must be 2..50");
  refused(std::string("--robot ") + kTx40 + " --torque-fraction 1.5", "--torque-fraction");
  refused(std::string("--robot ") + kTx40 + " --algorithm newton", "--algorithm");
  refused(std::string("--robot ") + kTx40 + " --rate 1", "grid points per period");
  refused(std::string("--robot ") + kTx40 + " --seed -1", "--seed");
  refused(std::string("--robot ") + kTx40 + " --frobnicate", "frobnicate");
  refused("--robot '" SID_SOURCE_DIR "/examples/dfki_double_pendulum.dh'", "give a URDF");
}

TEST_F(SidExcite, NeverOverwritesWithoutForce) {
  const std::string quick = std::string("--robot ") + kTx40 + " --random -o c.csv";
  write("c.csv", "keep");
  refused(quick, "refusing to overwrite");
  EXPECT_EQ(read(file("c.csv")), "keep");
  const AppRun r = run(quick + " --force");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("condition number"), std::string::npos) << r.out;
  EXPECT_EQ(sid::app::read_csv(file("c.csv")).rows(), 6);
}

// With the TX40's transmission the coupled wrist motor's friction and rotor join the regressor:
// the 61 base parameters sid_identify --robot fits to its motor-side log, not 58.
TEST_F(SidExcite, TransmissionPutsTheCoupledMotorsTermsInTheRegressor) {
  const std::string design = std::string("--robot ") + kTx40 +
                             " --harmonics 3 --base-frequency 0.5 --rate 50 --max-evaluations 20";
  const AppRun direct = run(design);
  ASSERT_EQ(direct.exit_code, 0) << direct.err;
  EXPECT_NE(direct.out.find("58 base parameters of 84"), std::string::npos) << direct.out;
  const AppRun coupled = run(design + " --transmission '" SID_TEST_DATA_DIR
                                      "/staubli_tx40/tx40_transmission.yaml' -o d.csv");
  ASSERT_EQ(coupled.exit_code, 0) << coupled.err;
  EXPECT_NE(coupled.out.find("61 base parameters of 87"), std::string::npos) << coupled.out;
  EXPECT_NE(read(file("d.csv")).find("the coupled motors of"), std::string::npos);
  const AppRun missing = run(design + " --transmission no_such.yaml");
  EXPECT_EQ(missing.exit_code, 2);
  EXPECT_NE(missing.err.find("no_such.yaml"), std::string::npos) << missing.err;
}

// --separate spring_j2,angle_offset_q4: the spring joins the model (59 base parameters of 85)
// and the encoder offset's column d(Y theta)/dq_4 the regressor, and the condition number the
// design reports and writes is that of those columns together, recomputed here from the file:
// above the base regressor's alone, since a column added to unit-norm columns can only widen
// the spread of their singular values.
TEST_F(SidExcite, SeparateConditionsTheRegressorWithTheCandidatesColumns) {
  const AppRun r = run(std::string("--robot ") + kTx40 +
                       " --harmonics 3 --base-frequency 0.5 --rate 50 --max-evaluations 20"
                       " --q-range 2 --separate spring_j2,angle_offset_q4 -o s.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("59 base parameters of 85 and 1 angle-offset column"), std::string::npos)
      << r.out;
  const std::string shares = "given all the others: spring_j2 ";
  const std::size_t first = r.out.find(shares);
  ASSERT_NE(first, std::string::npos) << r.out;
  EXPECT_NE(r.out.find(shares, first + 1), std::string::npos) << "random and designed: " << r.out;
  const std::string marker = "designed excitation: condition number ";
  const std::size_t at = r.out.find(marker);
  ASSERT_NE(at, std::string::npos) << r.out;
  const double reported = std::stod(r.out.substr(at + marker.size()));

  std::ifstream in(SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf");
  std::stringstream text;
  text << in.rdbuf();
  const sid::UrdfChain arm = sid::chain_from_urdf(text.str(), "base_link", "tool0");
  const sid::Transmission direct(6);
  std::vector<sid::DriveTerm> terms = sid::drive_terms(sid::default_drive_term_kinds(), direct);
  const sid::ChainModel base_model(arm.chain, arm.joint_names, terms, direct);
  terms.push_back({sid::DriveTermKind::Spring, 1, false});
  const sid::ChainModel model(arm.chain, arm.joint_names, terms, direct);
  // The offset's column needs only the links: the drive terms do not depend on the angle.
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.parameters());
  theta.head(60) = arm.theta.head(60);
  const sid::FourierTrajectory designed = sid::app::read_fourier_trajectory(file("s.csv"), 6);
  const Eigen::VectorXd grid = sid::excitation_grid(0.5, 100);
  const double with = sid::scaled_condition_number(sid::excitation_regressor(
      model, sid::chain_base_parameters(model).independent, designed, grid, theta, {3}));
  const double without = sid::scaled_condition_number(sid::excitation_regressor(
      base_model, sid::chain_base_parameters(base_model).independent, designed, grid));
  EXPECT_NEAR(reported, with, 1e-3 * with);  // printed to 4 significant digits
  EXPECT_GT(with, 1.01 * without);
  EXPECT_NE(read(file("s.csv")).find("separating spring_j2,angle_offset_q4"), std::string::npos);
}

// Ids that are no candidate, or candidates no motion separates, are refused with the reason.
TEST_F(SidExcite, SeparateRefusesBadIdsNamingThem) {
  const std::string robot = std::string("--robot ") + kTx40 + " --random --separate ";
  refused(robot + "foo_j2", "'foo_j2' is not a candidate id");
  refused(robot + "spring_j", "'spring_j' is not a candidate id");
  refused(robot + "angle_offset_q0", "'angle_offset_q0' is not a candidate id");
  refused(robot + "spring_j7", "the chain has 6 joints");
  refused(robot + "coulomb_m6", "motor 6 is not one the transmission couples");
  refused(robot + "spring_j2,offset_j3,spring_j2", "'spring_j2' is given twice");
  refused(robot + "offset_j2:0.1", "only a Stribeck candidate takes a width");
  refused(robot + "','", "--separate");
  // A rotor about the vertical first axis is that link's inertia; the link parameters absorb an
  // encoder offset of the first joint (a vertical axis) and of the last.
  refused(robot + "armature_j1", "no excitation separates it");
  refused(robot + "angle_offset_q1", "absorb this encoder offset");
  refused(robot + "angle_offset_q6", "absorb this encoder offset");
}

// A short design on the TX40, written, simulated through sid_simulate --trajectory: the run
// starts and ends (after one period) at rest, and the same seed gives the same file.
TEST_F(SidExcite, WritesCoefficientsSidSimulateTracksFromRestToRest) {
  const std::string design = std::string("--robot ") + kTx40 +
                             " --harmonics 3 --base-frequency 0.5 --rate 50 --max-evaluations 20";
  const AppRun r = run(design + " -o d.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("designed excitation: condition number"), std::string::npos) << r.out;
  ASSERT_EQ(run(design + " -o again.csv").exit_code, 0);
  EXPECT_EQ(read(file("again.csv")), read(file("d.csv")));
  const AppRun sim = shell(app("sid_simulate") + " --robot " + kTx40 +
                           " --trajectory d.csv --T 2 --Ts 0.01 --effect armature_j6:0.01"
                           " --sigma-q2 0 --sigma-tau2 0 --truth -q -o sim.csv");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const sid::app::CsvTable table = sid::app::read_csv(file("sim.csv"));
  ASSERT_EQ(table.rows(), 201);
  const sid::app::CsvTable coefficients = sid::app::read_csv(file("d.csv"));
  for (int j = 1; j <= 6; ++j) {
    const Eigen::VectorXd& qd = table.column("qd" + std::to_string(j));
    EXPECT_LT(std::abs(qd[0]), kRestTol) << "joint " << j;
    EXPECT_LT(std::abs(qd[200]), kRestTol) << "joint " << j;
    // q(0) = q0 - sum_l b_l / (l w): the file's own series.
    double q_start = coefficients.column("q0")[j - 1];
    for (int l = 1; l <= 3; ++l)
      q_start -= coefficients.column("b" + std::to_string(l))[j - 1] / (l * 2 * kPi * 0.5);
    EXPECT_NEAR(table.column("q" + std::to_string(j))[0], q_start, kRestTol) << "joint " << j;
  }
  const AppRun bad = shell(app("sid_simulate") + " --robot " + kTx40 +
                           " --trajectory sim.csv --effect armature_j6:0.01 -o x.csv");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("one row per joint"), std::string::npos) << bad.err;
}

}  // namespace
