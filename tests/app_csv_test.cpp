// Tests of the app-support layer in src/: CSV reading and writing, option helpers, output
// safety, JSON, the gnuplot bridge and run_app's error-to-exit-code mapping.

#include <CLI/CLI.hpp>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "app.hpp"
#include "csv.hpp"
#include "plot.hpp"

namespace fs = std::filesystem;

namespace {

// A fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            ("sid_app_csv_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::string write(const std::string& name, const std::string& text) const {
    std::ofstream(file(name), std::ios::binary) << text;
    return file(name);
  }

 private:
  fs::path path_;
};

sid::app::CsvTable parse(const std::string& text) {
  std::istringstream in(text);
  return sid::app::parse_csv(in, "data.csv");
}

// The message of the InputError that parse(text) throws ("" if none is thrown).
std::string parse_error(const std::string& text) {
  try {
    parse(text);
  } catch (const sid::app::InputError& e) {
    return e.what();
  }
  return "";
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

// --- reading -------------------------------------------------------------------------------

TEST(CsvRead, ReadsColumnsByNameInAnyOrder) {
  const auto table = parse("q1,t,tau1\n0.5,0,10\n0.25,1,20\n");
  ASSERT_EQ(table.rows(), 2);
  EXPECT_EQ(table.names, (std::vector<std::string>{"q1", "t", "tau1"}));
  EXPECT_EQ(table.column("t"), Eigen::Vector2d(0, 1));
  EXPECT_EQ(table.column("q1"), Eigen::Vector2d(0.5, 0.25));
  EXPECT_EQ(table.column("tau1"), Eigen::Vector2d(10, 20));
}

TEST(CsvRead, SkipsCommentsAndBlankLinesAnywhere) {
  const auto table = parse("# made by a robot\n\n#another\nt,q1\n\n0,1\n  # mid comment\n1,2\n\n");
  ASSERT_EQ(table.rows(), 2);
  EXPECT_EQ(table.column("q1"), Eigen::Vector2d(1, 2));
  EXPECT_EQ(table.line_numbers, (std::vector<long>{6, 8}));
}

TEST(CsvRead, ToleratesCrlfWhitespaceBomAndQuotedHeader) {
  const auto table = parse("\xEF\xBB\xBF\"t\" , q1 \r\n 0 ,\t1.5e-3\r\n1, -2E+2 \r\n");
  ASSERT_EQ(table.rows(), 2);
  EXPECT_EQ(table.names, (std::vector<std::string>{"t", "q1"}));
  EXPECT_EQ(table.column("q1")[0], 1.5e-3);
  EXPECT_EQ(table.column("q1")[1], -200.0);
}

TEST(CsvRead, ReadsFileFromDisk) {
  TempDir dir;
  const auto path = dir.write("a.csv", "t,x\n0,1\n");
  const auto table = sid::app::read_csv(path);
  EXPECT_EQ(table.source, path);
  EXPECT_EQ(table.column("x")[0], 1.0);
}

TEST(CsvRead, ReportsFileThatCannotBeOpened) {
  try {
    sid::app::read_csv("/nonexistent/dir/x.csv");
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open '/nonexistent/dir/x.csv'"), std::string::npos)
        << e.what();
  }
}

TEST(CsvRead, ReportsEmptyFile) {
  EXPECT_EQ(parse_error(""), "data.csv: the file is empty (expected a header row)");
  EXPECT_EQ(parse_error("# only a comment\n\n"),
            "data.csv: no header row (only comments and blank lines)");
}

TEST(CsvRead, ReportsDuplicateAndEmptyColumnNames) {
  EXPECT_EQ(parse_error("# c\nt,q1,q2,q1\n0,1,2,3\n"),
            "data.csv, line 2: the header names column 'q1' twice (columns 2 and 4)");
  EXPECT_EQ(parse_error("t,,q2\n0,1,2\n"),
            "data.csv, line 1: the header's column 2 has an empty name");
  EXPECT_EQ(parse_error("t,q1,\n0,1,2\n"),
            "data.csv, line 1: the header's column 3 has an empty name");
}

TEST(CsvRead, ReportsSemicolonSeparatedFile) {
  EXPECT_NE(parse_error("t;q1\n0;1\n").find("sid reads comma-separated files"), std::string::npos);
}

TEST(CsvRead, ReportsMissingDataRows) {
  EXPECT_EQ(parse_error("#x\nt,q1\n# nothing\n"),
            "data.csv: no data rows after the header (line 2)");
}

TEST(CsvRead, ReportsRaggedRowWithItsLine) {
  std::string text = "# comment\nt,a,b,c,d\n";
  for (int i = 0; i < 14; ++i) text += "0,1,2,3,4\n";
  text += "0,1,2,3\n";  // line 17
  EXPECT_EQ(parse_error(text), "data.csv, line 17: row has 4 cells, the header (line 2) has 5");
  EXPECT_EQ(parse_error("t,a\n0,1,2\n"),
            "data.csv, line 2: row has 3 cells, the header (line 1) has 2");
}

TEST(CsvRead, ReportsNonNumericCellWithLineAndColumn) {
  std::string text = "t,q1\n";
  for (int i = 0; i < 10; ++i) text += "0,1\n";
  text += "0, abc\n";  // line 12
  EXPECT_EQ(parse_error(text), "data.csv, line 12, column 'q1': 'abc' is not a number");
  EXPECT_EQ(parse_error("t,q1\n0,1.5x\n"), "data.csv, line 2, column 'q1': '1.5x' is not a number");
  EXPECT_EQ(parse_error("t,q1\n0,\n"), "data.csv, line 2, column 'q1': empty cell");
}

TEST(CsvRead, RejectsNanAndInfByDefault) {
  EXPECT_EQ(parse_error("t,q1\n0,1\n1,nan\n"),
            "data.csv, line 3, column 'q1': 'nan' is NaN (not allowed)");
  EXPECT_EQ(parse_error("t,q1\n-inf,1\n"),
            "data.csv, line 2, column 't': '-inf' is infinite (not allowed)");
  EXPECT_EQ(parse_error("t,q1\n0,1e999\n"),
            "data.csv, line 2, column 'q1': '1e999' is too large for a double");
}

TEST(CsvRead, AcceptsNanWhenAllowed) {
  std::istringstream in("t,q1\n0,NaN\n");
  sid::app::CsvReadOptions options;
  options.allow_non_finite = true;
  const auto table = sid::app::parse_csv(in, "x.csv", options);
  EXPECT_TRUE(std::isnan(table.column("q1")[0]));
}

TEST(CsvRead, ReportsMissingColumnListingTheColumns) {
  const auto table = parse("t,q1,q2,tau1\n0,1,2,3\n");
  try {
    table.column("tau2");
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_STREQ(e.what(), "data.csv: no column 'tau2'; columns are: t, q1, q2, tau1");
  }
  EXPECT_TRUE(table.has("q2"));
  EXPECT_FALSE(table.has("tau2"));
}

// --- trajectories ----------------------------------------------------------------------------

TEST(CsvTrajectory, BuildsTrajectoryIgnoringExtraColumns) {
  const auto table = parse("tau2,extra,q2,t,q1,tau1\n8,0,6,0.0,5,7\n9,0,7,0.1,6,8\n");
  const auto traj = sid::app::trajectory_from_table(table);
  ASSERT_EQ(traj.size(), 2);
  EXPECT_EQ(traj.t, Eigen::Vector2d(0.0, 0.1));
  EXPECT_EQ(traj.q(1, 0), 6.0);
  EXPECT_EQ(traj.q(1, 1), 7.0);
  EXPECT_EQ(traj.tau(0, 0), 7.0);
  EXPECT_EQ(traj.tau(0, 1), 8.0);
  EXPECT_NO_THROW(traj.validate());
}

TEST(CsvTrajectory, UsesCustomColumnNames) {
  const auto table = parse("time,a,b,c,d\n0,1,2,3,4\n");
  sid::app::TrajectoryColumns names;
  names.t = "time";
  names.q1 = "a";
  names.q2 = "b";
  names.tau1 = "c";
  names.tau2 = "d";
  EXPECT_EQ(sid::app::trajectory_from_table(table, names).tau(0, 1), 4.0);
}

TEST(CsvTrajectory, ReportsNonIncreasingTimeWithLine) {
  const auto table = parse("t,q1,q2,tau1,tau2\n# c\n0,0,0,0,0\n0.1,0,0,0,0\n0.1,0,0,0,0\n");
  try {
    sid::app::trajectory_from_table(table);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_STREQ(e.what(),
                 "data.csv, line 5, column 't': not strictly increasing (0.10000000000000001 "
                 "repeats 0.10000000000000001 on line 4)");
  }
  const auto back = parse("t,q1,q2,tau1,tau2\n0,0,0,0,0\n-1,0,0,0,0\n");
  EXPECT_THROW(sid::app::trajectory_from_table(back), sid::app::InputError);
}

TEST(CsvTrajectory, ReportsMissingColumnBeforeRowProblems) {
  const auto table = parse("t,q1,q2,tau1\n1,0,0,0\n0,0,0,0\n");
  try {
    sid::app::trajectory_from_table(table);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no column 'tau2'"), std::string::npos) << e.what();
  }
}

// --- writing -------------------------------------------------------------------------------

TEST(CsvWrite, RoundTripIsBitExact) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const Eigen::Index n = 200;
  Eigen::VectorXd a(n), b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    a[i] = uniform(rng) * std::pow(10.0, static_cast<double>(i % 40 - 20));
    b[i] = uniform(rng);
  }
  a[0] = std::numeric_limits<double>::min();
  a[1] = std::numeric_limits<double>::max();
  a[2] = std::numeric_limits<double>::denorm_min();
  a[3] = 0.1;
  a[4] = -0.0;
  TempDir dir;
  const auto path = dir.file("out.csv");
  sid::app::write_csv(path, {"a", "b"}, {a, b}, {"written by a test"});
  const auto table = sid::app::read_csv(path);
  ASSERT_EQ(table.rows(), n);
  for (Eigen::Index i = 0; i < n; ++i) {
    EXPECT_EQ(table.column("a")[i], a[i]) << "row " << i;
    EXPECT_EQ(table.column("b")[i], b[i]) << "row " << i;
  }
  EXPECT_EQ(read_text(path).substr(0, 26), "# written by a test\na,b\n2.");
}

