// The one place where a scene's run-time features pick a compiled specialisation of the loop.
#pragma once
#include <string>

namespace tsubu {

class Simulation;

enum class TangentialKind { None = 0, Rotate = 1, Literal = 2, RotateTruncate = 3 };

// The features a scene uses, decided once when a run starts.
struct LawKey {
  TangentialKind tangential = TangentialKind::None;
  bool rolling = false;
  bool moving_walls = false;
  bool roughness = false;
};

using StepFunction = void (*)(Simulation&, long steps);

StepFunction find_stepper(const LawKey& key);
std::string law_name(const LawKey& key);  // e.g. "hooke+rotate+rolling+moving-walls"

}  // namespace tsubu
