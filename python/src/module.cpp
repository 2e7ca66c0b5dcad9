// sid._sid: the compiled half of the Python package. It holds no logic of its own: each call
// goes to the code the command-line tools run (src/), so that Python and the CLI give the same
// numbers and the same messages. The Python half (python/sid) shapes the API.
#include <sid/close_abscissae.hpp>
#include <sid/identify_chain.hpp>
#include <sid/smoothing_spline.hpp>

#include "app.hpp"
#include "chain_diagnose_app.hpp"
#include "chain_excite_app.hpp"
#include "chain_identify_app.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"
#include "external_app.hpp"
#include "identified_arm.hpp"
#include "identify_report_html.hpp"
#include "payload_app.hpp"
#include "montecarlo_report.hpp"
#include "paper_study.hpp"
#include "robot_description.hpp"
#include "windows_app.hpp"

#include <nanobind/eigen/dense.h>
#include <nanobind/nanobind.h>
#include <nanobind/stl/optional.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <cmath>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace nb = nanobind;
using namespace nb::literals;

namespace {

using sid::app::InputError;

/// A robot description with the options that read it, as sid_identify --robot takes them.
struct Robot {
  sid::app::ChainIdentifyAppOptions source;
  std::vector<std::string> joint_names;
  bool motor_side = false;
  bool urdf = false;
  sid::Transmission transmission{1};
};

Robot load_robot(const std::string& path, const std::string& base, const std::string& tip,
                 const std::string& transmission, const std::string& hold) {
  Robot r;
  r.source.robot = path;
  r.source.base = base;
  r.source.tip = tip;
  r.source.transmission = transmission;
  r.source.hold = hold;
  const sid::app::LoadedChain loaded = sid::app::load_chain(r.source, {});
  r.joint_names = loaded.robot.joint_names;
  r.motor_side = loaded.motor_side;
  r.urdf = !loaded.robot.urdf.empty();
  r.transmission = loaded.transmission;
  return r;
}

/// A log as given from Python: its label and samples.
struct RunData {
  std::string name;
  Eigen::VectorXd t;
  Eigen::MatrixXd q, tau;
};

sid::app::ChainRunFile chain_run(const RunData& r, const sid::app::LoadedChain& loaded) {
  const int n = loaded.robot.chain.joints();
  if (r.q.cols() != n || r.tau.cols() != n)
    throw InputError(r.name + ": q and tau need one column per joint of the robot (" +
                     std::to_string(n) + "), got " + std::to_string(r.q.cols()) + " and " +
                     std::to_string(r.tau.cols()));
  sid::ChainTrajectory<double> run{r.t, r.q, r.tau};
  try {
    run.validate(r.name.c_str());
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  return sid::app::identification_run(r.name, std::move(run), loaded.transmission,
                                      loaded.motor_side);
}

/// A motor-side run at the joints (the robot's transmission applied); a joint-side robot's run
/// as it is.
std::tuple<Eigen::VectorXd, Eigen::MatrixXd, Eigen::MatrixXd> joint_side(const Robot& robot,
                                                                         const RunData& data) {
  sid::ChainTrajectory<double> run{data.t, data.q, data.tau};
  try {
    run.validate(data.name.c_str());
    if (robot.motor_side) run = robot.transmission.joint_side(run);
  } catch (const std::invalid_argument& e) {
    throw InputError(e.what());
  }
  return {run.t, run.q, run.tau};
}

/// The options of identify(), named as sid_identify's.
struct IdentifyOptions {
  std::string estimator = "ls";
  std::string effects;
  bool no_default_effects = false;
  std::string cutoff;
  std::optional<double> skip, rest_fraction, coulomb_epsilon, validate_fraction;
  std::optional<int> consistency_folds;
  std::optional<double> torque_delay, estimate_torque_delay;
  std::string window;  ///< identify_windows only
};

/// An identification, as sid_identify --robot makes it.
class Fit {
 public:
  /// robot_path: the description's file (where its meshes are found).
  Fit(sid::app::ChainIdentifyResult result, std::string robot_path)
      : r_(std::move(result)), robot_path_(std::move(robot_path)) {}

  const sid::app::ChainIdentifyResult& result() const { return r_; }

  /// The MJCF text of the consistent model, mesh paths relative to mjcf_directory; what it
  /// leaves out is in the text's first comment.
  std::string consistent_mjcf(const std::string& mjcf_directory) const {
    return sid::app::consistent_mjcf(r_, "write_mjcf", {},
                                     {sid::app::fs_parent(robot_path_), mjcf_directory})
        .text;
  }

  /// The model's torque at each sample of a run, on its spline-smoothed motion at the fit's
  /// cutoffs (joint side).
  Eigen::MatrixXd predict(const RunData& data) const {
    return predict_joint_side(chain_run(data, r_.loaded).data, data.name);
  }

  /// Each fitted run at the joints (the first cut by validate_fraction): its label, times,
  /// measured torque and the model's.
  nb::list fitted_runs() const {
    nb::list out;
    for (const auto& run : r_.result.fitted_runs) {
      Eigen::MatrixXd model;
      {
        nb::gil_scoped_release release;
        model = predict_joint_side(run.data, run.name);
      }
      out.append(nb::make_tuple(run.name, Eigen::VectorXd(run.data.t),
                                Eigen::MatrixXd(run.data.tau), model));
    }
    return out;
  }

 private:
  Eigen::MatrixXd predict_joint_side(const sid::ChainTrajectory<double>& run,
                                     const std::string& name) const {
    try {
      return sid::chain_torque(r_.loaded.model, r_.result.identification, run, r_.loaded.options);
    } catch (const std::invalid_argument& e) {
      throw InputError(name + ": " + e.what());
    }
  }

  sid::app::ChainIdentifyResult r_;
  std::string robot_path_;
};

sid::app::ChainIdentifyAppOptions identify_app_options(const Robot& robot,
                                                       const IdentifyOptions& options) {
  sid::app::ChainIdentifyAppOptions o = robot.source;
  o.estimator = options.estimator;
  o.cutoff = options.cutoff;
  o.skip = options.skip;
  o.rest_fraction = options.rest_fraction;
  o.coulomb_epsilon = options.coulomb_epsilon;
  o.validate_fraction = options.validate_fraction;
  o.consistency_folds = options.consistency_folds;
  o.torque_delay = options.torque_delay;
  o.estimate_torque_delay = options.estimate_torque_delay;
  o.effects = options.effects;
  o.no_default_effects = options.no_default_effects;
  o.window = options.window;
  return o;
}

sid::app::LoadedChain loaded_runs(const sid::app::ChainIdentifyAppOptions& o,
                                  const std::vector<RunData>& runs) {
  sid::app::require(!runs.empty(), "no run given");
  sid::app::LoadedChain loaded = sid::app::load_identify_chain(o);
  for (const auto& r : runs) loaded.runs.push_back(chain_run(r, loaded));
  return loaded;
}

Fit identify(const Robot& robot, const std::vector<RunData>& runs,
             const std::vector<RunData>& validate, const IdentifyOptions& options) {
  const sid::app::ChainIdentifyAppOptions o = identify_app_options(robot, options);
  sid::app::LoadedChain loaded = loaded_runs(o, runs);
  std::vector<sid::app::ChainRunFile> held_out;
  for (const auto& r : validate) held_out.push_back(chain_run(r, loaded));
  return Fit(sid::app::identify_loaded(o, std::move(loaded), std::move(held_out)), o.robot);
}

/// Each window identified on its own, as sid_identify --robot --window: its report and JSON.
std::pair<std::string, std::string> identify_windows(const Robot& robot,
                                                     const std::vector<RunData>& runs,
                                                     const IdentifyOptions& options) {
  const sid::app::ChainIdentifyAppOptions o = identify_app_options(robot, options);
  const sid::app::WindowsResult r = sid::app::identify_windows_loaded(o, loaded_runs(o, runs));
  return {r.text, r.json.dump()};
}

/// The arm a fit holds (sid_identify --json's text), on the robot's chain and transmission.
sid::app::IdentifiedArm arm_of(const sid::app::LoadedChain& loaded, const std::string& json,
                               const std::string& source) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(json);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(source + " is not JSON (" + e.what() + ")");
  }
  return sid::app::identified_arm(j, source, loaded.robot, loaded.transmission);
}