TEST(CsvWrite, UsesSeventeenSignificantDigits) {
  std::ostringstream out;
  sid::app::write_csv(out, {"x"}, {Eigen::VectorXd::Constant(1, 0.1)});
  EXPECT_EQ(out.str(), "x\n0.10000000000000001\n");
}

TEST(CsvWrite, RejectsColumnsOfDifferentLength) {
  std::ostringstream out;
  EXPECT_THROW(sid::app::write_csv(out, {"x", "y"}, {Eigen::VectorXd(2), Eigen::VectorXd(3)}),
               sid::app::InputError);
  EXPECT_THROW(sid::app::write_csv(out, {"x"}, {Eigen::VectorXd(2), Eigen::VectorXd(2)}),
               sid::app::InputError);
}

// --- output safety --------------------------------------------------------------------------

TEST(EnsureWritable, RefusesToOverwriteWithoutForce) {
  TempDir dir;
  const auto path = dir.write("x.csv", "old");
  try {
    sid::app::ensure_writable(path, false);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "refusing to overwrite '" + path + "' (use --force)");
  }
  EXPECT_NO_THROW(sid::app::ensure_writable(path, true));
  EXPECT_NO_THROW(sid::app::ensure_writable(dir.file("new.csv"), false));
  EXPECT_NO_THROW(sid::app::ensure_writable("-", false));
  EXPECT_EQ(read_text(path), "old");
}

