#include "svg_plot.hpp"

#include "csv.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace sid::app {
namespace {

std::string coordinate(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.1f", v);
  return buffer;
}

std::string tick_label(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buffer;
}

/// A round step (1, 2 or 5 times a power of ten) that cuts span into about `count` parts.
double tick_step(double span, int count) {
  const double raw = span / count;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0})
    if (m * power >= raw) return m * power;
  return 10.0 * power;
}

}  // namespace

std::string xml_escaped(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string svg_line_plot(const Eigen::VectorXd& x, const std::vector<SvgSeries>& series,
                          const std::string& x_label, const std::string& y_label, int width,
                          int height) {
  if (x.size() < 2) throw InputError("svg_line_plot: needs two abscissae or more");
  double low = std::numeric_limits<double>::infinity(), high = -low;
  for (const SvgSeries& s : series) {
    if (s.y.size() != x.size())
      throw InputError("svg_line_plot: series '" + s.label + "' has " + std::to_string(s.y.size()) +
                       " values for " + std::to_string(x.size()) + " abscissae");
    for (const double v : s.y)
      if (std::isfinite(v)) {
        low = std::min(low, v);
        high = std::max(high, v);
      }
  }
  if (!(low <= high)) low = high = 0.0;
  if (high - low < 1e-12 * std::max(1.0, std::abs(high))) {
    low -= 1.0;
    high += 1.0;
  }
  const double pad = 0.05 * (high - low);
  low -= pad;
  high += pad;
  const double left = 64, right = 12, top = 24, bottom = 38;
  const double plot_w = width - left - right, plot_h = height - top - bottom;
  const double x0 = x[0], x1 = x[x.size() - 1];
  const double x_span = x1 > x0 ? x1 - x0 : 1.0;
  const auto px = [&](double v) { return left + (v - x0) / x_span * plot_w; };
  const auto py = [&](double v) { return top + (high - v) / (high - low) * plot_h; };

  std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(width) +
                    "\" height=\"" + std::to_string(height) + "\" viewBox=\"0 0 " +
                    std::to_string(width) + " " + std::to_string(height) + "\">\n";
  svg += "<rect x=\"" + coordinate(left) + "\" y=\"" + coordinate(top) + "\" width=\"" +
         coordinate(plot_w) + "\" height=\"" + coordinate(plot_h) +
         "\" fill=\"none\" stroke=\"#999\"/>\n";
  const double y_step = tick_step(high - low, 4);
  for (double v = std::ceil(low / y_step) * y_step; v <= high; v += y_step) {
    svg += "<line x1=\"" + coordinate(left) + "\" x2=\"" + coordinate(left + plot_w) + "\" y1=\"" +
           coordinate(py(v)) + "\" y2=\"" + coordinate(py(v)) + "\" stroke=\"#e4e4e4\"/>\n";
    svg += "<text x=\"" + coordinate(left - 6) + "\" y=\"" + coordinate(py(v) + 4) +
           "\" text-anchor=\"end\">" + tick_label(v) + "</text>\n";
  }
  const double x_step = tick_step(x_span, 6);
  for (double v = std::ceil(x0 / x_step) * x_step; v <= x1 + 1e-9 * x_span; v += x_step)
    svg += "<text x=\"" + coordinate(px(v)) + "\" y=\"" + coordinate(top + plot_h + 16) +
           "\" text-anchor=\"middle\">" + tick_label(v) + "</text>\n";
  svg += "<text x=\"" + coordinate(left + plot_w / 2) + "\" y=\"" + coordinate(height - 4.0) +
         "\" text-anchor=\"middle\">" + xml_escaped(x_label) + "</text>\n";
  svg += "<text x=\"14\" y=\"" + coordinate(top + plot_h / 2) +
         "\" text-anchor=\"middle\" transform=\"rotate(-90 14 " + coordinate(top + plot_h / 2) +
         ")\">" + xml_escaped(y_label) + "</text>\n";

  const auto columns = static_cast<Eigen::Index>(plot_w);
  double legend_x = left + 8;
  for (const SvgSeries& s : series) {
    std::string points;
    const auto add = [&](Eigen::Index i) {
      if (std::isfinite(s.y[i]))
        points += coordinate(px(x[i])) + "," + coordinate(py(s.y[i])) + " ";
    };
    if (x.size() <= 2 * columns) {
      for (Eigen::Index i = 0; i < x.size(); ++i) add(i);
    } else {
      // Each pixel column's least and greatest value, in time order.
      Eigen::Index begin = 0;
      for (Eigen::Index c = 1; c <= columns && begin < x.size(); ++c) {
        const double edge = x0 + x_span * static_cast<double>(c) / static_cast<double>(columns);
        Eigen::Index end = begin;
        while (end < x.size() && (x[end] <= edge || c == columns)) ++end;
        if (end == begin) continue;
        Eigen::Index least = begin, greatest = begin;
        for (Eigen::Index i = begin; i < end; ++i) {
          if (s.y[i] < s.y[least]) least = i;
          if (s.y[i] > s.y[greatest]) greatest = i;
        }
        add(std::min(least, greatest));
        if (least != greatest) add(std::max(least, greatest));
        begin = end;
      }
    }
    svg += "<polyline fill=\"none\" stroke=\"" + xml_escaped(s.color) +
           "\" stroke-width=\"1.2\" points=\"" + points + "\"/>\n";
    svg += "<rect x=\"" + coordinate(legend_x) + "\" y=\"8\" width=\"12\" height=\"4\" fill=\"" +
           xml_escaped(s.color) + "\"/><text x=\"" + coordinate(legend_x + 16) + "\" y=\"14\">" +
           xml_escaped(s.label) + "</text>\n";
    legend_x += 24 + 7.0 * static_cast<double>(s.label.size());
  }
  return svg + "</svg>";
}

}  // namespace sid::app
