// Instantiates the time loop once per combination of features (X-macro below), and maps a
// LawKey to it. Adding a law: write its evaluator, add a TangentialKind/flag, add a line here.
#include "tsubu/registry.hpp"

#include "tsubu/step.hpp"

namespace tsubu {
namespace {

template <class T, class R, class Rough, bool Moving>
void step_fn(Simulation& s, long steps) {
  detail::Stepper<ContactLaw<T, R, Rough>, Moving>::run(s, steps);
}

struct Entry {
  TangentialKind tangential;
  bool rolling;
  bool rough;
  bool moving;
  StepFunction fn;
};

#define TSUBU_LAWS(X)                                  \
  X(None, NoTangential, false, NoRolling)              \
  X(None, NoTangential, true, RollingFriction)         \
  X(Rotate, TangentialRotate, false, NoRolling)        \
  X(Rotate, TangentialRotate, true, RollingFriction)   \
  X(Literal, TangentialLiteral, false, NoRolling)      \
  X(Literal, TangentialLiteral, true, RollingFriction)          \
  X(RotateTruncate, TangentialRotateTruncate, false, NoRolling) \
  X(RotateTruncate, TangentialRotateTruncate, true, RollingFriction)

#define TSUBU_ENTRY(KIND, T, ROLL, R)                                                  \
  {TangentialKind::KIND, ROLL, false, false, &step_fn<T, R, NoRoughness, false>},         \
  {TangentialKind::KIND, ROLL, false, true, &step_fn<T, R, NoRoughness, true>},           \
  {TangentialKind::KIND, ROLL, true, false, &step_fn<T, R, StochasticRoughness, false>},  \
  {TangentialKind::KIND, ROLL, true, true, &step_fn<T, R, StochasticRoughness, true>},

const Entry kRegistry[] = {TSUBU_LAWS(TSUBU_ENTRY)};

const Entry& lookup(const LawKey& key) {
  for (const Entry& e : kRegistry)
    if (e.tangential == key.tangential && e.rolling == key.rolling && e.rough == key.roughness &&
        e.moving == key.moving_walls)
      return e;
  throw InvalidArgument("no compiled contact law for this combination of features");
}

}  // namespace

StepFunction find_stepper(const LawKey& key) { return lookup(key).fn; }

std::string law_name(const LawKey& key) {
  std::string s = "hooke";
  s += key.tangential == TangentialKind::None      ? "+frictionless"
       : key.tangential == TangentialKind::Rotate  ? "+friction(rotate)"
       : key.tangential == TangentialKind::Literal ? "+friction(literal)"
                                                   : "+friction(rotate, truncate)";
  if (key.rolling) s += "+rolling";
  if (key.roughness) s += "+roughness";
  s += key.moving_walls ? "+moving-walls" : "";
  return s;
}

}  // namespace tsubu