TEST(EnsureWritable, RejectsDirectoryAndMissingParent) {
  TempDir dir;
  EXPECT_THROW(sid::app::ensure_writable(dir.file(""), true), sid::app::InputError);
  try {
    sid::app::ensure_writable(dir.file("nope/x.csv"), true);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
}

TEST(EnsureOutputDirectory, CreatesMissingDirectory) {
  TempDir dir;
  const auto out = dir.file("a/b");
  EXPECT_EQ(sid::app::ensure_output_directory(out, {"r.json"}, false), out);
  EXPECT_TRUE(fs::is_directory(out));
}

TEST(EnsureOutputDirectory, RefusesExistingFilesInsideWithoutForce) {
  TempDir dir;
  dir.write("r.json", "{}");
  const auto out = dir.file("");
  EXPECT_NO_THROW(sid::app::ensure_output_directory(out, {"other.csv"}, false));
  try {
    sid::app::ensure_output_directory(out, {"other.csv", "r.json"}, false);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("refusing to overwrite"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("r.json"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(sid::app::ensure_output_directory(out, {"r.json"}, true));
  EXPECT_THROW(sid::app::ensure_output_directory(out, false), sid::app::InputError);
  EXPECT_NO_THROW(sid::app::ensure_output_directory(out, true));
  EXPECT_NO_THROW(sid::app::ensure_output_directory(dir.file("empty"), false));
}

TEST(EnsureOutputDirectory, RejectsAFile) {
  TempDir dir;
  const auto path = dir.write("f", "x");
  EXPECT_THROW(sid::app::ensure_output_directory(path, {}, true), sid::app::InputError);
}

// --- option helpers -------------------------------------------------------------------------

TEST(ParseDoubles, ParsesCommaSeparatedNumbers) {
  EXPECT_EQ(sid::app::parse_doubles("0.1, 0.2,3e-4 ", "--x"),
            (std::vector<double>{0.1, 0.2, 3e-4}));
  EXPECT_EQ(sid::app::parse_doubles("-5", "--x"), (std::vector<double>{-5.0}));
}

TEST(ParseDoubles, ReportsBadValuesNamingTheOption) {
  auto message = [](const std::string& text) -> std::string {
    try {
      sid::app::parse_doubles(text, "--theta");
    } catch (const sid::app::InputError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_EQ(message("0.1,abc"), "--theta: value 2 'abc' is not a number");
  EXPECT_EQ(message("0.1,,0.2"), "--theta: value 2 is empty in '0.1,,0.2'");
  EXPECT_EQ(message(""), "--theta: no values given (expected numbers separated by commas)");
  EXPECT_EQ(message("1,inf"), "--theta: value 2 'inf' is not finite");
}

TEST(ParseDoubles, FixedCountReportsHowManyWereGiven) {
  try {
    sid::app::parse_doubles("1,2,3,4,5,6", "--theta", 7);
    FAIL() << "no error";
  } catch (const sid::app::InputError& e) {
    EXPECT_STREQ(e.what(), "--theta needs 7 values, got 6");
  }
  EXPECT_EQ(sid::app::parse_doubles("1,2", "--x", 2).size(), 2u);
}

TEST(WriteJson, PreservesEveryBitOfDoubles) {
  TempDir dir;
  const auto path = dir.file("r.json");
  const Eigen::Vector3d v(0.1, 1.0 / 3.0, 2.5e-300);
  Eigen::Matrix2d m;
  m << 1.0 / 7.0, 2, 3, 4;
  sid::app::write_json(path, {{"v", sid::app::to_json_array(v)}, {"m", sid::app::to_json_rows(m)}});
  const auto j = nlohmann::json::parse(read_text(path));
  for (int i = 0; i < 3; ++i) EXPECT_EQ(j["v"][i].get<double>(), v[i]);
  EXPECT_EQ(j["m"][0][0].get<double>(), m(0, 0));
  EXPECT_EQ(j["m"][1][0].get<double>(), 3.0);
  EXPECT_NE(read_text(path).find("\n  \""), std::string::npos) << "not pretty-printed";
}

// --- run_app ---------------------------------------------------------------------------------

namespace {
int run_with(std::vector<std::string> args, const std::function<int()>& body) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  double x = 0;
  return sid::app::run_app(
      "tool", "A test tool.", static_cast<int>(argv.size()), argv.data(),
      [&](CLI::App& cli) { cli.add_option("--x", x, "a number"); }, body);
}
}  // namespace

TEST(RunApp, MapsErrorsToExitCodes) {
  testing::internal::CaptureStderr();
  EXPECT_EQ(run_with({"tool"}, [] { return 0; }), 0);
  EXPECT_EQ(run_with({"tool", "--bogus"}, [] { return 0; }), 2);
  EXPECT_EQ(run_with({"tool", "--x", "abc"}, [] { return 0; }), 2);
  EXPECT_EQ(run_with({"tool"}, []() -> int { throw sid::app::InputError("bad file"); }), 2);
  EXPECT_EQ(run_with({"tool"}, []() -> int { throw std::invalid_argument("sid::x: bad"); }), 2);
  EXPECT_EQ(run_with({"tool"}, []() -> int { throw std::logic_error("bug"); }), 1);
  EXPECT_EQ(run_with({"tool"}, []() -> int { throw 42; }), 1);
  const std::string err = testing::internal::GetCapturedStderr();
  EXPECT_NE(err.find("tool: error: bad file\n"), std::string::npos) << err;
  EXPECT_NE(err.find("tool: error: sid::x: bad\n"), std::string::npos) << err;
  EXPECT_NE(err.find("--help"), std::string::npos) << err;
  EXPECT_NE(err.find("tool: internal error: bug"), std::string::npos) << err;
}

TEST(RunApp, HelpListsOptionsAndExitsZero) {
  testing::internal::CaptureStdout();
  bool ran = false;
  EXPECT_EQ(run_with({"tool", "--help"},
                     [&] {
                       ran = true;
                       return 0;
                     }),
            0);
  const std::string out = testing::internal::GetCapturedStdout();
  EXPECT_FALSE(ran);
  EXPECT_NE(out.find("A test tool."), std::string::npos) << out;
  EXPECT_NE(out.find("--x"), std::string::npos) << out;
}

// --- plotting --------------------------------------------------------------------------------

namespace {
// Sets SID_GNUPLOT for one test and restores it afterwards.
class GnuplotOverride {
 public:
  explicit GnuplotOverride(const char* value) {
    if (const char* old = std::getenv("SID_GNUPLOT")) old_ = old, had_ = true;
    ::setenv("SID_GNUPLOT", value, 1);
  }
  ~GnuplotOverride() {
    if (had_)
      ::setenv("SID_GNUPLOT", old_.c_str(), 1);
    else
      ::unsetenv("SID_GNUPLOT");
  }

 private:
  std::string old_;
  bool had_ = false;
};

sid::app::LinePlot sine_plot() {
  sid::app::LinePlot plot;
  plot.title = "it's a test";
  plot.x_label = "t [s]";
  plot.y_label = "q [rad]";
  plot.x = Eigen::VectorXd::LinSpaced(50, 0.0, 1.0);
  plot.series.push_back({"q1_d", plot.x.array().sin().matrix(), "lines"});
  plot.series.push_back({"raw", plot.x.array().cos().matrix(), "points"});
  plot.marked.push_back({0.0, 0.1, "clipped"});
  return plot;
}
}  // namespace

TEST(Plot, FilesSitNextToThePng) {
  EXPECT_EQ(sid::app::plot_files("out/fig.png"),
            (std::vector<std::string>{"out/fig.png", "out/fig.dat", "out/fig.gp"}));
  EXPECT_EQ(sid::app::plot_files("fig"),
            (std::vector<std::string>{"fig.png", "fig.dat", "fig.gp"}));
}

TEST(Plot, MissingGnuplotKeepsDataAndScriptAndSaysHowToInstall) {
  GnuplotOverride no_gnuplot("/nonexistent/gnuplot");
  TempDir dir;
  const auto result = sid::app::plot_lines(sine_plot(), dir.file("fig.png"));
  EXPECT_FALSE(result.rendered);
  EXPECT_TRUE(fs::exists(result.data));
  EXPECT_TRUE(fs::exists(result.script));
  EXPECT_FALSE(fs::exists(result.png));
  EXPECT_NE(result.message.find("sudo apt-get install gnuplot-nox"), std::string::npos)
      << result.message;
}

TEST(Plot, DrawsLinePlotWhenGnuplotIsInstalled) {
  if (sid::app::find_gnuplot().empty()) GTEST_SKIP() << "gnuplot not installed";
  TempDir dir;
  const auto result = sid::app::plot_lines(sine_plot(), dir.file("fig.png"));
  EXPECT_TRUE(result.rendered) << result.message;
  ASSERT_TRUE(fs::exists(result.png));
  EXPECT_EQ(read_text(result.png).substr(1, 3), "PNG");
  // The data file holds x and every series at full precision.
  const std::string data = read_text(result.data);
  EXPECT_NE(data.find("0.020408163265306121"), std::string::npos) << data.substr(0, 200);
}

TEST(Plot, DrawsBoxPlotWhenGnuplotIsInstalled) {
  if (sid::app::find_gnuplot().empty()) GTEST_SKIP() << "gnuplot not installed";
  TempDir dir;
  sid::app::BoxPlot plot;
  plot.title = "theta 1";
  plot.y_label = "estimate";
  plot.groups.push_back({"spline", Eigen::VectorXd::LinSpaced(30, 0.9, 1.1)});
  plot.groups.push_back({"empty", Eigen::VectorXd::Constant(3, std::nan(""))});
  plot.groups.push_back({"central diff", Eigen::VectorXd::LinSpaced(30, 0.7, 1.4)});
  plot.has_reference = true;
  plot.reference = 1.0;
  const auto result = sid::app::plot_boxes(plot, dir.file("box.png"));
  EXPECT_TRUE(result.rendered) << result.message;
  EXPECT_TRUE(fs::exists(result.png));
}

TEST(Plot, ReportsGnuplotFailureWithoutThrowing) {
  GnuplotOverride failing("/bin/false");
  TempDir dir;
  sid::app::PlotResult result;
  ASSERT_NO_THROW(result = sid::app::plot_lines(sine_plot(), dir.file("fig.png")));
  EXPECT_FALSE(result.rendered);
  EXPECT_NE(result.message.find("gnuplot could not draw"), std::string::npos) << result.message;
}

TEST(Plot, RejectsSeriesOfWrongLength) {
  auto plot = sine_plot();
  plot.series[0].y.resize(3);
  TempDir dir;
  EXPECT_THROW(sid::app::plot_lines(plot, dir.file("fig.png")), std::invalid_argument);
}
