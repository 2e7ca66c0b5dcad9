#pragma once
// Definitions of sid/model/effects.hpp (see sid/config.hpp).

#include <sid/model/effects.hpp>

namespace sid {

namespace detail {

SID_INLINE void check_effect_joint(Effect effect, const char* who) {
  if (effect.joint < 0 || effect.joint >= kEffectJoints)
    throw std::invalid_argument(std::string(who) + ": effect joint " +
                                std::to_string(effect.joint) + " is outside 0.." +
                                std::to_string(kEffectJoints - 1));
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

SID_INLINE std::string format_value(double v) {
  std::ostringstream out;
  out.precision(6);
  out << v;
  return out.str();
}

SID_INLINE std::array<const char*, 2> rotated_parameters(Effect angle_offset) {
  if (angle_offset.joint == 0) return {"theta4", "theta5"};
  return {"theta3", "theta5"};
}

}  // namespace detail

SID_INLINE std::string effect_look_alike(Effect effect) {
  if (effect.kind == EffectKind::TorqueOffset)
    return "a constant load torque on joint " + std::to_string(effect.joint + 1);
  if (effect.kind == EffectKind::AngleOffset && effect.joint == 0)
    return "a tilt of the base in the plane of motion";
  return "";
}

SID_INLINE std::string effect_name(Effect effect) {
  const EffectKindInfo& info = effect_kind_info(effect.kind);
  std::string name = std::string(info.noun) + " on " + (info.joint_letter == 'q' ? "q" : "joint ") +
                     std::to_string(effect.joint + 1);
  const std::string look_alike = effect_look_alike(effect);
  if (!look_alike.empty()) name += " (or " + look_alike + ": indistinguishable)";
  if (effect.kind == EffectKind::Armature && effect.joint == 0)
    name += " (theta1's own column: not separable, seen only as theta1 drifting)";
  return name;
}

SID_INLINE std::optional<Effect> contained_effect(Effect effect) {
  if (effect.kind == EffectKind::Stribeck) return Effect{EffectKind::Coulomb, effect.joint};
  return std::nullopt;
}

SID_INLINE std::vector<std::string> effect_value_names(Effect effect) {
  const EffectKindInfo& info = effect_kind_info(effect.kind);
  std::vector<std::string> names;
  for (std::size_t i = 0; i < info.value_count; ++i) names.emplace_back(info.values[i].name);
  return names;
}

SID_INLINE std::vector<std::string> effect_value_units(Effect effect) {
  const EffectKindInfo& info = effect_kind_info(effect.kind);
  std::vector<std::string> units;
  for (std::size_t i = 0; i < info.value_count; ++i) units.emplace_back(info.values[i].unit);
  return units;
}

SID_INLINE std::string admissibility_violation(Effect effect,
                                               const Eigen::Ref<const Eigen::VectorXd>& v) {
  const EffectKindInfo& info = effect_kind_info(effect.kind);
  const auto count = static_cast<Eigen::Index>(info.value_count);
  if (v.size() != count) {
    std::string list;
    for (std::size_t i = 0; i < info.value_count; ++i)
      list += (list.empty() ? "" : ",") + std::string(info.values[i].name);
    return "needs " + std::to_string(count) + " value" + (count == 1 ? "" : "s") + " (" + list +
           "), got " + std::to_string(v.size());
  }
  const auto text = [](double x) { return detail::format_value(x); };
  for (Eigen::Index i = 0; i < count; ++i) {
    const EffectValue& value = info.values[static_cast<std::size_t>(i)];
    const std::string name = value.name;
    if (!std::isfinite(v[i])) return name + " must be finite, got " + text(v[i]);
    switch (value.bound) {
      case ValueBound::Any:
        break;
      case ValueBound::Positive:
        if (!(v[i] > 0.0)) return name + " must be > 0 [" + value.unit + "], got " + text(v[i]);
        break;
      case ValueBound::AboveFirst:
        if (!(v[i] > v[0]))
          return name + " must be > " + info.values[0].name + " (static friction above Coulomb), " +
                 "got " + name + " = " + text(v[i]) + ", " + info.values[0].name + " = " +
                 text(v[0]);
        break;
      case ValueBound::BelowHalfPi:
        if (!(std::fabs(v[i]) < 1.5707963267948966))
          return "|" + name + "| must be < pi/2 [" + value.unit + "], got " + text(v[i]);
        break;
    }
  }
  return "";
}

SID_INLINE Term<double> effect_term(Effect effect, const EffectSettings& settings) {
  constexpr const char* who = "sid::effect_term";
  detail::check_effect_joint(effect, who);
  detail::check_effect_settings(settings, who);
  const std::string id = effect.id();
  const Eigen::Index j = effect.joint, other = 1 - effect.joint;
  const double eps = settings.coulomb_epsilon, vs = settings.stribeck_velocity;
  const CoulombShape shape = settings.coulomb_shape;
  const double g = settings.gravity;
  using V = const Vector2<double>&;
  using Out = RegressorView<double>;
  switch (effect.kind) {
    case EffectKind::Coulomb:
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
    case EffectKind::Stribeck:
      return {
          id, {id + ".Fc", id + ".Fs_minus_Fc"}, [j, other, eps, vs, shape](V, V qd, V, Out out) {
            const double sign = detail::smooth_sign(qd[j], eps, shape);
            out(j, 0) = sign;
            out(j, 1) = detail::stribeck_bump(qd[j], vs) * sign;
            out(other, 0) = 0.0;
            out(other, 1) = 0.0;
          }};
    case EffectKind::TorqueOffset:
      return {id, {id + ".b"}, [j, other](V, V, V, Out out) {
                out(j, 0) = 1.0;
                out(other, 0) = 0.0;
              }};
    case EffectKind::AngleOffset:
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
    case EffectKind::Armature:
      return {id, {id + ".Ia"}, [j, other](V, V, V qdd, Out out) {
                out(j, 0) = qdd[j];
                out(other, 0) = 0.0;
              }};
    case EffectKind::Spring:
      return {id, {id + ".k"}, [j, other](V q, V, V, Out out) {
                out(j, 0) = q[j];
                out(other, 0) = 0.0;
              }};
  }
  throw std::invalid_argument(std::string(who) + ": unhandled effect '" + id + "'");
}

SID_INLINE Eigen::VectorXd effect_signature(Effect effect,
                                            const Eigen::Ref<const Eigen::VectorXd>& theta,
                                            const Model<double>& model) {
  if (effect.kind == EffectKind::Stribeck) return Eigen::Vector2d(0.0, 1.0);
  if (effect.kind == EffectKind::AngleOffset) {
    const auto rotated = detail::rotated_parameters(effect);
    return Eigen::Vector2d(theta[model.parameter_index(rotated[0])],
                           theta[model.parameter_index(rotated[1])]);
  }
  return Eigen::VectorXd::Ones(1);
}

SID_INLINE EffectEstimate effect_estimate(Effect effect,
                                          const Eigen::Ref<const Eigen::VectorXd>& theta_full,
                                          const Eigen::Ref<const Eigen::MatrixXd>& covariance_full,
                                          const Model<double>& model,
                                          const EffectSettings& settings) {
  constexpr const char* who = "sid::effect_estimate";
  detail::check_effect_joint(effect, who);
  detail::check_effect_settings(settings, who);
  const std::string id = effect.id();
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
  EffectEstimate e{effect, Eigen::VectorXd(), Eigen::VectorXd()};
  switch (effect.kind) {
    case EffectKind::Stribeck: {
      const double var_fs = cov(k, k) + cov(k + 1, k + 1) + 2.0 * cov(k, k + 1);
      e.value = Eigen::Vector3d(theta_full[k], theta_full[k] + theta_full[k + 1],
                                settings.stribeck_velocity);
      e.std = Eigen::Vector3d(std::sqrt(cov(k, k)), std::sqrt(var_fs), 0.0);
      return e;
    }
    case EffectKind::AngleOffset: {
      if (!model.has_term("rigid_body"))
        throw std::invalid_argument(std::string(who) + ": '" + id +
                                    "' needs the model's \"rigid_body\" term (theta1..theta5)");
      // Indices of (c_0, c_1) in theta_full; (s_0, s_1) are k, k + 1.
      const auto rotated = detail::rotated_parameters(effect);
      const Eigen::Index c_index[2] = {model.parameter_index(rotated[0]),
                                       model.parameter_index(rotated[1])};
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
    case EffectKind::Coulomb:
    case EffectKind::TorqueOffset:
    case EffectKind::Armature:
    case EffectKind::Spring:
      e.value = Eigen::VectorXd::Constant(1, theta_full[k]);
      e.std = Eigen::VectorXd::Constant(1, std::sqrt(cov(k, k)));
      return e;
  }
  return e;
}

SID_INLINE void validate_effect(const EffectSpec& spec, const char* who) {
  detail::check_effect_joint(spec.effect, who);
  const std::string violation = admissibility_violation(
      spec.effect, Eigen::Map<const Eigen::VectorXd>(
                       spec.values.data(), static_cast<Eigen::Index>(spec.values.size())));
  if (!violation.empty())
    throw std::invalid_argument(std::string(who) + ": " + spec.effect.id() + ": " + violation);
}

SID_INLINE EffectSpec parse_effect(const std::string& text) {
  constexpr const char* who = "sid::parse_effect";
  const auto colon = text.find(':');
  if (colon == std::string::npos)
    throw std::invalid_argument(std::string(who) + ": '" + text +
                                "' has no ':' (expected ID:VALUES, e.g. coulomb_j2:0.1)");
  EffectSpec spec{Effect::parse(text.substr(0, colon), who), {}};
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
      throw std::invalid_argument(std::string(who) + ": " + spec.effect.id() + ": value " +
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
      if (effects[k].effect == spec.effect)
        throw std::invalid_argument(std::string(who) + ": effect '" + spec.effect.id() +
                                    "' is given more than once");
    const auto append = [&arm](const Term<double>& term, std::initializer_list<double> values) {
      arm.model.add(term);
      const Eigen::Index old = arm.theta.size();
      arm.theta.conservativeResize(old + static_cast<Eigen::Index>(values.size()));
      Eigen::Index r = old;
      for (double v : values) arm.theta[r++] = v;
    };
    const int joint = spec.effect.joint;
    switch (spec.effect.kind) {
      case EffectKind::TorqueOffset:
        arm.torque_offset[joint] = spec.values[0];
        break;
      case EffectKind::AngleOffset:
        arm.angle_offset[joint] = spec.values[0];
        break;
      case EffectKind::Stribeck: {
        EffectSettings at_vs = settings;
        at_vs.stribeck_velocity = spec.values[2];
        append(effect_term(spec.effect, at_vs), {spec.values[0], spec.values[1] - spec.values[0]});
        break;
      }
      case EffectKind::Coulomb:
      case EffectKind::Armature:
      case EffectKind::Spring:
        append(effect_term(spec.effect, settings), {spec.values[0]});
        break;
    }
  }
  return arm;
}

}  // namespace sid
