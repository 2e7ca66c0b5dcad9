#pragma once
/// @file
/// @brief An effect of the library in sid/model/effects.hpp as a value: its kind and the joint it
/// acts on, with one descriptor per kind (its text stem, its physical values and their units,
/// whether it changes the motion).
///
/// Text ids such as "coulomb_j2" or "angle_offset_q1" are parsed once, where text enters (a
/// command line, an options file, a literal in code); past that, effects are compared as values.

#include <array>
#include <cstddef>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace sid {

enum class EffectKind { Coulomb, Stribeck, TorqueOffset, AngleOffset, Armature, Spring };

/// @brief Joints the effect library serves: the two-link arm's.
inline constexpr int kEffectJoints = 2;

/// @brief What a physical value of an effect must satisfy to be admissible.
enum class ValueBound {
  Any,          ///< any finite value
  Positive,     ///< > 0
  AboveFirst,   ///< > the effect's first value (Fs > Fc)
  BelowHalfPi,  ///< |value| < pi/2 (an angle offset that keeps cos(delta) > 0)
};

/// @brief One physical value an effect is given by and a fit reports.
struct EffectValue {
  const char* name;  ///< e.g. "Fc"
  const char* unit;  ///< e.g. "N m"
  ValueBound bound;
};

/// @brief What is fixed by an effect's kind.
struct EffectKindInfo {
  EffectKind kind;
  const char* stem;   ///< the id's stem, e.g. "coulomb" in "coulomb_j2"
  char joint_letter;  ///< 'j' (the id names a joint) or 'q' (it names an angle sensor)
  const char* noun;   ///< e.g. "Coulomb friction"
  /// True for effects that change the motion; false for those that change only the recorded
  /// signals (sensor offsets), which a simulator applies to its outputs.
  bool dynamic;
  std::size_t value_count;
  std::array<EffectValue, 3> values;  ///< the first value_count are used
};

/// @brief The descriptors, one per kind, in EffectKind order.
inline const std::array<EffectKindInfo, 6>& effect_kinds() noexcept {
  static const std::array<EffectKindInfo, 6> kinds{{
      {EffectKind::Coulomb,
       "coulomb",
       'j',
       "Coulomb friction",
       true,
       1,
       {{{"Fc", "N m", ValueBound::Positive}}}},
      {EffectKind::Stribeck,
       "stribeck",
       'j',
       "Stribeck friction",
       true,
       3,
       {{{"Fc", "N m", ValueBound::Positive},
         {"Fs", "N m", ValueBound::AboveFirst},
         {"vs", "rad/s", ValueBound::Positive}}}},
      {EffectKind::TorqueOffset,
       "torque_offset",
       'j',
       "torque sensor offset",
       false,
       1,
       {{{"b", "N m", ValueBound::Any}}}},
      {EffectKind::AngleOffset,
       "angle_offset",
       'q',
       "angle sensor offset",
       false,
       1,
       {{{"delta", "rad", ValueBound::BelowHalfPi}}}},
      {EffectKind::Armature,
       "armature",
       'j',
       "rotor inertia (armature)",
       true,
       1,
       {{{"Ia", "kg m^2", ValueBound::Positive}}}},
      {EffectKind::Spring,
       "spring",
       'j',
       "joint spring (stiffness)",
       true,
       1,
       {{{"k", "N m/rad", ValueBound::Positive}}}},
  }};
  return kinds;
}

/// @brief The descriptor of a kind.
inline const EffectKindInfo& effect_kind_info(EffectKind kind) noexcept {
  return effect_kinds()[static_cast<std::size_t>(kind)];
}

/// @brief An effect: a kind acting on one joint (0-based: 0 is joint 1, or q1).
struct Effect {
  EffectKind kind = EffectKind::Coulomb;
  int joint = 0;

  constexpr Effect() = default;
  constexpr Effect(EffectKind effect_kind, int effect_joint) noexcept
      : kind(effect_kind), joint(effect_joint) {}
  /// Parses an id such as "coulomb_j2"; implicit so that a literal reads as the effect it names
  /// (options.candidates = {"coulomb_j2", "stribeck_j1"}).
  /// @throws std::invalid_argument for an unknown id, listing the valid ones.
  Effect(const char* id) : Effect(parse(id, "sid::Effect")) {}  // NOLINT: implicit on purpose
  /// @throws std::invalid_argument for an unknown id, listing the valid ones.
  explicit Effect(const std::string& id) : Effect(parse(id, "sid::Effect")) {}

  /// The text id, e.g. "coulomb_j2", "angle_offset_q1".
  std::string id() const {
    const EffectKindInfo& info = effect_kind_info(kind);
    return std::string(info.stem) + '_' + info.joint_letter + std::to_string(joint + 1);
  }

  /// @throws std::invalid_argument (message starts with who) for an unknown id.
  static Effect parse(const std::string& id, const char* who);

  friend constexpr bool operator==(Effect a, Effect b) noexcept {
    return a.kind == b.kind && a.joint == b.joint;
  }
  friend constexpr bool operator!=(Effect a, Effect b) noexcept { return !(a == b); }
};

inline std::ostream& operator<<(std::ostream& out, Effect effect) { return out << effect.id(); }

/// @brief The rotor of drive 2, carried by link 1: with theta1 and theta2 free it enters the
/// regression only as an armature on joint 2, Ia = (gr² + gr) Ir for a gear ratio gr.
inline constexpr Effect kRotorCoupling{EffectKind::Armature, 1};

/// @brief Every effect of the library, kind by kind and joint by joint (coulomb_j1, coulomb_j2,
/// stribeck_j1, ...). armature_j1 is included so that a diagnosis can report it as not
/// separable from theta1.
inline const std::vector<Effect>& all_effects() {
  static const std::vector<Effect> effects = [] {
    std::vector<Effect> list;
    for (const auto& info : effect_kinds())
      for (int joint = 0; joint < kEffectJoints; ++joint) list.emplace_back(info.kind, joint);
    return list;
  }();
  return effects;
}

/// @brief The ids of all_effects(), comma-separated, for messages and help texts.
inline std::string effect_id_list() {
  std::string list;
  for (const Effect& e : all_effects()) list += (list.empty() ? "" : ", ") + e.id();
  return list;
}

inline Effect Effect::parse(const std::string& id, const char* who) {
  for (const Effect& e : all_effects())
    if (e.id() == id) return e;
  throw std::invalid_argument(std::string(who) + ": unknown effect id '" + id +
                              "' (valid ids: " + effect_id_list() + ")");
}

}  // namespace sid
