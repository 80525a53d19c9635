// A compile-time list of types: the registry's slots (registry.hpp) and the contact laws'
// parameter sets (contact/parameters.hpp).
#pragma once
#include <cstddef>
#include <tuple>
#include <type_traits>

namespace tsubu {

template <class... T>
struct TypeList {
  static constexpr std::size_t size = sizeof...(T);
  template <std::size_t I>
  using at = std::tuple_element_t<I, std::tuple<T...>>;
  // The position of U in the list.
  template <class U>
  static constexpr std::size_t index_of() {
    std::size_t i = 0, found = size;
    ((std::is_same_v<U, T> ? (found = i, ++i) : ++i), ...);
    return found;
  }
  // f(tag) for each type, in order; the tag is a null T*, so that f can name T without making one.
  template <class F>
  static constexpr void for_each(F&& f) {
    (f(static_cast<T*>(nullptr)), ...);
  }
};

}  // namespace tsubu
