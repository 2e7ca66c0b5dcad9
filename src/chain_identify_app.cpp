#include "chain_identify_app.hpp"

#include <sid/chain_consistency.hpp>
#include <sid/cvode/identify_robot.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>
#include <sid/model/joint_dynamics.hpp>

#include "app.hpp"
#include "csv.hpp"
#include "identify_report_html.hpp"
#include "robot_description.hpp"
#include "mjcf_writer.hpp"
#include "urdf_writer.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <initializer_list>
#include <iostream>
#include <sstream>

namespace sid::app {

std::string fs_parent(const std::string& path) {
  return std::filesystem::path(path).parent_path().string();
}

void require_model_files(const ChainIdentifyAppOptions& o, const RobotDescription& robot) {
  require(o.write_urdf.empty() || !robot.urdf.empty(),
          "--write-urdf needs a URDF as --robot, not a DH table");
  require(o.write_mjcf.empty() || !robot.urdf.empty(),
          "--write-mjcf needs a URDF as --robot, not a DH table");
}

ChainRunFile identification_run(const std::string& name, sid::ChainTrajectory<double> run,
                                const sid::Transmission& transmission, bool motor_side) {
  if (run.size() < 4)
    throw InputError(name + ": identification needs at least 4 data rows, got " +
                     std::to_string(run.size()));
  try {
    if (motor_side) run = transmission.joint_side(run);
  } catch (const std::invalid_argument& e) {
    throw InputError(name + ": " + e.what());
  }
  return {name, std::move(run)};
}

namespace {

ChainRunFile load_run(const std::string& path, const sid::Transmission& transmission,
                      bool motor_side, const std::vector<std::string>& columns) {
  const CsvTable table = read_csv(path);
  return identification_run(table.source,
                            chain_trajectory_from_table(table, transmission.joints(), columns),
                            transmission, motor_side);
}

sid::ChainIdentifyOptions make_options(const ChainIdentifyAppOptions& o, int joints) {
  sid::ChainIdentifyOptions options;
  options.threads = 0;  // a tool's run has the machine to itself
  if (!o.cutoff.empty()) {
    options.cutoff_hz = parse_doubles(o.cutoff, "--cutoff");
    require(options.cutoff_hz.size() == 1 || options.cutoff_hz.size() == std::size_t(joints),
            "--cutoff takes one value or one per joint (" + std::to_string(joints) + ")");
    for (const double c : options.cutoff_hz) require(c > 0.0, "--cutoff values must be > 0 Hz");
  }
  if (o.rest_fraction) {
    require(*o.rest_fraction >= 0.0 && *o.rest_fraction < 1.0, "--rest-fraction must be in [0, 1)");
    options.rest_fraction = *o.rest_fraction;
  }
  if (o.skip) {
    require(*o.skip >= 0.0 && std::isfinite(*o.skip), "--skip must be finite and >= 0 s");
    options.skip = options.skip_end = *o.skip;
  }
  if (o.torque_delay) {
    require(std::isfinite(*o.torque_delay) &&
                std::abs(*o.torque_delay) <= std::min(options.skip, options.skip_end),
            "--torque-delay must be finite and at most --skip (" +
                format_number("%g", std::min(options.skip, options.skip_end)) + " s) either way");
    options.torque_delay = *o.torque_delay;
  }
  require(o.estimator == "ls" || o.estimator == "wls" || o.estimator == "iv",
          "--estimator: the estimators are ls, wls and iv, not '" + o.estimator + "'");
  options.weighted = o.estimator == "wls";
  return options;
}

std::string number(const char* format, double v) { return format_number(format, v); }

/// "v ± s" with s to two significant digits and v to the same decimals: a delay found at
/// 7e-17 ms is 0.0 ± 1.4 ms.
std::string value_and_std(double v, double s) {
  if (!(std::isfinite(v) && std::isfinite(s) && s > 0.0))
    return number("%.3g", v) + " ± " + number("%.2g", s);
  int decimals = std::max(0, 1 - static_cast<int>(std::floor(std::log10(s))));
  // 9.97 rounds to 10: two digits are "10", not "10.0".
  if (decimals > 0 && std::round(s * std::pow(10.0, decimals)) >= 100.0) --decimals;
  const double scale = std::pow(10.0, decimals);
  const double rounded = std::round(v * scale) / scale + 0.0;  // + 0.0: no "-0.0"
  char text[96];
  std::snprintf(text, sizeof text, "%.*f ± %.*f", decimals, rounded, decimals, s);
  return text;
}

/// The kinds of drive term the model fits, in its order, and the names of their parameters.
std::vector<std::string> drive_term_keywords(const sid::ChainModel& model) {
  std::vector<std::string> kinds;
  for (const sid::DriveTerm& t : model.terms()) {
    const std::string word = sid::drive_term_keyword(t.kind);
    if (std::find(kinds.begin(), kinds.end(), word) == kinds.end()) kinds.push_back(word);
  }
  return kinds;
}

std::vector<std::string> drive_term_parameters(const sid::ChainModel& model) {
  const auto& names = model.parameter_names();
  return {names.begin() + model.rigid_body_parameters(), names.end()};
}

nlohmann::json prediction_json(const sid::ChainPrediction& p) {
  nlohmann::json j;
  j["file"] = p.source;
  j["residual_rms"] = to_json_array(p.residual_rms);
  j["relative_residual"] = p.relative_residual;
  j["relative_residual_per_joint"] = to_json_array(p.relative_per_joint);
  j["relative_residual_unfiltered"] = p.relative_residual_unfiltered;
  j["residual_rms_measured"] = to_json_array(p.measured_residual_rms);
  j["relative_residual_measured"] = p.measured_relative_residual;
  j["equations"] = to_json_array(p.equations.cast<double>());
  return j;
}

void print_prediction_rows(std::ostream& out, const sid::ChainModel& model,
                           const sid::ChainPrediction& p) {
  for (int j = 0; j < model.joints(); ++j)
    out << "  " << model.joint_names()[static_cast<std::size_t>(j)] << ": RMS "
        << number("%.4g", p.residual_rms[j]) << " N m, "
        << number("%.2f", 100.0 * p.relative_per_joint[j]) << " %, " << p.equations[j]
        << " equations; the log as recorded: RMS " << number("%.4g", p.measured_residual_rms[j])
        << " N m\n";
  out << "  all joints: " << number("%.2f", 100.0 * p.relative_residual)
      << " % of the torque (against the unfiltered torque: "
      << number("%.2f", 100.0 * p.relative_residual_unfiltered)
      << " %; the log as recorded, at rest too: "
      << number("%.2f", 100.0 * p.measured_relative_residual) << " %)\n";
}

std::string report_text(const ChainIdentifyAppOptions& o, const sid::ChainModel& model,
                        const sid::RobotIdentification& r,
                        const std::vector<std::string>& link_names) {
  const sid::ChainIdentification& id = r.identification;
  const sid::ChainIvRefinement& iv = r.iv;
  const sid::ChainConsistentFit& consistent = r.consistent;
  std::ostringstream out;
  out << "robot " << o.robot << ": " << model.joints() << " joints (" << [&] {
    std::string s;
    for (const auto& n : model.joint_names()) s += (s.empty() ? "" : ", ") + n;
    return s;
  }() << ")\n";
  out << "smoothing cutoff per joint [Hz]"
      << (id.cutoff_chosen ? " (chosen by held-out torque prediction)" : "") << ":";
  for (int j = 0; j < model.joints(); ++j) out << " " << number("%.3g", id.cutoff_hz[j]);
  out << "\n";
  if (const auto& d = r.torque_delay_estimate)
    out << "torque's delay behind the angles: " << value_and_std(1e3 * d->delay, 1e3 * d->std_dev)
        << " ms (estimated within ±" << number("%g", 1e3 * d->delays.maxCoeff())
        << " ms, every joint smoothed at " << number("%.3g", d->cutoff_hz)
        << " Hz); each torque paired with the angles then\n";
  else if (r.torque_delay != 0.0)
    out << "torque paired with the angles " << number("%.4g", 1e3 * r.torque_delay)
        << " ms before it was logged (--torque-delay)\n";
  out << id.base.rank() << " base parameters of " << model.parameters() << " (rank gap "
      << number("%.2g", id.base.rank_gap) << "), condition number "
      << number("%.4g", id.fit.condition_number) << "\n";
  {
    const std::vector<std::string> kinds = drive_term_keywords(model);
    std::string list;
    for (const auto& k : kinds) list += (list.empty() ? "" : ", ") + k;
    out << "drive terms: "
        << (kinds.empty()
                ? std::string("none (rigid bodies only)")
                : list + " on every joint" +
                      (model.transmission().coupled_motors().empty() ? std::string()
                                                                     : " and coupled motor") +
                      " (" + std::to_string(model.terms().size()) + " parameters)")
        << "\n";
  }
  if (id.structural_rank > id.base.rank())
    out << "  (" << id.structural_rank - id.base.rank()
        << " more the model has, which these runs do not tell apart: regrouped)\n";
  if (iv.used)
    out << "estimator iv: instruments from simulations of the physically consistent arm nearest "
           "to each estimate (angles smoothed by GCV, torque as measured); "
        << iv.iterations << " iterations, " << (iv.converged ? "converged" : "not converged")
        << ", residual " << number("%.3g", iv.residual_ratio) << "x least squares'"
        << (iv.applied ? "" : "; not used: " + iv.message + "; the least-squares fit follows")
        << "\n";
  out << "\n";
  std::size_t width = 10;
  for (const auto& n : id.parameter_names)
    width = std::max(width, std::min<std::size_t>(n.size(), 60));
  char line[512];
  std::snprintf(line, sizeof line, "  %-3s %-*s %13s %11s %9s\n", "#", int(width), "parameter",
                "value", "std", "std %");
  out << line;
  for (Eigen::Index i = 0; i < id.fit.theta.size(); ++i) {
    std::string name = id.parameter_names[static_cast<std::size_t>(i)];
    if (name.size() > 60) name = name.substr(0, 57) + "...";
    std::snprintf(line, sizeof line, "  %-3d %-*s %13.6g %11.3g %9s\n", int(i + 1), int(width),
                  name.c_str(), id.fit.theta[i], id.std_dev[i],
                  number("%.2f", id.relative_std_dev[i]).c_str());
    out << line;
  }
  out << (iv.applied ? "  (std: of the IV estimate, for uncorrelated residuals: on measured logs "
                       "too small; the HAC std of --estimator ls are honest there"
                     : "  (std: HAC, for residuals correlated in time")
      << (id.jackknife_std_dev.size() ? "; leave-one-run-out in the JSON" : "") << ")\n\n";
  if (iv.applied) {
    // The least-squares fit's equations (its cutoffs, rest rule), for comparison.
    for (const auto& r : iv.runs) {
      out << "residual of the IV estimate on " << r.source << ":\n";
      print_prediction_rows(out, model, r);
    }
  } else {
    out << "residual of the fit:\n";
    print_prediction_rows(out, model, id.fitted);
  }
  for (const auto& v : r.validation) {
    out << "prediction of " << v.source << ":\n";
    print_prediction_rows(out, model, v);
  }
  out << "\nphysically consistent links (each a real body, near the description's values where "
         "the data say little): "
      << number("%.2f", 100.0 * consistent.relative_residual) << " % of the torque (least squares "
      << number("%.2f", 100.0 * consistent.least_squares_relative_residual) << " %)\n"
      << "  prior toward the description: weight " << number("%.3g", consistent.prior_weight)
      << " of the least-squares RSS per unit change in a link's own scale"
      << (consistent.correlation_inflation > 1.0
              ? " (the residuals' correlation in time inflates the estimate's variance " +
                    number("%.3g", consistent.correlation_inflation) + "-fold)"
              : std::string())
      << "\n";
  const sid::ConsistentCost cost = sid::consistent_cost(r);
  if (cost.held_out)
    out << "  held-out torque: " << number("%.2f", 100.0 * cost.consistent)
        << " % error against the estimate's " << number("%.2f", 100.0 * cost.estimate) << " %\n";
  else if (cost.folds > 0)
    out << "  cross-validated torque (" << cost.measured_on()
        << "): " << number("%.2f", 100.0 * cost.consistent) << " % error against the estimate's "
        << number("%.2f", 100.0 * cost.estimate) << " %\n";
  else if (!r.consistent_cross_validation.skipped.empty())
    out << "  judged on the fitted equations: no cross-validation ("
        << r.consistent_cross_validation.skipped << ")\n";
  const std::string problem = sid::consistent_links_problem(r, o.consistency());
  if (!consistent.converged)
    out << "  NOT CONVERGED in " << consistent.iterations
        << " Newton steps: the links below are the last iterate, not a result (--write-urdf "
           "refuses them)\n";
  else if (!consistent.fits_estimate)
    out << "  REAL BODIES DO NOT FIT THE ESTIMATE: misfit " << number("%.3g", consistent.misfit)
        << " where noise alone gives at most " << number("%.3g", consistent.misfit_limit)
        << " (the model probably lacks a drive term the data have; see --effects): the links "
           "below are the nearest real bodies, not the arm's"
        << (problem.empty() ? "; their torque error (" + cost.measured_on() + ") is within " +
                                  number("%.0f", 100.0 * o.consistency().max_extra_error) +
                                  " % of the estimate's, so --write-urdf writes them "
                                  "(--strict-consistency refuses)\n"
                            : " (--write-urdf refuses them: " + problem + ")\n");
  else if (!problem.empty())
    out << "  REAL BODIES COST TOO MUCH: " << problem << " (--write-urdf refuses them)\n";
  for (int i = 0; i < model.joints(); ++i) {
    const double m = consistent.theta[10 * i];
    const Eigen::Vector3d c = consistent.theta.segment<3>(10 * i + 1) / m;
    const auto k = static_cast<std::size_t>(i);
    out << "  " << (k < link_names.size() ? link_names[k] : "link " + std::to_string(i + 1))
        << ": mass " << number("%.4g", m) << " kg, centre of mass (" << number("%.3g", c[0]) << ", "
        << number("%.3g", c[1]) << ", " << number("%.3g", c[2]) << ") m\n";
  }
  return out.str();
}

nlohmann::json report_json(const ChainIdentifyAppOptions& o, const sid::ChainModel& model,
                           const sid::RobotIdentification& r) {
  const sid::ChainIdentification& id = r.identification;
  const sid::ChainIvRefinement& iv = r.iv;
  const sid::ChainConsistentFit& consistent = r.consistent;
  nlohmann::json j;
  j["robot"] = o.robot;
  j["joint_names"] = model.joint_names();
  j["parameter_names"] = id.parameter_names;
  j["parameter_combinations"] = id.parameter_combinations;
  j["theta"] = to_json_array(id.fit.theta);
  j["std_dev"] = to_json_array(id.std_dev);
  j["relative_std_dev_pct"] = to_json_array(id.relative_std_dev);
  j["std_dev_uncorrelated"] = to_json_array(id.fit.std_dev);
  if (id.jackknife_std_dev.size()) j["jackknife_std_dev"] = to_json_array(id.jackknife_std_dev);
  j["condition_number"] = id.fit.condition_number;
  j["rank"] = id.base.rank();
  j["structural_rank"] = id.structural_rank;
  j["rank_gap"] = id.base.rank_gap;
  j["model_parameters"] = model.parameter_names();
  j["drive_terms"] = drive_term_keywords(model);
  j["drive_term_parameters"] = drive_term_parameters(model);
  j["coulomb_epsilon"] = model.coulomb_epsilon();
  j["cutoff_hz"] = to_json_array(id.cutoff_hz);
  j["cutoff_chosen"] = id.cutoff_chosen;
  if (r.torque_delay != 0.0 || r.torque_delay_estimate) j["torque_delay"] = r.torque_delay;
  if (const auto& d = r.torque_delay_estimate) {
    j["torque_delay_std_dev"] = d->std_dev;
    j["torque_delay_cutoff_hz"] = d->cutoff_hz;
    j["torque_delay_at_bound"] = d->at_bound;
  }
  j["residual_rms"] = to_json_array(id.fitted.residual_rms);
  j["relative_residual"] = id.fitted.relative_residual;
  j["relative_residual_per_joint"] = to_json_array(id.fitted.relative_per_joint);
  j["relative_residual_unfiltered"] = id.fitted.relative_residual_unfiltered;
  j["residual_rms_measured"] = to_json_array(id.fitted.measured_residual_rms);
  j["relative_residual_measured"] = id.fitted.measured_relative_residual;
  j["estimator"] = o.estimator;
  if (iv.used) {
    j["iv_applied"] = iv.applied;
    j["iv_iterations"] = iv.iterations;
    j["iv_converged"] = iv.converged;
    j["iv_residual_ratio"] = iv.residual_ratio;
    j["iv_message"] = iv.message;
    j["least_squares_theta"] = to_json_array(iv.least_squares);
    j["iv_fit"] = nlohmann::json::array();
    for (const auto& r : iv.runs) j["iv_fit"].push_back(prediction_json(r));
  }
  j["validation"] = nlohmann::json::array();
  for (const auto& v : r.validation) j["validation"].push_back(prediction_json(v));
  nlohmann::json physical;
  physical["theta"] = to_json_array(consistent.theta);
  physical["beta"] = to_json_array(consistent.beta);
  physical["relative_residual"] = consistent.relative_residual;
  physical["least_squares_relative_residual"] = consistent.least_squares_relative_residual;
  physical["converged"] = consistent.converged;
  physical["iterations"] = consistent.iterations;
  physical["prior_weight"] = consistent.prior_weight;
  physical["correlation_inflation"] = consistent.correlation_inflation;
  physical["misfit"] = consistent.misfit;
  physical["fits_estimate"] = consistent.fits_estimate;
  const sid::ConsistentCost cost = sid::consistent_cost(r);
  physical["torque_error"] = cost.consistent;
  physical["estimate_torque_error"] = cost.estimate;
  physical["torque_error_on"] = cost.measured_on();
  if (!r.consistent_cross_validation.skipped.empty())
    physical["cross_validation_skipped"] = r.consistent_cross_validation.skipped;
  physical["validation"] = nlohmann::json::array();
  for (const auto& v : r.consistent_validation)
    physical["validation"].push_back(prediction_json(v));
  physical["written"] = sid::consistent_links_problem(r, o.consistency()).empty();
  j["physically_consistent"] = physical;
  return j;
}

}  // namespace

std::vector<sid::DriveTermKind> identify_drive_term_kinds(const std::string& effects,
                                                          bool no_default_effects) {
  require(!no_default_effects || !effects.empty(),
          "--no-default-effects: name every drive term to fit with --effects (none for rigid "
          "bodies only)");
  if (effects == "none") return {};
  if (effects.empty()) return sid::robot_drive_term_kinds();
  std::vector<sid::DriveTermKind> listed;
  try {
    listed = sid::parse_drive_term_kinds(effects);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("--effects: ") + e.what());
  }
  if (!no_default_effects) return sid::robot_drive_term_kinds(listed);
  // One order whatever the list's, so the same terms give the same parameters.
  std::sort(listed.begin(), listed.end());
  listed.erase(std::unique(listed.begin(), listed.end()), listed.end());
  return listed;
}

