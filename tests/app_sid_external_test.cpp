// Runs sid_simulate --push, sid_identify and sid_external as a user would: a UR5 identified on a
// log without contact, then a log where the outside pushes at the tool twice. Both pushes must
// be found where they were and nothing else, and the external torque must match the pushes'
// J^T f, which sid_simulate --truth writes.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <sid/detail/format.hpp>
#include <sid/external_torque.hpp>

#include "app_test_support.hpp"
#include "csv.hpp"
#include "identified_arm.hpp"
#include "robot_description.hpp"

namespace {

const std::string kRobot = "--robot '" SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf' --tip tool0 ";

// Angles with 1e-6 rad of noise (a motor encoder seen through its gear), torques with 0.1 N m
// (about 1 % of the arm's torque), at 1 kHz.
const std::string kNoise = "--T 10 --Ts 0.001 --sigma-q2 1e-12 --sigma-tau2 0.01 ";

// Two pushes at the tool: 36 N for 0.3 s and 27 N for 0.4 s, each with 20 ms ramps.
constexpr double kPushes[2][2] = {{3.0, 3.3}, {6.5, 6.9}};
const std::string kPushOptions = "--push 3,3.3,0,30,-20 --push 6.5,6.9,25,0,10 ";

class SidExternal : public sid_test::AppTest {
 protected:
  // The arm's fit and the pushed log, made once for the suite.
  static void SetUpTestSuite() {
    shared_ =
        std::filesystem::temp_directory_path() / ("SidExternal_" + std::to_string(::getpid()));
    std::filesystem::create_directories(shared_);
    const std::string in = "cd '" + shared_.string() + "' && ";
    const std::string sim = in + app("sid_simulate") + " " + kRobot + kNoise;
    ASSERT_EQ(std::system((sim + "--seed 1 -o fit.csv 2>/dev/null").c_str()), 0);
    ASSERT_EQ(std::system((in + app("sid_identify") + " " + kRobot +
                           "--json arm.json fit.csv >/dev/null 2>&1")
                              .c_str()),
              0);
    ASSERT_EQ(
        std::system((sim + "--seed 2 " + kPushOptions + "--truth -o push.csv 2>/dev/null").c_str()),
        0);
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    std::filesystem::remove_all(shared_, ec);
  }
  static std::string shared(const std::string& name) {
    return "'" + (shared_ / name).string() + "'";
  }

  sid_test::AppRun external(const std::string& options) const {
    return shell(app("sid_external") + " " + kRobot + "--model " + shared("arm.json") + " " +
                 options + " " + shared("push.csv"));
  }

  // Checks the contacts and the external torque an EXT.csv and its JSON give.
  void expect_both_pushes(const std::string& csv, const std::string& json_file, double tolerance,
                          double end_tolerance = 0.050) const {
    const nlohmann::json j = nlohmann::json::parse(read(file(json_file)));
    ASSERT_EQ(j["contacts"].size(), 2u) << j["contacts"].dump();
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(j["contacts"][c]["start"].get<double>(), kPushes[c][0], 0.030) << "contact " << c;
      EXPECT_NEAR(j["contacts"][c]["end"].get<double>(), kPushes[c][1], end_tolerance)
          << "contact " << c;
    }
    const sid::app::CsvTable truth = sid::app::read_csv((shared_ / "push.csv").string());
    const sid::app::CsvTable ext = sid::app::read_csv(file(csv));
    ASSERT_EQ(ext.rows(), truth.rows());
    const Eigen::VectorXd& t = truth.column("t");
    for (int joint = 1; joint <= 6; ++joint) {
      const Eigen::VectorXd& expected = truth.column("tau" + std::to_string(joint) + "_ext");
      const Eigen::VectorXd& found = ext.column("tau_ext" + std::to_string(joint));
      const double peak = expected.cwiseAbs().maxCoeff();
      const double threshold = j["thresholds"][joint - 1].get<double>();
      if (peak < threshold) continue;  // a push this joint barely feels is no contact on it
      double worst = 0.0;
      for (Eigen::Index i = 0; i < t.size(); ++i)
        for (const auto& push : kPushes)
          if (t[i] >= push[0] && t[i] <= push[1])
            worst = std::max(worst, std::abs(found[i] - expected[i]));
      EXPECT_LT(worst, tolerance * peak) << "joint " << joint << ", peak " << peak;
    }
    // Nothing else: outside the pushes the contact column stays 0.
    const Eigen::VectorXd& contact = ext.column("contact");
    for (Eigen::Index i = 0; i < t.size(); ++i) {
      const bool pushed = (t[i] > kPushes[0][0] - 0.03 && t[i] < kPushes[0][1] + end_tolerance) ||
                          (t[i] > kPushes[1][0] - 0.03 && t[i] < kPushes[1][1] + end_tolerance);
      if (!pushed) {
        ASSERT_EQ(contact[i], 0.0) << "t = " << t[i];
      }
    }
  }