nb::dict external_torque(const Robot& robot, const std::string& model_json,
                         const std::string& source, const RunData& data,
                         const sid::app::ExternalOptions& options) {
  sid::app::ExternalResult r;
  {
    nb::gil_scoped_release release;
    const sid::app::LoadedChain loaded = sid::app::load_chain(robot.source, {});
    const sid::app::IdentifiedArm arm = arm_of(loaded, model_json, source);
    r = sid::app::external_torque(arm, chain_run(data, loaded), options);
  }
  nb::dict d;
  d["t"] = r.torque.t;
  d["tau_ext"] = r.torque.external;
  d["contact"] = Eigen::VectorXi(r.torque.contact);
  d["thresholds"] = r.torque.thresholds;
  d["method"] = r.method;
  d["gain"] = r.torque.gain;
  d["report"] = r.text;
  d["json"] = r.json.dump();
  d["warnings"] = r.warnings;
  return d;
}

/// The load on the tip link from runs that carry it, the fit's arm held, in the frame of link
/// payload_frame (empty: the tip link) (sid_identify --payload-of --payload-frame).
nb::dict identify_payload(const Robot& robot, const std::string& model_json,
                          const std::string& source, const std::vector<RunData>& runs,
                          const std::string& payload_frame) {
  sid::app::PayloadResult r;
  {
    nb::gil_scoped_release release;
    sid::app::require(!runs.empty(), "no run given");
    const sid::app::LoadedChain loaded = sid::app::load_chain(robot.source, {});
    const sid::app::PayloadReportOptions options = sid::app::payload_report_options(
        loaded, robot.source.robot, payload_frame, "payload_frame");
    const sid::app::IdentifiedArm arm = arm_of(loaded, model_json, source);
    std::vector<sid::app::ChainRunFile> files;
    for (const auto& run : runs) files.push_back(chain_run(run, loaded));
    r = sid::app::identify_payload(arm, files, options);
  }
  nb::dict d;
  d["standard_parameters"] = Eigen::VectorXd(r.id.phi);
  d["report"] = r.text;
  d["json"] = r.json.dump();
  d["warnings"] = r.warnings;
  return d;
}

