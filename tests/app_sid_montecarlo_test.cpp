// Runs the sid_montecarlo binary on short studies, as a user would, and checks its terminal
// output, JSON, CSV and figures, its refusal to overwrite, and its messages and exit codes.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "app_test_support.hpp"
#include "csv.hpp"
#include "plot.hpp"

namespace fs = std::filesystem;

namespace {

using sid_test::AppRun;

class SidMonteCarlo : public sid_test::AppTest {
 protected:
  // env is prepended to the command (e.g. "X=1 ").
  AppRun run(const std::string& args, const std::string& env = "") const {
    return shell(env + app("sid_montecarlo") + " " + args);
  }

  // Expects exit code 2, nothing on stdout and an error message containing what.
  void expect_input_error(const std::string& args, const std::string& what) const {
    const AppRun r = run(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("sid_montecarlo: error: ", 0), 0u) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos)
        << args << "\nexpected: " << what << "\ngot: " << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
  }

  nlohmann::json read_json(const std::string& name) const {
    return nlohmann::json::parse(read(file(name)));
  }
};

// stdout without the wall-time line (the only one that may differ between runs).
std::string without_wall_time(const std::string& text) {
  std::istringstream in(text);
  std::string line, out;
  while (std::getline(in, line))
    if (line.rfind("wall time", 0) != 0) out += line + "\n";
  return out;
}

void expect_vector7(const nlohmann::json& method, const char* key, const std::string& where) {
  ASSERT_TRUE(method.contains(key)) << where << " has no " << key;
  ASSERT_TRUE(method[key].is_array()) << where << "." << key;
  ASSERT_EQ(method[key].size(), 7u) << where << "." << key;
  for (const auto& v : method[key]) EXPECT_TRUE(v.is_number()) << where << "." << key << ": " << v;
}

int count_data_lines(const std::string& text) {
  std::istringstream in(text);
  std::string line;
  int rows = -1;  // the header
  while (std::getline(in, line))
    if (!line.empty() && line[0] != '#') ++rows;
  return rows;
}

}  // namespace

TEST_F(SidMonteCarlo, HelpExplainsEveryOptionAndTheMethodsAndExitsZero) {
  const AppRun r = run("--help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* word : {"--runs",         "--levels",
                           "--sigma-tau2",   "--methods",
                           "--seed",         "--threads",
                           "--json",         "--csv-dir",
                           "--plots",        "--quiet",
                           "--force",        "raw",
                           "filtered",       "css",
                           "oracle",         "forward differences",
                           "Butterworth",    "smoothing spline",
                           "exact q",        "1.7475",
                           "gnuplot-nox",    "--robot",
                           "--tip",          "--rate",
                           "base parameters"})
    EXPECT_NE(r.out.find(word), std::string::npos) << "help does not mention " << word;
}

