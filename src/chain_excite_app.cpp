#include "chain_excite_app.hpp"

#include <sid/diagnose_chain.hpp>
#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>

#include "app.hpp"
#include "chain_identify_app.hpp"
#include "chain_simulate_app.hpp"
#include "csv.hpp"
#include "robot_description.hpp"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>

namespace sid::app {

namespace {

std::string number(const char* format, double v) { return format_number(format, v); }

/// A candidate of the chain diagnosis that --separate names: a drive term or an angle offset.
struct Separated {
  std::string id;
  bool angle_offset = false;
  sid::DriveTerm term;  ///< for an angle offset only term.index (the joint)
};

constexpr const char* kSeparateForm =
    "KIND_jN or KIND_mN (KIND coulomb, coulomb_asymmetry, offset, armature, spring, viscous or "
    "stribeck, stribeck_jN:VS for a width other than 0.1 rad/s) or angle_offset_qN, N from 1, "
    "as sid_diagnose --robot names them";

/// The 1-based number after `prefix` in `text` (digits only), or 0.
int number_after(const std::string& text, std::size_t prefix) {
  if (text.size() <= prefix || text.size() > prefix + 6) return 0;
  for (std::size_t i = prefix; i < text.size(); ++i)
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return 0;
  return std::stoi(text.substr(prefix));
}

std::vector<Separated> parse_separate(const std::string& text, int joints,
                                      const sid::Transmission& transmission) {
  std::vector<Separated> out;
  const std::vector<std::string> ids =
      parse_name_list(text, "--separate", "candidate id", "candidate ids", kSeparateForm);
  const std::vector<int> motors = transmission.coupled_motors();
  const sid::DriveTermKind kinds[] = {
      sid::DriveTermKind::Viscous,          sid::DriveTermKind::Coulomb,
      sid::DriveTermKind::CoulombAsymmetry, sid::DriveTermKind::Offset,
      sid::DriveTermKind::Armature,         sid::DriveTermKind::Spring,
      sid::DriveTermKind::Stribeck};
  for (const std::string& given : ids) {
    Separated c;
    const std::string bad = "--separate: '" + given + "' is not a candidate id: " + kSeparateForm;
    std::string id = given;
    double width = sid::DriveTerm{}.velocity;
    const std::size_t colon = given.find(':');
    if (colon != std::string::npos) {
      id = given.substr(0, colon);
      require(id.rfind("stribeck_", 0) == 0,
              "--separate: '" + given + "': only a Stribeck candidate takes a width (:VS)");
      const std::vector<double> v = parse_doubles(given.substr(colon + 1), "--separate " + id, 1);
      require(v[0] > 0.0, "--separate: '" + given + "': the width must be > 0 [rad/s]");
      width = v[0];
    }
    int number = 0;
    if (id.rfind("angle_offset_q", 0) == 0) {
      c.angle_offset = true;
      number = number_after(id, std::string("angle_offset_q").size());
      require(number >= 1, bad);
    } else {
      const std::size_t cut = id.find_last_of('_');
      require(cut != std::string::npos && cut + 1 < id.size(), bad);
      const std::string keyword = id.substr(0, cut);
      const char where = id[cut + 1];
      const auto kind = std::find_if(std::begin(kinds), std::end(kinds),
                                     [&](auto k) { return keyword == sid::drive_term_keyword(k); });
      number = number_after(id, cut + 2);
      require(kind != std::end(kinds) && (where == 'j' || where == 'm') && number >= 1, bad);
      c.term = {*kind, number - 1, where == 'm', width};
    }
    c.term.index = number - 1;
    c.id = colon == std::string::npos ? id : given;
    if (c.term.on_motor) {
      std::string list;
      for (const int m : motors) list += (list.empty() ? "" : ", ") + std::to_string(m + 1);
      require(std::find(motors.begin(), motors.end(), c.term.index) != motors.end(),
              "--separate: '" + given + "': motor " + std::to_string(number) +
                  " is not one the transmission couples to several joints (" +
                  (list.empty() ? "none is" : "coupled: " + list) + ")");
      require(
          c.term.kind != sid::DriveTermKind::Offset,
          "--separate: '" + given + "': a motor has no offset of its own (its joints' hold it)");
    } else {
      require(number <= joints,
              "--separate: '" + given + "': the chain has " + std::to_string(joints) + " joints");
    }
    for (const Separated& other : out)
      require(other.id != c.id, "--separate: '" + given + "' is given twice");
    out.push_back(c);
  }
  return out;
}

/// The torque per radian of an angle offset that no other column explains, over the torque,
/// below which the offset counts as absorbed on every motion: its central differences are good
/// to about 1e-8 of the torque; an offset the link parameters absorb exactly leaves about that,
/// one they do not 1e-2 and more (the UR5's shoulder behind its light wrist: 0.03).
constexpr double kAbsorbed = 1e-6;

/// 1 - R^2 of each of the last `count` columns of w on all its other columns (the share of
/// its norm no other column explains): sid::diagnose_chain calls a candidate whose share is
/// below 1 - ChainDiagnoseOptions::separability_r2 (0.005) not separable.
Eigen::VectorXd unexplained_shares(const Eigen::MatrixXd& w, Eigen::Index count) {
  const Eigen::MatrixXd scaled =
      w * w.colwise().norm().cwiseMax(1e-300).cwiseInverse().asDiagonal();
  Eigen::VectorXd out(count);
  for (Eigen::Index i = 0; i < count; ++i) {
    const Eigen::Index c = w.cols() - count + i;
    Eigen::MatrixXd others(scaled.rows(), scaled.cols() - 1);
    others << scaled.leftCols(c), scaled.rightCols(scaled.cols() - c - 1);
    const Eigen::VectorXd z = scaled.col(c);
    const Eigen::VectorXd fit = others * others.colPivHouseholderQr().solve(z);
    out[i] = (z - fit).squaredNorm() / std::max(z.squaredNorm(), 1e-300);
  }
  return out;
}

/// Per joint of `joints`: the RMS of the part of its angle-offset column [N m/rad] that the base
/// columns and the other offsets' do not explain, over the RMS torque [N m], on random states of
/// the whole joint space (as sid::chain_base_parameters decides what no motion tells apart).
/// Against the torque, not the column: at the description's parameters a column may be zero
/// (the TX40's last link is a point mass on its axis), and its rounding then has any direction.
Eigen::VectorXd angle_offset_unexplained(const sid::ChainModel& model, const Eigen::VectorXd& theta,
                                         const std::vector<Eigen::Index>& columns,
                                         const std::vector<int>& joints) {
  if (joints.empty()) return {};
  constexpr int kSamples = 200;
  constexpr double kPi = 3.14159265358979323846;
  const int n = model.joints();
  std::mt19937 g(1);
  std::uniform_real_distribution<double> angle(-kPi, kPi), rate(-2.0, 2.0), acceleration(-10, 10);
  const auto m = static_cast<Eigen::Index>(joints.size());
  Eigen::MatrixXd w(kSamples * n, static_cast<Eigen::Index>(columns.size()) + m);
  Eigen::MatrixXd y(n, model.parameters()), slopes;
  sid::ChainModel::Vector q(n), qd(n), qdd(n);
  double torque = 0.0;
  for (int s = 0; s < kSamples; ++s) {
    for (int j = 0; j < n; ++j) {
      q[j] = angle(g);
      qd[j] = rate(g);
      qdd[j] = acceleration(g);
    }
    model.regressor(q, qd, qdd, y);
    torque += (y * theta).squaredNorm();
    w.block(s * n, 0, n, static_cast<Eigen::Index>(columns.size())) = y(Eigen::all, columns);
    sid::detail::angle_offset_columns(model, theta, joints, q, qd, qdd, y, slopes);
    w.block(s * n, static_cast<Eigen::Index>(columns.size()), n, m) = slopes;
  }
  const Eigen::ArrayXd column = w.rightCols(m).colwise().squaredNorm().transpose().array();
  return (unexplained_shares(w, m).array() * column / std::max(torque, 1e-300)).sqrt();
}

std::string use_text(const sid::ExcitationUse& use) {
  return "largest share of the limits: q " + number("%.3f", use.q.maxCoeff()) + ", qd " +
         number("%.3f", use.qd.maxCoeff()) + ", qdd " + number("%.3f", use.qdd.maxCoeff()) +
         ", tau " + number("%.3f", use.tau.maxCoeff());
}

}  // namespace

void write_fourier_trajectory(const std::string& path, const sid::FourierTrajectory& f,
                              const std::vector<std::string>& comments) {
  const int n = f.joints(), h = f.harmonics();
  std::vector<std::string> names{"joint", "base_frequency", "q0"};
  std::vector<Eigen::VectorXd> columns{Eigen::VectorXd::LinSpaced(n, 1.0, n),
                                       Eigen::VectorXd::Constant(n, f.base_frequency), f.q0};
  for (const char* stem : {"a", "b"})
    for (int l = 1; l <= h; ++l) {
      names.push_back(stem + std::to_string(l));
      columns.push_back(std::string(stem) == "a" ? f.a.col(l - 1) : f.b.col(l - 1));
    }
  write_csv(path, names, columns, comments);
}

sid::FourierTrajectory read_fourier_trajectory(const std::string& path, int joints) {
  const CsvTable table = read_csv(path);
  require(table.rows() == joints, table.source +
                                      ": a Fourier trajectory file has one row per "
                                      "joint; the chain has " +
                                      std::to_string(joints) + ", the file " +
                                      std::to_string(table.rows()));
  int h = 0;
  while (table.has("a" + std::to_string(h + 1)) && table.has("b" + std::to_string(h + 1))) ++h;
  require(h >= 1, table.source +
                      ": no columns a1 and b1 (expected joint,base_frequency,q0,"
                      "a1..aH,b1..bH as sid_excite writes)");
  require(!table.has("a" + std::to_string(h + 1)) && !table.has("b" + std::to_string(h + 1)),
          table.source + ": the columns a" + std::to_string(h + 1) + " and b" +
              std::to_string(h + 1) + " do not both exist");
  const Eigen::VectorXd& joint = table.column("joint");
  const Eigen::VectorXd& frequency = table.column("base_frequency");
  for (Eigen::Index r = 0; r < table.rows(); ++r) {
    require(joint[r] == static_cast<double>(r + 1),
            table.where(r) + ": joint must be " + std::to_string(r + 1) + " (rows in joint order)");
    require(frequency[r] == frequency[0] && frequency[r] > 0.0,
            table.where(r) + ": base_frequency must be > 0 and the same on every row");
  }
  sid::FourierTrajectory f;
  f.base_frequency = frequency[0];
  f.q0 = table.column("q0");
  f.a.resize(joints, h);
  f.b.resize(joints, h);
  for (int l = 1; l <= h; ++l) {
    f.a.col(l - 1) = table.column("a" + std::to_string(l));
    f.b.col(l - 1) = table.column("b" + std::to_string(l));
  }
  try {
    f.validate("Fourier trajectory");
  } catch (const std::invalid_argument& e) {
    throw InputError(table.source + ": " + e.what());
  }
  return f;
}

ChainExcitation design_robot_excitation(const ChainExciteOptions& o, const char* app_name) {
  require(o.harmonics >= 2 && o.harmonics <= 50,
          "--harmonics must be 2..50 (the first harmonic is spent on starting at rest)");
  const auto positive = [](double v, const std::string& option, const std::string& unit) {
    require(std::isfinite(v) && v > 0.0,
            option + " must be a finite number > 0" + unit + ", got " + shortest_number(v));
  };
  positive(o.base_frequency, "--base-frequency", " [Hz]");
  positive(o.q_range, "--q-range", "");
  positive(o.qd_max, "--qd-max", "");
  positive(o.qdd_max, "--qdd-max", "");
  positive(o.rate, "--rate", " [Hz]");
  require(std::isfinite(o.torque_fraction) && o.torque_fraction > 0.0 && o.torque_fraction <= 1.0,
          "--torque-fraction must be in (0, 1], got " + shortest_number(o.torque_fraction));
  require(o.max_evaluations >= 1 && o.max_evaluations <= 100000,
          "--max-evaluations must be 1..100000");
  require(o.algorithm == "slsqp" || o.algorithm == "mma",
          "--algorithm must be slsqp or mma, got '" + o.algorithm + "'");
  const double samples = std::round(o.rate / o.base_frequency);
  require(samples >= 8.0 * o.harmonics && samples <= 1e5,
          "--rate / --base-frequency = " + shortest_number(samples) +
              " grid points per period; needs 8 x --harmonics (" + std::to_string(8 * o.harmonics) +
              ") to 100000");

  const RobotDescription robot =
      read_robot_description(o.robot, o.base, o.tip, parse_held_joints(o.hold, "--hold"));
  require(robot.link_parameters.size() > 0,
          o.robot + ": a DH table has no link inertias to compute torques with; give a URDF");
  const int n = robot.chain.joints();
  // The model sid_identify --robot fits to the arm's log (with the transmission's coupled motors);
  // torques from the description's links and <dynamics> damping and friction.
  const sid::Transmission transmission = o.transmission.empty()
                                             ? sid::Transmission(n)
                                             : read_transmission(o.transmission, robot.joint_names);
  std::vector<sid::DriveTerm> terms =
      sid::drive_terms(sid::default_drive_term_kinds(), transmission);
  const std::vector<Separated> separate =
      o.separate.empty() ? std::vector<Separated>{} : parse_separate(o.separate, n, transmission);
  // A drive-term candidate joins the model's terms where they lack it; its column then counts.
  std::vector<std::ptrdiff_t> separate_terms;  // positions in terms
  std::vector<int> angle_offsets;
  const auto same = [](const sid::DriveTerm& a, const sid::DriveTerm& b) {
    return a.kind == b.kind && a.index == b.index && a.on_motor == b.on_motor &&
           (a.kind != sid::DriveTermKind::Stribeck || a.velocity == b.velocity);
  };
  for (const Separated& c : separate) {
    if (c.angle_offset) {
      angle_offsets.push_back(c.term.index);
      continue;
    }
    auto at = std::find_if(terms.begin(), terms.end(),
                           [&](const sid::DriveTerm& t) { return same(t, c.term); });
    if (at == terms.end()) at = terms.insert(terms.end(), c.term);
    separate_terms.push_back(at - terms.begin());
  }
  const sid::ChainModel model(robot.chain, robot.joint_names, terms, transmission);
  const Eigen::VectorXd theta = description_prior(robot, model);
  const std::vector<Eigen::Index> columns = sid::chain_base_parameters(model).independent;
  // What no motion tells apart, no excitation can: say so rather than design for it.
  std::vector<Eigen::Index> separate_columns;
  for (const std::ptrdiff_t t : separate_terms)
    separate_columns.push_back(model.rigid_body_parameters() + t);
  for (std::size_t i = 0, k = 0; i < separate.size(); ++i) {
    if (separate[i].angle_offset) continue;
    const Eigen::Index column = separate_columns[k++];
    require(std::find(columns.begin(), columns.end(), column) != columns.end(),
            "--separate: " + separate[i].id +
                " is a combination of the other parameters on every motion (e.g. a rotor "
                "about a vertical first axis is that link's inertia): no excitation separates it");
  }
  const Eigen::VectorXd together = angle_offset_unexplained(model, theta, columns, angle_offsets);
  for (std::size_t i = 0, k = 0; i < separate.size(); ++i) {
    if (!separate[i].angle_offset) continue;
    const int joint = separate[i].term.index;
    require(angle_offset_unexplained(model, theta, columns, {joint})[0] > kAbsorbed,
            "--separate: " + separate[i].id +
                ": the link parameters absorb this encoder offset on every motion (turning the "
                "links beyond the joint about its axis changes no torque they cannot hold): no "
                "excitation separates it; its zero needs a kinematic calibration");
    require(together[static_cast<Eigen::Index>(k++)] > kAbsorbed,
            "--separate: " + separate[i].id +
                " and the other angle offsets given are a combination of each other and the link "
                "parameters on every motion (offsets of parallel axes turn the same links): no "
                "excitation separates them; give one of them");
  }

  const ExcitationRoom room = excitation_room(robot, o.robot, o.q_range, o.qd_max);
  sid::ExcitationLimits limits{
      room.q_range, room.qd_max, Eigen::VectorXd::Constant(n, o.qdd_max),
      Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity())};
  for (int j = 0; j < n && j < static_cast<int>(robot.limits.size()); ++j) {
    const double effort = robot.limits[static_cast<std::size_t>(j)].effort;
    if (std::isfinite(effort) && effort > 0.0) limits.tau_max[j] = o.torque_fraction * effort;
  }
  sid::ExcitationDesignOptions options;
  options.harmonics = o.harmonics;
  options.base_frequency = o.base_frequency;
  options.samples = static_cast<int>(samples);
  options.max_evaluations = o.max_evaluations;
  options.algorithm =
      o.algorithm == "mma" ? sid::ExcitationAlgorithm::Mma : sid::ExcitationAlgorithm::Slsqp;
  options.angle_offsets = angle_offsets;
  // The conditioned regressor: the base columns, then the angle offsets'. The candidates'
  // shares are reported in --separate's order.
  const Eigen::VectorXd grid = sid::excitation_grid(o.base_frequency, options.samples);
  const auto regressor = [&](const sid::FourierTrajectory& f) {
    return sid::excitation_regressor(model, columns, f, grid, theta, angle_offsets);
  };
  const auto shares = [&](const sid::FourierTrajectory& f) {
    const Eigen::MatrixXd w = regressor(f);
    Eigen::MatrixXd reordered(w.rows(), w.cols());
    // Each candidate's column moved last in turn: its share given all the others.
    Eigen::VectorXd out(static_cast<Eigen::Index>(separate.size()));
    for (std::size_t i = 0, drive = 0, offset = 0; i < separate.size(); ++i) {
      const Eigen::Index c =
          separate[i].angle_offset
              ? static_cast<Eigen::Index>(columns.size() + offset++)
              : static_cast<Eigen::Index>(
                    std::find(columns.begin(), columns.end(), separate_columns[drive++]) -
                    columns.begin());
      reordered << w.leftCols(c), w.rightCols(w.cols() - c - 1), w.col(c);
      out[static_cast<Eigen::Index>(i)] = unexplained_shares(reordered, 1)[0];
    }
    return out;
  };
  const auto shares_text = [&](const Eigen::VectorXd& v) {
    std::string text;
    for (std::size_t i = 0; i < separate.size(); ++i)
      text += (text.empty() ? "" : ", ") + separate[i].id + " " +
              number("%.3g", v[static_cast<Eigen::Index>(i)]);
    return text;
  };
  const int check_samples = 4 * options.samples;  // between the design's grid points too