/// The robot's URDF with a load of ten standard parameters, in link frame's frame, fixed to its
/// tip.
std::string payload_urdf(const Robot& robot, const Eigen::VectorXd& phi, const std::string& frame) {
  sid::app::require(phi.size() == 10, "a load has ten standard parameters");
  const sid::app::LoadedChain loaded = sid::app::load_chain(robot.source, {});
  return sid::app::urdf_with_payload(loaded.robot, sid::LinkParameters<double>(phi), frame);
}

/// The options of diagnose(), named as sid_diagnose --robot's.
struct DiagnoseOptions {
  std::string drives, candidates, cutoff;
  std::optional<double> rest_fraction, negligible_size;
  bool measured = false;
};

sid::app::ChainDiagnoseResult diagnose(const Robot& robot, const std::vector<RunData>& runs,
                                       const DiagnoseOptions& options) {
  sid::app::ChainDiagnoseAppOptions o;
  o.chain = robot.source;
  o.chain.effects = options.drives;
  o.chain.cutoff = options.cutoff;
  o.chain.rest_fraction = options.rest_fraction;
  o.candidates = options.candidates;
  o.negligible_size = options.negligible_size;
  o.measured = options.measured;
  sid::app::require(!runs.empty(), "no run given");
  sid::app::LoadedChain loaded =
      sid::app::load_chain(o.chain, {sid::DriveTermKind::Viscous, sid::DriveTermKind::Armature});
  for (const auto& r : runs) loaded.runs.push_back(chain_run(r, loaded));
  return sid::app::diagnose_loaded(o, loaded);
}

nb::dict effect_test_dict(const sid::ChainEffectTest& t) {
  nb::dict d;
  d["id"] = t.id;
  d["value"] = t.value;
  d["std"] = t.std;
  d["unit"] = t.unit;
  d["p_value"] = t.p_value;
  d["detection_limit"] = t.detection_limit;
  d["reason"] = t.reason;
  d["caveat"] = t.caveat;
  d["look_alikes"] = t.look_alikes;
  return d;
}

/// The options of simulate(), named as sid_simulate --robot's.
struct SimulateOptions {
  double duration = 10.0, sample_time = 0.0025, sigma_q2 = 1e-6, sigma_tau2 = 1e-2;
  std::uint64_t seed = 1;
  std::vector<std::string> effects;
  int harmonics = 5;
  double base_frequency = 0.1, q_range = 1.0, qd_max = 1.5;
  double rtol = 1e-10, atol = 1e-10;  // sid_simulate's defaults
  std::string trajectory;
  std::string encoder_bits, encoder_ratio;  // as --encoder-bits, --encoder-ratio
  double torque_delay = 0.0;
};

