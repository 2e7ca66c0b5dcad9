// Runs the sid_smooth binary on temporary files, as a user would, and checks its output, messages
// and exit codes.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <utility>

#include "app_test_support.hpp"
#include "csv.hpp"

namespace fs = std::filesystem;

namespace {

constexpr double kExactTol = 1e-12;      // a line is in the penalty's null space: rounding only
constexpr double kDerivativeTol = 1e-9;  // derivatives divide by knot spacings

using sid_test::AppRun;

class SidSmooth : public sid_test::AppTest {
 protected:
  AppRun run(const std::string& args) const { return shell(app("sid_smooth") + " " + args); }

  // Expects exit code 2, nothing on stdout and an error message containing what.
  void expect_input_error(const std::string& args, const std::string& what) const {
    const AppRun r = run(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("sid_smooth: error: ", 0), 0u) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos)
        << args << "\nexpected: " << what << "\ngot: " << r.err;
    EXPECT_TRUE(r.out.empty()) << args << "\n" << r.out;
  }

  sid::app::CsvTable parse_output(const std::string& text) const {
    std::istringstream in(text);
    return sid::app::parse_csv(in, "sid_smooth output");
  }
};

// Uneven sampling so the derivatives are not helped by symmetric spacing.
std::string line_csv() {
  std::string text = "# a straight line\ny,t,z\n";
  double t = 0.0;
  for (int i = 0; i < 40; ++i) {
    text += sid::app::format_double(2.0 + 3.0 * t) + "," + sid::app::format_double(t) + "," +
            sid::app::format_double(-1.0 - 0.5 * t) + "\n";
    t += 0.01 + 0.005 * (i % 3);
  }
  return text;
}

void expect_line(const sid::app::CsvTable& table, const std::string& name, double a, double b) {
  const Eigen::VectorXd& t = table.column("t");
  const Eigen::VectorXd& y = table.column(name);
  const Eigen::VectorXd& yd = table.column(name + "_d");
  const Eigen::VectorXd& ydd = table.column(name + "_dd");
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(y[i], a + b * t[i], kExactTol) << name << " row " << i;
    EXPECT_NEAR(yd[i], b, kDerivativeTol) << name << " row " << i;
    EXPECT_NEAR(ydd[i], 0.0, kDerivativeTol) << name << " row " << i;
  }
}

// n samples of sin(t) + N(0, sigma^2) on t = 0, 0.005, ... (fixed seed).
std::string noisy_sine_csv(int n, double sigma, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  std::string text = "t,q\n";
  for (int i = 0; i < n; ++i) {
    const double t = 0.005 * i;
    text +=
        sid::app::format_double(t) + "," + sid::app::format_double(std::sin(t) + noise(rng)) + "\n";
  }
  return text;
}

// The number after "key = " in text (NaN if absent).
double reported(const std::string& text, const std::string& key) {
  const auto at = text.find(key + " = ");
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

// RMS errors of q_d against cos t and q_dd against -sin t, away from the ends.
std::pair<double, double> sine_derivative_rms(const sid::app::CsvTable& table,
                                              Eigen::Index margin) {
  const Eigen::VectorXd t = table.column("t");
  const Eigen::Index len = t.size() - 2 * margin;
  const Eigen::ArrayXd ts = t.segment(margin, len).array();
  const double d_rms =
      std::sqrt((table.column("q_d").segment(margin, len).array() - ts.cos()).square().mean());
  const double dd_rms =
      std::sqrt((table.column("q_dd").segment(margin, len).array() + ts.sin()).square().mean());
  return {d_rms, dd_rms};
}

}  // namespace

TEST_F(SidSmooth, HelpExplainsEveryOptionAndExitsZero) {
  const AppRun r = run("--help");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  for (const char* word :
       {"--time", "--signal", "--sigma", "--weights", "--S", "--lambda", "--output", "--force",
        "--quiet", "S = n", "lambda = 1/p", "_dd", "--smoothing", "s-constraint", "gcv", "cv",
        "tr A", "sigma_hat", "degrees of freedom"})
    EXPECT_NE(r.out.find(word), std::string::npos) << "help does not mention " << word;
}