Eigen::VectorXd description_prior(const RobotDescription& robot, const sid::ChainModel& model) {
  return sid::description_prior(model, description_dynamics(robot));
}

LoadedChain load_chain(const ChainIdentifyAppOptions& o,
                       const std::vector<sid::DriveTermKind>& default_kinds) {
  RobotDescription robot =
      read_robot_description(o.robot, o.base, o.tip, parse_held_joints(o.hold, "--hold"));
  const int n = robot.chain.joints();
  const bool motor_side = !o.transmission.empty();
  sid::Transmission transmission =
      motor_side ? read_transmission(o.transmission, robot.joint_names) : sid::Transmission(n);
  std::vector<sid::DriveTermKind> kinds = default_kinds;
  if (!o.effects.empty()) {
    try {
      kinds = sid::parse_drive_term_kinds(o.effects);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--effects: ") + e.what());
    }
  }
  if (o.coulomb_epsilon)
    require(*o.coulomb_epsilon >= 0.0 && std::isfinite(*o.coulomb_epsilon),
            "--coulomb-epsilon must be finite and >= 0");
  sid::ChainModel model(robot.chain, robot.joint_names, sid::drive_terms(kinds, transmission),
                        transmission, o.coulomb_epsilon.value_or(0.01));
  sid::ChainIdentifyOptions options = make_options(o, n);
  const std::vector<std::string> columns = chain_columns(o.columns, n, "--columns");
  std::vector<ChainRunFile> runs;
  for (const auto& f : o.inputs) runs.push_back(load_run(f, transmission, motor_side, columns));
  return {std::move(robot), std::move(transmission), motor_side,
          std::move(model), std::move(options),      std::move(runs)};
}