TEST_F(SidMonteCarlo, OutputIsTheSameForAnyThreadCountAndJsonHasEveryKey) {
  const std::string study = "--runs 4 --levels 1e-6 --seed 11 ";
  const AppRun one = run(study + "--threads 1 --json one.json");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  const AppRun two = run(study + "--threads 2 --json two.json");
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_EQ(without_wall_time(one.out), without_wall_time(two.out));
  EXPECT_NE(one.out.find("wall time"), std::string::npos) << one.out;

  // The terminal report: settings, the paper's values beside ours, the ranking.
  for (const char* text :
       {"runs per level   4", "seed             11", "sigma_tau2", "1e-6", "tables 4 and 5",
        "Sample means", "Sample variances", "ours / paper", "0.0366", "~1e-08", "bias %", "std %",
        "best first", "worst |bias|", "theta7"})
    EXPECT_NE(one.out.find(text), std::string::npos) << "stdout lacks '" << text << "'\n"
                                                     << one.out;
  std::istringstream lines(one.out);
  for (std::string line; std::getline(lines, line);)
    EXPECT_LE(line.size(), 100u) << "too wide for a 100-column terminal: " << line;

  nlohmann::json a = read_json("one.json"), b = read_json("two.json");
  for (const char* key : {"runs", "seed", "true_theta", "levels", "wall_seconds"})
    ASSERT_TRUE(a.contains(key)) << "JSON lacks " << key;
  EXPECT_EQ(a["runs"], 4);
  EXPECT_EQ(a["seed"], 11);
  ASSERT_EQ(a["true_theta"].size(), 7u);
  EXPECT_DOUBLE_EQ(a["true_theta"][0].get<double>(), 0.034015193438);
  EXPECT_TRUE(a["wall_seconds"].is_number());
  ASSERT_EQ(a["levels"].size(), 1u);
  const auto& level = a["levels"][0];
  EXPECT_DOUBLE_EQ(level["sigma_q2"].get<double>(), 1e-6);
  ASSERT_TRUE(level["methods"].is_object());
  for (const char* m : {"raw", "filtered", "css", "oracle"}) {
    ASSERT_TRUE(level["methods"].contains(m)) << "JSON lacks method " << m;
    const auto& method = level["methods"][m];
    for (const char* key : {"mean", "var", "bias_pct", "std_pct"}) expect_vector7(method, key, m);
    ASSERT_TRUE(method.contains("rms_rel_error_pct")) << m;
    EXPECT_TRUE(method["rms_rel_error_pct"].is_number()) << m;
  }
  EXPECT_EQ(level["methods"].size(), 4u);
  const double oracle = level["methods"]["oracle"]["rms_rel_error_pct"];
  const double css = level["methods"]["css"]["rms_rel_error_pct"];
  const double raw = level["methods"]["raw"]["rms_rel_error_pct"];
  EXPECT_LT(oracle, 10.0);
  EXPECT_GT(raw, css);

  // The numbers are identical for any thread count; only the timing may differ.
  for (auto* j : {&a, &b}) {
    j->erase("wall_seconds");
    j->erase("threads");
  }
  EXPECT_EQ(a, b);
}

