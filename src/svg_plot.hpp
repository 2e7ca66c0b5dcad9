#pragma once
/// @file
/// @brief Line plots and bar charts as inline SVG, for reports that must stand alone (no script, no
/// network).

#include <Eigen/Core>

#include <string>
#include <vector>

namespace sid::app {

/// @brief One line of a plot: its legend, its colour (CSS) and a value per abscissa.
struct SvgSeries {
  std::string label;
  std::string color;
  Eigen::VectorXd y;
};

/// @brief An <svg> element plotting each series against x (increasing), with axes, ticks and a
/// legend. A series longer than the plot is wide keeps each pixel column's least and greatest
/// value, so that a spike stays visible.
/// @throws InputError when a series' length is not x's, or x has fewer than two values.
std::string svg_line_plot(const Eigen::VectorXd& x, const std::vector<SvgSeries>& series,
                          const std::string& x_label, const std::string& y_label, int width = 760,
                          int height = 220);

/// @brief An <svg> element of grouped bars from 0: per category, one bar of each series (whose
/// values are one per category), with the y axis's ticks, the categories below and a legend.
/// Non-finite or non-positive values draw no bar.
/// @throws InputError when a series' length is not the categories' count, or there is none.
std::string svg_bar_chart(const std::vector<std::string>& categories,
                          const std::vector<SvgSeries>& series, const std::string& y_label,
                          int width = 760, int height = 220);

/// @brief Text with &, <, > and " written as XML entities.
std::string xml_escaped(const std::string& text);

}  // namespace sid::app
