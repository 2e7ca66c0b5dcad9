#include "plot.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace sid::app {
namespace fs = std::filesystem;

namespace {

std::string number(double v) {
  if (std::isnan(v)) return "NaN";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

// gnuplot single-quoted strings: a quote is written twice, nothing else is special.
std::string gp_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += (c == '\'') ? std::string("''") : std::string(1, c);
  return out + "'";
}

std::string sh_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw std::runtime_error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw std::runtime_error("error while writing '" + path + "'");
}

bool is_executable(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec) && ::access(path.c_str(), X_OK) == 0;
}

// Terminal selection happens inside the script so that the script stays valid on a machine whose
// gnuplot lacks cairo. noenhanced keeps underscores in names like "q1_d" literal.
std::string preamble(const std::string& png_name, int width, int height, const std::string& title) {
  std::ostringstream gp;
  gp << "# Written by sid. Redraw with: gnuplot " << fs::path(png_name).stem().string() << ".gp\n"
     << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
     << "  set terminal pngcairo noenhanced size " << width << "," << height << "\n"
     << "} else {\n"
     << "  set terminal png noenhanced size " << width << "," << height << "\n"
     << "}\n"
     << "set output " << gp_quote(png_name) << "\n"
     << "set title " << gp_quote(title) << "\n"
     << "set grid\n";
  return gp.str();
}

PlotResult render(const std::string& png_path, const std::string& data, const std::string& script) {
  const std::vector<std::string> files = plot_files(png_path);
  PlotResult result;
  result.png = files[0];
  result.data = files[1];
  result.script = files[2];
  write_file(result.data, data);
  write_file(result.script, script);

  // The script names its files relative to its own directory, so run it from there.
  const fs::path dir = fs::path(result.script).parent_path();
  const std::string dir_text = dir.empty() ? "." : dir.string();
  const std::string script_name = fs::path(result.script).filename().string();
  const std::string redraw = "cd " + sh_quote(dir_text) + " && gnuplot " + sh_quote(script_name);

  const std::string gnuplot = find_gnuplot();
  if (gnuplot.empty()) {
    result.message = "gnuplot not found, so " + result.png +
                     " was not drawn; its data and script are in " + result.data + " and " +
                     result.script +
                     ". Install gnuplot (sudo apt-get install gnuplot-nox) and run: " + redraw;
    return result;
  }
  const std::string command = "cd " + sh_quote(dir_text) + " && " + sh_quote(gnuplot) + " " +
                              sh_quote(script_name) + " 2>&1";
  std::string output;
  int status = -1;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    char buffer[512];
    while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    status = ::pclose(pipe);
  }
  if (status == 0 && fs::exists(result.png)) {
    result.rendered = true;
    result.message = "wrote " + result.png;
  } else {
    while (!output.empty() && (output.back() == '\n' || output.back() == '\r')) output.pop_back();
    result.message = "gnuplot could not draw " + result.png + " (data and script kept in " +
                     result.data + ", " + result.script + ")" +
                     (output.empty() ? std::string() : ": " + output);
  }
  return result;
}

}  // namespace

std::vector<std::string> plot_files(const std::string& png_path) {
  fs::path png(png_path);
  if (png.extension() != ".png") png += ".png";
  fs::path dat = png, gp = png;
  dat.replace_extension(".dat");
  gp.replace_extension(".gp");
  return {png.string(), dat.string(), gp.string()};
}

std::string find_gnuplot() {
  std::string program = "gnuplot";
  if (const char* env = std::getenv("SID_GNUPLOT")) program = env;
  if (program.empty()) return {};
  if (program.find('/') != std::string::npos)
    return is_executable(program) ? program : std::string();
  const char* path = std::getenv("PATH");
  std::stringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    const std::string candidate = (fs::path(dir.empty() ? "." : dir) / program).string();
    if (is_executable(candidate)) return candidate;
  }
  return {};
}

