#pragma once
// Definitions of sid/model/effects.hpp (see sid/config.hpp).

#include <sid/model/effects.hpp>

namespace sid {

SID_INLINE const std::vector<std::string>& effect_ids() {
  static const std::vector<std::string> ids{
      "coulomb_j1",       "coulomb_j2",       "stribeck_j1",     "stribeck_j2",
      "torque_offset_j1", "torque_offset_j2", "angle_offset_q1", "angle_offset_q2",
      "armature_j1",      "armature_j2",      "spring_j1",       "spring_j2"};
  return ids;
}

SID_INLINE bool is_effect_id(const std::string& id) {
  for (const auto& known : effect_ids())
    if (known == id) return true;
  return false;
}

namespace detail {

SID_INLINE std::string effect_id_list() {
  std::string list;
  for (const auto& id : effect_ids()) list += (list.empty() ? "" : ", ") + id;
  return list;
}

SID_INLINE EffectInfo effect_info(const std::string& id, const char* who) {
  const auto ends_with_joint = [&id](const std::string& stem, const char* letter) -> int {
    if (id == stem + "_" + letter + "1") return 0;
    if (id == stem + "_" + letter + "2") return 1;
    return -1;
  };
  struct Stem {
    const char* stem;
    const char* letter;
    EffectKind kind;
  };
  static const Stem stems[] = {{"coulomb", "j", EffectKind::Coulomb},
                               {"stribeck", "j", EffectKind::Stribeck},
                               {"torque_offset", "j", EffectKind::TorqueOffset},
                               {"angle_offset", "q", EffectKind::AngleOffset},
                               {"armature", "j", EffectKind::Armature},
                               {"spring", "j", EffectKind::Spring}};
  for (const auto& s : stems) {
    const int joint = ends_with_joint(s.stem, s.letter);
    if (joint >= 0) return {s.kind, joint};
  }
  throw std::invalid_argument(std::string(who) + ": unknown effect id '" + id +
                              "' (valid ids: " + effect_id_list() + ")");
}

SID_INLINE void check_effect_settings(const EffectSettings& settings, const char* who) {
  using std::isfinite;
  if (!(settings.coulomb_epsilon > 0.0) || !isfinite(settings.coulomb_epsilon))
    throw std::invalid_argument(std::string(who) +
                                ": settings.coulomb_epsilon must be finite and > 0 [rad/s]");
  if (!isfinite(settings.gravity))
    throw std::invalid_argument(std::string(who) + ": settings.gravity must be finite [m/s^2]");
  if (!(settings.stribeck_velocity > 0.0) || !isfinite(settings.stribeck_velocity))
    throw std::invalid_argument(std::string(who) +
                                ": settings.stribeck_velocity must be finite and > 0 [rad/s]");
}

SID_INLINE double stribeck_bump(double v, double vs) noexcept {
  const double x = v / vs;
  if (!(std::fabs(x) < 40.0)) return std::isnan(x) ? x : 0.0;
  return std::exp(-x * x);
}

SID_INLINE std::string joint_text(int joint) { return joint == 0 ? "1" : "2"; }

SID_INLINE std::string format_value(double v) {
  std::ostringstream out;
  out.precision(6);
  out << v;
  return out.str();
}

}  // namespace detail

SID_INLINE std::string effect_name(const std::string& id) {
  const detail::EffectInfo info = detail::effect_info(id, "sid::effect_name");
  const std::string j = detail::joint_text(info.joint);
  switch (info.kind) {
    case detail::EffectKind::Coulomb:
      return "Coulomb friction on joint " + j;
    case detail::EffectKind::Stribeck:
      return "Stribeck friction on joint " + j;
    case detail::EffectKind::TorqueOffset:
      return "torque sensor offset on joint " + j +
             " (or a constant load torque: indistinguishable)";
    case detail::EffectKind::AngleOffset:
      return info.joint == 0 ? "angle sensor offset on q1 (or a tilt of the base in the plane of "
                               "motion: indistinguishable)"
                             : "angle sensor offset on q2";
    case detail::EffectKind::Armature:
      return info.joint == 0 ? "rotor inertia (armature) on joint 1 (theta1's own column: not "
                               "separable, seen only as theta1 drifting)"
                             : "rotor inertia (armature) on joint 2";
    case detail::EffectKind::Spring:
      return "joint spring (stiffness) on joint " + j;
  }
  return id;  // unreachable: every kind is handled above
}

SID_INLINE std::vector<std::string> effect_value_names(const std::string& id) {
  switch (detail::effect_info(id, "sid::effect_value_names").kind) {
    case detail::EffectKind::Coulomb:
      return {"Fc"};
    case detail::EffectKind::Stribeck:
      return {"Fc", "Fs", "vs"};
    case detail::EffectKind::TorqueOffset:
      return {"b"};
    case detail::EffectKind::AngleOffset:
      return {"delta"};
    case detail::EffectKind::Armature:
      return {"Ia"};
    case detail::EffectKind::Spring:
      return {"k"};
  }
  return {};
}

SID_INLINE std::vector<std::string> effect_value_units(const std::string& id) {
  switch (detail::effect_info(id, "sid::effect_value_units").kind) {
    case detail::EffectKind::Coulomb:
      return {"N m"};
    case detail::EffectKind::Stribeck:
      return {"N m", "N m", "rad/s"};
    case detail::EffectKind::TorqueOffset:
      return {"N m"};
    case detail::EffectKind::AngleOffset:
      return {"rad"};
    case detail::EffectKind::Armature:
      return {"kg m^2"};
    case detail::EffectKind::Spring:
      return {"N m/rad"};
  }
  return {};
}

SID_INLINE bool is_dynamic_effect(const std::string& id) {
  const detail::EffectKind kind = detail::effect_info(id, "sid::is_dynamic_effect").kind;
  return kind != detail::EffectKind::TorqueOffset && kind != detail::EffectKind::AngleOffset;
}

SID_INLINE Term<double> effect_term(const std::string& id, const EffectSettings& settings) {
  constexpr const char* who = "sid::effect_term";
  const detail::EffectInfo info = detail::effect_info(id, who);
  detail::check_effect_settings(settings, who);
  const Eigen::Index j = info.joint, other = 1 - info.joint;
  const double eps = settings.coulomb_epsilon, vs = settings.stribeck_velocity;
  const CoulombShape shape = settings.coulomb_shape;
  const double g = settings.gravity;
  using V = const Vector2<double>&;
  using Out = RegressorView<double>;
  switch (info.kind) {
    case detail::EffectKind::Coulomb:
      if (settings.coulomb_asymmetric)
        return {id, {id + ".Fc", id + ".dFc"}, [j, other, eps, shape](V, V qd, V, Out out) {
                  const double sign = detail::smooth_sign(qd[j], eps, shape);
                  out(j, 0) = sign;
                  out(j, 1) = std::abs(sign);
                  out(other, 0) = 0.0;
                  out(other, 1) = 0.0;
                }};
      return {id, {id + ".Fc"}, [j, other, eps, shape](V, V qd, V, Out out) {
                out(j, 0) = detail::smooth_sign(qd[j], eps, shape);
                out(other, 0) = 0.0;
              }};
    case detail::EffectKind::Stribeck:
      return {
          id, {id + ".Fc", id + ".Fs_minus_Fc"}, [j, other, eps, vs, shape](V, V qd, V, Out out) {
            const double sign = detail::smooth_sign(qd[j], eps, shape);
            out(j, 0) = sign;
            out(j, 1) = detail::stribeck_bump(qd[j], vs) * sign;
            out(other, 0) = 0.0;
            out(other, 1) = 0.0;
          }};
    case detail::EffectKind::TorqueOffset:
      return {id, {id + ".b"}, [j, other](V, V, V, Out out) {
                out(j, 0) = 1.0;
                out(other, 0) = 0.0;
              }};
    case detail::EffectKind::AngleOffset:
      if (j == 0)
        return {id, {id + ".theta4_sin", id + ".theta5_sin"}, [g](V q, V, V, Out out) {
                  const double gc12 = g * std::cos(q[0] + q[1]);
                  out(0, 0) = g * std::cos(q[0]);
                  out(1, 0) = 0.0;
                  out(0, 1) = gc12;
                  out(1, 1) = gc12;
                }};
      return {id, {id + ".theta3_sin", id + ".theta5_sin"}, [g](V q, V qd, V qdd, Out out) {
                const double s2 = std::sin(q[1]), c2 = std::cos(q[1]);
                const double gc12 = g * std::cos(q[0] + q[1]);
                out(0, 0) = -s2 * (2.0 * qdd[0] + qdd[1]) - c2 * (2.0 * qd[0] + qd[1]) * qd[1];
                out(1, 0) = -s2 * qdd[0] + c2 * qd[0] * qd[0];
                out(0, 1) = gc12;
                out(1, 1) = gc12;
              }};
    case detail::EffectKind::Armature:
      return {id, {id + ".Ia"}, [j, other](V, V, V qdd, Out out) {
                out(j, 0) = qdd[j];
                out(other, 0) = 0.0;
              }};
    case detail::EffectKind::Spring:
      return {id, {id + ".k"}, [j, other](V q, V, V, Out out) {
                out(j, 0) = q[j];
                out(other, 0) = 0.0;
              }};
  }
  throw std::invalid_argument(std::string(who) + ": unhandled effect id '" + id + "'");
}

SID_INLINE EffectEstimate effect_estimate(const std::string& id,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta_full,
                                          const Eigen::Ref<const Eigen::MatrixXd>& covariance_full,
                                          const Model<double>& model,
                                          const EffectSettings& settings) {
  constexpr const char* who = "sid::effect_estimate";
  const detail::EffectInfo info = detail::effect_info(id, who);
  detail::check_effect_settings(settings, who);
  const Eigen::Index p = model.num_parameters();
  if (theta_full.size() != p)
    throw std::invalid_argument(std::string(who) + ": theta_full has " +
                                std::to_string(theta_full.size()) + " entries but the model has " +
                                std::to_string(p) + " parameters");
  if (covariance_full.rows() != p || covariance_full.cols() != p)
    throw std::invalid_argument(std::string(who) + ": covariance_full is " +
                                std::to_string(covariance_full.rows()) + " x " +
                                std::to_string(covariance_full.cols()) + " but must be " +
                                std::to_string(p) + " x " + std::to_string(p));
  if (!model.has_term(id))
    throw std::invalid_argument(std::string(who) + ": the model has no term '" + id + "'");
  const Eigen::Index k = model.parameter_offset(id);
  const auto& cov = covariance_full;
  EffectEstimate e{id, Eigen::VectorXd(), Eigen::VectorXd()};
  switch (info.kind) {
    case detail::EffectKind::Stribeck: {
      const double var_fs = cov(k, k) + cov(k + 1, k + 1) + 2.0 * cov(k, k + 1);
      e.value = Eigen::Vector3d(theta_full[k], theta_full[k] + theta_full[k + 1],
                                settings.stribeck_velocity);
      e.std = Eigen::Vector3d(std::sqrt(cov(k, k)), std::sqrt(var_fs), 0.0);
      return e;
    }
    case detail::EffectKind::AngleOffset: {
      if (!model.has_term("rigid_body"))
        throw std::invalid_argument(std::string(who) + ": '" + id +
                                    "' needs the model's \"rigid_body\" term (theta1..theta5)");
      const Eigen::Index rb = model.parameter_offset("rigid_body");
      // Indices of (c_0, c_1) in theta_full; (s_0, s_1) are k, k + 1.
      const Eigen::Index c_index[2] = {info.joint == 0 ? rb + 3 : rb + 2, rb + 4};
      double num = 0.0, den = 0.0;
      for (int i = 0; i < 2; ++i) {
        num += theta_full[c_index[i]] * theta_full[k + i];
        den += theta_full[c_index[i]] * theta_full[c_index[i]];
      }
      const double delta = std::atan2(num, den);
      // d delta = (den d num - num d den) / (den^2 + num^2).
      Eigen::VectorXd gradient = Eigen::VectorXd::Zero(p);
      const double scale = 1.0 / (den * den + num * num);
      for (int i = 0; i < 2; ++i) {
        const double c = theta_full[c_index[i]], s = theta_full[k + i];
        gradient[c_index[i]] += scale * (den * s - num * 2.0 * c);
        gradient[k + i] += scale * den * c;
      }
      e.value = Eigen::VectorXd::Constant(1, delta);
      e.std = Eigen::VectorXd::Constant(1, std::sqrt(gradient.dot(cov * gradient)));
      return e;
    }
    case detail::EffectKind::Coulomb:
    case detail::EffectKind::TorqueOffset:
    case detail::EffectKind::Armature:
    case detail::EffectKind::Spring:
      e.value = Eigen::VectorXd::Constant(1, theta_full[k]);
      e.std = Eigen::VectorXd::Constant(1, std::sqrt(cov(k, k)));
      return e;
  }
  return e;
}

SID_INLINE void validate_effect(const EffectSpec& spec, const char* who) {
  const detail::EffectInfo info = detail::effect_info(spec.id, who);
  const std::vector<std::string> names = effect_value_names(spec.id);
  const std::string prefix = std::string(who) + ": " + spec.id + ": ";
  if (spec.values.size() != names.size()) {
    std::string list;
    for (const auto& n : names) list += (list.empty() ? "" : ",") + n;
    throw std::invalid_argument(prefix + "needs " + std::to_string(names.size()) + " value" +
                                (names.size() == 1 ? "" : "s") + " (" + list + "), got " +
                                std::to_string(spec.values.size()));
  }
  for (std::size_t i = 0; i < names.size(); ++i)
    if (!std::isfinite(spec.values[i]))
      throw std::invalid_argument(prefix + names[i] + " must be finite, got " +
                                  detail::format_value(spec.values[i]));
  const auto& v = spec.values;
  const auto require_positive = [&](std::size_t i, const char* unit) {
    if (!(v[i] > 0.0))
      throw std::invalid_argument(prefix + names[i] + " must be > 0 [" + unit + "], got " +
                                  detail::format_value(v[i]));
  };
  switch (info.kind) {
    case detail::EffectKind::Coulomb:
      require_positive(0, "N m");
      return;
    case detail::EffectKind::Stribeck:
      require_positive(0, "N m");
      if (!(v[1] > v[0]))
        throw std::invalid_argument(prefix +
                                    "Fs must be > Fc (static friction above Coulomb), "
                                    "got Fs = " +
                                    detail::format_value(v[1]) +
                                    ", Fc = " + detail::format_value(v[0]));
      require_positive(2, "rad/s");
      return;
    case detail::EffectKind::TorqueOffset:
      return;
    case detail::EffectKind::AngleOffset:
      if (!(std::fabs(v[0]) < 1.5707963267948966))
        throw std::invalid_argument(prefix + "|delta| must be < pi/2 [rad], got " +
                                    detail::format_value(v[0]));
      return;
    case detail::EffectKind::Armature:
      require_positive(0, "kg m^2");
      return;
    case detail::EffectKind::Spring:
      require_positive(0, "N m/rad");
      return;
  }
}

SID_INLINE EffectSpec parse_effect(const std::string& text) {
  constexpr const char* who = "sid::parse_effect";
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw std::invalid_argument(std::string(who) + ": '" + text +
                                "' has no ':' (expected ID:VALUES, e.g. coulomb_j2:0.1)");
  EffectSpec spec{text.substr(0, colon), {}};
  detail::effect_info(spec.id, who);
  const std::string list = text.substr(colon + 1);
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = list.find(',', start);
    const std::string item =
        list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    const std::size_t first = item.find_first_not_of(' ');
    const std::size_t last = item.find_last_not_of(' ');
    const std::string trimmed =
        first == std::string::npos ? std::string() : item.substr(first, last - first + 1);
    char* end = nullptr;
    const double value = trimmed.empty() ? 0.0 : std::strtod(trimmed.c_str(), &end);
    if (trimmed.empty() || end != trimmed.c_str() + trimmed.size())
      throw std::invalid_argument(std::string(who) + ": " + spec.id + ": value " +
                                  std::to_string(spec.values.size() + 1) + " '" + trimmed +
                                  "' is not a number (in '" + text + "')");
    spec.values.push_back(value);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  validate_effect(spec, who);
  return spec;
}

SID_INLINE EffectfulArm effectful_arm(const TwoLinkParameters<double>& theta,
                                      const std::vector<EffectSpec>& effects,
                                      const EffectSettings& settings) {
  constexpr const char* who = "sid::effectful_arm";
  detail::check_effect_settings(settings, who);
  if (!theta.allFinite()) throw std::invalid_argument(std::string(who) + ": theta must be finite");
  EffectfulArm arm{two_link_arm_model<double>(settings.gravity), Eigen::VectorXd(theta), {}, {}};
  arm.torque_offset.setZero();
  arm.angle_offset.setZero();
  for (std::size_t i = 0; i < effects.size(); ++i) {
    const EffectSpec& spec = effects[i];
    validate_effect(spec, who);
    for (std::size_t k = 0; k < i; ++k)
      if (effects[k].id == spec.id)
        throw std::invalid_argument(std::string(who) + ": effect '" + spec.id +
                                    "' is given more than once");
    const detail::EffectInfo info = detail::effect_info(spec.id, who);
    const auto append = [&arm](const Term<double>& term, std::initializer_list<double> values) {
      arm.model.add(term);
      const Eigen::Index old = arm.theta.size();
      arm.theta.conservativeResize(old + static_cast<Eigen::Index>(values.size()));
      Eigen::Index r = old;
      for (double v : values) arm.theta[r++] = v;
    };
    switch (info.kind) {
      case detail::EffectKind::TorqueOffset:
        arm.torque_offset[info.joint] = spec.values[0];
        break;
      case detail::EffectKind::AngleOffset:
        arm.angle_offset[info.joint] = spec.values[0];
        break;
      case detail::EffectKind::Stribeck: {
        EffectSettings at_vs = settings;
        at_vs.stribeck_velocity = spec.values[2];
        append(effect_term(spec.id, at_vs), {spec.values[0], spec.values[1] - spec.values[0]});
        break;
      }
      case detail::EffectKind::Coulomb:
      case detail::EffectKind::Armature:
      case detail::EffectKind::Spring:
        append(effect_term(spec.id, settings), {spec.values[0]});
        break;
    }
  }
  return arm;
}

}  // namespace sid
