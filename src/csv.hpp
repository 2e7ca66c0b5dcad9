#pragma once
/// @file
/// @brief Reading and writing the numeric CSV files that users feed to the sid apps.
///
/// Accepted input: one header row of column names, then rows of numbers separated by commas.
/// Lines starting with `#` (after optional spaces) are comments and may appear anywhere, also
/// before the header; blank lines are skipped; spaces around cells, a UTF-8 byte-order mark and
/// CRLF line ends are tolerated. Column order is free; callers look columns up by name and ignore
/// the ones they do not need. Every error is an InputError whose message names the file, the line
/// of the file (counting every line, comments and blank lines included) and the column.

#include <Eigen/Core>
#include <cstddef>
#include <iosfwd>
#include <sid/trajectory.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid::app {

/// @brief Bad input from the user (a file, a column, an option value). The apps print its
/// message and exit with code 2; the message is complete on its own (file, line, column).
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct CsvReadOptions {
  /// NaN and Inf cells are rejected unless this is set (a log with gaps should fail loudly
  /// rather than poison a fit).
  bool allow_non_finite = false;
};

/// @brief A numeric table read from CSV.
/// Class invariant: names are unique and non-empty; every column and line_numbers have rows()
/// entries.
class CsvTable {
 public:
  std::string source;                    ///< file name used in messages ("-" shown as "<stdin>")
  std::vector<std::string> names;        ///< column names in file order
  std::vector<Eigen::VectorXd> columns;  ///< columns[j] belongs to names[j]
  std::vector<long> line_numbers;        ///< line in the file (1-based) of each data row

  Eigen::Index rows() const {
    return line_numbers.empty() ? 0 : static_cast<Eigen::Index>(line_numbers.size());
  }
  bool has(const std::string& name) const;
  /// @throws InputError "FILE: no column 'tau2'; columns are: t, q1, ..."
  std::size_t index_of(const std::string& name) const;
  /// @throws InputError as index_of.
  const Eigen::VectorXd& column(const std::string& name) const;
  /// The file line of data row i, for messages ("line 17").
  long line_of(Eigen::Index row) const { return line_numbers[static_cast<std::size_t>(row)]; }
  /// "FILE, line N" for data row i: the prefix every row-level message uses.
  std::string where(Eigen::Index row) const;
};

/// @brief Reads a CSV file ("-" reads standard input).
/// @throws InputError when the file cannot be opened or its content is invalid.
CsvTable read_csv(const std::string& path, const CsvReadOptions& options = {});

/// @brief Parses CSV text from a stream; source names it in messages.
CsvTable parse_csv(std::istream& in, const std::string& source, const CsvReadOptions& options = {});

/// @throws InputError naming the line when column is not strictly increasing.
void require_strictly_increasing(const CsvTable& table, const std::string& column);

/// Column names of a trajectory table (defaults match the files sid writes).
struct TrajectoryColumns {
  std::string t = "t";
  std::string q1 = "q1";
  std::string q2 = "q2";
  std::string tau1 = "tau1";
  std::string tau2 = "tau2";
};

/// @brief Builds a trajectory from the named columns (extra columns are ignored).
/// @throws InputError on a missing column or time that is not strictly increasing.
sid::Trajectory<double> trajectory_from_table(const CsvTable& table,
                                              const TrajectoryColumns& names = {});

/// @brief Formats a double with 17 significant digits (`%.17g`), enough to read back the exact
/// same double.
std::string format_double(double value);

/// @brief Writes a header and the columns, values with 17 significant digits. Each comment
/// (without its leading '#') becomes a `# ...` line before the header, for provenance.
/// @throws InputError when the columns differ in length or the names and columns do not match.
void write_csv(std::ostream& out, const std::vector<std::string>& names,
               const std::vector<Eigen::VectorXd>& columns,
               const std::vector<std::string>& comments = {});

/// @brief As above, to a file ("-" is standard output). Overwrites: call ensure_writable first.
/// @throws std::runtime_error when the file cannot be written.
void write_csv(const std::string& path, const std::vector<std::string>& names,
               const std::vector<Eigen::VectorXd>& columns,
               const std::vector<std::string>& comments = {});

}  // namespace sid::app
