#pragma once
/// @file
/// @brief A small bridge to gnuplot: every plot is a PNG plus, beside it, the data (.dat,
/// whitespace-separated) and the script (.gp) that draws it, so a user can restyle the figure
/// or redraw it on a machine that has gnuplot.
///
/// Missing gnuplot never fails an app: the data and script are still written and the result's
/// message says how to install gnuplot (`sudo apt-get install gnuplot-nox`) and redraw.
/// The environment variable SID_GNUPLOT, when set, names the gnuplot program to run.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace sid::app {

/// One curve of a line plot, sampled at LinePlot::x.
struct PlotSeries {
  std::string name;
  Eigen::VectorXd y;            ///< same length as LinePlot::x; NaN leaves a gap
  std::string style = "lines";  ///< gnuplot style: "lines", "points", "linespoints"
};

/// A marked (shaded) x-interval, e.g. the samples an estimator clipped.
struct XRange {
  double from = 0.0;
  double to = 0.0;
  std::string label;  ///< written inside the shaded area; may be empty
};

struct LinePlot {
  std::string title;
  std::string x_label;
  std::string y_label;
  Eigen::VectorXd x;
  std::vector<PlotSeries> series;
  std::vector<XRange> marked;  ///< shaded behind the curves
  bool log_y = false;
  int width = 1000;  ///< [pixel]
  int height = 600;  ///< [pixel]
};

/// One box of a box plot (e.g. the estimates of one parameter by one method).
struct BoxGroup {
  std::string name;
  Eigen::VectorXd values;  ///< non-finite values are left out
};

struct BoxPlot {
  std::string title;
  std::string y_label;
  std::vector<BoxGroup> groups;  ///< drawn left to right, named on the x axis
  bool has_reference = false;    ///< draw a dashed horizontal line at reference
  double reference = 0.0;        ///< e.g. the true parameter value
  std::string reference_label = "true value";
  bool log_y = false;  ///< values <= 0 are then left out too
  int width = 800;
  int height = 600;
};

/// What a plot call produced.
struct PlotResult {
  bool rendered = false;  ///< the PNG was drawn
  std::string png;        ///< path of the PNG (drawn or not)
  std::string data;       ///< path of the .dat file (always written)
  std::string script;     ///< path of the .gp script (always written)
  std::string message;    ///< one line for the user: what was written, or how to draw it
};

/// @brief The files a plot to png_path writes: {png, dat, gp}. Apps pass them to
/// ensure_writable before any work. A png_path without ".png" gets it appended.
std::vector<std::string> plot_files(const std::string& png_path);

/// @brief The gnuplot program found (SID_GNUPLOT, else "gnuplot" on PATH), or "" if none.
std::string find_gnuplot();

/// @brief Draws a line plot of the series over x.
/// @throws std::invalid_argument if a series length differs from x; std::runtime_error if the
///   data or script cannot be written. A missing or failing gnuplot is reported in the result.
PlotResult plot_lines(const LinePlot& plot, const std::string& png_path);

/// @brief Draws one box (median, quartiles, whiskers, outliers) per group.
/// @throws std::runtime_error if the data or script cannot be written.
PlotResult plot_boxes(const BoxPlot& plot, const std::string& png_path);

}  // namespace sid::app
