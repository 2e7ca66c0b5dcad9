// Runs sid_excite as a user would: its help, its refusals, --force, and the file it writes read
// back by sid_simulate --robot --trajectory.

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "app_test_support.hpp"
#include "csv.hpp"

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
                            "joint,base_frequency,q0,a1..aH,b1..bH", "--trajectory"})
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