nb::dict simulate(const Robot& robot, const SimulateOptions& options) {
  if (robot.motor_side)
    throw InputError("simulate gives joint-side logs: load the robot without a transmission");
  using sid::app::require;
  require(std::isfinite(options.sample_time) && options.sample_time > 0.0,
          "sample_time must be a finite number > 0 [s]");
  require(std::isfinite(options.duration) && options.duration > options.sample_time,
          "duration must be a finite number greater than sample_time [s]");
  require(options.duration / options.sample_time <= 1e8,
          "duration / sample_time is too many samples (at most 1e8)");
  require(std::isfinite(options.sigma_q2) && options.sigma_q2 >= 0.0,
          "sigma_q2 must be a finite variance >= 0 [rad^2]");
  require(std::isfinite(options.sigma_tau2) && options.sigma_tau2 >= 0.0,
          "sigma_tau2 must be a finite variance >= 0 [(N m)^2]");
  require(std::isfinite(options.rtol) && options.rtol > 0.0 && std::isfinite(options.atol) &&
              options.atol > 0.0,
          "rtol and atol must be finite numbers > 0");
  sid::app::ChainSimulateOptions o;
  o.robot = robot.source.robot;
  o.base = robot.source.base;
  o.tip = robot.source.tip;
  o.hold = robot.source.hold;
  o.duration = options.duration;
  o.sample_time = options.sample_time;
  o.sigma_q2 = options.sigma_q2;
  o.sigma_tau2 = options.sigma_tau2;
  o.seed = options.seed;
  o.effects = options.effects;
  o.harmonics = options.harmonics;
  o.base_frequency = options.base_frequency;
  o.q_range = options.q_range;
  o.qd_max = options.qd_max;
  o.trajectory = options.trajectory;
  o.rtol = options.rtol;
  o.atol = options.atol;
  o.encoder_bits = options.encoder_bits;
  o.encoder_ratio = options.encoder_ratio;
  o.torque_delay = options.torque_delay;
  const sid::app::SimulatedLog log = [&] {
    nb::gil_scoped_release release;
    return sid::app::simulate_robot_log(o);
  }();
  const sid::ChainKinematics<double>& k = log.simulated.truth;
  nb::dict d;
  d["t"] = Eigen::VectorXd(log.measured.t);
  d["q"] = Eigen::MatrixXd(log.measured.q);
  d["tau"] = Eigen::MatrixXd(log.measured.tau);
  d["q_true"] = Eigen::MatrixXd(k.q);
  d["qd_true"] = Eigen::MatrixXd(k.qd);
  d["qdd_true"] = Eigen::MatrixXd(k.qdd);
  d["tau_true"] = Eigen::MatrixXd(k.tau);
  d["theta"] = Eigen::VectorXd(log.simulated.theta);
  d["parameter_names"] = log.simulated.model.parameter_names();
  d["warnings"] = log.warnings;
  return d;
}

/// The options of excite(), named as sid_excite's.
struct ExciteOptions {
  int harmonics = 5;
  double base_frequency = 0.1, q_range = 1.0, qd_max = 1.5, qdd_max = 10.0;
  double torque_fraction = 0.8, rate = 20.0;
  int max_evaluations = 300;
  std::string algorithm = "slsqp", separate;
  std::uint64_t seed = 1;
  bool random_only = false;
};

sid::app::ChainExcitation excite(const Robot& robot, const ExciteOptions& options) {
  sid::app::ChainExciteOptions o;
  o.robot = robot.source.robot;
  o.base = robot.source.base;
  o.tip = robot.source.tip;
  o.hold = robot.source.hold;
  o.transmission = robot.source.transmission;
  o.harmonics = options.harmonics;
  o.base_frequency = options.base_frequency;
  o.q_range = options.q_range;
  o.qd_max = options.qd_max;
  o.qdd_max = options.qdd_max;
  o.torque_fraction = options.torque_fraction;
  o.rate = options.rate;
  o.max_evaluations = options.max_evaluations;
  o.algorithm = options.algorithm;
  o.separate = options.separate;
  o.seed = options.seed;
  o.random_only = options.random_only;
  return sid::app::design_robot_excitation(o, "sid_excite");
}

void write_excitation(const sid::app::ChainExcitation& e, const std::string& path, bool force) {
  sid::app::ensure_writable(path, force);
  sid::app::write_fourier_trajectory(path, e.trajectory, e.comments);
}

/// sid_montecarlo's study of the paper's arm: its JSON summary.
std::string montecarlo(const sid::app::PaperStudyOptions& options) {
  const sid::MonteCarloOptions study = sid::app::paper_study_options(options);
  const sid::Kinematics<double> truth = sid::app::paper_study_truth(study.theta);
  const sid::MonteCarloResult result = sid::run_monte_carlo(truth, study);
  return sid::app::montecarlo_json(result, study, truth.size()).dump();
}

