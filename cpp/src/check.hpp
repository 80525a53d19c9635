// The core's argument checks and number formatting (private to the library).
#pragma once
#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

#include "tsubu/types.hpp"

namespace tsubu::detail {

inline std::string fmt(double x) {
  std::ostringstream o;
  o.precision(6);
  o << x;
  return o.str();
}

// `what` is the message, or a function that builds it: checks made once per sphere pass a
// function, so that the message is only built when the check fails (building it every time took
// seconds for a million spheres).
template <class Message>
void require(bool ok, Message&& what) {
  if (ok) return;
  if constexpr (std::is_invocable_v<Message>)
    throw InvalidArgument(what());
  else
    throw InvalidArgument(what);
}

inline bool finite3(const double* p) {
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

}  // namespace tsubu::detail