namespace {

sid::ChainEstimator estimator_named(const std::string& name) {
  if (name == "wls") return sid::ChainEstimator::WeightedLeastSquares;
  if (name == "iv") return sid::ChainEstimator::InstrumentalVariables;
  require(name == "ls", "--estimator: the estimators are ls, wls and iv, not '" + name + "'");
  return sid::ChainEstimator::LeastSquares;
}

}  // namespace

sid::RobotIdentifyOptions robot_identify_options(const ChainIdentifyAppOptions& o,
                                                 const LoadedChain& loaded) {
  require(!o.validate_fraction || (*o.validate_fraction > 0.0 && *o.validate_fraction < 1.0),
          "--validate-fraction must be in (0, 1)");
  sid::RobotIdentifyOptions options;
  options.fit = loaded.options;
  options.estimator = estimator_named(o.estimator);
  options.validate_fraction = o.validate_fraction.value_or(0.0);
  require(!o.consistency_folds || *o.consistency_folds == 0 || *o.consistency_folds >= 2,
          "--consistency-folds must be 0 (judge on the fitted equations) or >= 2");
  if (o.consistency_folds) options.consistency_folds = *o.consistency_folds;
  if (o.estimate_torque_delay) {
    require(!o.torque_delay, "--torque-delay and --estimate-torque-delay exclude each other");
    const double reach = std::min(options.fit.skip, options.fit.skip_end);
    require(*o.estimate_torque_delay > 0.0 && *o.estimate_torque_delay <= reach,
            "--estimate-torque-delay must be > 0 and at most --skip (" +
                format_number("%g", reach) + " s)");
    options.estimate_torque_delay = sid::TorqueDelaySearch{*o.estimate_torque_delay};
  }
  options.description = description_dynamics(loaded.robot);
  return options;
}

