#include "html_page.hpp"

#include "svg_plot.hpp"

#include <cstdio>

namespace sid::app {
namespace {

const char* const kStyle = R"(body { font-family: sans-serif; margin: 2em auto; max-width: 64em;
  color: #222; line-height: 1.4; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 2em; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; margin: 0.5em 0; }
th, td { border: 1px solid #ddd; padding: 0.2em 0.6em; text-align: left; font-size: 0.9em; }
td.number { text-align: right; font-variant-numeric: tabular-nums; }
.verdict { padding: 0.6em 1em; border-left: 4px solid #2a7; background: #f3faf6; }
.verdict.bad { border-color: #c33; background: #fbf1f1; }
.warning { color: #a40; }
svg { display: block; margin: 0.3em 0 1em; font-size: 11px; font-family: sans-serif; }
pre { background: #f6f6f6; padding: 1em; overflow-x: auto; font-size: 0.8em; })";

}  // namespace

std::string html_number(double v, const char* format) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, format, v);
  return buffer;
}

std::string html_percent(double fraction) { return html_number(100.0 * fraction, "%.3g") + " %"; }

std::string html_cell(const std::string& text) { return "<td>" + xml_escaped(text) + "</td>"; }

std::string html_number_cell(double v, const char* format) {
  return "<td class=\"number\">" + html_number(v, format) + "</td>";
}

std::string html_row(const std::string& head, const std::string& value) {
  return "<tr><th>" + xml_escaped(head) + "</th>" + html_cell(value) + "</tr>\n";
}

std::string html_document(const std::string& title, const std::string& body) {
  return "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n<title>" +
         xml_escaped(title) + "</title>\n<style>\n" + kStyle + "\n</style>\n</head>\n<body>\n" +
         body + "</body>\n</html>\n";
}

}  // namespace sid::app