  static std::filesystem::path shared_;
};

std::filesystem::path SidExternal::shared_;

TEST_F(SidExternal, TheObserverFindsBothPushesAndNothingElse) {
  const sid_test::AppRun r = external("-o ext.csv --json ext.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("2 contacts"), std::string::npos) << r.out;
  expect_both_pushes("ext.csv", "ext.json", 0.15);
  const nlohmann::json j = nlohmann::json::parse(read(file("ext.json")));
  EXPECT_EQ(j["method"], "observer");
  EXPECT_EQ(j["gain"].get<double>(), 300.0);
}

TEST_F(SidExternal, TheResidualFindsThemToo) {
  // The inverse-dynamics residual takes accelerations smoothed at the fit's cutoffs, which
  // blur the jolt a push gives the arm: it finds both, with a looser end and match.
  const sid_test::AppRun r = external("--method residual -o ext.csv --json ext.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  expect_both_pushes("ext.csv", "ext.json", 0.6, 0.080);
}

TEST_F(SidExternal, ALogWithoutContactHasNone) {
  // The fit's own log: the model's residual sets the thresholds, so it must stay under them.
  const sid_test::AppRun r = shell(app("sid_external") + " " + kRobot + "--model " +
                                   shared("arm.json") + " --json ext.json " + shared("fit.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(read(file("ext.json")))["contacts"].size(), 0u) << r.out;
}

TEST_F(SidExternal, FindsBothPushesInAMeasuredLog) {
  // The same logs with their angles logged to 1e-5 rad, as a robot's controller writes them:
  // GCV would take the steps for motion, so the rates come from the fit's cutoffs scaled to
  // the log, and the observer is no faster than they are.
  const auto rounded = [&](const std::string& from, const std::string& to) {
    sid::app::CsvTable table = sid::app::read_csv((shared_ / from).string());
    for (std::size_t c = 0; c < table.names.size(); ++c)
      if (table.names[c][0] == 'q')
        table.columns[c] = (table.columns[c] * 1e5).array().round() / 1e5;
    sid::app::write_csv(file(to), table.names, table.columns);
  };
  rounded("fit.csv", "fit_rounded.csv");
  rounded("push.csv", "push_rounded.csv");
  ASSERT_EQ(shell(app("sid_identify") + " " + kRobot + "--json arm.json fit_rounded.csv").exit_code,
            0);
  const sid_test::AppRun r = shell(app("sid_external") + " " + kRobot +
                                   "--model arm.json -o ext.csv --json ext.json push_rounded.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read(file("ext.json")));
  EXPECT_NE(j["rate_cutoff_choice"].get<std::string>().find("grid"), std::string::npos)
      << j["rate_cutoff_choice"];
  // The slower observer rounds the pushes' 20 ms ramps more at their corners: 0.20 of the peak
  // at most here, against 0.15 for the log as simulated.
  expect_both_pushes("ext.csv", "ext.json", 0.25);
  EXPECT_LT(j["gain"].get<double>(), 300.0);
}

TEST_F(SidExternal, AnEstimateBeyondAJointsEffortLimitIsTheModelsFailureNotAContact) {
  // The same arm, its shoulder's drive rated 9 N m: the first push (10.7 N m there) is more
  // than it could hold against, the second (7.8 N m) is not.
  std::string urdf = read(SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf");
  const std::size_t joint = urdf.find("<joint name=\"shoulder_pan_joint\"");
  ASSERT_NE(joint, std::string::npos);
  const std::size_t effort = urdf.find("effort=\"", joint) + std::string("effort=\"").size();
  urdf.replace(effort, urdf.find('"', effort) - effort, "9.0");
  write("weak.urdf", urdf);
  const sid_test::AppRun r =
      shell(app("sid_external") + " --robot weak.urdf --tip tool0 --model " + shared("arm.json") +
            " -o ext.csv --json ext.json " + shared("push.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("beyond its effort limit"), std::string::npos) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read(file("ext.json")));
  ASSERT_EQ(j["contacts"].size(), 1u) << j["contacts"].dump();
  EXPECT_NEAR(j["contacts"][0]["start"].get<double>(), kPushes[1][0], 0.030);
  ASSERT_EQ(j["beyond_effort_limit"].size(), 1u) << j.dump();
  EXPECT_NEAR(j["beyond_effort_limit"][0]["start"].get<double>(), kPushes[0][0], 0.030);
  EXPECT_EQ(j["effort_limit"][0].get<double>(), 9.0);
  // Its samples are not marked as contact.
  const sid::app::CsvTable ext = sid::app::read_csv(file("ext.csv"));
  for (Eigen::Index i = 0; i < ext.rows(); ++i)
    if (ext.column("t")[i] > kPushes[0][0] && ext.column("t")[i] < kPushes[0][1]) {
      ASSERT_EQ(ext.column("contact")[i], 0.0) << "t = " << ext.column("t")[i];
    }
}

TEST_F(SidExternal, RefusesWhatItCannotUse) {
  // Another model: the fit's parameters are not this chain's.
  nlohmann::json arm = nlohmann::json::parse(read((shared_ / "arm.json").string()));
  arm["drive_terms"] = {"viscous"};
  write("other.json", arm.dump());
  sid_test::AppRun r =
      shell(app("sid_external") + " " + kRobot + "--model other.json " + shared("push.csv"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("another model"), std::string::npos) << r.err;

  write("bad.json", "{\"drive_terms\": [");
  r = shell(app("sid_external") + " " + kRobot + "--model bad.json " + shared("push.csv"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("not JSON"), std::string::npos) << r.err;

  r = external("--gain 0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--gain"), std::string::npos) << r.err;

  r = external("--method kalman");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--method"), std::string::npos) << r.err;

  write("ext.csv", "keep");
  r = external("-o ext.csv");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--force"), std::string::npos) << r.err;
  EXPECT_EQ(read(file("ext.csv")), "keep");
}

}  // namespace

// A C++ program that links the library gets sid_external's numbers from one call of
// sid::estimate_external_torque on the arm the tool reads.
TEST_F(SidExternal, TheLibraryCallGivesTheToolsNumbers) {
  const sid_test::AppRun r = external("--json ext.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(read(file("ext.json")));
  const sid::RobotDescription robot =
      sid::app::read_robot_description(SID_TEST_DATA_DIR "/urdf/real/ur5_robot.urdf", "", "tool0");
  const sid::app::IdentifiedArm arm = sid::app::read_identified_arm(
      (shared_ / "arm.json").string(), robot, sid::Transmission(robot.chain.joints()));
  const sid::ChainTrajectory<double> log =
      sid::app::chain_trajectory_from_table(sid::app::read_csv((shared_ / "push.csv").string()), 6,
                                            sid::app::chain_columns("", 6, "--columns"));
  const sid::ExternalTorque e = sid::estimate_external_torque(arm.model, arm.theta, arm.cutoff_hz,
                                                              arm.residual_rms_measured, log);
  const auto expect_same = [](const nlohmann::json& tool, const Eigen::VectorXd& library,
                              const char* what) {
    ASSERT_EQ(tool.size(), std::size_t(library.size())) << what;
    for (Eigen::Index i = 0; i < library.size(); ++i)
      EXPECT_EQ(tool[std::size_t(i)].get<double>(), library[i]) << what << " " << i;
  };
  expect_same(j["rate_cutoff_hz"], e.rate_cutoff_hz, "rate_cutoff_hz");
  EXPECT_EQ(j["rate_cutoff_choice"].get<std::string>(), e.rate_cutoff_choice);
  EXPECT_EQ(j["gain"].get<double>(), e.gain);
  expect_same(j["thresholds"], e.thresholds, "thresholds");
  expect_same(j["peak"], e.external.cwiseAbs().colwise().maxCoeff().transpose(), "peak");
  ASSERT_EQ(j["contacts"].size(), e.contacts.size());
  for (std::size_t c = 0; c < e.contacts.size(); ++c) {
    EXPECT_EQ(j["contacts"][c]["start"].get<double>(), e.contacts[c].start);
    EXPECT_EQ(j["contacts"][c]["end"].get<double>(), e.contacts[c].end);
  }
  // The library refuses what it cannot use, naming it.
  sid::ExternalTorqueOptions bad;
  bad.skip = 6.0;
  try {
    (void)sid::estimate_external_torque(arm.model, arm.theta, arm.cutoff_hz,
                                        arm.residual_rms_measured, log, bad);
    ADD_FAILURE() << "a skip longer than half the log was taken";
  } catch (const std::invalid_argument& error) {
    EXPECT_NE(std::string(error.what()).find("skip"), std::string::npos) << error.what();
  }
}

// The real logs the project ships, each with the tool's defaults: none has a contact, so none
// may be found, and the estimate (the model's own error, seen through the observer) must stay
// within twice the model's residual on that log.
// - The DFKI double pendulum (14-bit encoders, 3.8e-4 rad per count): GCV takes the encoder's
//   steps for motion (it smoothed at some 144 Hz and the momentum's spread reached 3 N m on
//   held-out run 12), so the rates come from the fit's cutoffs scaled to the log. Run 12 is a
//   swing-up faster than the fitted runs: at the fit's 4 Hz its elbow's reversal was smoothed
//   away and a 1.9 N m "contact" found on the shoulder.
// - The Staubli TX40 (motor-side, through its gears): the log's angles are not on a grid, so
//   GCV chooses their rates.
namespace {
/// The RMS of each tau_ext column of an EXT.csv away from the ends (skip at each).
std::vector<double> external_rms(const std::string& csv, std::size_t joints, double skip) {
  const sid::app::CsvTable table = sid::app::read_csv(csv);
  const Eigen::VectorXd& t = table.column("t");
  std::vector<double> rms;
  for (std::size_t j = 1; j <= joints; ++j) {
    const Eigen::VectorXd& external = table.column("tau_ext" + std::to_string(j));
    double squares = 0.0;
    int count = 0;
    for (Eigen::Index i = 0; i < t.size(); ++i)
      if (t[i] >= t[0] + skip && t[i] <= t[t.size() - 1] - skip) {
        squares += external[i] * external[i];
        ++count;
      }
    rms.push_back(std::sqrt(squares / count));
  }
  return rms;
}

class SidExternalRealLog : public sid_test::AppTest {
 protected:
  /// Runs sid_external with its defaults on log and checks what it says against the residual
  /// the model leaves there [N m, per joint].
  void expect_free_motion(const std::string& arm, const std::string& log,
                          const nlohmann::json& residual) {
    const sid_test::AppRun r =
        shell(app("sid_external") + " " + arm +
              "--model fit.json --json ext.json -o ext.csv --force '" + log + "'");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const nlohmann::json ext = nlohmann::json::parse(read(file("ext.json")));
    EXPECT_EQ(ext["contacts"].size(), 0u) << log << ": " << ext["contacts"].dump();
    EXPECT_EQ(ext["beyond_effort_limit"].size(), 0u) << log;
    const std::vector<double> rms = external_rms(file("ext.csv"), residual.size(), 0.1);
    for (std::size_t j = 0; j < residual.size(); ++j)
      EXPECT_LT(rms[j], 2.0 * residual[j].get<double>()) << log << ", joint " << j + 1;
  }
};
}  // namespace

TEST_F(SidExternalRealLog, TheDoublePendulumsRunsHaveNoContact) {
  const std::string data = SID_TEST_DATA_DIR "/dfki_double_pendulum/trajectory_";
  const std::string arm = "--robot '" SID_SOURCE_DIR
                          "/examples/dfki_double_pendulum.dh' --columns "
                          "t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2 ";
  std::string fitted;
  for (const char* run : {"00", "01", "02", "03", "05"}) fitted += " '" + data + run + ".csv'";
  const sid_test::AppRun fit = shell(app("sid_identify") + " " + arm + "--json fit.json" + fitted +
                                     " --validate '" + data + "12.csv'");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const nlohmann::json model = nlohmann::json::parse(read(file("fit.json")));
  for (const char* run : {"00", "01", "02", "03", "05"})
    expect_free_motion(arm, data + run + ".csv", model["residual_rms_measured"]);
  expect_free_motion(arm, data + "12.csv", model["validation"][0]["residual_rms_measured"]);
  const nlohmann::json ext = nlohmann::json::parse(read(file("ext.json")));
  EXPECT_NE(ext["rate_cutoff_choice"].get<std::string>().find("grid"), std::string::npos)
      << ext["rate_cutoff_choice"];
  // The observer no faster than its rates.
  EXPECT_LE(ext["gain"].get<double>(),
            2.0 * 3.14159265358979 * ext["rate_cutoff_hz"][0].get<double>() * (1.0 + 1e-12));
}

TEST_F(SidExternalRealLog, TheTx40sRunHasNoContact) {
  const std::string data = SID_TEST_DATA_DIR "/staubli_tx40/";
  // The log as the tools read it: the angles and the motor currents side by side, at 5 kHz.
  std::ifstream angles(data + "pos_read_data.csv"), currents(data + "curr_data.csv");
  std::string a, c;
  std::getline(angles, a);
  std::getline(currents, c);
  std::ostringstream log;
  log << "t,q1,q2,q3,q4,q5,q6,tau1,tau2,tau3,tau4,tau5,tau6\n";
  for (int i = 0; std::getline(angles, a) && std::getline(currents, c); ++i)
    log << sid::detail::format_number("%.4f", i * 0.0002) << "," << a << "," << c << "\n";
  write("tx40.csv", log.str());
  const std::string arm = "--robot '" + data + "tx40_mdh_modified.urdf' --transmission '" + data +
                          "tx40_transmission.yaml' ";
  const sid_test::AppRun fit = shell(app("sid_identify") + " " + arm + "--json fit.json tx40.csv");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  const nlohmann::json model = nlohmann::json::parse(read(file("fit.json")));
  expect_free_motion(arm, file("tx40.csv"), model["residual_rms_measured"]);
}

// A torque logged 10 ms behind the angles, identified with that delay: sid_external pairs each
// torque with the motion 10 ms earlier, as the fit did, and its estimate on free motion is the
// model's small error. Paired at no delay (the same fit without it), the motion's lag is taken
// for an outside torque three to six times larger on the first three joints.
TEST_F(SidExternal, PairsEachTorqueWithTheAnglesAtTheFitsDelay) {
  const std::string sim = app("sid_simulate") + " " + kRobot +
                          "--T 6 --Ts 0.001 --sigma-q2 1e-12 --sigma-tau2 1e-4 "
                          "--torque-delay 0.01 -q ";
  ASSERT_EQ(shell(sim + "--seed 1 -o fit.csv").exit_code, 0);
  ASSERT_EQ(shell(sim + "--seed 2 -o free.csv").exit_code, 0);
  const sid_test::AppRun fit =
      shell(app("sid_identify") + " " + kRobot + "--torque-delay 0.01 --json arm.json fit.csv");
  ASSERT_EQ(fit.exit_code, 0) << fit.err;
  nlohmann::json without = nlohmann::json::parse(read(file("arm.json")));
  ASSERT_EQ(without["torque_delay"].get<double>(), 0.01);
  without.erase("torque_delay");
  write("arm0.json", without.dump());

  const auto run = [&](const std::string& model, const std::string& name) {
    const sid_test::AppRun r = shell(app("sid_external") + " " + kRobot + "--model " + model +
                                     " --json " + name + ".json -o " + name + ".csv free.csv");
    EXPECT_EQ(r.exit_code, 0) << r.err;
    return r;
  };
  const sid_test::AppRun paired = run("arm.json", "paired");
  EXPECT_NE(paired.out.find("each torque paired with the angles 10 ms earlier"), std::string::npos)
      << paired.out;
  (void)run("arm0.json", "unpaired");
  const nlohmann::json j = nlohmann::json::parse(read(file("paired.json")));
  EXPECT_EQ(j["torque_delay"].get<double>(), 0.01);
  EXPECT_EQ(j["contacts"].size(), 0u) << j["contacts"].dump();
  const std::vector<double> at_delay = external_rms(file("paired.csv"), 6, 0.12),
                            at_none = external_rms(file("unpaired.csv"), 6, 0.12);
  for (int joint = 0; joint < 3; ++joint)
    EXPECT_LT(at_delay[joint], 0.5 * at_none[joint]) << "joint " << joint + 1;
  for (int joint = 0; joint < 6; ++joint)
    EXPECT_LT(at_delay[joint], 1.2 * at_none[joint]) << "joint " << joint + 1;

  // The delay needs as much of the log at each end.
  const sid_test::AppRun short_skip =
      shell(app("sid_external") + " " + kRobot + "--model arm.json --skip 0.005 free.csv");
  EXPECT_EQ(short_skip.exit_code, 2);
  EXPECT_NE(short_skip.err.find("shorter than the torque delay"), std::string::npos)
      << short_skip.err;
}