ChainIdentifyResult identify_report(const ChainIdentifyAppOptions& o, LoadedChain loaded,
                                    sid::RobotIdentification result) {
  loaded.options.torque_delay = result.torque_delay;  // estimated, the plots pair at it too
  std::string text = report_text(o, loaded.model, result, loaded.robot.link_names);
  nlohmann::json json = report_json(o, loaded.model, result);
  return {std::move(loaded), std::move(result), std::move(text), std::move(json)};
}

ChainIdentifyResult identify_loaded(const ChainIdentifyAppOptions& o, LoadedChain loaded,
                                    std::vector<ChainRunFile> held_out) {
  require(!loaded.runs.empty(), "no run given");
  require(!o.validate_fraction || loaded.runs.size() == 1,
          "--validate-fraction splits one run; give one run (or use --validate)");
  const sid::RobotIdentifyOptions options = robot_identify_options(o, loaded);
  std::vector<sid::NamedChainRun> runs, held;
  for (auto& r : loaded.runs) runs.push_back({std::move(r.file), std::move(r.data)});
  for (auto& r : held_out) held.push_back({std::move(r.file), std::move(r.data)});
  loaded.runs.clear();  // the result holds the runs it fitted
  sid::RobotIdentification result;
  try {
    result = sid::identify_robot(loaded.model, std::move(runs), std::move(held), options);
  } catch (const std::invalid_argument& e) {
    const std::string what = e.what();
    throw InputError(what.rfind("estimator iv: ", 0) == 0 ? "--" + what : what);
  }
  return identify_report(o, std::move(loaded), std::move(result));
}

