// Tests of sid_diagnose --robot as a user runs it: a simulated TX40 log with a hidden spring
// (sid_simulate --robot) diagnosed from its URDF and checked by free simulation, and bad
// options refused with a message.

#include <nlohmann/json.hpp>

#include "app_test_support.hpp"

#include <gtest/gtest.h>

#include <string>

namespace {

class DiagnoseRobot : public sid_test::AppTest {
 protected:
  static std::string urdf() {
    return "'" SID_TEST_DATA_DIR "/staubli_tx40/tx40_mdh_modified.urdf'";
  }
};

}  // namespace

TEST_F(DiagnoseRobot, NamesTheSpringHiddenInASimulatedLog) {
  const sid_test::AppRun sim = shell(app("sid_simulate") + " --robot " + urdf() +
                                     " --T 8 --Ts 0.002 --effect armature_j6:0.01"
                                     " --effect spring_j5:1.5 --sigma-q2 1e-8 -q -o sim.csv");
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const sid_test::AppRun run =
      shell(app("sid_diagnose") + " --robot " + urdf() + " --json d.json sim.csv");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("spring_j5 = "), std::string::npos) << run.out;
  const nlohmann::json j = nlohmann::json::parse(read(file("d.json")));
  ASSERT_EQ(j["named"].size(), 1u) << j["named"].dump();
  EXPECT_EQ(j["named"][0]["id"], "spring_j5");
  const double value = j["named"][0]["value"].get<double>(), std = j["named"][0]["std"];
  EXPECT_LT(std::abs(value - 1.5), std::max(4.0 * std, 0.05 * 1.5)) << value << " +- " << std;
  EXPECT_EQ(j["noise_floor"].size(), 6u);
  // The free simulation through the O(n) dynamics: the named spring brings joint 5's simulated
  // angles closer to the measured ones.
  const auto& free = j["free_simulation"];
  ASSERT_TRUE(free.is_object()) << free.dump();
  EXPECT_EQ(free["failed_segments_final"], 0);
  EXPECT_LT(free["error_rms_final"][4].get<double>(),
            0.5 * free["error_rms_nominal"][4].get<double>());
  // Nothing the user gave is overwritten.
  const sid_test::AppRun again =
      shell(app("sid_diagnose") + " --robot " + urdf() + " --json d.json sim.csv");
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("d.json"), std::string::npos) << again.err;
}

TEST_F(DiagnoseRobot, RefusesOptionsThatDoNotApply) {
  write("run.csv", "t,q1,q2,tau1,tau2\n0,0,0,0,0\n0.1,0,0,0,0\n");
  const auto refused = [&](const std::string& options, const std::string& message) {
    const sid_test::AppRun r = shell(app("sid_diagnose") + " " + options);
    EXPECT_EQ(r.exit_code, 2) << options;
    EXPECT_NE(r.err.find(message), std::string::npos) << options << ": " << r.err;
  };
  refused("--robot " + urdf() + " --plots p run.csv", "apply to two-link logs");
  refused("--tip tool0 run.csv", "need --robot");
  refused("--robot " + urdf() + " --candidates coulomb,wobble run.csv", "--candidates");
  refused("--robot " + urdf() + " --negligible-size 2 run.csv", "--negligible-size");
  refused("--robot " + urdf() + " run.csv", "run.csv");
}
