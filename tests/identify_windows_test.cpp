#include <sid/identify_windows.hpp>

#include <gtest/gtest.h>

#include "chain_simulation.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

sid::NamedChainRun ramp(const std::string& name, double duration, double rate = 100.0) {
  const auto n = static_cast<Eigen::Index>(std::round(duration * rate)) + 1;
  sid::ChainTrajectory<double> run;
  run.t = Eigen::VectorXd::LinSpaced(n, 0.0, duration);
  run.q = Eigen::MatrixXd::Zero(n, 2);
  run.q.col(0) = run.t;
  run.tau = Eigen::MatrixXd::Zero(n, 2);
  return {name, run};
}

std::size_t parameter_index(const sid::ChainWindows& w, const std::string& name) {
  for (std::size_t i = 0; i < w.parameters.size(); ++i)
    if (w.parameters[i].combination == name) return i;
  ADD_FAILURE() << name << " is not a parameter of every window";
  return 0;
}

/// Equal entries, NaN where the other is NaN.
bool same(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         ((a.array() == b.array()) || (a.array().isNaN() && b.array().isNaN())).all();
}

}  // namespace

// Whole windows from each run's start; the last piece joins the window before unless it is at
// least half a window; every sample lands in exactly one window, in order.
TEST(CutIntoWindows, CutsEachRunFromItsStartAndKeepsEverySample) {
  const auto cut = sid::cut_into_windows({ramp("a", 25.0), ramp("b", 24.0), ramp("c", 3.0)}, 10.0);
  ASSERT_EQ(cut.size(), 3u + 2u + 1u);
  const std::vector<std::string> names = {"a [0-9.99 s]", "a [10-19.99 s]", "a [20-25 s]",
                                          "b [0-9.99 s]", "b [10-24 s]",    "c"};
  for (std::size_t i = 0; i < cut.size(); ++i) EXPECT_EQ(cut[i].name, names[i]);
  EXPECT_EQ(cut[0].data.size() + cut[1].data.size() + cut[2].data.size(), 2501);
  EXPECT_EQ(cut[3].data.size() + cut[4].data.size(), 2401);
  EXPECT_NEAR(cut[1].data.t[0], 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(cut[1].data.q(0, 0), cut[1].data.t[0]);  // the rows travel with their times
  // No window: each run whole.
  EXPECT_EQ(sid::cut_into_windows({ramp("a", 25.0), ramp("b", 3.0)}, 0.0).size(), 2u);
}

TEST(CutIntoWindows, RefusesWhatItCannotCut) {
  EXPECT_THROW((void)sid::cut_into_windows({ramp("a", 5.0)}, -1.0), std::invalid_argument);
  EXPECT_THROW((void)sid::cut_into_windows({ramp("a", 5.0)}, std::nan("")), std::invalid_argument);
  EXPECT_THROW((void)sid::cut_into_windows({}, 1.0), std::invalid_argument);
  // More windows than samples: refused before a start is computed (1e-300 s would be 5e300).
  EXPECT_THROW((void)sid::cut_into_windows({ramp("a", 5.0)}, 1e-300), std::invalid_argument);
  EXPECT_THROW((void)sid::cut_into_windows({ramp("a", 5.0)}, 0.001), std::invalid_argument);
  sid::NamedChainRun backwards = ramp("a", 5.0);
  backwards.data.t[3] = backwards.data.t[1];
  EXPECT_THROW((void)sid::cut_into_windows({backwards}, 1.0), std::invalid_argument);
}

// Estimates exactly on a line: the slope is the line's and its deviation the weighted fit's
// own (no scatter to inflate it). Scatter beyond the deviations inflates it by the Birge ratio.
TEST(FitDrift, FitsALineWeightedByTheDeviationsAndInflatesItForScatter) {
  const Eigen::Vector4d hours(0.0, 1.0, 2.0, 3.0), sd(0.1, 0.1, 0.2, 0.2);
  const Eigen::Vector4d on_line = 2.0 + 0.5 * hours.array();
  const sid::ParameterTrend d = sid::fit_drift(hours, on_line, sd);
  EXPECT_EQ(d.windows, 4);
  EXPECT_NEAR(d.slope, 0.5, 1e-12);
  // Σw(t − t̄)² with w = 100, 100, 25, 25: t̄ = 0.9, so 81 + 1 + 30.25 + 110.25 = 222.5.
  EXPECT_NEAR(d.slope_std_dev, 1.0 / std::sqrt(222.5), 1e-12);
  EXPECT_NEAR(d.birge_ratio, 0.0, 1e-9);
  EXPECT_TRUE(d.drifts);  // 0.5 / (1/15) = 7.5 deviations
  const Eigen::Vector4d scattered = on_line + Eigen::Vector4d(1.0, -1.0, 1.0, -1.0);
  const sid::ParameterTrend s = sid::fit_drift(hours, scattered, sd);
  EXPECT_GT(s.birge_ratio, 1.0);
  EXPECT_NEAR(s.slope_std_dev, s.birge_ratio / std::sqrt(222.5), 1e-12);
  EXPECT_FALSE(s.drifts);
  // One last window far from the others with a small std: the line through all five is 3.2
  // std steep, but without that window it is flat. No drift.
  const Eigen::VectorXd t5 = Eigen::VectorXd::LinSpaced(5, 0.0, 4.0);
  Eigen::VectorXd y5(5), sd5(5);
  y5 << 0.0, 0.1, -0.1, 0.0, 1.0;
  sd5 << 0.2, 0.2, 0.2, 0.2, 0.05;
  const sid::ParameterTrend outlier = sid::fit_drift(t5, y5, sd5);
  EXPECT_GT(std::abs(outlier.slope), 3.0 * outlier.slope_std_dev);
  EXPECT_FALSE(outlier.drifts);
  y5[4] = 0.4;  // on the line the others keep: drift with or without any one window
  sd5[4] = 0.2;
  y5 += 0.4 * t5;
  EXPECT_TRUE(sid::fit_drift(t5, y5, sd5).drifts);
  // A month of daily windows on a clear trend: each left-out line is judged alone (not by
  // leaving out more windows in turn, which would take factorial time).
  const Eigen::VectorXd days = Eigen::VectorXd::LinSpaced(30, 0.0, 29.0 * 24.0);
  const Eigen::VectorXd rising = 1.0 + 1e-3 * days.array();
  const sid::ParameterTrend month =
      sid::fit_drift(days, rising, Eigen::VectorXd::Constant(30, 0.01));
  EXPECT_TRUE(month.drifts);
  EXPECT_NEAR(month.slope, 1e-3, 1e-12);
  // A window that does not determine the parameter (NaN) is left out; two windows give a slope
  // but no verdict; one gives the value alone.
  const Eigen::Vector4d missing(std::nan(""), 0.1, std::nan(""), 0.2);
  const sid::ParameterTrend two = sid::fit_drift(hours, on_line, missing);
  EXPECT_EQ(two.windows, 2);
  EXPECT_NEAR(two.slope, 0.5, 1e-12);
  EXPECT_FALSE(two.drifts);
  EXPECT_TRUE(std::isnan(two.birge_ratio));
  const sid::ParameterTrend one =
      sid::fit_drift(hours, on_line, Eigen::Vector4d(0.1, std::nan(""), std::nan(""), -1.0));
  EXPECT_EQ(one.windows, 1);
  EXPECT_DOUBLE_EQ(one.mean, 2.0);
  EXPECT_TRUE(std::isnan(one.slope));
}

// Four days of logs of an arm whose Coulomb friction rises by 10 % a day (30 % over the four):
// each day's estimate lies within two of its standard deviations of that day's truth, the
// Coulomb terms are found to drift and the viscous ones, which do not change, are not.
TEST(IdentifyChainWindows, SeesCoulombFrictionRiseOverDaysOfLogs) {
  const sid_test::SimulatedArm arm;
  const std::vector<std::string> names = arm.model.parameter_names();
  std::vector<Eigen::Index> coulomb, viscous;
  for (Eigen::Index i = 0; i < arm.model.parameters(); ++i) {
    const std::string& name = names[static_cast<std::size_t>(i)];
    if (name.rfind("fc_", 0) == 0) coulomb.push_back(i);
    if (name.rfind("fv_", 0) == 0) viscous.push_back(i);
  }
  ASSERT_EQ(coulomb.size(), 3u);
  std::vector<sid::NamedChainRun> days;
  std::vector<Eigen::VectorXd> truth;
  for (int day = 0; day < 4; ++day) {
    sid_test::SimulatedArm worn = arm;
    for (const Eigen::Index i : coulomb) worn.theta[i] *= 1.0 + 0.1 * day;
    days.push_back({"day" + std::to_string(day + 1) + ".csv",
                    worn.run(8.0, 10 + static_cast<unsigned>(day), 0.2)});
    truth.push_back(worn.theta);
  }
  sid::ChainWindowOptions options;  // each log one window, its cutoffs chosen
  options.threads = 2;
  const sid::ChainWindows w = sid::identify_chain_windows(arm.model, days, options);
  ASSERT_EQ(w.windows.size(), 4u);
  EXPECT_TRUE(w.warnings.empty()) << w.warnings.front();  // every day excites every parameter
  EXPECT_EQ(w.windows[2].source, "day3.csv");
  EXPECT_NEAR(w.windows[1].operating_time - w.windows[0].operating_time, 8.0, 0.01);
  for (std::size_t k = 0; k < 4; ++k) {
    ASSERT_TRUE(w.windows[k].identification.fit.ok());
    for (const Eigen::Index i : coulomb) {
      const std::size_t c = parameter_index(w, names[static_cast<std::size_t>(i)]);
      const auto row = static_cast<Eigen::Index>(k);
      const auto col = static_cast<Eigen::Index>(c);
      EXPECT_NEAR(w.value(row, col), truth[k][i], 2.0 * w.std_dev(row, col))
          << names[static_cast<std::size_t>(i)] << " on day " << k + 1;
    }
  }
  for (const Eigen::Index i : coulomb) {
    const sid::ParameterTrend& d =
        w.parameters[parameter_index(w, names[static_cast<std::size_t>(i)])];
    EXPECT_EQ(d.windows, 4);
    EXPECT_TRUE(d.drifts) << d.name << ": slope " << d.slope << " ± " << d.slope_std_dev;
    // 10 % of the first day's value per 8 s of operation.
    EXPECT_NEAR(d.slope, 0.1 * arm.theta[i] * 3600.0 / 8.0, 3.0 * d.slope_std_dev) << d.name;
  }
  for (const Eigen::Index i : viscous)
    EXPECT_FALSE(w.parameters[parameter_index(w, names[static_cast<std::size_t>(i)])].drifts)
        << names[static_cast<std::size_t>(i)];
}

// One long log cut by time: a window too short for the fit is refused with its name.
TEST(IdentifyChainWindows, NamesTheWindowItCannotFit) {
  const sid_test::SimulatedArm arm;
  sid::ChainWindowOptions options;
  options.fit.cutoff_hz = {16.0};
  options.window = 0.15;  // less than the skips at its two ends
  try {
    (void)sid::identify_chain_windows(arm.model, {{"log.csv", arm.run(0.4, 1, 0.2)}}, options);
    FAIL() << "a window shorter than its skips was fitted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("window log.csv [0-"), std::string::npos) << e.what();
  }
  options.window = 1.0;
  options.drift_z = 0.0;
  EXPECT_THROW(
      (void)sid::identify_chain_windows(arm.model, {{"log.csv", arm.run(2.0, 1, 0.2)}}, options),
      std::invalid_argument);
}

// Runs read through a loader, in order and as many at a time as windows are fitted side by
// side, give what the runs in memory give, bit for bit, whatever the thread count.
TEST(IdentifyChainWindows, ReadsTheRunsInTurnWithTheSameResult) {
  const sid_test::SimulatedArm arm;
  std::vector<sid::NamedChainRun> runs;
  for (unsigned day = 0; day < 3; ++day)
    runs.push_back({"day" + std::to_string(day), arm.run(3.0, 20 + day, 0.2)});
  sid::ChainWindowOptions options;
  options.fit.cutoff_hz = {16.0};
  options.window = 1.5;
  const sid::ChainWindows in_memory = sid::identify_chain_windows(arm.model, runs, options);
  ASSERT_EQ(in_memory.windows.size(), 6u);
  for (const int threads : {1, 2}) {
    std::vector<std::size_t> asked;
    options.threads = threads;
    const sid::ChainWindows read = sid::identify_chain_windows(
        arm.model, runs.size(),
        [&](std::size_t i) {
          asked.push_back(i);
          return runs[i];
        },
        options);
    EXPECT_EQ(asked, (std::vector<std::size_t>{0, 1, 2}));
    ASSERT_EQ(read.windows.size(), 6u);
    for (std::size_t k = 0; k < 6; ++k) {
      EXPECT_EQ(read.windows[k].source, in_memory.windows[k].source);
      EXPECT_EQ(read.windows[k].operating_time, in_memory.windows[k].operating_time);
    }
    EXPECT_TRUE(same(read.value, in_memory.value)) << threads << " threads";
    EXPECT_TRUE(same(read.std_dev, in_memory.std_dev)) << threads << " threads";
  }
  EXPECT_THROW((void)sid::identify_chain_windows(
                   arm.model, 0, [&](std::size_t i) { return runs[i]; }, options),
               std::invalid_argument);
}