namespace {

/// The names of model's drive terms that a file holding `written` kinds per joint cannot hold:
/// the other kinds, and those that no joint feels alone.
std::vector<std::string> unwritable_terms(const sid::ChainModel& model,
                                          const sid::JointDynamics& per_joint,
                                          std::initializer_list<sid::DriveTermKind> written) {
  std::vector<std::string> left_out;
  const std::size_t first = static_cast<std::size_t>(model.parameters()) - model.terms().size();
  for (std::size_t i = 0; i < model.terms().size(); ++i)
    if (std::find(written.begin(), written.end(), model.terms()[i].kind) == written.end())
      left_out.push_back(model.parameter_names()[first + i]);
  for (const std::string& name : per_joint.coupled)
    if (std::find(left_out.begin(), left_out.end(), name) == left_out.end())
      left_out.push_back(name);
  return left_out;
}

}  // namespace

std::string consistent_urdf(const ChainIdentifyResult& r, const std::string& what,
                            const sid::ConsistentLinksPolicy& policy) {
  const RobotDescription& robot = r.loaded.robot;
  require(!robot.urdf.empty(), what + " needs a URDF as the robot, not a DH table");
  const std::string problem = sid::consistent_links_problem(r.result, policy);
  if (!problem.empty()) throw InputError(what + ": " + problem);
  std::vector<sid::LinkParameters<double>> phi;
  for (int i = 0; i < robot.chain.joints(); ++i)
    phi.push_back(r.result.consistent.theta.segment<10>(10 * i));
  const std::string links =
      urdf_with_link_parameters(robot.urdf, robot.base, robot.tip, robot.link_names, phi, what);
  const sid::ChainModel& model = r.loaded.model;
  const sid::JointDynamics friction = sid::joint_dynamics(model, r.result.consistent.theta);
  const std::string written = urdf_with_joint_dynamics(
      links, robot.joint_names, friction.damping, friction.friction,
      unwritable_terms(model, friction,
                       {sid::DriveTermKind::Viscous, sid::DriveTermKind::Coulomb}));
  // What was written must read back as what was identified.
  const RobotDescription back = sid::robot_description_from_urdf(written, robot.base, robot.tip);
  const auto close = [](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return a.size() == b.size() && ((a - b).array().abs() <= 1e-12 * (1.0 + b.array().abs())).all();
  };
  if (!close(back.damping, friction.damping) || !close(back.friction, friction.friction))
    throw std::runtime_error(what + ": the joints' <dynamics> do not read back as identified");
  return written;
}