TEST_F(SidSmooth, StraightLineComesOutExactlyWithSlopeAndZeroCurvature) {
  write("line.csv", line_csv());
  const AppRun r = run("--sigma 0.01 line.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto table = parse_output(r.out);
  EXPECT_EQ(table.names, (std::vector<std::string>{"t", "y", "y_d", "y_dd", "z", "z_d", "z_dd"}));
  ASSERT_EQ(table.rows(), 40);
  expect_line(table, "y", 2.0, 3.0);
  expect_line(table, "z", -1.0, -0.5);
  // The summary names each signal and its parameters.
  EXPECT_NE(r.err.find("y: p = "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("lambda = "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("iterations = "), std::string::npos) << r.err;
}

TEST_F(SidSmooth, StraightLineIsExactInPenaltyFormToo) {
  write("line.csv", line_csv());
  const AppRun r = run("--sigma 0.01 --lambda 1e-4 --signal z -q line.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << "--quiet still printed: " << r.err;
  const auto table = parse_output(r.out);
  EXPECT_EQ(table.names, (std::vector<std::string>{"t", "z", "z_d", "z_dd"}));
  expect_line(table, "z", -1.0, -0.5);
}

TEST_F(SidSmooth, RecoversDerivativesOfNoisySine) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::string text = "t,q\n";
  for (int i = 0; i <= 400; ++i) {
    const double t = 0.01 * i;
    text +=
        sid::app::format_double(t) + "," + sid::app::format_double(std::sin(t) + noise(rng)) + "\n";
  }
  write("sine.csv", text);
  const AppRun r = run("--sigma 0.01 -o out.csv sine.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto table = sid::app::read_csv(file("out.csv"));
  const Eigen::VectorXd t = table.column("t");
  // Away from the ends (natural end conditions bias g'' there) the derivatives are close in
  // the RMS sense; the bounds are about twice what other noise draws give.
  const Eigen::Index lo = 40, len = t.size() - 80;
  const Eigen::ArrayXd ts = t.segment(lo, len).array();
  const double d_rms =
      std::sqrt((table.column("q_d").segment(lo, len).array() - ts.cos()).square().mean());
  const double dd_rms =
      std::sqrt((table.column("q_dd").segment(lo, len).array() + ts.sin()).square().mean());
  EXPECT_LT(d_rms, 0.04);
  EXPECT_LT(dd_rms, 0.5);
}

TEST_F(SidSmooth, PerSampleWeightsColumnIsUsedAndNotSmoothed) {
  std::string text = "t,y,dy\n";
  for (int i = 0; i < 20; ++i)
    text += std::to_string(i) + "," + std::to_string(1.0 + 0.25 * i) + "," +
            (i % 2 ? "0.1" : "0.2") + "\n";
  write("w.csv", text);
  const AppRun r = run("--weights dy w.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto table = parse_output(r.out);
  EXPECT_EQ(table.names, (std::vector<std::string>{"t", "y", "y_d", "y_dd"}));
  expect_line(table, "y", 1.0, 0.25);
}

TEST_F(SidSmooth, SigmaPerSignalMustMatchSignalCount) {
  write("line.csv", line_csv());
  EXPECT_EQ(run("--sigma 0.01,0.02 line.csv").exit_code, 0);
  expect_input_error("--sigma 0.01,0.02,0.03 line.csv",
                     "--sigma needs 1 value or 2 (one per signal: y, z), got 3");
}

TEST_F(SidSmooth, RefusesToOverwriteWithoutForce) {
  write("line.csv", line_csv());
  write("out.csv", "precious\n");
  expect_input_error("--sigma 0.01 -o out.csv line.csv",
                     "refusing to overwrite 'out.csv' (use --force)");
  EXPECT_EQ(read(file("out.csv")), "precious\n");
  const AppRun r = run("--sigma 0.01 -o out.csv --force line.csv");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(read(file("out.csv")).substr(0, 4), "t,y,");
}

TEST_F(SidSmooth, ReportsBadCsvContent) {
  write("empty.csv", "");
  expect_input_error("--sigma 1 empty.csv", "empty.csv: the file is empty");
  write("one.csv", "t,y\n0,1\n");
  expect_input_error("--sigma 1 one.csv", "needs at least 2 data rows, got 1");
  write("back.csv", "t,y\n0,1\n1,2\n0.5,3\n");
  expect_input_error("--sigma 1 back.csv", "back.csv, line 4, column 't': not strictly increasing");
  write("dup.csv", "t,y\n0,1\n1,2\n1,3\n");
  expect_input_error("--sigma 1 dup.csv",
                     "dup.csv, line 4, column 't': not strictly increasing (1 repeats 1");
  write("nan.csv", "t,y\n0,1\n1,nan\n");
  expect_input_error("--sigma 1 nan.csv", "nan.csv, line 3, column 'y': 'nan' is NaN");
  write("inf.csv", "t,y\n0,1\n1,-Inf\n");
  expect_input_error("--sigma 1 inf.csv", "inf.csv, line 3, column 'y': '-Inf' is infinite");
  write("ragged.csv", "t,y\n0,1\n1\n");
  expect_input_error("--sigma 1 ragged.csv",
                     "ragged.csv, line 3: row has 1 cells, the header (line 1) has 2");
  write("text.csv", "t,y\n0,1\n1,abc\n");
  expect_input_error("--sigma 1 text.csv", "text.csv, line 3, column 'y': 'abc' is not a number");
  write("zero_dy.csv", "t,y,dy\n0,1,1\n1,2,0\n");
  expect_input_error("--weights dy zero_dy.csv",
                     "line 3, column 'dy' (--weights): a standard deviation must be > 0");
  write("only_t.csv", "t\n0\n1\n");
  expect_input_error("--sigma 1 only_t.csv", "nothing to smooth");
  expect_input_error("--sigma 1 missing.csv", "cannot open 'missing.csv'");
}

TEST_F(SidSmooth, ReportsMissingColumns) {
  write("line.csv", line_csv());
  expect_input_error("--sigma 1 --time time line.csv", "no column 'time'; columns are: y, t, z");
  expect_input_error("--sigma 1 --signal q1 line.csv", "no column 'q1'; columns are: y, t, z");
  expect_input_error("--weights dy line.csv", "no column 'dy'");
  expect_input_error("--sigma 1 --signal t line.csv", "--signal t: that is the time column");
  expect_input_error("--sigma 1 --signal y,y line.csv", "--signal y is given twice");
}

TEST_F(SidSmooth, ReportsBadOptionValues) {
  write("line.csv", line_csv());
  expect_input_error("--smoothing s-constraint line.csv", "needs a noise level: give --sigma");
  expect_input_error("--sigma 0 line.csv", "--sigma must be > 0, got 0");
  expect_input_error("--sigma -1 line.csv", "--sigma must be > 0, got -1");
  expect_input_error("--sigma 1,-2 line.csv", "--sigma must be > 0, got -2 (for z)");
  expect_input_error("--sigma abc line.csv", "--sigma: value 1 'abc' is not a number");
  expect_input_error("--sigma 1 --S -1 line.csv", "--S must be a finite number >= 0, got -1");
  expect_input_error("--sigma 1 --S nan line.csv", "--S must be a finite number >= 0, got nan");
  expect_input_error("--sigma 1 --lambda 0 line.csv",
                     "--lambda must be a finite number > 0, got 0");
  expect_input_error("--sigma 1 --lambda -3 line.csv",
                     "--lambda must be a finite number > 0, got -3");
  expect_input_error("--sigma 1 --S abc line.csv", "--S");
  expect_input_error("--sigma 1 --S 1 --lambda 1 line.csv", "excludes");
  expect_input_error("--sigma 1 --weights y line.csv", "excludes");
  expect_input_error("--sigma 1 --bogus line.csv", "--bogus");
  expect_input_error("--sigma 1", "INPUT");
  expect_input_error("--sigma 1 -o nodir/out.csv line.csv", "directory 'nodir' does not exist");
}

TEST_F(SidSmooth, ParseErrorsPointToHelp) {
  const AppRun r = run("--bogus");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("sid_smooth --help"), std::string::npos) << r.err;
}

TEST_F(SidSmooth, SZeroInterpolatesTheData) {
  write("pts.csv", "t,y\n0,0\n1,1\n2,0\n3,1\n4,0\n");
  const AppRun r = run("--sigma 0.1 --S 0 -q pts.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto table = parse_output(r.out);
  const Eigen::VectorXd expected = (Eigen::VectorXd(5) << 0, 1, 0, 1, 0).finished();
  EXPECT_LT((table.column("y") - expected).cwiseAbs().maxCoeff(), kExactTol);
}

TEST_F(SidSmooth, GcvByDefaultEstimatesTheNoiseAndRecoversDerivativesOfNoisySine) {
  write("sine.csv", noisy_sine_csv(2000, 0.01, 11));
  const AppRun r = run("-o out.csv sine.csv");  // no --sigma: gcv
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("(gcv)"), std::string::npos) << r.err;
  const double sigma_hat = reported(r.err, "sigma_hat");
  EXPECT_NEAR(sigma_hat / 0.01, 1.0, 0.1) << r.err;
  const double trace = reported(r.err, "tr A");
  EXPECT_GT(trace, 2.0) << r.err;
  EXPECT_LT(trace, 200.0) << r.err;
  EXPECT_NEAR(reported(r.err, "p") * reported(r.err, "lambda"), 1.0, 1e-5) << r.err;
  const auto table = sid::app::read_csv(file("out.csv"));
  ASSERT_EQ(table.rows(), 2000);
  const auto [d_rms, dd_rms] = sine_derivative_rms(table, 200);
  EXPECT_LT(d_rms, 0.012);
  EXPECT_LT(dd_rms, 0.1);
}

TEST_F(SidSmooth, CrossValidationModeMatchesGcvOnNoisySine) {
  write("sine.csv", noisy_sine_csv(2000, 0.01, 11));
  const AppRun r = run("--smoothing cv -o out.csv sine.csv");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("(cv)"), std::string::npos) << r.err;
  EXPECT_NEAR(reported(r.err, "sigma_hat") / 0.01, 1.0, 0.1) << r.err;
  const auto [d_rms, dd_rms] = sine_derivative_rms(sid::app::read_csv(file("out.csv")), 200);
  EXPECT_LT(d_rms, 0.012);
  EXPECT_LT(dd_rms, 0.1);
}

TEST_F(SidSmooth, SigmaOnlySetsRelativeWeightsUnderGcv) {
  write("sine.csv", noisy_sine_csv(500, 0.01, 5));
  const AppRun plain = run("--smoothing gcv sine.csv");
  const AppRun scaled = run("--smoothing gcv --sigma 0.5 sine.csv");
  ASSERT_EQ(plain.exit_code, 0) << plain.err;
  ASSERT_EQ(scaled.exit_code, 0) << scaled.err;
  // sigma_hat stays in the signal's units; lambda is in the weighted convention (w = 1/dy^2).
  EXPECT_NEAR(reported(scaled.err, "sigma_hat") / reported(plain.err, "sigma_hat"), 1.0, 1e-4)
      << plain.err << scaled.err;
  EXPECT_NEAR(reported(scaled.err, "lambda") * 0.25 / reported(plain.err, "lambda"), 1.0, 1e-3)
      << plain.err << scaled.err;
  const auto a = parse_output(plain.out), b = parse_output(scaled.out);
  EXPECT_LT((a.column("q_d") - b.column("q_d")).cwiseAbs().maxCoeff(), 1e-4);
}

TEST_F(SidSmooth, StraightLineComesOutExactlyUnderGcv) {
  write("line.csv", line_csv());
  for (const char* args : {"line.csv", "--smoothing cv line.csv"}) {
    const AppRun r = run(args);
    ASSERT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    const auto table = parse_output(r.out);
    ASSERT_EQ(table.rows(), 40) << args;
    expect_line(table, "y", 2.0, 3.0);
    expect_line(table, "z", -1.0, -0.5);
    EXPECT_NE(r.err.find("tr A = "), std::string::npos) << args << "\n" << r.err;
  }
}

TEST_F(SidSmooth, ModeIsImpliedByTheOtherOptions) {
  write("line.csv", line_csv());
  EXPECT_NE(run("line.csv").err.find("(gcv)"), std::string::npos);
  const AppRun by_sigma = run("--sigma 0.01 line.csv");
  EXPECT_NE(by_sigma.err.find("(S = 40)"), std::string::npos) << by_sigma.err;
  EXPECT_EQ(by_sigma.err.find("sigma_hat"), std::string::npos) << by_sigma.err;
  const AppRun by_s = run("--S 1 line.csv");  // unit weights
  ASSERT_EQ(by_s.exit_code, 0) << by_s.err;
  EXPECT_NE(by_s.err.find("(S = 1)"), std::string::npos) << by_s.err;
  const AppRun by_lambda = run("--lambda 1e-3 line.csv");  // unit weights
  ASSERT_EQ(by_lambda.exit_code, 0) << by_lambda.err;
  EXPECT_NEAR(reported(by_lambda.err, "lambda"), 1e-3, 1e-15) << by_lambda.err;
  EXPECT_EQ(by_lambda.err.find("(S = "), std::string::npos) << by_lambda.err;
  expect_line(parse_output(by_lambda.out), "y", 2.0, 3.0);
}

TEST_F(SidSmooth, BadSmoothingCombinationsExitTwo) {
  write("line.csv", line_csv());
  write("three.csv", "t,y\n0,1\n1,2\n2,4\n");
  expect_input_error("--smoothing fancy line.csv", "--smoothing: unknown mode 'fancy'");
  expect_input_error("--smoothing gcv --S 10 line.csv", "--S does not apply to --smoothing gcv");
  expect_input_error("--smoothing cv --lambda 1 line.csv",
                     "--lambda does not apply to --smoothing cv");
  expect_input_error("--smoothing s-constraint --sigma 1 --lambda 1 line.csv",
                     "--lambda does not apply to --smoothing s-constraint");
  expect_input_error("--smoothing lambda --sigma 1 line.csv", "--smoothing lambda needs --lambda");
  expect_input_error("--smoothing lambda --S 3 line.csv",
                     "--S does not apply to --smoothing lambda");
  expect_input_error("--smoothing s-constraint line.csv", "needs a noise level");
  expect_input_error("three.csv", "--smoothing gcv needs at least 4 data rows, got 3");
}
