#include "chain_diagnose_app.hpp"

#include <sid/chain_consistency.hpp>
#include <sid/cvode/chain_free_simulation.hpp>
#include <sid/diagnose_chain.hpp>

#include "app.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <iostream>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

/// " (vs = 0.1 rad/s)" for a Stribeck term: which of its widths was tried.
std::string width(const sid::DriveTerm& term) {
  return term.kind == sid::DriveTermKind::Stribeck
             ? " (vs = " + number("%.3g", term.velocity) + " rad/s)"
             : std::string();
}

/// Simulations of the torque noise alone per run, and their seed: the figure is a scale, and four
/// runs give it to about a quarter.
constexpr int kNoiseRuns = 4;
constexpr std::uint64_t kNoiseSeed = 20261205;
/// A joint whose final free-simulation error exceeds this many times the noise alone's moves in
/// a way the final model does not explain: the two-link check's threshold.
constexpr double kSimulationThreshold = 6.0;

/// The free simulations of the nominal and the final model (each at its physically consistent
/// fit), their angle error per joint over all runs.
struct FreeSimulations {
  std::string note;     ///< why there are none
  std::string failure;  ///< the first failed segment's message
  Eigen::VectorXd nominal, final;
  /// What white torque noise at the floor alone does to the final model's simulation, per joint.
  Eigen::VectorXd noise_alone;
  Eigen::Index segments = 0, failed_nominal = 0, failed_final = 0;
  double seconds = 0.0;
};