Mjcf consistent_mjcf(const ChainIdentifyResult& r, const std::string& what,
                     const sid::ConsistentLinksPolicy& policy, const MjcfPaths& paths) {
  const std::string urdf = consistent_urdf(r, what, policy);
  const RobotDescription& robot = r.loaded.robot;
  const sid::JointDynamics drives = sid::joint_dynamics(r.loaded.model, r.result.consistent.theta);
  using K = sid::DriveTermKind;
  return mjcf_from_urdf(
      urdf, robot.base, robot.chain.gravity(),
      {robot.joint_names, drives.damping, drives.friction, drives.armature, drives.stiffness},
      unwritable_terms(r.loaded.model, drives, {K::Viscous, K::Coulomb, K::Armature, K::Spring}),
      paths);
}

ChainRunFile load_chain_run(const ChainIdentifyAppOptions& o, const LoadedChain& loaded,
                            const std::string& path) {
  return load_run(path, loaded.transmission, loaded.motor_side,
                  chain_columns(o.columns, loaded.robot.chain.joints(), "--columns"));
}

LoadedChain load_identify_chain(const ChainIdentifyAppOptions& o) {
  // load_chain takes --effects as the exact list (sid_diagnose's --drives); here it adds.
  ChainIdentifyAppOptions exact = o;
  exact.effects.clear();
  return load_chain(exact, identify_drive_term_kinds(o.effects, o.no_default_effects));
}

