#pragma once
/// @file
/// @brief sid::ChainModel: the identification model of a serial chain, its links' rigid-body
/// parameters plus the terms real drives add on each joint (viscous and Coulomb friction, a
/// torque offset, the rotor's inertia) and on each motor a transmission couples to several
/// joints.
///
/// tau = Y(q, qd, qdd) theta with theta = [link parameters (ten per link, in
/// chain_parameter_names order), drive terms (in the order given)]. Every term is linear in its
/// parameter; a joint term writes only its own joint's row. The model is a sid::Model of the
/// chain's joint count, so the mass matrix and forward dynamics come with it.

#include <sid/config.hpp>
#include <sid/model/articulated_body.hpp>
#include <sid/model/chain_regressor.hpp>
#include <sid/model/model.hpp>
#include <sid/model/serial_chain.hpp>
#include <sid/model/transmission.hpp>

#include <Eigen/Core>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sid {

/// @brief What a drive adds to the torque of the joint (or motor combination) it acts on, with x
/// its angle, v its rate and a its acceleration.
enum class DriveTermKind {
  Viscous,           ///< fv v
  Coulomb,           ///< fc c(v), c = tanh(v / epsilon) (sign(v) when epsilon = 0)
  CoulombAsymmetry,  ///< fa |c(v)|: a Coulomb level that differs between the two directions
  Offset,            ///< a constant torque (the drive's current offset)
  Armature,          ///< Ia a: the rotor's inertia seen through the gear
  Spring,            ///< k x, x its angle: a spring or a cable that pulls back to zero
  /// fs exp(-(v / vs)^2) c(v): friction above the Coulomb level at low speed (the Stribeck
  /// curve's excess, vs = DriveTerm::velocity); with a Coulomb term fc it makes
  /// (fc + fs exp(-(v / vs)^2)) c(v).
  Stribeck,
};

/// @brief One drive term; on_motor: it acts on motor `index`'s combination of joint rates
/// (Transmission::motor_direction) instead of on joint `index` alone.
struct DriveTerm {
  DriveTermKind kind = DriveTermKind::Viscous;
  int index = 0;
  bool on_motor = false;
  double velocity = 0.1;  ///< vs of a Stribeck term [rad/s or m/s], > 0; unused by the others
};

/// @brief The same kind on the same joint or motor (Stribeck terms of any widths).
inline bool same_place(const DriveTerm& a, const DriveTerm& b) noexcept {
  return a.kind == b.kind && a.index == b.index && a.on_motor == b.on_motor;
}

/// @brief The same term: the same place and, for a Stribeck term, the same width.
inline bool same_term(const DriveTerm& a, const DriveTerm& b) noexcept {
  return same_place(a, b) && (a.kind != DriveTermKind::Stribeck || a.velocity == b.velocity);
}

/// @brief The keyword of a kind, as --effects takes it.
inline const char* drive_term_keyword(DriveTermKind kind) {
  switch (kind) {
    case DriveTermKind::Viscous:
      return "viscous";
    case DriveTermKind::Coulomb:
      return "coulomb";
    case DriveTermKind::CoulombAsymmetry:
      return "coulomb_asymmetry";
    case DriveTermKind::Offset:
      return "offset";
    case DriveTermKind::Armature:
      return "armature";
    case DriveTermKind::Spring:
      return "spring";
    case DriveTermKind::Stribeck:
      return "stribeck";
  }
  return "?";
}

/// @brief Parses a comma-separated list of kinds ("viscous,coulomb,offset,armature"); "none"
/// gives the empty list. A Stribeck term made from the list has the default width
/// (DriveTerm::velocity).
/// @throws std::invalid_argument naming an unknown or repeated keyword.
inline std::vector<DriveTermKind> parse_drive_term_kinds(const std::string& text) {
  std::vector<DriveTermKind> kinds;
  if (text == "none") return kinds;
  std::stringstream in(text);
  std::string word;
  const DriveTermKind all[] = {DriveTermKind::Viscous,          DriveTermKind::Coulomb,
                               DriveTermKind::CoulombAsymmetry, DriveTermKind::Offset,
                               DriveTermKind::Armature,         DriveTermKind::Spring,
                               DriveTermKind::Stribeck};
  while (std::getline(in, word, ',')) {
    const auto found = std::find_if(std::begin(all), std::end(all),
                                    [&](DriveTermKind k) { return word == drive_term_keyword(k); });
    if (found == std::end(all))
      throw std::invalid_argument(
          "unknown drive term '" + word +
          "'; known: viscous, coulomb, coulomb_asymmetry, offset, armature, spring, stribeck, "
          "or none");
    if (std::find(kinds.begin(), kinds.end(), *found) != kinds.end())
      throw std::invalid_argument("drive term '" + word + "' is given twice");
    kinds.push_back(*found);
  }
  if (kinds.empty()) throw std::invalid_argument("no drive term given (write none for none)");
  return kinds;
}

