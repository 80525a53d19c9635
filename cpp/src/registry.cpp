// Instantiates the time loop once per combination of the slots' evaluator lists (registry.hpp)
// and maps a LawKey to it.
#include "tsubu/registry.hpp"

#include <array>
#include <utility>

#include "tsubu/engine/driver.hpp"

namespace tsubu {
namespace {

template <class Law>
CompiledLaw compile() {
  return {&detail::Stepper<Law>::run,
          &Law::name,
          &Law::critical_time_step,
          &Law::contact_duration,
          &Law::damping_term,
          &Law::normal_energy,
          &Law::elastic_force,
          &Law::tangential_energy,
          Law::history_width,
          Law::roughness::state_width,
          Law::has_torque,
          Law::rolling::enabled};
}

// Specialisation k: its slots' indices in mixed radix, the roughness slot the fastest.
constexpr std::size_t kG = RoughnessLaws::size, kR = RollingLaws::size, kT = TangentialLaws::size,
                      kD = DampingLaws::size, kN = NormalLaws::size;
constexpr std::size_t kCount = kN * kD * kT * kR * kG;

constexpr std::size_t flat(const LawKey& k) {
  return (((k.normal * kD + k.damping) * kT + k.tangential) * kR + k.rolling) * kG + k.roughness;
}

template <std::size_t K>
CompiledLaw compile_at() {
  using Law = ContactLaw<typename NormalLaws::template at<K / (kD * kT * kR * kG)>,
                         typename DampingLaws::template at<K / (kT * kR * kG) % kD>,
                         typename TangentialLaws::template at<K / (kR * kG) % kT>,
                         typename RollingLaws::template at<K / kG % kR>,
                         typename RoughnessLaws::template at<K % kG>>;
  return compile<Law>();
}

template <std::size_t... K>
std::array<CompiledLaw, kCount> compile_all(std::index_sequence<K...>) {
  return {compile_at<K>()...};
}

const std::array<CompiledLaw, kCount> kLaws = compile_all(std::make_index_sequence<kCount>());

}  // namespace

const CompiledLaw& find_law(const LawKey& key) {
  if (key.normal >= kN || key.damping >= kD || key.tangential >= kT || key.rolling >= kR ||
      key.roughness >= kG)
    throw InvalidArgument("no compiled contact law for this combination of features");
  return kLaws[flat(key)];
}

std::size_t compiled_law_count() { return kCount; }

}  // namespace tsubu