/// sid_montecarlo --robot: the same study on a chain of a URDF; its JSON summary.
std::string chain_montecarlo(const Robot& robot, const sid::app::PaperStudyOptions& shared,
                             sid::app::ChainStudyOptions chain) {
  if (robot.motor_side)
    throw InputError("the study simulates joint-side runs: load the robot without a transmission");
  chain.robot = robot.source.robot;
  chain.base = robot.source.base;
  chain.tip = robot.source.tip;
  chain.hold = robot.source.hold;
  sid::ChainMonteCarloOptions options = sid::app::chain_study_options(shared, chain);
  const sid::app::ChainStudyTruth truth = sid::app::chain_study_truth(chain, options);
  const sid::ChainMonteCarloResult result = sid::run_chain_monte_carlo(
      truth.simulated.model, truth.simulated.theta, truth.simulated.truth, options);
  return sid::app::chain_montecarlo_json(result, options, truth.setup).dump();
}

/// A smoothing spline fitted to (x, y), callable as s(x, nu).
class Spline {
 public:
  explicit Spline(sid::ScatteredFit<double> fit) : fit_(std::move(fit)) {}
  Eigen::VectorXd operator()(const Eigen::VectorXd& x, int nu) const {
    if (nu < 0 || nu > 2)
      throw std::invalid_argument("nu must be 0, 1 or 2, not " + std::to_string(nu));
    return fit_.fit.spline.evaluate(x, nu);
  }
  const sid::SmoothingFit<double>& fit() const { return fit_.fit; }
  double merge_tolerance() const { return fit_.merge_tolerance; }

 private:
  sid::ScatteredFit<double> fit_;
};

Spline smooth(const Eigen::VectorXd& x, const Eigen::VectorXd& y, std::optional<double> lam,
              std::optional<Eigen::VectorXd> weights, const std::string& smoothing) {
  if (x.size() != y.size())
    throw std::invalid_argument(
        "x and y must have the same length (x: " + std::to_string(x.size()) +
        ", y: " + std::to_string(y.size()) + ")");
  Eigen::VectorXd dy = Eigen::VectorXd::Ones(x.size());
  if (weights) {
    if (weights->size() != x.size())
      throw std::invalid_argument("weights must have one entry per point (" +
                                  std::to_string(x.size()) + "), got " +
                                  std::to_string(weights->size()));
    for (Eigen::Index i = 0; i < weights->size(); ++i)
      if (!((*weights)[i] > 0.0) || !std::isfinite((*weights)[i]))
        throw std::invalid_argument("weights must be finite and > 0 (weights[" + std::to_string(i) +
                                    "] is not)");
    dy = weights->cwiseSqrt().cwiseInverse();
  }
  if (lam && (!(*lam >= 0.0) || !std::isfinite(*lam)))
    throw std::invalid_argument("lam must be finite and >= 0");
  if (!lam && smoothing != "gcv" && smoothing != "cv")
    throw std::invalid_argument("smoothing must be 'gcv' or 'cv' (or give lam), not '" + smoothing +
                                "'");
  for (Eigen::Index i = 0; i < x.size(); ++i)
    if (!std::isfinite(x[i]) || !std::isfinite(y[i]))
      throw std::invalid_argument("x[" + std::to_string(i) + "] or y[" + std::to_string(i) +
                                  "] is not finite");
  const auto criterion =
      smoothing == "cv" ? sid::SmoothingCriterion::Cv : sid::SmoothingCriterion::Gcv;
  return Spline(sid::fit_merging_close_abscissae<double>(
      x, y, dy,
      [&](const sid::SmoothingSpline<double>& s, const Eigen::VectorXd& ym,
          const Eigen::VectorXd& dym) {
        if (!lam) return s.fit_cross_validated(ym, dym, criterion);
        return *lam == 0.0 ? s.fit_penalized(ym, dym, std::numeric_limits<double>::infinity())
                           : s.fit_penalized(ym, dym, 1.0 / *lam);
      }));
}

/// A chain log from a CSV file, by sid_identify's column rules.
std::tuple<Eigen::VectorXd, Eigen::MatrixXd, Eigen::MatrixXd> read_chain_csv(
    const std::string& path, const std::string& columns, int joints) {
  const sid::app::CsvTable table = sid::app::read_csv(path);
  const sid::ChainTrajectory<double> run = sid::app::chain_trajectory_from_table(
      table, joints, sid::app::chain_columns(columns, joints, "columns"));
  return {run.t, run.q, run.tau};
}

std::vector<std::string> csv_column_names(const std::string& path) {
  return sid::app::read_csv(path).names;
}

nb::dict prediction_dict(const sid::ChainPrediction& p) {
  nb::dict d;
  d["name"] = p.source;
  d["residual_rms"] = p.residual_rms;
  d["residual_rms_measured"] = p.measured_residual_rms;
  d["relative_residual"] = p.relative_residual;
  d["relative_residual_measured"] = p.measured_relative_residual;
  return d;
}

}  // namespace