/// @brief The terms a real chain's drives have: every kind on every joint, and friction and
/// inertia on every motor the transmission couples to several joints (an offset there would
/// repeat the joints' own).
inline std::vector<DriveTerm> drive_terms(const std::vector<DriveTermKind>& kinds,
                                          const Transmission& transmission) {
  std::vector<DriveTerm> terms;
  for (int j = 0; j < transmission.joints(); ++j)
    for (const DriveTermKind kind : kinds) terms.push_back({kind, j, false});
  for (const int motor : transmission.coupled_motors())
    for (const DriveTermKind kind : kinds)
      if (kind != DriveTermKind::Offset) terms.push_back({kind, motor, true});
  return terms;
}

/// @brief The default model of a real drive: viscous and Coulomb friction, offset, armature.
inline std::vector<DriveTermKind> default_drive_term_kinds() {
  return {DriveTermKind::Viscous, DriveTermKind::Coulomb, DriveTermKind::Offset,
          DriveTermKind::Armature};
}

/// @brief The value of a drive term's regressor column (the torque per unit of its parameter)
/// at angle x, rate v and acceleration a of what it acts on; epsilon: the Coulomb terms' tanh
/// velocity (0: sign).
inline double drive_term_value(const DriveTerm& t, double epsilon, double x, double v,
                               double a) noexcept {
  const auto coulomb = [&] {
    return epsilon > 0.0 ? std::tanh(v / epsilon) : double((v > 0.0) - (v < 0.0));
  };
  switch (t.kind) {
    case DriveTermKind::Viscous:
      return v;
    case DriveTermKind::Coulomb:
      return coulomb();
    case DriveTermKind::CoulombAsymmetry:
      return std::abs(coulomb());
    case DriveTermKind::Offset:
      return 1.0;
    case DriveTermKind::Armature:
      return a;
    case DriveTermKind::Spring:
      return x;
    case DriveTermKind::Stribeck: {
      const double r = v / t.velocity;
      return std::exp(-r * r) * coulomb();
    }
  }
  return 0.0;
}

/// @brief A chain, its drives and the names of its joints, as one sid::Model: a rigid-body term
/// (the links' ten parameters each, by the chain's Newton-Euler regressor) and one term per
/// drive term. Immutable; holds no parameter values.
/// Class invariant: joint_names, the transmission and the chain agree on the joint count; every
/// term's index is a joint (or motor); coulomb_epsilon >= 0.
class ChainModel {
 public:
  using Vector = JointVector<double, Eigen::Dynamic>;

  /// @param joint_names one per joint, for reports; empty: "1".."n".
  /// @param coulomb_epsilon the Coulomb terms' tanh velocity [rad/s, or m/s]; 0 takes sign(v).
  /// @throws std::invalid_argument if the sizes disagree, an index is out of range or the same
  ///         term is given twice (Stribeck terms of different widths are different terms).
  SID_INLINE ChainModel(SerialChain<double> chain, std::vector<std::string> joint_names,
                        std::vector<DriveTerm> terms, Transmission transmission,
                        double coulomb_epsilon = 0.01);

