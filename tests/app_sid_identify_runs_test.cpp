// Runs sid_identify on measured runs of a real arm (tests/data/dfki_double_pendulum) as a user
// would: several runs, the file's own column names, runs kept for validation, bad input.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "app_test_support.hpp"
#include "csv.hpp"

namespace fs = std::filesystem;

namespace {

using sid_test::AppRun;

constexpr const char* kColumns =
    "--columns t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2";
// The lab's published model in sid's parameters (tests/data/dfki_double_pendulum/README.md).
constexpr const char* kLabTheta = "0.049269,0.053878,0.036235,0.241126,0.181177,0.001,0.001";

std::string run(const char* id) {
  return "'" SID_TEST_DATA_DIR "/dfki_double_pendulum/trajectory_" + std::string(id) + ".csv'";
}

std::vector<double> numbers(const nlohmann::json& array) {
  std::vector<double> v;
  for (const auto& x : array) v.push_back(x.get<double>());
  return v;
}

class SidIdentifyRuns : public sid_test::AppTest {
 protected:
  AppRun identify(const std::string& args) const {
    return shell("'" SID_APP_DIR "/sid_identify' " + args);
  }
  nlohmann::json identify_json(const std::string& args) const {
    std::error_code ec;
    fs::remove(file("result.json"), ec);
    const AppRun r = identify(args + " --json result.json");
    EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    if (r.exit_code != 0) return nlohmann::json::object();
    return nlohmann::json::parse(read(file("result.json")));
  }
  void expect_input_error(const std::string& args, const std::string& what) const {
    const AppRun r = identify(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos)
        << args << "\nexpected: " << what << "\ngot: " << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
  }
};

}  // namespace

TEST_F(SidIdentifyRuns, FitsSeveralRunsAndValidatesOnAnother) {
  const nlohmann::json j = identify_json(std::string(kColumns) + " --validate " + run("05") + " " +
                                         run("01") + " " + run("03"));
  ASSERT_TRUE(j.contains("validation")) << j.dump();
  EXPECT_EQ(j["input"].size(), 2u);
  EXPECT_EQ(j["smoothing"]["mode"], "torque-cv");
  EXPECT_TRUE(j["smoothing"]["chosen"].get<bool>());
  const double cutoff = j["smoothing"]["cutoff_hz"].get<double>();
  EXPECT_GT(cutoff, 1.0);  // not the near-interpolation GCV chooses on encoder angles
  EXPECT_LT(cutoff, 20.0);
  ASSERT_EQ(j["runs"].size(), 2u);
  ASSERT_EQ(j["validation"].size(), 1u);
  const nlohmann::json& v = j["validation"][0];
  EXPECT_NE(v["file"].get<std::string>().find("trajectory_05.csv"), std::string::npos);
  const auto rms = numbers(v["residual_rms"]);
  ASSERT_EQ(rms.size(), 2u);
  EXPECT_EQ(numbers(v["nominal_residual_rms"]), rms);  // sid_identify reports one model
  // The run kept back is predicted about as well as the fitted ones are fitted (the drives'
  // torque noise alone is about 0.1 N m), and far better than by the torque's own spread.
  for (int k = 0; k < 2; ++k) {
    EXPECT_LT(rms[static_cast<std::size_t>(k)], 0.25) << "joint " << k + 1;
    EXPECT_GT(rms[static_cast<std::size_t>(k)], 0.03) << "joint " << k + 1;
  }
  EXPECT_TRUE(j["physical"]["plausible"].get<bool>()) << j["physical"].dump();
  EXPECT_TRUE(j["physical"]["consistent_theta"].is_null());
  // std is the HAC one: larger than least squares' on correlated residuals; two runs give no
  // leave-one-run-out spread.
  const auto hac = numbers(j["std"]), ls = numbers(j["ls_std"]);
  ASSERT_EQ(hac.size(), 7u);
  for (std::size_t k = 0; k < 7; ++k) EXPECT_GT(hac[k], ls[k]) << "theta" << k + 1;
  EXPECT_TRUE(j["jackknife_std"].is_null());
  EXPECT_TRUE(j["runs"][0]["left_out_prediction_rms"].is_null());
}