PlotResult plot_lines(const LinePlot& plot, const std::string& png_path) {
  for (const auto& s : plot.series)
    if (s.y.size() != plot.x.size())
      throw std::invalid_argument("sid::app::plot_lines: series '" + s.name + "' has " +
                                  std::to_string(s.y.size()) + " values, x has " +
                                  std::to_string(plot.x.size()));
  const std::vector<std::string> files = plot_files(png_path);

  std::ostringstream data;
  data << "# " << (plot.x_label.empty() ? "x" : plot.x_label);
  for (const auto& s : plot.series) data << " | " << s.name;
  data << "\n";
  for (Eigen::Index i = 0; i < plot.x.size(); ++i) {
    data << number(plot.x[i]);
    for (const auto& s : plot.series) data << ' ' << number(s.y[i]);
    data << '\n';
  }

  std::ostringstream gp;
  gp << preamble(fs::path(files[0]).filename().string(), plot.width, plot.height, plot.title)
     << "set xlabel " << gp_quote(plot.x_label) << "\n"
     << "set ylabel " << gp_quote(plot.y_label) << "\n"
     << "set key outside right top\n";
  if (plot.log_y) gp << "set logscale y\n";
  int object = 1;
  for (const auto& r : plot.marked) {
    gp << "set object " << object << " rect from " << number(r.from) << ", graph 0 to "
       << number(r.to) << ", graph 1 behind fillcolor rgb '#d9d9d9' fillstyle solid 0.6 noborder\n";
    if (!r.label.empty())
      gp << "set label " << object << " " << gp_quote(r.label) << " at " << number(r.from)
         << ", graph 0.97 offset 0.5,0 front\n";
    ++object;
  }
  const std::string dat_name = fs::path(files[1]).filename().string();
  gp << "plot ";
  for (std::size_t j = 0; j < plot.series.size(); ++j) {
    gp << (j ? ", \\\n     " : "") << (j ? "''" : gp_quote(dat_name)) << " using 1:" << j + 2
       << " with " << plot.series[j].style << " title " << gp_quote(plot.series[j].name);
  }
  if (plot.series.empty()) gp << gp_quote(dat_name) << " using 1:1 with points notitle";
  gp << "\n";
  return render(png_path, data.str(), gp.str());
}

PlotResult plot_boxes(const BoxPlot& plot, const std::string& png_path) {
  const std::vector<std::string> files = plot_files(png_path);
  const std::string dat_name = fs::path(files[1]).filename().string();

  // One data block per non-empty group (blocks separated by two blank lines = gnuplot "index").
  std::ostringstream data;
  std::ostringstream commands;
  int block = 0;
  for (std::size_t g = 0; g < plot.groups.size(); ++g) {
    const BoxGroup& group = plot.groups[g];
    std::ostringstream values;
    int count = 0;
    for (Eigen::Index i = 0; i < group.values.size(); ++i)
      if (std::isfinite(group.values[i]) && (!plot.log_y || group.values[i] > 0.0)) {
        values << number(group.values[i]) << '\n';
        ++count;
      }
    if (count == 0) continue;  // gnuplot rejects an empty block; the tic still names the group
    if (block) data << "\n\n";
    data << "# " << group.name << "\n" << values.str();
    commands << (block ? ", \\\n     " : "") << gp_quote(dat_name) << " index " << block
             << " using (" << g + 1 << "):1 with boxplot notitle";
    ++block;
  }

  std::ostringstream gp;
  gp << preamble(fs::path(files[0]).filename().string(), plot.width, plot.height, plot.title)
     << "set ylabel " << gp_quote(plot.y_label) << "\n"
     << "set style fill solid 0.3 border -1\n"
     << "set style boxplot outliers pointtype 7\n"
     << (plot.log_y ? "set logscale y\n" : "") << "set pointsize 0.5\n"
     << "set xrange [0.5:" << plot.groups.size() + 0.5 << "]\n"
     << "set offsets 0, 0, graph 0.05, graph 0.05\n"
     << "set xtics (";
  for (std::size_t g = 0; g < plot.groups.size(); ++g)
    gp << (g ? ", " : "") << gp_quote(plot.groups[g].name) << " " << g + 1;
  gp << ") scale 0\n";
  std::string plot_commands = commands.str();
  if (plot.has_reference) {
    gp << "set key outside bottom center horizontal\n";
    plot_commands += (plot_commands.empty() ? "" : ", \\\n     ") + number(plot.reference) +
                     " with lines dashtype 2 linecolor rgb 'black' title " +
                     gp_quote(plot.reference_label);
  } else {
    gp << "unset key\n";
  }
  if (plot_commands.empty()) plot_commands = "NaN notitle";  // nothing finite: an empty frame
  gp << "plot " << plot_commands << "\n";
  return render(png_path, data.str(), gp.str());
}

}  // namespace sid::app