  const auto started = std::chrono::steady_clock::now();
  std::mt19937_64 rng(o.seed);
  sid::FourierTrajectory random;
  try {
    random = sid::random_excitation(model, theta, room.q0, limits, options, rng);
  } catch (const std::invalid_argument& e) {
    throw InputError(o.robot + ": " + e.what());
  }
  const double random_cond = sid::scaled_condition_number(regressor(random));
  std::ostringstream out;
  out << "robot " << o.robot << ": " << n << " joints, " << columns.size() << " base parameters of "
      << model.parameters()
      << (angle_offsets.empty()
              ? std::string()
              : " and " + std::to_string(angle_offsets.size()) + " angle-offset column" +
                    (angle_offsets.size() > 1 ? "s" : ""))
      << "; " << o.harmonics << " harmonics of " << shortest_number(o.base_frequency) << " Hz, "
      << options.samples << " grid points per period\n"
      << "random excitation (seed " << o.seed << "): condition number "
      << number("%.4g", random_cond) << "; "
      << use_text(sid::excitation_use(model, theta, random, limits, check_samples)) << "\n";
  const Eigen::VectorXd random_shares = separate.empty() ? Eigen::VectorXd() : shares(random);
  if (!separate.empty())
    out << "  1 - R^2 of each --separate column given all the others: "
        << shares_text(random_shares) << "\n";
  ChainExcitation result;
  result.trajectory = random;
  result.random_condition_number = result.condition_number = random_cond;
  std::string comment = "the random excitation from seed " + std::to_string(o.seed) +
                        ", condition number " + number("%.6g", random_cond);
  if (!o.random_only) {
    sid::ExcitationDesign design;
    try {
      design = sid::design_excitation(model, theta, columns, room.q0, limits, random, options);
    } catch (const std::invalid_argument& e) {
      throw InputError(o.robot + ": " + e.what());
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const double cond = sid::scaled_condition_number(regressor(design.trajectory));
    result.trajectory = design.trajectory;
    result.condition_number = cond;
    out << "designed excitation: condition number " << number("%.4g", cond) << " ("
        << number("%.3g", random_cond / cond) << " times smaller); exp(objective) "
        << number("%.4g", std::exp(design.objective)) << " (random "
        << number("%.4g", std::exp(design.start_objective)) << "); "
        << use_text(sid::excitation_use(model, theta, design.trajectory, limits, check_samples))
        << "\n"
        << "  " << design.evaluations << " evaluations (" << o.algorithm << ", "
        << design.stop_reason << ") in " << number("%.3g", seconds) << " s\n";
    if (!separate.empty()) {
      const Eigen::VectorXd designed = shares(design.trajectory);
      out << "  1 - R^2 of each --separate column given all the others: " << shares_text(designed)
          << "\n";
      // sid_diagnose --robot calls a candidate not separable below this share given its nominal
      // model's columns; those are fewer than these, so there the share is at least this one.
      const double kSeparable = 1.0 - sid::ChainDiagnoseOptions().separability_r2;
      std::string weak;
      for (std::size_t i = 0; i < separate.size(); ++i)
        if (designed[static_cast<Eigen::Index>(i)] < kSeparable)
          weak += (weak.empty() ? "" : ", ") + separate[i].id;
      out << (weak.empty() ? "  each above " + number("%.3g", kSeparable) +
                                 ": sid_diagnose --robot can test them on a run of this "
                                 "excitation"
                           : "  still below " + number("%.3g", kSeparable) + " (" + weak +
                                 "): on a run of this excitation sid_diagnose --robot will "
                                 "likely call them not separable; give the motion more room "
                                 "(a wider --q-range, --qd-max, more --harmonics)")
          << "\n";
    }
    comment = "designed from the random excitation of seed " + std::to_string(o.seed) +
              ": condition number " + number("%.6g", cond) + " (random " +
              number("%.6g", random_cond) + ")";
    if (!separate.empty()) comment += "; separating " + o.separate;
  }
  std::string joint_list;
  for (const auto& name : robot.joint_names) joint_list += (joint_list.empty() ? "" : ",") + name;
  result.comments = {
      std::string(app_name) + " --robot " + o.robot + ": " + std::to_string(n) + " joints (" +
          joint_list + ")" +
          (o.transmission.empty() ? "" : ", the coupled motors of " + o.transmission),
      "q_j(t) = q0_j + sum_l a_jl / (l w) sin(l w t) - b_jl / (l w) cos(l w t), w = 2 pi f; "
      "at rest at t = k / f",
      comment,
      "limits: |q - q0| <= min(" + shortest_number(o.q_range) + ", 90 % of <limit>), |qd| <= min(" +
          shortest_number(o.qd_max) + ", 90 % of <limit>), |qdd| <= " + shortest_number(o.qdd_max) +
          ", |tau| <= " + shortest_number(o.torque_fraction) + " <limit effort>"};
  result.report = out.str();
  return result;
}

int excite_robot(const ChainExciteOptions& o, const char* app_name) {
  if (!o.output.empty()) ensure_writable(o.output, o.force);
  const ChainExcitation e = design_robot_excitation(o, app_name);
  // The report goes where the coefficients do not.
  (o.output == "-" ? std::cerr : std::cout) << e.report << std::flush;
  if (!o.output.empty()) {
    write_fourier_trajectory(o.output, e.trajectory, e.comments);
    if (o.output != "-") std::cerr << app_name << ": coefficients written to " << o.output << "\n";
  }
  return kExitOk;
}

}  // namespace sid::app
