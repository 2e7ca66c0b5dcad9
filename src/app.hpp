#pragma once
/// @file
/// @brief Plumbing every sid app shares: option parsing and error reporting around main,
/// refusing to overwrite outputs, parsing lists of numbers, writing JSON.

#include <Eigen/Core>
#include <algorithm>
#include <cstddef>
#include <functional>
#include <nlohmann/json.hpp>
#include <sid/model/effect.hpp>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "csv.hpp"  // InputError

// Declared, not included: CLI11 costs 8 s of compile time per file, and the report files that
// include this header for its JSON helpers need none of it. Callers of run_app include it.
namespace CLI {
class App;
}

namespace sid::app {

/// Exit codes of every app.
inline constexpr int kExitOk = 0;
inline constexpr int kExitInternalError = 1;  ///< a bug: an exception nobody expected
inline constexpr int kExitBadInput = 2;       ///< bad options, bad files, refused overwrite

/// Keeps large allocations in the heap (glibc only; see app.cpp). run_app calls it.
void tune_allocator();

/// @brief The body of every main. Builds a CLI::App (name, description), lets define_options
/// add the options, parses argv, then calls run and returns its exit code.
///
/// Errors become messages on stderr and exit codes, never a crash:
/// - `--help` prints every option to stdout and returns 0;
/// - a CLI11 parse error prints "NAME: error: MESSAGE" and a hint to `--help`, returns 2;
/// - InputError, std::invalid_argument (the library's bad-input error) and other
///   std::runtime_error print "NAME: error: MESSAGE", return 2;
/// - anything else prints "NAME: internal error: ..." and returns 1.
/// @param define_options adds options bound to variables that outlive the call (typically
///   locals of main captured by reference).
int run_app(const char* name, const std::string& description, int argc, char** argv,
            const std::function<void(CLI::App&)>& define_options, const std::function<int()>& run);

/// @brief The error-to-exit-code part of run_app alone, for code that parses by itself.
int report_errors(const char* name, const std::function<int()>& body);

/// @brief Throws InputError(message) unless ok: the one-line check for option values.
void require(bool ok, const std::string& message);

/// @brief Refuses to overwrite: throws InputError "refusing to overwrite 'x.csv' (use --force)"
/// when path exists and force is false. Also fails early (before any work is done) when path is
/// a directory or its parent directory does not exist. "-" (standard output) always passes.
void ensure_writable(const std::string& path, bool force);

/// @brief Prepares a directory of outputs: creates it (and its parents) if missing; fails if it
/// is a file. Without force, refuses when any of the named files already exists in it.
/// @return dir itself, for chaining.
std::string ensure_output_directory(const std::string& dir, const std::vector<std::string>& files,
                                    bool force);

/// @brief As above when the file names are not known in advance: without force, refuses any
/// directory that already holds files.
std::string ensure_output_directory(const std::string& dir, bool force);

/// @brief dir + "/" + file (std::filesystem join, as a string).
std::string path_in(const std::string& dir, const std::string& file);

/// @brief A seed given as text: digits only (CLI11 would wrap "-1" around to 2^64 - 1).
/// @throws InputError naming --seed and the text.
std::uint64_t parse_seed(const std::string& text);

/// @brief The shortest text that reads back as exactly v (for settings recorded in a file).
std::string shortest_number(double v);

/// "each torque paired with the angles 3.1 ms earlier" ("later" for a negative delay [s]).
std::string torque_pairing(double delay);

/// @brief Parses "0.1, 0.2,3e-4" (commas, optional spaces). what names the option in messages.
/// @throws InputError "--theta: value 3 'abc' is not a number" and the like; NaN/Inf rejected.
std::vector<double> parse_doubles(const std::string& text, const std::string& what);

/// @brief As above, requiring exactly count values: "--theta needs 7 values, got 6".
std::vector<double> parse_doubles(const std::string& text, const std::string& what,
                                  std::size_t count);

/// @brief Splits "a, b,c" at commas into trimmed names (an option's list of ids or methods).
/// @param option e.g. "--methods"; item, items e.g. "method name", "methods" (for messages);
///        expected, if not empty, is shown with the empty-list error ("(expected raw, css)").
/// @throws InputError "--methods: no methods given", "--methods: empty method name in 'a,,b'",
///         "--methods: 'css' is given twice".
std::vector<std::string> parse_name_list(const std::string& text, const std::string& option,
                                         const std::string& item, const std::string& items,
                                         const std::string& expected = "");

/// @brief Parses "key=value, key=value" (each key and value trimmed, each key once) for the
/// option named option; form describes one entry in the message for a missing '='.
/// @throws InputError "--columns: 'time' is not KEY=NAME (...)", "--columns: key 't' is given
///         twice", and the errors of parse_name_list.
std::vector<std::pair<std::string, std::string>> parse_assignments(const std::string& text,
                                                                   const std::string& option,
                                                                   const std::string& form);

/// @brief A comma-separated list of effect ids, e.g. "coulomb_j1, armature_j2".
/// @throws InputError "--effects: unknown effect 'x' (expected coulomb_j1, ...)" and the errors
///         of parse_name_list.
std::vector<sid::Effect> parse_effect_list(const std::string& text, const std::string& option);

/// @brief An Eigen vector as a JSON array (numbers keep every bit: nlohmann prints the shortest
/// text that reads back the same double; NaN/Inf become null).
nlohmann::json to_json_array(const Eigen::Ref<const Eigen::VectorXd>& v);

/// @brief v printed with a printf format, or "n/a" for NaN (a figure the report could not compute).
std::string format_number(const char* format, double v);

/// @brief The width of a column of file names: the longest `file` of the entries, at least
/// `minimum`, so that the columns after it stay aligned.
template <typename... Lists>
int file_column_width(std::size_t minimum, const Lists&... lists) {
  std::size_t width = minimum;
  const auto widen = [&width](const auto& list) {
    for (const auto& entry : list) width = std::max(width, entry.file.size());
  };
  (widen(lists), ...);
  return static_cast<int>(width);
}

/// @brief A matrix as a JSON array of rows.
nlohmann::json to_json_rows(const Eigen::Ref<const Eigen::MatrixXd>& m);

/// @brief Writes pretty JSON (indent 2, trailing newline) to path ("-" is standard output).
/// Overwrites: call ensure_writable first.
/// @throws std::runtime_error when the file cannot be written.
void write_json(const std::string& path, const nlohmann::json& value);

/// @brief Writes text as it is to the file path (a URDF, an MJCF, an HTML report). Overwrites:
/// call ensure_writable first.
/// @throws std::runtime_error when the file cannot be written.
void write_text(const std::string& path, const std::string& text);

/// @brief Parses a column map "t=time,q1=pos_meas1,q2=pos_meas2,tau1=tau_meas1,tau2=tau_meas2"
/// (any subset, any order; the others keep their default names) for the option named option.
/// @throws InputError on an unknown key, a key given twice, a missing '=' or an empty name.
TrajectoryColumns parse_trajectory_columns(const std::string& text, const std::string& option);

}  // namespace sid::app
