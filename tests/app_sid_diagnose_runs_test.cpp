// Runs sid_diagnose on measured runs of a real arm (tests/data/dfki_double_pendulum) as a user
// would: several runs with the file's own column names, a run kept for validation, bad input.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app_test_support.hpp"

namespace fs = std::filesystem;

namespace {

using sid_test::AppRun;

constexpr const char* kColumns =
    "--columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2 ";

std::string run(const char* id) {
  return "'" SID_TEST_DATA_DIR "/dfki_double_pendulum/trajectory_" + std::string(id) + ".csv' ";
}

class SidDiagnoseRuns : public sid_test::AppTest {
 protected:
  AppRun diagnose(const std::string& args) const {
    return shell("'" SID_APP_DIR "/sid_diagnose' " + args);
  }
  void expect_input_error(const std::string& args, const std::string& what) const {
    const AppRun r = diagnose(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos)
        << args << "\nexpected: " << what << "\ngot: " << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
  }
};

TEST_F(SidDiagnoseRuns, DiagnosesSeveralRunsAndValidatesOnAnother) {
  const AppRun r = diagnose(std::string(kColumns) + run("01") + run("02") + run("05") +
                            "--validate " + run("00") + "--gear-ratio 6 --json " + file("d.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* word :
       {"diagnosed together", "named effects", "not named", "rotor coupling of drive 2",
        "what no effect explains", "physical plausibility", "free simulation of the final model",
        "validation (runs not used in the fit)"})
    EXPECT_NE(r.out.find(word), std::string::npos) << "report lacks " << word << "\n" << r.out;
  const nlohmann::json j = nlohmann::json::parse(read(file("d.json")));
  EXPECT_EQ(j["input"].size(), 3u);
  EXPECT_TRUE(j["cutoff_chosen"].get<bool>());
  ASSERT_EQ(j["runs"].size(), 3u);
  EXPECT_EQ(j["runs"][2]["left_out_prediction_rms"].size(), 2u);
  ASSERT_EQ(j["validation"].size(), 1u);
  const nlohmann::json& v = j["validation"][0];
  EXPECT_NE(v["file"].get<std::string>().find("trajectory_00.csv"), std::string::npos);
  ASSERT_EQ(v["residual_rms"].size(), 2u);
  ASSERT_EQ(v["nominal_residual_rms"].size(), 2u);
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT(v["residual_rms"][k].get<double>(), 0.3);
    EXPECT_GT(v["residual_rms"][k].get<double>(), 0.03);
  }
  ASSERT_EQ(j["simulation"].size(), 3u);
  EXPECT_EQ(j["simulation"][0]["error_rms"].size(), 2u);
  // The effects named are never a spring; each not named carries its reason.
  for (const auto& e : j["effects"])
    EXPECT_EQ(e["id"].get<std::string>().rfind("spring", 0), std::string::npos);
  for (const auto& e : j["not_named"])
    EXPECT_FALSE(e["reason"].get<std::string>().empty()) << e.dump();
  if (j.contains("rotor_coupling")) {
    EXPECT_NEAR(j["rotor_coupling"]["Ir"].get<double>(),
                j["rotor_coupling"]["Ia"].get<double>() / 42.0, 1e-15);
  }
  EXPECT_TRUE(j["physical"].contains("plausible"));
  EXPECT_EQ(j["excess_rms"].size(), 2u);
  for (const auto& s : j["friction_shapes"])
    EXPECT_TRUE(s["shape"] == "tanh" || s["shape"] == "atan") << s.dump();
}

TEST_F(SidDiagnoseRuns, BadInputIsRefusedWithAMessageNamingIt) {
  expect_input_error(std::string(kColumns) + run("01") + "--validate " + run("02"),
                     "--validate and --gear-ratio apply to measured runs");
  expect_input_error(std::string(kColumns) + run("01") + run("02") + "--gear-ratio 0",
                     "--gear-ratio must be");
  expect_input_error(std::string(kColumns) + run("01") + run("02") + "--plots " + file("p"),
                     "apply to the diagnosis of a single log");
  expect_input_error(run("01") + run("02"), "no column 't'");
  expect_input_error(std::string(kColumns) + run("01") + run("02") + "--candidates spring_j3",
                     "unknown effect");
  expect_input_error(std::string(kColumns) + "- - ", "standard input ('-') can be read only once");
  write("taken.json", "{}");
  expect_input_error(std::string(kColumns) + run("01") + run("02") + "--json " + file("taken.json"),
                     "--force");
  EXPECT_FALSE(fs::exists(file("p")));
}

}  // namespace
