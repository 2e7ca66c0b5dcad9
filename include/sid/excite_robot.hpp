#pragma once
/// @file
/// @brief An excitation for a robot's identification in one call: the model sid_identify --robot
/// fits, with the description's dynamics as the torques' source, a random start and its design
/// (sid::design_excitation), each judged by its condition number, its use of the limits and how
/// well it tells apart the diagnosis candidates asked for.
///
/// Needs NLopt, as sid/excitation_design.hpp does.

#include <sid/description_prior.hpp>
#include <sid/diagnose_chain.hpp>
#include <sid/excitation_design.hpp>
#include <sid/identify_chain.hpp>
#include <sid/model/chain_model.hpp>

#include <Eigen/Core>
#include <Eigen/QR>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <optional>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief A candidate of the chain diagnosis (sid::diagnose_chain) the excitation should tell
/// apart from the model's other parameters: a drive term, or an encoder's angle offset.
struct ExcitationCandidate {
  std::string id;             ///< its name in reports and errors (e.g. spring_j2)
  bool angle_offset = false;  ///< an angle offset of joint term.index (0-based)
  DriveTerm term;             ///< the drive term (for an angle offset only term.index counts)
};

/// @brief Thrown when no motion can tell a candidate apart: its column is a combination of the
/// others on every motion (what() names it).
struct InseparableCandidate : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/// @brief Settings of excite_robot().
struct RobotExcitationOptions {
  /// The design's settings; its angle_offsets are those of `separate` (what it holds is replaced).
  ExcitationDesignOptions design;
  std::vector<ExcitationCandidate> separate;  ///< candidates whose columns join the regressor
  std::uint64_t seed = 1;                     ///< of the random start (std::mt19937_64)
  bool random_only = false;                   ///< the random start only, no design
};

/// @brief A trajectory as the workflow judges it.
struct ExcitationAssessment {
  FourierTrajectory trajectory;
  double condition_number = 0.0;  ///< of the scaled conditioned regressor
  ExcitationUse use;              ///< of the limits, on a grid four times the design's
  /// Per candidate of RobotExcitationOptions::separate, in its order: 1 - R^2 of its column on
  /// all the others (the share diagnose_chain compares with 1 - separability_r2).
  Eigen::VectorXd separate_shares;
};

/// @brief What excite_robot() found.
struct RobotExcitation {
  explicit RobotExcitation(ChainModel with_candidates) : model(std::move(with_candidates)) {}

  ChainModel model;       ///< the nominal model with the candidates' drive terms it lacked
  Eigen::VectorXd theta;  ///< model's parameters from the description (the torques' source)
  std::vector<Eigen::Index> columns;  ///< the base columns the regressor is conditioned on
  std::vector<int> angle_offsets;     ///< the angle-offset candidates' joints, their columns last
  ExcitationAssessment random;        ///< the random start
  std::optional<ExcitationDesign> design;        ///< the optimizer's result (none with random_only)
  std::optional<ExcitationAssessment> designed;  ///< its trajectory judged as the random one
  double design_seconds = 0.0;  ///< from the random start to the design's end (wall clock)
  /// The share each candidate needs for sid::diagnose_chain to test it: 1 - its default
  /// separability_r2 (the diagnosis's nominal columns are fewer, so its share is at least ours).
  double separable_share = 0.0;
  /// The designed excitation, or the random one with random_only.
  const ExcitationAssessment& chosen() const { return designed ? *designed : random; }
};