FreeSimulations free_simulations(const LoadedChain& loaded, const sid::ChainDiagnosis& r,
                                 const sid::ChainDiagnoseOptions& options,
                                 const std::vector<sid::ChainTrajectory<double>>& runs) {
  const auto start = std::chrono::steady_clock::now();
  FreeSimulations out;
  if (loaded.robot.link_parameters.size() == 0) {
    out.note = "no free simulation: a DH table has no link inertias";
    return out;
  }
  sid::ChainIdentifyOptions given = options.identify;
  given.cutoff_hz.assign(r.cutoff_hz.data(), r.cutoff_hz.data() + r.cutoff_hz.size());
  const sid::ChainModel& nominal = loaded.model;
  const sid::ChainModel final_model(nominal.chain(), nominal.joint_names(), r.final_terms,
                                    nominal.transmission(), nominal.coulomb_epsilon());
  const int n = nominal.joints();
  // The final model lives at the true angles: the measured ones plus the named offsets.
  const auto corrected = [&](Eigen::MatrixXd q) {
    q.rowwise() += r.angle_offset.transpose();
    return q;
  };
  std::vector<sid::ChainTrajectory<double>> corrected_runs = runs;
  for (auto& run : corrected_runs) run.q = corrected(run.q);
  // The noise-alone runs only set a scale: a looser tolerance (as the two-link check's).
  sid::ChainFreeSimulationOptions loose;
  loose.simulator.rtol = loose.simulator.atol = 1e-5;
  Eigen::VectorXd noise_squares = Eigen::VectorXd::Zero(n);
  double noise_samples = 0.0;
  for (const bool is_final : {false, true}) {
    const sid::ChainModel& model = is_final ? final_model : nominal;
    const sid::ChainIdentification id =
        sid::identify_chain(model, is_final ? corrected_runs : runs, given);
    if (!id.fit.ok()) {
      out.note = "no free simulation: " + id.fit.message;
      return out;
    }
    const sid::ChainConsistentFit fit =
        sid::consistent_chain_parameters(model, id, description_prior(loaded.robot, model));
    Eigen::VectorXd squares = Eigen::VectorXd::Zero(n), counts = Eigen::VectorXd::Zero(n);
    for (const auto& k : r.kinematics) {
      // Compared at up to 500 samples per second: enough for the motion, and CVODE stops at
      // every output time.
      const double period = (k.t[k.t.size() - 1] - k.t[0]) / static_cast<double>(k.t.size() - 1);
      const auto stride = static_cast<Eigen::Index>(std::max(1.0, std::round(0.002 / period)));
      const Eigen::Index rows = (k.t.size() + stride - 1) / stride;
      const auto every = Eigen::seqN(0, rows, stride);
      sid::ChainKinematics<double> sampled;
      sampled.t = k.t(every);
      sampled.q = k.q(every, Eigen::all);
      if (is_final) sampled.q = corrected(sampled.q);
      sampled.qd = k.qd(every, Eigen::all);
      sampled.qdd = k.qdd(every, Eigen::all);
      sampled.tau = k.tau(every, Eigen::all);
      const sid::ChainFreeSimulation sim = sid::free_chain_simulation(model, fit.theta, sampled);
      if (is_final) {
        const Eigen::VectorXd alone = sid::chain_noise_alone_error(
            model, fit.theta, sampled, r.noise_floor, kNoiseRuns, kNoiseSeed, loose);
        const auto samples = static_cast<double>(sampled.t.size());
        noise_squares += samples * alone.array().square().matrix();
        noise_samples += samples;
      }
      (is_final ? out.failed_final : out.failed_nominal) += sim.failed_segments;
      if (out.failure.empty() && !sim.ok())
        out.failure = std::string(is_final ? "final" : "nominal") + " model, " + sim.message;
      if (!is_final) out.segments += sim.segments;
      for (Eigen::Index i = 0; i < sim.error.rows(); ++i)
        for (int j = 0; j < n; ++j)
          if (std::isfinite(sim.error(i, j))) {
            squares[j] += sim.error(i, j) * sim.error(i, j);
            counts[j] += 1.0;
          }
    }
    (is_final ? out.final : out.nominal) = (squares.array() / counts.array().max(1.0)).sqrt();
  }
  out.noise_alone = (noise_squares / std::max(noise_samples, 1.0)).cwiseSqrt();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

/// The sid_excite call that designs a motion on which a named term and its look-alikes are told
/// apart.
std::string separating(const ChainDiagnoseAppOptions& o, const sid::ChainEffectTest& e) {
  std::string ids = e.id;
  if (!e.angle_offset && e.term.kind == sid::DriveTermKind::Stribeck)
    ids += ":" + number("%.3g", e.term.velocity);
  for (const std::string& other : e.look_alikes) ids += "," + other;
  const auto option = [](const char* name, const std::string& value) {
    return value.empty() ? std::string() : std::string(" ") + name + " " + value;
  };
  return "    a motion that separates them: sid_excite --robot " + o.chain.robot +
         option("--base", o.chain.base) + option("--tip", o.chain.tip) +
         option("--hold", o.chain.hold) + option("--transmission", o.chain.transmission) +
         " --separate " + ids + "\n";
}

std::string report_text(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                        const sid::ChainDiagnosis& r, const FreeSimulations& sim) {
  std::ostringstream out;
  out << "robot " << o.chain.robot << ": " << nominal.joints() << " joints; nominal model: rigid "
      << "bodies";
  for (const sid::DriveTerm& t : nominal.terms())
    if (!t.on_motor && t.index == 0) out << ", " << sid::drive_term_keyword(t.kind);
  out << " (" << r.equations << " equations)\nsmoothing cutoffs [Hz]:";
  for (Eigen::Index j = 0; j < r.cutoff_hz.size(); ++j)
    out << " " << number("%.3g", r.cutoff_hz[j]);
  out << "\n\nper joint [N m]: torque noise | residual nominal -> final | unexplained\n";
  for (int j = 0; j < nominal.joints(); ++j)
    out << "  " << nominal.joint_names()[static_cast<std::size_t>(j)] << ": "
        << number("%.4g", r.noise_floor[j]) << " | " << number("%.4g", r.nominal_residual_rms[j])
        << " -> " << number("%.4g", r.final_residual_rms[j]) << " | "
        << number("%.4g", r.unexplained_rms[j]) << "\n";
  out << "\nnamed (" << r.named.size() << "):\n";
  if (r.named.empty())
    out << "  nothing: no tried term passes the tests and is of practical size\n";
  for (const auto& e : r.named)
    out << "  " << e.id << " = " << number("%.5g", e.value) << " +- " << number("%.2g", e.std)
        << " " << e.unit << width(e.term) << "  (Wald " << number("%.3g", e.wald) << ", p (Holm) "
        << number("%.2g", e.p_value) << ", BIC drop " << number("%.3g", e.bic_drop) << ", CV drop "
        << number("%.2f", 100.0 * e.cv_drop) << " %, size "
        << number("%.0f", 100.0 * e.practical_size.maxCoeff()) << " % of the noise)\n"
        << (e.caveat.empty() ? "" : "    but: " + e.caveat + "\n" + separating(o, e));
  out << "\nnot named:\n";
  for (const auto& t : r.not_named)
    out << "  " << t.id << width(t.term) << ": " << t.reason << "\n";
  double unexplained = 0.0;
  for (Eigen::Index j = 0; j < r.unexplained_rms.size(); ++j)
    unexplained = std::max(unexplained, r.unexplained_rms[j] / r.noise_floor[j]);
  if (sim.nominal.size()) {
    out << "\nfree simulation (" << sim.segments
        << " segments of 1 s from the smoothed state, driven by the smoothed torque; each model "
           "at its physically consistent fit): angle error RMS nominal -> final [rad], and what "
           "white torque noise at the floor alone does to the final model\n";
    std::string beyond;
    for (int j = 0; j < nominal.joints(); ++j) {
      const std::string& name = nominal.joint_names()[static_cast<std::size_t>(j)];
      const double ratio = sim.final[j] / sim.noise_alone[j];
      out << "  " << name << ": " << number("%.3g", sim.nominal[j]) << " -> "
          << number("%.3g", sim.final[j]) << " (noise alone " << number("%.2g", sim.noise_alone[j])
          << ", " << number("%.2g", ratio) << "x)\n";
      if (ratio > kSimulationThreshold) beyond += (beyond.empty() ? "" : ", ") + name;
    }
    out << (beyond.empty()
                ? "  the final model follows the motion within " +
                      number("%.0f", kSimulationThreshold) + "x what the noise alone gives\n"
                : "  beyond " + number("%.0f", kSimulationThreshold) +
                      "x what the noise alone gives: " + beyond +
                      ": motion the final model does not explain\n");
    if (sim.failed_nominal + sim.failed_final > 0)
      out << "  segments that blew up or failed: nominal " << sim.failed_nominal << ", final "
          << sim.failed_final << " (first: " << sim.failure << ")\n";
  }
  if (!sim.note.empty()) out << "\n" << sim.note << "\n";
  out << "\n"
      << (unexplained > 0.5
              ? "what remains above the noise (unexplained, per joint above) is not a tried drive "
                "term: look at the rigid-body model, the kinematics or effects not in the library\n"
              : "what remains is at the noise\n")
      << "time " << number("%.2f", r.seconds) << " s (the free simulations "
      << number("%.2f", sim.seconds) << " s)\n";
  return out.str();
}

nlohmann::json test_json(const sid::ChainEffectTest& t) {
  nlohmann::json j = {{"id", t.id},           {"angle_offset", t.angle_offset},
                      {"value", t.value},     {"std", t.std},
                      {"unit", t.unit},       {"wald", t.wald},
                      {"p_value", t.p_value}, {"bic_drop", t.bic_drop},
                      {"cv_drop", t.cv_drop}, {"practical_size", to_json_array(t.practical_size)},
                      {"reason", t.reason},   {"caveat", t.caveat}};
  j["look_alikes"] = t.look_alikes;
  if (t.term.kind == sid::DriveTermKind::Stribeck) j["stribeck_velocity"] = t.term.velocity;
  return j;
}

nlohmann::json report_json(const ChainDiagnoseAppOptions& o, const sid::ChainModel& nominal,
                           const sid::ChainDiagnosis& r, const FreeSimulations& sim) {
  nlohmann::json j;
  j["robot"] = o.chain.robot;
  j["joint_names"] = nominal.joint_names();
  j["cutoff_hz"] = to_json_array(r.cutoff_hz);
  j["equations"] = r.equations;
  j["noise_floor"] = to_json_array(r.noise_floor);
  j["nominal_residual_rms"] = to_json_array(r.nominal_residual_rms);
  j["final_residual_rms"] = to_json_array(r.final_residual_rms);
  j["unexplained_rms"] = to_json_array(r.unexplained_rms);
  j["angle_offset"] = to_json_array(r.angle_offset);
  j["named"] = nlohmann::json::array();
  for (const auto& e : r.named) j["named"].push_back(test_json(e));
  j["not_named"] = nlohmann::json::array();
  for (const auto& t : r.not_named) j["not_named"].push_back(test_json(t));
  if (sim.nominal.size())
    j["free_simulation"] = {{"segments", sim.segments},
                            {"error_rms_nominal", to_json_array(sim.nominal)},
                            {"error_rms_final", to_json_array(sim.final)},
                            {"noise_alone_rms", to_json_array(sim.noise_alone)},
                            {"threshold", kSimulationThreshold},
                            {"failed_segments_nominal", sim.failed_nominal},
                            {"failed_segments_final", sim.failed_final}};
  else
    j["free_simulation"] = sim.note;
  j["seconds"] = r.seconds;
  return j;
}

}  // namespace