NB_MODULE(_sid, m) {
  m.doc() = "The compiled core of sid; use the sid package.";
  nb::register_exception_translator([](const std::exception_ptr& p, void*) {
    try {
      std::rethrow_exception(p);
    } catch (const InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const sid::SmoothingError& e) {
      PyErr_SetString(PyExc_RuntimeError, e.what());
    }
  });

  nb::class_<Robot>(m, "_Robot")
      .def_ro("joint_names", &Robot::joint_names)
      .def_ro("motor_side", &Robot::motor_side)
      .def_ro("urdf", &Robot::urdf)
      .def_prop_ro("path", [](const Robot& r) { return r.source.robot; });
  m.def("joint_side", &joint_side, "robot"_a, "run"_a, nb::call_guard<nb::gil_scoped_release>());
  m.def("load_robot", &load_robot, "path"_a, "base"_a, "tip"_a, "transmission"_a, "hold"_a,
        nb::call_guard<nb::gil_scoped_release>());

  nb::class_<RunData>(m, "_RunData")
      .def(nb::init<std::string, Eigen::VectorXd, Eigen::MatrixXd, Eigen::MatrixXd>(), "name"_a,
           "t"_a, "q"_a, "tau"_a);

  nb::class_<IdentifyOptions>(m, "_IdentifyOptions")
      .def(nb::init<>())
      .def_rw("estimator", &IdentifyOptions::estimator)
      .def_rw("effects", &IdentifyOptions::effects)
      .def_rw("no_default_effects", &IdentifyOptions::no_default_effects)
      .def_rw("cutoff", &IdentifyOptions::cutoff)
      .def_rw("skip", &IdentifyOptions::skip)
      .def_rw("rest_fraction", &IdentifyOptions::rest_fraction)
      .def_rw("coulomb_epsilon", &IdentifyOptions::coulomb_epsilon)
      .def_rw("validate_fraction", &IdentifyOptions::validate_fraction)
      .def_rw("consistency_folds", &IdentifyOptions::consistency_folds)
      .def_rw("torque_delay", &IdentifyOptions::torque_delay)
      .def_rw("estimate_torque_delay", &IdentifyOptions::estimate_torque_delay)
      .def_rw("window", &IdentifyOptions::window);

  nb::class_<Fit>(m, "_Fit")
      .def_prop_ro("parameter_names",
                   [](const Fit& f) { return f.result().result.identification.parameter_names; })
      .def_prop_ro(
          "theta",
          [](const Fit& f) { return Eigen::VectorXd(f.result().result.identification.fit.theta); })
      .def_prop_ro(
          "std_dev",
          [](const Fit& f) { return Eigen::VectorXd(f.result().result.identification.std_dev); })
      .def_prop_ro(
          "fitted",
          [](const Fit& f) { return prediction_dict(f.result().result.identification.fitted); })
      .def_prop_ro("validation",
                   [](const Fit& f) {
                     nb::list l;
                     for (const auto& v : f.result().result.validation)
                       l.append(prediction_dict(v));
                     return l;
                   })
      .def_prop_ro("report", [](const Fit& f) { return f.result().text; })
      .def_prop_ro("warnings", [](const Fit& f) { return f.result().result.warnings; })
      .def("json", [](const Fit& f) { return f.result().json.dump(); })
      .def("predict", &Fit::predict, "run"_a, nb::call_guard<nb::gil_scoped_release>())
      .def("fitted_runs", &Fit::fitted_runs)
      .def_prop_ro("joint_names", [](const Fit& f) { return f.result().loaded.robot.joint_names; })
      .def("consistent_urdf",
           [](const Fit& f) { return sid::app::consistent_urdf(f.result(), "write_urdf"); })
      .def("consistent_mjcf", &Fit::consistent_mjcf, "mjcf_directory"_a)
      .def(
          "report_html", [](const Fit& f) { return sid::app::identify_report_html(f.result()); },
          nb::call_guard<nb::gil_scoped_release>());
  m.def("identify", &identify, "robot"_a, "runs"_a, "validate"_a, "options"_a,
        nb::call_guard<nb::gil_scoped_release>());

  m.def("identify_windows", &identify_windows, "robot"_a, "runs"_a, "options"_a,
        nb::call_guard<nb::gil_scoped_release>());

  m.def("identify_payload", &identify_payload, "robot"_a, "model_json"_a, "source"_a, "runs"_a,
        "payload_frame"_a = "");
  m.def("payload_urdf", &payload_urdf, "robot"_a, "phi"_a, "frame"_a = "",
        nb::call_guard<nb::gil_scoped_release>());
  // sid_external's own options; the log and the outputs come from Python instead.
  using ExternalOptions = sid::app::ExternalOptions;
  nb::class_<ExternalOptions>(m, "_ExternalOptions")
      .def(nb::init<>())
      .def_rw("method", &ExternalOptions::method)
      .def_rw("cutoff", &ExternalOptions::cutoff)
      .def_rw("gain", &ExternalOptions::gain)
      .def_rw("threshold", &ExternalOptions::threshold_factor)
      .def_rw("min_duration", &ExternalOptions::min_duration)
      .def_rw("merge_gap", &ExternalOptions::merge_gap)
      .def_rw("skip", &ExternalOptions::skip);
  m.def("external_torque", &external_torque, "robot"_a, "model_json"_a, "source"_a, "run"_a,
        "options"_a);

  nb::class_<DiagnoseOptions>(m, "_DiagnoseOptions")
      .def(nb::init<>())
      .def_rw("drives", &DiagnoseOptions::drives)
      .def_rw("candidates", &DiagnoseOptions::candidates)
      .def_rw("cutoff", &DiagnoseOptions::cutoff)
      .def_rw("rest_fraction", &DiagnoseOptions::rest_fraction)
      .def_rw("negligible_size", &DiagnoseOptions::negligible_size)
      .def_rw("measured", &DiagnoseOptions::measured);
  using Diagnosis = sid::app::ChainDiagnoseResult;
  nb::class_<Diagnosis>(m, "_Diagnosis")
      .def_prop_ro("named",
                   [](const Diagnosis& d) {
                     nb::list l;
                     for (const auto& t : d.result.diagnosis.named) l.append(effect_test_dict(t));
                     return l;
                   })
      .def_prop_ro("not_named",
                   [](const Diagnosis& d) {
                     nb::list l;
                     for (const auto& t : d.result.diagnosis.not_named)
                       l.append(effect_test_dict(t));
                     return l;
                   })
      .def_prop_ro(
          "noise_floor",
          [](const Diagnosis& d) { return Eigen::VectorXd(d.result.diagnosis.noise_floor); })
      .def_prop_ro("nominal_residual_rms",
                   [](const Diagnosis& d) {
                     return Eigen::VectorXd(d.result.diagnosis.nominal_residual_rms);
                   })
      .def_prop_ro(
          "final_residual_rms",
          [](const Diagnosis& d) { return Eigen::VectorXd(d.result.diagnosis.final_residual_rms); })
      .def_prop_ro(
          "unexplained_rms",
          [](const Diagnosis& d) { return Eigen::VectorXd(d.result.diagnosis.unexplained_rms); })
      .def_prop_ro("cutoff_hz",
                   [](const Diagnosis& d) { return Eigen::VectorXd(d.result.diagnosis.cutoff_hz); })
      .def_prop_ro("smoothing", [](const Diagnosis& d) { return d.result.diagnosis.smoothing; })
      .def_prop_ro("beyond", [](const Diagnosis& d) { return d.result.motion.beyond; })
      .def_prop_ro("motion_note", [](const Diagnosis& d) { return d.result.motion_note; })
      .def_prop_ro("report", [](const Diagnosis& d) { return d.text; })
      .def("report_html", [](const Diagnosis& d) { return d.html; })
      .def("json", [](const Diagnosis& d) { return d.json.dump(); });
  m.def("diagnose", &diagnose, "robot"_a, "runs"_a, "options"_a,
        nb::call_guard<nb::gil_scoped_release>());

  nb::class_<SimulateOptions>(m, "_SimulateOptions")
      .def(nb::init<>())
      .def_rw("duration", &SimulateOptions::duration)
      .def_rw("sample_time", &SimulateOptions::sample_time)
      .def_rw("sigma_q2", &SimulateOptions::sigma_q2)
      .def_rw("sigma_tau2", &SimulateOptions::sigma_tau2)
      .def_rw("seed", &SimulateOptions::seed)
      .def_rw("effects", &SimulateOptions::effects)
      .def_rw("harmonics", &SimulateOptions::harmonics)
      .def_rw("base_frequency", &SimulateOptions::base_frequency)
      .def_rw("q_range", &SimulateOptions::q_range)
      .def_rw("qd_max", &SimulateOptions::qd_max)
      .def_rw("rtol", &SimulateOptions::rtol)
      .def_rw("atol", &SimulateOptions::atol)
      .def_rw("trajectory", &SimulateOptions::trajectory)
      .def_rw("encoder_bits", &SimulateOptions::encoder_bits)
      .def_rw("encoder_ratio", &SimulateOptions::encoder_ratio)
      .def_rw("torque_delay", &SimulateOptions::torque_delay);
  m.def("simulate", &simulate, "robot"_a, "options"_a);

  nb::class_<ExciteOptions>(m, "_ExciteOptions")
      .def(nb::init<>())
      .def_rw("harmonics", &ExciteOptions::harmonics)
      .def_rw("base_frequency", &ExciteOptions::base_frequency)
      .def_rw("q_range", &ExciteOptions::q_range)
      .def_rw("qd_max", &ExciteOptions::qd_max)
      .def_rw("qdd_max", &ExciteOptions::qdd_max)
      .def_rw("torque_fraction", &ExciteOptions::torque_fraction)
      .def_rw("rate", &ExciteOptions::rate)
      .def_rw("max_evaluations", &ExciteOptions::max_evaluations)
      .def_rw("algorithm", &ExciteOptions::algorithm)
      .def_rw("separate", &ExciteOptions::separate)
      .def_rw("seed", &ExciteOptions::seed)
      .def_rw("random_only", &ExciteOptions::random_only);
  using Excitation = sid::app::ChainExcitation;
  nb::class_<Excitation>(m, "_Excitation")
      .def_ro("condition_number", &Excitation::condition_number)
      .def_ro("random_condition_number", &Excitation::random_condition_number)
      .def_ro("report", &Excitation::report)
      .def_prop_ro("base_frequency",
                   [](const Excitation& e) { return e.trajectory.base_frequency; })
      .def_prop_ro("q0", [](const Excitation& e) { return Eigen::VectorXd(e.trajectory.q0); })
      .def_prop_ro("a", [](const Excitation& e) { return Eigen::MatrixXd(e.trajectory.a); })
      .def_prop_ro("b", [](const Excitation& e) { return Eigen::MatrixXd(e.trajectory.b); })
      .def("write", &write_excitation, "path"_a, "force"_a);
  m.def("excite", &excite, "robot"_a, "options"_a, nb::call_guard<nb::gil_scoped_release>());

  using PaperStudy = sid::app::PaperStudyOptions;
  nb::class_<PaperStudy>(m, "_PaperStudyOptions")
      .def(nb::init<>())
      .def_rw("runs", &PaperStudy::runs)
      .def_rw("levels", &PaperStudy::levels)
      .def_rw("sigma_tau2", &PaperStudy::sigma_tau2)
      .def_rw("methods", &PaperStudy::methods)
      .def_rw("seed", &PaperStudy::seed)
      .def_rw("threads", &PaperStudy::threads);
  m.def("montecarlo", &montecarlo, "options"_a, nb::call_guard<nb::gil_scoped_release>());
  using ChainStudy = sid::app::ChainStudyOptions;
  nb::class_<ChainStudy>(m, "_ChainStudyOptions")
      .def(nb::init<>())
      .def_rw("harmonics", &ChainStudy::harmonics)
      .def_rw("base_frequency", &ChainStudy::base_frequency)
      .def_rw("q_range", &ChainStudy::q_range)
      .def_rw("qd_max", &ChainStudy::qd_max)
      .def_rw("duration", &ChainStudy::duration)
      .def_rw("rate", &ChainStudy::rate)
      .def_rw("encoder_bits", &ChainStudy::encoder_bits)
      .def_rw("encoder_ratio", &ChainStudy::encoder_ratio)
      .def_rw("torque_delay", &ChainStudy::torque_delay)
      .def_rw("estimate_torque_delay", &ChainStudy::estimate_torque_delay);
  m.def("chain_montecarlo", &chain_montecarlo, "robot"_a, "options"_a, "chain"_a,
        nb::call_guard<nb::gil_scoped_release>());

  nb::class_<Spline>(m, "Spline")
      .def("__call__", &Spline::operator(), "x"_a, "nu"_a = 0,
           nb::call_guard<nb::gil_scoped_release>())
      .def_prop_ro("lam", [](const Spline& s) { return s.fit().lambda; })
      .def_prop_ro("p", [](const Spline& s) { return s.fit().p; })
      .def_prop_ro("trace", [](const Spline& s) { return s.fit().trace; })
      .def_prop_ro("sigma", [](const Spline& s) { return s.fit().sigma; })
      .def_prop_ro("knots", [](const Spline& s) { return s.fit().spline.knots(); })
      .def_prop_ro("merge_tolerance", &Spline::merge_tolerance);
  m.def("smooth", &smooth, "x"_a, "y"_a, "lam"_a = nb::none(), "weights"_a = nb::none(),
        "smoothing"_a = "gcv", nb::call_guard<nb::gil_scoped_release>());

  m.def("read_chain_csv", &read_chain_csv, "path"_a, "columns"_a, "joints"_a,
        nb::call_guard<nb::gil_scoped_release>());
  m.def("csv_column_names", &csv_column_names, "path"_a);
}