namespace detail {

/// An angle offset no other column explains, over the torque, below this counts as absorbed on
/// every motion: its central differences are good to about 1e-8 of the torque; an offset the
/// link parameters absorb exactly leaves about that, one they do not 1e-2 and more (the UR5's
/// shoulder behind its light wrist: 0.03).
constexpr double kAbsorbedAngleOffset = 1e-6;

/// 1 - R^2 of each of the last `count` columns of w on all its other columns (the share of its
/// norm no other column explains), each column scaled to unit norm first.
inline Eigen::VectorXd unexplained_shares(const Eigen::MatrixXd& w, Eigen::Index count) {
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
/// the whole joint space (as chain_base_parameters decides what no motion tells apart). Against
/// the torque, not the column: at the description's parameters a column may be zero (the TX40's
/// last link is a point mass on its axis), and its rounding then has any direction.
inline Eigen::VectorXd angle_offset_unexplained(const ChainModel& model,
                                                const Eigen::VectorXd& theta,
                                                const std::vector<Eigen::Index>& columns,
                                                const std::vector<int>& joints) {
  if (joints.empty()) return {};
  constexpr int kSamples = 200;
  constexpr double kPi = 3.14159265358979323846;
  const int n = model.joints();
  std::mt19937 g(1);
  std::uniform_real_distribution<double> angle(-kPi, kPi), rate(-2.0, 2.0), acceleration(-10, 10);
  const auto m = static_cast<Eigen::Index>(joints.size());
  const auto base = static_cast<Eigen::Index>(columns.size());
  Eigen::MatrixXd w(kSamples * n, base + m);
  Eigen::MatrixXd y(n, model.parameters()), slopes;
  ChainModel::Vector q(n), qd(n), qdd(n);
  double torque = 0.0;
  for (int s = 0; s < kSamples; ++s) {
    for (int j = 0; j < n; ++j) {
      q[j] = angle(g);
      qd[j] = rate(g);
      qdd[j] = acceleration(g);
    }
    model.regressor(q, qd, qdd, y);
    torque += (y * theta).squaredNorm();
    w.block(s * n, 0, n, base) = y(Eigen::all, columns);
    angle_offset_columns(model, theta, joints, q, qd, qdd, y, slopes);
    w.block(s * n, base, n, m) = slopes;
  }
  const Eigen::ArrayXd column = w.rightCols(m).colwise().squaredNorm().transpose().array();
  return (unexplained_shares(w, m).array() * column / std::max(torque, 1e-300)).sqrt();
}

/// The nominal model's drive terms with each drive-term candidate's added where they lack it;
/// positions[i] is candidate i's place among them (-1 for an angle offset).
inline std::vector<DriveTerm> terms_with_candidates(
    const ChainModel& nominal, const std::vector<ExcitationCandidate>& separate,
    std::vector<std::ptrdiff_t>& positions) {
  std::vector<DriveTerm> terms = nominal.terms();
  positions.clear();
  for (const ExcitationCandidate& c : separate) {
    if (c.angle_offset) {
      positions.push_back(-1);
      continue;
    }
    auto at = std::find_if(terms.begin(), terms.end(),
                           [&](const DriveTerm& t) { return same_term(t, c.term); });
    if (at == terms.end()) at = terms.insert(terms.end(), c.term);
    positions.push_back(at - terms.begin());
  }
  return terms;
}

/// Each candidate's column in the conditioned regressor (the base columns, then the angle
/// offsets'), from its place among the model's terms; -1 for a drive term whose column is not a
/// base column.
inline std::vector<Eigen::Index> regressor_positions(
    const RobotExcitation& e, const std::vector<ExcitationCandidate>& separate,
    const std::vector<std::ptrdiff_t>& term_positions) {
  std::vector<Eigen::Index> out;
  auto offset = static_cast<Eigen::Index>(e.columns.size());
  for (std::size_t i = 0; i < separate.size(); ++i) {
    if (separate[i].angle_offset) {
      out.push_back(offset++);
      continue;
    }
    const auto at = std::find(e.columns.begin(), e.columns.end(),
                              e.model.rigid_body_parameters() + term_positions[i]);
    out.push_back(at == e.columns.end() ? -1 : at - e.columns.begin());
  }
  return out;
}

/// Refuses a candidate no excitation separates: a drive term whose column is not a base column,
/// an angle offset the link parameters absorb on every motion, alone or with the others given.
inline void check_separable(const RobotExcitation& e,
                            const std::vector<ExcitationCandidate>& separate,
                            const std::vector<Eigen::Index>& positions) {
  for (std::size_t i = 0; i < separate.size(); ++i)
    if (positions[i] < 0)
      throw InseparableCandidate(
          separate[i].id +
          " is a combination of the other parameters on every motion (e.g. a rotor about a "
          "vertical first axis is that link's inertia): no excitation separates it");
  const Eigen::VectorXd together =
      angle_offset_unexplained(e.model, e.theta, e.columns, e.angle_offsets);
  for (std::size_t i = 0, k = 0; i < separate.size(); ++i) {
    if (!separate[i].angle_offset) continue;
    const int joint = separate[i].term.index;
    if (!(angle_offset_unexplained(e.model, e.theta, e.columns, {joint})[0] > kAbsorbedAngleOffset))
      throw InseparableCandidate(
          separate[i].id +
          ": the link parameters absorb this encoder offset on every motion (turning the links "
          "beyond the joint about its axis changes no torque they cannot hold): no excitation "
          "separates it; its zero needs a kinematic calibration");
    if (!(together[static_cast<Eigen::Index>(k++)] > kAbsorbedAngleOffset))
      throw InseparableCandidate(
          separate[i].id +
          " and the other angle offsets given are a combination of each other and the link "
          "parameters on every motion (offsets of parallel axes turn the same links): no "
          "excitation separates them; give one of them");
  }
}

/// Each candidate's share given all the other columns of the conditioned regressor w: its column
/// moved last in turn.
inline Eigen::VectorXd candidate_shares(const Eigen::MatrixXd& w,
                                        const std::vector<Eigen::Index>& positions) {
  Eigen::MatrixXd reordered(w.rows(), w.cols());
  Eigen::VectorXd out(static_cast<Eigen::Index>(positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    const Eigen::Index c = positions[i];
    reordered << w.leftCols(c), w.rightCols(w.cols() - c - 1), w.col(c);
    out[static_cast<Eigen::Index>(i)] = unexplained_shares(reordered, 1)[0];
  }
  return out;
}

}  // namespace detail

/// @brief Designs an excitation for identifying `nominal` (the model sid_identify --robot fits:
/// its links, drive terms and transmission) from a random start, both within `limits` about
/// `q0`, the torques computed from `description`'s dynamics (sid::description_prior).
/// Drive-term candidates of `options.separate` join the model's terms where it lacks them; the
/// angle offsets' columns join the conditioned regressor.
/// @throws InseparableCandidate for a candidate no motion separates.
/// @throws std::invalid_argument when the description has no link parameters (a DH table), for
///         sizes that are not the model's, or as random_excitation and design_excitation do.
inline RobotExcitation excite_robot(const ChainModel& nominal,
                                    const DescriptionDynamics& description,
                                    const Eigen::Ref<const Eigen::VectorXd>& q0,
                                    const ExcitationLimits& limits,
                                    const RobotExcitationOptions& options) {
  if (description.link_parameters.size() == 0)
    throw std::invalid_argument(
        "sid::excite_robot: the description has no link inertias to compute torques with (a DH "
        "table); give a URDF's");
  std::vector<std::ptrdiff_t> term_positions;
  const std::vector<DriveTerm> terms =
      detail::terms_with_candidates(nominal, options.separate, term_positions);
  RobotExcitation e(ChainModel(nominal.chain(), nominal.joint_names(), terms,
                               nominal.transmission(), nominal.coulomb_epsilon()));
  e.theta = description_prior(e.model, description);
  e.columns = chain_base_parameters(e.model).independent;
  for (const ExcitationCandidate& c : options.separate)
    if (c.angle_offset) e.angle_offsets.push_back(c.term.index);
  const std::vector<Eigen::Index> positions =
      detail::regressor_positions(e, options.separate, term_positions);
  detail::check_separable(e, options.separate, positions);
  e.separable_share = 1.0 - ChainDiagnoseOptions().separability_r2;

  ExcitationDesignOptions design = options.design;
  design.angle_offsets = e.angle_offsets;
  const Eigen::VectorXd grid = excitation_grid(design.base_frequency, design.samples);
  const int check_samples = 4 * design.samples;  // between the design's grid points too
  const auto assess = [&](const FourierTrajectory& f) {
    const Eigen::MatrixXd w =
        excitation_regressor(e.model, e.columns, f, grid, e.theta, e.angle_offsets);
    ExcitationAssessment a{f,
                           scaled_condition_number(w),
                           excitation_use(e.model, e.theta, f, limits, check_samples),
                           {}};
    if (!options.separate.empty()) a.separate_shares = detail::candidate_shares(w, positions);
    return a;
  };
  const auto started = std::chrono::steady_clock::now();
  std::mt19937_64 rng(options.seed);
  e.random = assess(random_excitation(e.model, e.theta, q0, limits, design, rng));
  if (options.random_only) return e;
  e.design =
      design_excitation(e.model, e.theta, e.columns, q0, limits, e.random.trajectory, design);
  e.design_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  e.designed = assess(e.design->trajectory);
  return e;
}

}  // namespace sid