TEST_F(SidIdentifyRuns, ColumnMapGivesTheSameResultAsRenamedColumns) {
  const sid::app::CsvTable table =
      sid::app::read_csv(SID_TEST_DATA_DIR "/dfki_double_pendulum/trajectory_01.csv");
  sid::app::write_csv(file("renamed.csv"), {"t", "q1", "q2", "tau1", "tau2"},
                      {table.column("time"), table.column("pos_meas1"), table.column("pos_meas2"),
                       table.column("tau_meas1"), table.column("tau_meas2")});
  const nlohmann::json mapped = identify_json(std::string(kColumns) + " " + run("01"));
  const nlohmann::json renamed = identify_json(file("renamed.csv"));
  ASSERT_TRUE(mapped.contains("theta") && renamed.contains("theta"));
  EXPECT_EQ(numbers(mapped["theta"]), numbers(renamed["theta"]));
  // Without the map the file's names are reported, with the ones it has.
  expect_input_error(run("01"), "no column 't'");
}

TEST_F(SidIdentifyRuns, ReferenceThetaIsScoredOnFittedAndValidationRuns) {
  const AppRun r = identify(std::string(kColumns) + " --reference-theta " + kLabTheta +
                            " --validate " + run("03") + " " + run("02"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* word : {"validation (runs not used in the fit)", "reference",
                           "physical plausibility", "cutoff", "trajectory_03.csv", "theta7"})
    EXPECT_NE(r.out.find(word), std::string::npos) << "report lacks " << word << "\n" << r.out;
  const nlohmann::json j = identify_json(std::string(kColumns) + " --reference-theta " + kLabTheta +
                                         " --validate " + run("03") + " " + run("02"));
  ASSERT_EQ(j["validation"].size(), 1u);
  const auto reference = numbers(j["validation"][0]["reference_residual_rms"]);
  ASSERT_EQ(reference.size(), 2u);
  // The lab's rigid-body values without its friction and rotor terms miss the friction torque.
  EXPECT_GT(reference[0], numbers(j["validation"][0]["residual_rms"])[0]);
  EXPECT_EQ(j["runs"][0]["reference_residual_rms"].size(), 2u);
}

TEST_F(SidIdentifyRuns, EffectsAndGearRatioReportTheRotorOfDriveTwo) {
  const nlohmann::json j = identify_json(
      std::string(kColumns) + " --effects coulomb_j1,coulomb_j2,armature_j2 --gear-ratio 6,6 " +
      run("00") + " " + run("01") + " " + run("12"));
  ASSERT_TRUE(j.contains("rotor")) << j.dump();
  EXPECT_EQ(j["jackknife_std"].size(), 10u);
  EXPECT_EQ(j["runs"][2]["left_out_prediction_rms"].size(), 2u);
  EXPECT_EQ(j["names"].size(), 10u);
  EXPECT_EQ(j["names"][9], "armature_j2.Ia");
  EXPECT_EQ(j["units"][7], "N m");
  const double ia = j["theta"][9].get<double>();
  EXPECT_NEAR(j["rotor"]["Ir"].get<double>(), ia / 42.0, 1e-15 + 1e-12 * std::abs(ia));
  EXPECT_EQ(j["rotor"]["gear_ratio"].get<double>(), 6.0);
}

TEST_F(SidIdentifyRuns, BadInputIsRefusedWithAMessageNamingIt) {
  const std::string c = std::string(kColumns) + " ";
  expect_input_error("--columns t=time,speed=v " + run("01"), "unknown key 'speed'");
  expect_input_error("--columns t=time,t=x " + run("01"), "'t' is given twice");
  expect_input_error("--columns time " + run("01"), "is not KEY=NAME");
  expect_input_error(c + "--validate missing.csv " + run("01"), "missing.csv");
  expect_input_error(c + "--effects friction " + run("01"), "unknown effect id 'friction'");
  expect_input_error(c + "--gear-ratio 6 " + run("01"), "--gear-ratio needs armature_j2");
  expect_input_error(c + "--cutoff -1 " + run("01"), "--cutoff must be a finite number > 0");
  expect_input_error(c + "--smoothing torque-cv --sigma-q 1e-3 " + run("01"),
                     "do not apply to --smoothing torque-cv");
  expect_input_error(c + "--smoothing gcv " + run("01") + " " + run("02"),
                     "several runs are fitted together only");
  expect_input_error(c + "--reference-theta 1,2,3 " + run("01"),
                     "--reference-theta needs 7 values");
  expect_input_error(c + "- -", "standard input ('-') can be read only once");
}

TEST_F(SidIdentifyRuns, HelpExplainsTheRunOptions) {
  const AppRun r = identify("--help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* word : {"--columns", "--validate", "--cutoff", "--effects", "--reference-theta",
                           "--gear-ratio", "torque-cv", "Several runs", "validation", "physical"})
    EXPECT_NE(r.out.find(word), std::string::npos) << "help lacks " << word;
}
