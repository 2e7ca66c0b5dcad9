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

/// The plotting area of an <svg> width x height, in pixels, and the value range of its y axis.
struct Frame {
  double left = 64, right = 12, top = 24, bottom = 38;
  double width, height, low, high;
  double plot_w() const { return width - left - right; }
  double plot_h() const { return height - top - bottom; }
  double py(double v) const { return top + (high - v) / (high - low) * plot_h(); }
};

/// The <svg> element's opening, the plot's box, the y axis's grid and ticks, the x axis's
/// markup as given, and the y axis's label.
std::string open_frame(const Frame& f, const std::string& x_axis, const std::string& y_label) {
  const std::string width = std::to_string(static_cast<int>(f.width)),
                    height = std::to_string(static_cast<int>(f.height));
  std::string svg = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + width + "\" height=\"" +
                    height + "\" viewBox=\"0 0 " + width + " " + height + "\">\n";
  svg += "<rect x=\"" + coordinate(f.left) + "\" y=\"" + coordinate(f.top) + "\" width=\"" +
         coordinate(f.plot_w()) + "\" height=\"" + coordinate(f.plot_h()) +
         "\" fill=\"none\" stroke=\"#999\"/>\n";
  const double y_step = tick_step(f.high - f.low, 4);
  for (double v = std::ceil(f.low / y_step) * y_step; v <= f.high; v += y_step) {
    svg += "<line x1=\"" + coordinate(f.left) + "\" x2=\"" + coordinate(f.left + f.plot_w()) +
           "\" y1=\"" + coordinate(f.py(v)) + "\" y2=\"" + coordinate(f.py(v)) +
           "\" stroke=\"#e4e4e4\"/>\n";
    svg += "<text x=\"" + coordinate(f.left - 6) + "\" y=\"" + coordinate(f.py(v) + 4) +
           "\" text-anchor=\"end\">" + tick_label(v) + "</text>\n";
  }
  svg += x_axis;
  const double middle = f.top + f.plot_h() / 2;
  svg += "<text x=\"14\" y=\"" + coordinate(middle) +
         "\" text-anchor=\"middle\" transform=\"rotate(-90 14 " + coordinate(middle) + ")\">" +
         xml_escaped(y_label) + "</text>\n";
  return svg;
}

/// One legend entry at x (moved past it): a swatch of the series' colour and its label.
std::string legend_entry(const SvgSeries& s, double& x) {
  const std::string svg = "<rect x=\"" + coordinate(x) +
                          "\" y=\"8\" width=\"12\" height=\"4\" fill=\"" + xml_escaped(s.color) +
                          "\"/><text x=\"" + coordinate(x + 16) + "\" y=\"14\">" +
                          xml_escaped(s.label) + "</text>\n";
  x += 24 + 7.0 * static_cast<double>(s.label.size());
  return svg;
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
  const Frame f{64, 12, 24, 38, double(width), double(height), low, high};
  const double left = f.left, top = f.top, plot_w = f.plot_w(), plot_h = f.plot_h();
  const double x0 = x[0], x1 = x[x.size() - 1];
  const double x_span = x1 > x0 ? x1 - x0 : 1.0;
  const auto px = [&](double v) { return left + (v - x0) / x_span * plot_w; };
  const auto py = [&](double v) { return f.py(v); };

  std::string x_axis;
  const double x_step = tick_step(x_span, 6);
  for (double v = std::ceil(x0 / x_step) * x_step; v <= x1 + 1e-9 * x_span; v += x_step)
    x_axis += "<text x=\"" + coordinate(px(v)) + "\" y=\"" + coordinate(top + plot_h + 16) +
              "\" text-anchor=\"middle\">" + tick_label(v) + "</text>\n";
  x_axis += "<text x=\"" + coordinate(left + plot_w / 2) + "\" y=\"" + coordinate(height - 4.0) +
            "\" text-anchor=\"middle\">" + xml_escaped(x_label) + "</text>\n";
  std::string svg = open_frame(f, x_axis, y_label);

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
    svg += legend_entry(s, legend_x);
  }
  return svg + "</svg>";
}

std::string svg_bar_chart(const std::vector<std::string>& categories,
                          const std::vector<SvgSeries>& series, const std::string& y_label,
                          int width, int height) {
  const auto count = static_cast<Eigen::Index>(categories.size());
  if (count == 0 || series.empty())
    throw InputError("svg_bar_chart: needs a category and a series or more");
  double high = 0.0;
  for (const SvgSeries& s : series) {
    if (s.y.size() != count)
      throw InputError("svg_bar_chart: series '" + s.label + "' has " + std::to_string(s.y.size()) +
                       " values for " + std::to_string(count) + " categories");
    for (const double v : s.y)
      if (std::isfinite(v)) high = std::max(high, v);
  }
  if (!(high > 0.0)) high = 1.0;
  const Frame f{64, 12, 24, 38, double(width), double(height), 0.0, 1.05 * high};
  const double group = f.plot_w() / static_cast<double>(count);
  std::string categories_axis;
  for (Eigen::Index c = 0; c < count; ++c)
    categories_axis += "<text x=\"" + coordinate(f.left + group * (static_cast<double>(c) + 0.5)) +
                       "\" y=\"" + coordinate(f.top + f.plot_h() + 16) +
                       "\" text-anchor=\"middle\">" + xml_escaped(categories[std::size_t(c)]) +
                       "</text>\n";
  std::string svg = open_frame(f, categories_axis, y_label);
  const double bar = 0.8 * group / static_cast<double>(series.size());
  double legend_x = f.left + 8;
  for (std::size_t k = 0; k < series.size(); ++k) {
    const SvgSeries& s = series[k];
    for (Eigen::Index c = 0; c < count; ++c) {
      if (!std::isfinite(s.y[c]) || s.y[c] <= 0.0) continue;
      const double x = f.left + group * (static_cast<double>(c) + 0.1) + bar * double(k);
      svg += "<rect x=\"" + coordinate(x) + "\" y=\"" + coordinate(f.py(s.y[c])) + "\" width=\"" +
             coordinate(bar) + "\" height=\"" + coordinate(f.py(0.0) - f.py(s.y[c])) +
             "\" fill=\"" + xml_escaped(s.color) + "\"><title>" +
             xml_escaped(s.label + ", " + categories[std::size_t(c)] + ": ") + tick_label(s.y[c]) +
             "</title></rect>\n";
    }
    svg += legend_entry(s, legend_x);
  }
  return svg + "</svg>";
}

}  // namespace sid::app