TEST_F(SidMonteCarlo, MethodsSubsetInAnyOrder) {
  const AppRun r = run("--runs 3 --levels 1e-8 --methods css,raw -q --json s.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "--quiet still printed: " << r.err;
  EXPECT_NE(r.out.find("methods          css, raw"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("oracle"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("filtered"), std::string::npos) << r.out;
  const auto j = read_json("s.json");
  std::set<std::string> keys;
  for (const auto& [key, value] : j["levels"][0]["methods"].items()) keys.insert(key);
  EXPECT_EQ(keys, (std::set<std::string>{"css", "raw"}));
}

TEST_F(SidMonteCarlo, CsvDirHoldsEveryEstimateOfEveryRun) {
  const AppRun r =
      run("--runs 3 --levels 1e-8,1e-6 --methods raw,css,oracle --csv-dir est --json s.json -q");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // One long file: runs x levels x methods rows.
  const std::string all = read(file("est/estimates.csv"));
  EXPECT_NE(all.find("level,method,run,theta1,theta2,theta3,theta4,theta5,theta6,theta7"),
            std::string::npos)
      << all;
  EXPECT_EQ(count_data_lines(all), 3 * 2 * 3);
  // One numeric file per level and method, whose column means are the JSON's means.
  const auto j = read_json("s.json");
  const std::vector<std::string> levels{"1e-8", "1e-6"};
  for (std::size_t l = 0; l < levels.size(); ++l)
    for (const char* m : {"raw", "css", "oracle"}) {
      const std::string name = std::string(m) + "_" + levels[l] + ".csv";
      ASSERT_TRUE(fs::exists(file("est/" + name))) << name;
      const auto table = sid::app::read_csv(file("est/" + name));
      ASSERT_EQ(table.rows(), 3) << name;
      for (int p = 0; p < 7; ++p) {
        const double mean = table.column("theta" + std::to_string(p + 1)).mean();
        const double expected = j["levels"][l]["methods"][m]["mean"][static_cast<std::size_t>(p)];
        EXPECT_NEAR(mean, expected, 1e-12 * std::fabs(expected)) << name << " theta" << p + 1;
      }
    }
}

TEST_F(SidMonteCarlo, PlotsWriteTheFiguresOrTheirDataWithoutGnuplot) {
  const std::vector<std::string> figures{
      "fig2_qdd1", "fig2_qdd1_detail", "fig3_qdd2", "fig3_qdd2_detail", "theta1", "theta2",
      "theta3",    "theta4",           "theta5",    "theta6",           "theta7"};
  const AppRun r = run("--runs 3 --levels 1e-6 --plots figs");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const bool have_gnuplot = !sid::app::find_gnuplot().empty();
  for (const auto& f : figures) {
    EXPECT_TRUE(fs::exists(file("figs/" + f + ".dat"))) << f;
    EXPECT_TRUE(fs::exists(file("figs/" + f + ".gp"))) << f;
    if (have_gnuplot) {
      EXPECT_TRUE(fs::exists(file("figs/" + f + ".png"))) << f << "\n" << r.err;
    }
  }
  // The box plots name the groups "method level"; Fig. 2 shows exact, CSS and filtered.
  EXPECT_NE(read(file("figs/theta3.dat")).find("css 1e-6"), std::string::npos);
  const std::string fig2 = read(file("figs/fig2_qdd1.gp"));
  for (const char* series : {"exact", "CSS", "filtered", "clipped"})
    EXPECT_NE(fig2.find(series), std::string::npos) << series << "\n" << fig2;

  // Without gnuplot the data is still written, the user is told how to install it, exit 0.
  const AppRun missing =
      run("--runs 3 --levels 1e-6 --plots nogp", "SID_GNUPLOT=/nonexistent/gnuplot ");
  EXPECT_EQ(missing.exit_code, 0) << missing.err;
  EXPECT_NE(missing.err.find("gnuplot-nox"), std::string::npos) << missing.err;
  for (const auto& f : figures) EXPECT_TRUE(fs::exists(file("nogp/" + f + ".dat"))) << f;
}

TEST_F(SidMonteCarlo, RefusesToOverwriteWithoutForce) {
  std::ofstream(file("s.json")) << "keep";
  expect_input_error("--runs 2 --levels 1e-6 --json s.json", "--force");
  EXPECT_EQ(read(file("s.json")), "keep");

  fs::create_directories(file("est"));
  std::ofstream(file("est/estimates.csv")) << "keep";
  expect_input_error("--runs 2 --levels 1e-6 --csv-dir est", "--force");
  EXPECT_EQ(read(file("est/estimates.csv")), "keep");

  fs::create_directories(file("figs"));
  std::ofstream(file("figs/theta1.gp")) << "keep";
  expect_input_error("--runs 2 --levels 1e-6 --plots figs", "--force");
  EXPECT_EQ(read(file("figs/theta1.gp")), "keep");

  const AppRun forced =
      run("--runs 2 --levels 1e-6 --methods oracle --json s.json --csv-dir est --force -q");
  ASSERT_EQ(forced.exit_code, 0) << forced.err;
  EXPECT_EQ(read_json("s.json")["runs"], 2);
  EXPECT_NE(read(file("est/estimates.csv")), "keep");
}

TEST_F(SidMonteCarlo, BadOptionsExitTwoNamingTheOption) {
  expect_input_error("--runs 1", "--runs");
  expect_input_error("--runs x", "--runs");
  expect_input_error("--levels ''", "--levels");
  expect_input_error("--levels 1e-6,-1e-4", "--levels");
  expect_input_error("--levels 0", "--levels");
  expect_input_error("--levels nan", "--levels");
  expect_input_error("--levels 1e-6,abc", "--levels");
  expect_input_error("--methods raw,kalman", "--methods: unknown method 'kalman'");
  expect_input_error("--methods ''", "--methods");
  expect_input_error("--methods css,css", "--methods");
  expect_input_error("--threads -1", "--threads");
  expect_input_error("--sigma-tau2 -0.1", "--sigma-tau2");
  expect_input_error("--seed -5", "--seed");
  expect_input_error("--json no_such_dir/s.json", "--json");
  expect_input_error("--unknown-option", "unknown-option");
  std::ofstream(file("plain_file")) << "x";
  expect_input_error("--plots plain_file", "--plots");
}

TEST_F(SidMonteCarlo, EstimatorMethodsCssWlsAndCssIvRunInTheStudy) {
  const AppRun r = run("--runs 3 --levels 1e-6 --methods css_gcv,css_wls,css_iv -q --json s.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = read_json("s.json");
  const auto& methods = j["levels"][0]["methods"];
  for (const char* m : {"css_gcv", "css_wls", "css_iv"}) {
    ASSERT_TRUE(methods.contains(m)) << m;
    EXPECT_EQ(methods[m]["failed_runs"], 0) << m;
    // Within a few percent of the truth at this noise level (the oracle's floor is about 2 %).
    EXPECT_LT(methods[m]["rms_rel_error_pct"].get<double>(), 5.0) << m;
  }
  EXPECT_NE(methods["css_iv"]["mean"], methods["css_gcv"]["mean"]);
  const AppRun bad = run("--methods css_iv,oracle,css_iv");
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("'css_iv' is given twice"), std::string::npos) << bad.err;
}

TEST_F(SidMonteCarlo, RobotRunsTheStudyOnAChainOfAUrdf) {
  // The first two joints of a URDF arm (damping on both, Coulomb friction on the first), 3 s at
  // 200 Hz: every method fits the chain's base parameters.
  const std::string robot = "--robot '" SID_TEST_DATA_DIR "/urdf/arm_hand.urdf' --tip link2 ";
  const std::string study = robot +
                            "--duration 3 --rate 200 --runs 3 --levels 1e-6 --seed 3 "
                            "--methods raw,css,css_iv,oracle ";
  const AppRun one = run(study + "--threads 1 --json one.json --csv-dir est");
  ASSERT_EQ(one.exit_code, 0) << one.err;
  // Every estimate of every run: estimates.csv and one file per method and level.
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(file("est"))) {
    ++files;
    const std::string name = entry.path().filename().string();
    if (name == "estimates.csv") continue;
    const sid::app::CsvTable table = sid::app::read_csv(entry.path().string());
    EXPECT_EQ(table.rows(), 3) << name;
    EXPECT_TRUE(table.has("run") && table.has("beta1")) << name;
  }
  EXPECT_EQ(files, 5u);
  EXPECT_NE(read(file("est/estimates.csv")).find("# beta1 = "), std::string::npos);
  const AppRun two = run(study + "--threads 2 --json two.json -q --plots figs");
  ASSERT_EQ(two.exit_code, 0) << two.err;
  EXPECT_EQ(without_wall_time(one.out), without_wall_time(two.out));
  for (const char* word :
       {"Monte Carlo study of a chain", "j1, j2", "base parameters", "oracle", "zero in truth"})
    EXPECT_NE(one.out.find(word), std::string::npos) << word << "\n" << one.out;
  auto a = read_json("one.json"), b = read_json("two.json");
  a.erase("wall_seconds");
  b.erase("wall_seconds");
  a.erase("threads");
  b.erase("threads");
  EXPECT_EQ(a, b);
  EXPECT_EQ(a["joint_names"], (nlohmann::json{"j1", "j2"}));
  const std::size_t p = a["parameter_names"].size();
  EXPECT_EQ(a["true_beta"].size(), p);
  const auto& methods = a["levels"][0]["methods"];
  for (const char* m : {"raw", "css", "css_iv", "oracle"}) {
    ASSERT_TRUE(methods.contains(m)) << m;
    EXPECT_EQ(methods[m]["failed_runs"], 0) << m;
    EXPECT_EQ(methods[m]["mean"].size(), p) << m;
    EXPECT_EQ(methods[m]["torque_error_pct"].size(), 3u) << m;
  }
  EXPECT_LT(methods["css"]["mean_torque_error_pct"].get<double>(),
            methods["raw"]["mean_torque_error_pct"].get<double>());
  EXPECT_LT(methods["oracle"]["mean_torque_error_pct"].get<double>(), 1.0);

  // The figures: the torque errors, each joint's acceleration, each base parameter's estimates.
  std::vector<std::string> figures{"torque_error", "qdd_j1", "qdd_j2"};
  for (std::size_t k = 1; k <= p; ++k) figures.push_back("beta" + std::to_string(k));
  const bool have_gnuplot = !sid::app::find_gnuplot().empty();
  std::size_t written = 0;
  for (const auto& entry : fs::directory_iterator(file("figs"))) (void)entry, ++written;
  EXPECT_EQ(written, figures.size() * (have_gnuplot ? 3 : 2));
  for (const auto& f : figures) {
    EXPECT_TRUE(fs::exists(file("figs/" + f + ".dat"))) << f;
    if (have_gnuplot) {
      EXPECT_TRUE(fs::exists(file("figs/" + f + ".png"))) << f << "\n" << two.err;
    }
  }
  // A box per method and level, each holding the three runs' torque errors as the JSON has them.
  const std::string torque = read(file("figs/torque_error.dat"));
  for (const char* m : {"raw", "css", "css_iv", "oracle"}) {
    const std::string header = std::string("# ") + m + " 1e-6\n";
    const auto at = torque.find(header);
    ASSERT_NE(at, std::string::npos) << m << "\n" << torque;
    std::istringstream values(torque.substr(at + header.size()));
    for (int run = 0; run < 3; ++run) {
      double v = 0;
      ASSERT_TRUE(values >> v) << m;
      EXPECT_NEAR(v, methods[m]["torque_error_pct"][run].get<double>(), 1e-6 * std::abs(v))
          << m << " run " << run;
    }
  }
  EXPECT_NE(read(file("figs/qdd_j2.gp")).find("dropped by filtered"), std::string::npos);
  EXPECT_NE(read(file("figs/beta1.gp")).find("true value"), std::string::npos);
}

TEST_F(SidMonteCarlo, RobotOptionsAreCheckedBeforeAnyWork) {
  const std::string robot = "--robot '" SID_TEST_DATA_DIR "/urdf/arm_hand.urdf' --tip link2 ";
  expect_input_error("--tip link2", "--tip is an option of --robot");
  expect_input_error("--duration 5", "--duration is an option of --robot");
  fs::create_directories(file("figs"));
  std::ofstream(file("figs/qdd_j2.gp")) << "keep";
  expect_input_error(robot + "--runs 2 --plots figs", "--force");
  EXPECT_EQ(read(file("figs/qdd_j2.gp")), "keep");
  fs::create_directories(file("taken"));
  std::ofstream(file("taken/estimates.csv")) << "keep";
  expect_input_error(robot + "--runs 2 --csv-dir taken", "--force");
  expect_input_error(robot + "--rate 10", "--rate");
  expect_input_error(robot + "--duration 0.5", "--duration");
  expect_input_error(robot + "--harmonics 0", "--harmonics");
  expect_input_error("--robot no_such_file.urdf", "no_such_file.urdf");
  std::ofstream(file("s.json")) << "keep";
  expect_input_error(robot + "--runs 2 --json s.json", "--force");
  EXPECT_EQ(read(file("s.json")), "keep");
}

// A cheap arm's sensors in the study: the header says what they are, the JSON records them and
// css_tcv's estimate of the torque's delay on every run.
TEST_F(SidMonteCarlo, RobotRunsAreLoggedThroughACheapArmsSensors) {
  const std::string robot = "--robot '" SID_TEST_DATA_DIR "/urdf/arm_hand.urdf' --tip link2 ";
  const AppRun r = run(robot +
                       "--duration 3 --rate 200 --runs 2 --levels 1e-8 --seed 3 "
                       "--methods css,css_tcv,oracle --encoder-bits 12 --torque-delay 0.01 "
                       "--estimate-torque-delay 0.05 --json s.json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* line : {"sensors          12-bit encoders on the joints, torque logged 10 ms",
                           "css_tcv          estimates the torque's delay within +-50 ms",
                           "css_tcv's torque delay found: "})
    EXPECT_NE(r.out.find(line), std::string::npos) << line << "\n" << r.out;
  const nlohmann::json j = read_json("s.json");
  EXPECT_EQ(j["sensors"]["encoder_bits"], (nlohmann::json{12}));
  EXPECT_EQ(j["sensors"]["torque_delay"].get<double>(), 0.01);
  EXPECT_EQ(j["estimate_torque_delay"].get<double>(), 0.05);
  const auto& delays = j["levels"][0]["torque_delays"];
  ASSERT_EQ(delays.size(), 2u);
  // Where it lies is the library's test (a 3 s run of two joints says little); here, within
  // the search.
  for (const auto& d : delays) EXPECT_LE(std::abs(d.get<double>()), 0.05) << d;

  expect_input_error(robot + "--encoder-bits 0", "--encoder-bits");
  expect_input_error(robot + "--encoder-bits 12,12,12", "--encoder-bits");
  expect_input_error(robot + "--encoder-ratio 50", "--encoder-ratio needs --encoder-bits");
  expect_input_error(robot + "--estimate-torque-delay 0.01", "add css_tcv to --methods");
  expect_input_error(robot + "--methods css_tcv --estimate-torque-delay 0.5",
                     "--estimate-torque-delay must be in (0, 0.1] s");
  expect_input_error("--encoder-bits 12", "--encoder-bits is an option of --robot");
}
