#pragma once
/// @file
/// @brief The report of an identification from several runs (sid_identify's torque-cv path):
/// the estimate, each run's fit, the runs kept for validation, physical plausibility.

#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <sid/identify_runs.hpp>
#include <sid/model/effect.hpp>
#include <sid/model/model.hpp>
#include <sid/physical_consistency.hpp>
#include <string>
#include <vector>

#include "csv.hpp"

namespace sid::app {

/// One measured run as read: its file name (as the user gave it) and its samples.
struct RunFile {
  std::string file;
  sid::Trajectory<double> data;
};

/// The torque prediction on one run not used in the fit.
struct ValidationRow {
  std::string file;
  sid::TorquePrediction prediction;                ///< of the identified model
  std::optional<sid::TorquePrediction> reference;  ///< of --reference-theta, when given
};

/// Everything the report shows; the apps fill it, make_runs_report only formats.
struct RunsReportInput {
  const char* program = "";
  std::vector<RunFile> runs;
  sid::RunsIdentifyOptions options;
  sid::Model<double> model;
  sid::RunsIdentification id;
  sid::PhysicalCheck physical;
  std::optional<sid::ConsistentEstimate> consistent;  ///< when the estimate is not physical
  std::vector<ValidationRow> validation;
  std::optional<Eigen::VectorXd> reference_theta;
  std::vector<sid::TorquePrediction> reference_on_fitted;  ///< per fitted run, with reference
  std::optional<double> gear_ratio;                        ///< of drive 2, for the rotor line
};

struct RunsReport {
  std::string text;
  nlohmann::json json;
};

/// @brief The unit of a model parameter, from its name ("theta4" → "kg m", "coulomb_j1.Fc" → "N
/// m").
std::string parameter_unit(const std::string& name);

RunsReport make_runs_report(const RunsReportInput& in);

/// @brief The plausibility lines of a report (and "physical" in its JSON): the check and, when
/// given, the nearest physically consistent estimate, labelled as such.
void physical_lines(const sid::Model<double>& model, const sid::PhysicalCheck& check,
                    const std::optional<sid::ConsistentEstimate>& consistent,
                    std::ostringstream& out, nlohmann::json& j);

/// @brief Reads one run (columns mapped as given).
/// @throws InputError on a bad file or fewer than 3 rows.
RunFile read_run(const std::string& file, const TrajectoryColumns& columns);

/// @brief Reads runs in order (columns mapped as given).
/// @throws InputError as read_run.
std::vector<RunFile> read_runs(const std::vector<std::string>& files,
                               const TrajectoryColumns& columns);

/// @brief Refuses standard input ('-') named more than once among the fitted and held-out runs.
/// @throws InputError naming the problem.
void require_stdin_at_most_once(const std::vector<std::string>& fitted,
                                const std::vector<std::string>& held_out);

}  // namespace sid::app