int identify_robot(const ChainIdentifyAppOptions& o, const char* app_name) {
  require(!o.inputs.empty(), "no run given");
  if (!o.json.empty()) ensure_writable(o.json, o.force);
  if (!o.write_urdf.empty()) ensure_writable(o.write_urdf, o.force);
  if (!o.write_mjcf.empty()) ensure_writable(o.write_mjcf, o.force);
  if (!o.report.empty()) ensure_writable(o.report, o.force);
  LoadedChain loaded = load_identify_chain(o);
  require_model_files(o, loaded.robot);
  std::vector<ChainRunFile> held_out;
  for (const auto& f : o.validate) held_out.push_back(load_chain_run(o, loaded, f));
  write_identify_outputs(o, identify_loaded(o, std::move(loaded), std::move(held_out)), app_name);
  return kExitOk;
}

void write_identify_outputs(const ChainIdentifyAppOptions& o, const ChainIdentifyResult& r,
                            const char* app_name) {
  (o.json == "-" ? std::cerr : std::cout) << r.text << std::flush;
  for (const auto& w : r.result.warnings) std::cerr << app_name << ": warning: " << w << "\n";
  if (!o.json.empty()) write_json(o.json, r.json);
  const auto refused = [](const InputError& e, const std::string& path) {
    return InputError(std::string(e.what()) + "; " + path + " is not written");
  };
  if (!o.report.empty()) write_text(o.report, identify_report_html(r));
  if (!o.write_urdf.empty()) {
    try {
      write_text(o.write_urdf, consistent_urdf(r, "--write-urdf", o.consistency()));
    } catch (const InputError& e) {
      throw refused(e, o.write_urdf);
    }
  }
  if (!o.write_mjcf.empty()) {
    Mjcf mjcf;
    try {
      mjcf = consistent_mjcf(r, "--write-mjcf", o.consistency(),
                             {fs_parent(o.robot), fs_parent(o.write_mjcf)});
    } catch (const InputError& e) {
      throw refused(e, o.write_mjcf);
    }
    write_text(o.write_mjcf, mjcf.text);
    if (!mjcf.left_out.empty())
      std::cerr << app_name << ": note: " << o.write_mjcf << " leaves out " << mjcf.left_out.size()
                << " part(s) of the description (listed in its first comment), e.g. "
                << mjcf.left_out.front() << "\n";
  }
}

}  // namespace sid::app
