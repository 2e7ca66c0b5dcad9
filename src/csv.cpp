#include "csv.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>

namespace sid::app {
namespace {

std::string display_name(const std::string& path) { return path == "-" ? "<stdin>" : path; }

std::string trim(const std::string& s) {
  const char* ws = " \t\r\n\v\f";
  const auto begin = s.find_first_not_of(ws);
  if (begin == std::string::npos) return {};
  const auto end = s.find_last_not_of(ws);
  return s.substr(begin, end - begin + 1);
}

// Spreadsheets quote header names ("t","q1"); numbers are never quoted by them, but a quoted
// number is harmless, so both lose one pair of enclosing quotes.
std::string unquote(const std::string& s) {
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') return trim(s.substr(1, s.size() - 2));
  return s;
}

std::vector<std::string> split_cells(const std::string& line) {
  std::vector<std::string> cells;
  std::string::size_type start = 0;
  while (true) {
    const auto comma = line.find(',', start);
    cells.push_back(unquote(trim(line.substr(start, comma - start))));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t j = 0; j < names.size(); ++j) out += (j ? ", " : "") + names[j];
  return out;
}

}  // namespace

bool CsvTable::has(const std::string& name) const {
  for (const auto& n : names)
    if (n == name) return true;
  return false;
}

std::size_t CsvTable::index_of(const std::string& name) const {
  for (std::size_t j = 0; j < names.size(); ++j)
    if (names[j] == name) return j;
  throw InputError(display_name(source) + ": no column '" + name +
                   "'; columns are: " + join(names));
}

const Eigen::VectorXd& CsvTable::column(const std::string& name) const {
  return columns[index_of(name)];
}

std::string CsvTable::where(Eigen::Index row) const {
  return display_name(source) + ", line " + std::to_string(line_of(row));
}

CsvTable parse_csv(std::istream& in, const std::string& source, const CsvReadOptions& options) {
  const std::string file = display_name(source);
  CsvTable table;
  table.source = source;
  std::vector<std::vector<double>> columns;
  long line_number = 0;
  long header_line = 0;
  std::string line;
  while (std::getline(in, line)) {
    ++line_number;
    // Excel writes a UTF-8 byte-order mark before the first header name.
    if (line_number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    const std::string content = trim(line);
    if (content.empty() || content[0] == '#') continue;
    const std::string at = file + ", line " + std::to_string(line_number);
    std::vector<std::string> cells = split_cells(content);
    if (header_line == 0) {
      header_line = line_number;
      if (cells.size() == 1 && cells[0].find_first_of(";\t") != std::string::npos)
        throw InputError(at + ": the header '" + cells[0] +
                         "' has no commas; sid reads comma-separated files (not ';' or tabs)");
      for (std::size_t j = 0; j < cells.size(); ++j) {
        if (cells[j].empty())
          throw InputError(at + ": the header's column " + std::to_string(j + 1) +
                           " has an empty name");
        for (std::size_t k = 0; k < j; ++k)
          if (cells[k] == cells[j])
            throw InputError(at + ": the header names column '" + cells[j] + "' twice (columns " +
                             std::to_string(k + 1) + " and " + std::to_string(j + 1) + ")");
      }
      table.names = cells;
      columns.resize(cells.size());
      continue;
    }
    if (cells.size() != table.names.size())
      throw InputError(at + ": row has " + std::to_string(cells.size()) +
                       " cells, the header (line " + std::to_string(header_line) + ") has " +
                       std::to_string(table.names.size()));
    for (std::size_t j = 0; j < cells.size(); ++j) {
      const std::string& cell = cells[j];
      const std::string where = at + ", column '" + table.names[j] + "': ";
      if (cell.empty()) throw InputError(where + "empty cell");
      const char* begin = cell.c_str();
      char* end = nullptr;
      errno = 0;
      const double value = std::strtod(begin, &end);
      if (end == begin || *end != '\0') throw InputError(where + "'" + cell + "' is not a number");
      if (!options.allow_non_finite) {
        if (std::isnan(value)) throw InputError(where + "'" + cell + "' is NaN (not allowed)");
        if (std::isinf(value))
          throw InputError(where + "'" + cell + "' is " +
                           (errno == ERANGE ? "too large for a double" : "infinite (not allowed)"));
      }
      columns[j].push_back(value);
    }
    table.line_numbers.push_back(line_number);
  }
  if (in.bad()) throw InputError(file + ": read error");
  if (header_line == 0)
    throw InputError(file + (line_number == 0 ? ": the file is empty (expected a header row)"
                                              : ": no header row (only comments and blank lines)"));
  if (table.line_numbers.empty())
    throw InputError(file + ": no data rows after the header (line " + std::to_string(header_line) +
                     ")");
  for (const auto& c : columns)
    table.columns.push_back(
        Eigen::Map<const Eigen::VectorXd>(c.data(), static_cast<Eigen::Index>(c.size())));
  return table;
}

CsvTable read_csv(const std::string& path, const CsvReadOptions& options) {
  if (path == "-") return parse_csv(std::cin, path, options);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError("cannot open '" + path + "': " + std::strerror(errno));
  return parse_csv(in, path, options);
}

void require_strictly_increasing(const CsvTable& table, const std::string& column) {
  const Eigen::VectorXd& v = table.column(column);
  for (Eigen::Index i = 1; i < v.size(); ++i)
    if (!(v[i] > v[i - 1]))
      throw InputError(table.where(i) + ", column '" + column + "': not strictly increasing (" +
                       format_double(v[i]) + (v[i] == v[i - 1] ? " repeats " : " after ") +
                       format_double(v[i - 1]) + " on line " +
                       std::to_string(table.line_of(i - 1)) + ")");
}

sid::Trajectory<double> trajectory_from_table(const CsvTable& table,
                                              const TrajectoryColumns& names) {
  // Look up every column first, so a missing one is reported before any row problem.
  const Eigen::VectorXd& t = table.column(names.t);
  const Eigen::VectorXd& q1 = table.column(names.q1);
  const Eigen::VectorXd& q2 = table.column(names.q2);
  const Eigen::VectorXd& tau1 = table.column(names.tau1);
  const Eigen::VectorXd& tau2 = table.column(names.tau2);
  require_strictly_increasing(table, names.t);
  sid::Trajectory<double> trajectory;
  trajectory.t = t;
  trajectory.q.resize(t.size(), 2);
  trajectory.q << q1, q2;
  trajectory.tau.resize(t.size(), 2);
  trajectory.tau << tau1, tau2;
  return trajectory;
}

std::string format_double(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

void write_csv(std::ostream& out, const std::vector<std::string>& names,
               const std::vector<Eigen::VectorXd>& columns,
               const std::vector<std::string>& comments) {
  if (names.size() != columns.size())
    throw InputError("write_csv: " + std::to_string(names.size()) + " names for " +
                     std::to_string(columns.size()) + " columns");
  for (std::size_t j = 1; j < columns.size(); ++j)
    if (columns[j].size() != columns[0].size())
      throw InputError("write_csv: column '" + names[j] + "' has " +
                       std::to_string(columns[j].size()) + " rows, '" + names[0] + "' has " +
                       std::to_string(columns[0].size()));
  for (const auto& c : comments) out << "# " << c << '\n';
  for (std::size_t j = 0; j < names.size(); ++j) out << (j ? "," : "") << names[j];
  out << '\n';
  const Eigen::Index rows = columns.empty() ? 0 : columns[0].size();
  std::string buffer;
  for (Eigen::Index i = 0; i < rows; ++i) {
    buffer.clear();
    for (std::size_t j = 0; j < columns.size(); ++j) {
      if (j) buffer += ',';
      buffer += format_double(columns[j][i]);
    }
    buffer += '\n';
    out << buffer;
  }
}

void write_csv(const std::string& path, const std::vector<std::string>& names,
               const std::vector<Eigen::VectorXd>& columns,
               const std::vector<std::string>& comments) {
  if (path == "-") {
    write_csv(std::cout, names, columns, comments);
    std::cout.flush();
    if (!std::cout) throw std::runtime_error("cannot write to standard output");
    return;
  }
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw std::runtime_error("cannot open '" + path + "' for writing: " + std::strerror(errno));
  write_csv(out, names, columns, comments);
  out.close();
  if (!out) throw std::runtime_error("error while writing '" + path + "' (disk full?)");
}

}  // namespace sid::app