int diagnose_robot(const ChainDiagnoseAppOptions& o) {
  require(!o.chain.inputs.empty(), "no run given");
  if (!o.chain.json.empty()) ensure_writable(o.chain.json, o.chain.force);
  sid::ChainDiagnoseOptions options;
  if (!o.candidates.empty()) {
    // angle_offset is not a drive term: the rest of the list is.
    std::string kinds;
    std::stringstream in(o.candidates);
    options.angle_offsets = false;
    for (std::string word; std::getline(in, word, ',');) {
      if (word == "angle_offset") {
        require(!options.angle_offsets, "--candidates: angle_offset is given twice");
        options.angle_offsets = true;
      } else {
        kinds += (kinds.empty() ? "" : ",") + word;
      }
    }
    try {
      options.candidate_kinds =
          sid::parse_drive_term_kinds(kinds.empty() && options.angle_offsets ? "none" : kinds);
    } catch (const std::invalid_argument& e) {
      throw InputError(std::string("--candidates: ") + e.what() + " (or angle_offset)");
    }
  }
  if (o.negligible_size) {
    require(*o.negligible_size >= 0.0 && *o.negligible_size < 1.0,
            "--negligible-size must be in [0, 1)");
    options.negligible_size = *o.negligible_size;
  }
  // The options are checked before the files are read.
  const LoadedChain loaded =
      load_chain(o.chain, {sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature});
  options.identify = loaded.options;
  std::vector<sid::ChainTrajectory<double>> runs;
  for (const auto& r : loaded.runs) runs.push_back(r.data);
  sid::ChainDiagnosis result;
  try {
    result = sid::diagnose_chain(loaded.model, runs, options);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  const FreeSimulations sim = free_simulations(loaded, result, options, runs);
  (o.chain.json == "-" ? std::cerr : std::cout)
      << report_text(o, loaded.model, result, sim) << std::flush;
  if (!o.chain.json.empty()) write_json(o.chain.json, report_json(o, loaded.model, result, sim));
  return kExitOk;
}

}  // namespace sid::app