  int joints() const noexcept { return chain_.joints(); }
  Eigen::Index parameters() const noexcept { return model_.num_parameters(); }
  Eigen::Index rigid_body_parameters() const noexcept { return kLinkParameters * joints(); }
  const SerialChain<double>& chain() const noexcept { return chain_; }
  const std::vector<std::string>& joint_names() const noexcept { return joint_names_; }
  const std::vector<DriveTerm>& terms() const noexcept { return terms_; }
  const Transmission& transmission() const noexcept { return transmission_; }
  double coulomb_epsilon() const noexcept { return epsilon_; }
  /// @brief m_1, mx_1, ..., Izz_n, then per term fv_j, fc_j, fa_j, off_j, Ia_j, k_j, fs_j (motors:
  /// fv_mj ...).
  const std::vector<std::string>& parameter_names() const noexcept { return names_; }
  /// @brief The model itself: its terms, inverse and forward dynamics, mass matrix.
  const Model<double, Eigen::Dynamic>& model() const noexcept { return model_; }

  /// @brief Y(q, qd, qdd) into out (joints() x parameters()); allocates nothing.
  /// @throws std::invalid_argument if a size does not match.
  template <typename Q, typename Out>
  void regressor(const Eigen::MatrixBase<Q>& q, const Eigen::MatrixBase<Q>& qd,
                 const Eigen::MatrixBase<Q>& qdd, Eigen::MatrixBase<Out>& out) const {
    if (q.size() != joints() || qd.size() != joints() || qdd.size() != joints() ||
        out.rows() != joints() || out.cols() != parameters())
      throw std::invalid_argument("sid::ChainModel::regressor: sizes do not match the model's " +
                                  std::to_string(joints()) + " joints and " +
                                  std::to_string(parameters()) + " parameters");
    const Vector qv = q, qdv = qd, qddv = qdd;  // a row or a column of samples
    model_.regressor(qv, qdv, qddv, RegressorView<double, Eigen::Dynamic>(out.derived()));
  }

  /// @brief qdd [rad/s^2 or m/s^2] under applied torques tau [N m or N] in O(n): the
  /// articulated-body algorithm with each joint's rotor inertia, the other drive terms' torques
  /// (friction, offsets) opposing tau, and each coupled motor's rotor inertia (a rank-one term
  /// I_m d d^T of the mass matrix, d the motor's direction) by the Sherman-Morrison-Woodbury
  /// identity, one more pass per such motor. The same accelerations as model().forward_dynamics
  /// (the O(n^3) route). Allocates nothing.
  /// @return NaN where theta is not a physical arm at q.
  /// @throws std::invalid_argument if a size does not match the model.
  SID_INLINE Vector forward_dynamics(const Eigen::Ref<const Eigen::VectorXd>& theta,
                                     const Vector& q, const Vector& qd, const Vector& tau) const;

 private:
  using ModelTerm = Term<double, Eigen::Dynamic>;

  SID_INLINE ModelTerm rigid_body_term() const;
  SID_INLINE ModelTerm drive_term(const DriveTerm& t) const;

  static std::string term_place(const DriveTerm& t) {
    return (t.on_motor ? "motor " : "joint ") + std::to_string(t.index + 1);
  }

  /// fv_3, fc_m6, ...; a Stribeck term that shares its joint with one of another width has its
  /// width too (fs_3@0.1), so that every parameter has a name of its own.
  std::string term_name(const DriveTerm& t) const {
    static const char* const prefix[] = {"fv_", "fc_", "fa_", "off_", "Ia_", "k_", "fs_"};
    std::string name = prefix[static_cast<int>(t.kind)] + std::string(t.on_motor ? "m" : "") +
                       std::to_string(t.index + 1);
    const bool widths = std::count_if(terms_.begin(), terms_.end(),
                                      [&](const DriveTerm& o) { return same_place(o, t); }) > 1;
    if (t.kind == DriveTermKind::Stribeck && widths) {
      std::ostringstream width;
      width << t.velocity;
      name += "@" + width.str();
    }
    return name;
  }

  SerialChain<double> chain_;
  std::vector<std::string> joint_names_;
  std::vector<DriveTerm> terms_;
  Transmission transmission_;
  double epsilon_;
  Model<double, Eigen::Dynamic> model_;
  std::vector<std::string> names_;
  Eigen::MatrixXd directions_;  ///< row m: the joint rates motor m turns with
};

}  // namespace sid

#ifdef SID_HEADER_ONLY
#include <sid/model/chain_model-inl.hpp>
#endif
