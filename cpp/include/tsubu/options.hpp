// The options of a run, and the checks of every option a user sets (materials, pairs, run
// options): one place that names each option's range, so that the C++ API, the bindings and the
// Python layer refuse the same values with the same words.
#pragma once
#include <array>
#include <cstdint>

#include "archive.hpp"
#include "material.hpp"
#include "option_table.hpp"
#include "types.hpp"

namespace tsubu {

// How the stored tangential displacement follows the contact (docs/physics.md). (The values of a
// choice are the indices of its names in the option's declaration, option_table.hpp.)
enum class HistoryRule { Rotate = 0, Literal = 1 };
// What a slipping contact does (docs/physics.md): the notes' (1.17)-(1.18), force mu |f_n|
// against the slip velocity with the displacement frozen; or LAMMPS's, the spring force scaled
// to the cap in its own direction with the displacement truncated (rotate history only).
enum class SlipRule { Frozen = 0, Truncate = 1 };

struct Options {
  Vec3 gravity = Vec3(0, 0, -9.81);  // m/s^2
  double dt = 0;                     // s; 0: default_time_step()
  int threads = 0;                   // 0: OpenMP's default
  // Below this many spheres the loops run on one thread: a parallel region's start and
  // barrier cost more than the work (results are bit-identical either way).
  int parallel_min = 2048;
  double skin = 0;                   // m; 0: 0.2 x the mean diameter
  HistoryRule history = HistoryRule::Rotate;
  SlipRule slip = SlipRule::Frozen;
  double max_overlap = 0.5;          // instability if overlap > max_overlap x the smaller radius
  double initial_overlap = 0.05;     // refused at the first run if an overlap exceeds this x radius
  bool allow_unstable_dt = false;    // run with dt above critical_time_step()
  bool rebuild_every_step = false;   // testing aid: rebuild the neighbour list every step
  std::uint64_t seed = 0;            // seed of the roughness draws (reproducible per contact)
  // Hertzian contacts: clip F_n at zero (never pull), with the dashpot corrected to keep the
  // restitution (HertzDamping); false: the beta form, which may pull at the end of an impact.
  bool repulsive = false;
  // The normal impact speed a Hertzian scene's contact duration and time-step bound are taken
  // at, m/s; 0: characteristic_speed()'s default.
  double impact_speed = 0;
  // The run options the contact laws' selection reads (declared law_choice, option_table.hpp;
  // contact/selection.hpp): each the index of its choice, 0 (the first) by default, at
  // law_choice_slot(name).
  std::array<int, kLawChoiceCount> law_choices{};

  // Checkpoints (docs/checkpoints.md): every field, by name.
  void save(archive::Writer& w) const;
  void restore(archive::Reader& r);
};

// Throw InvalidArgument naming the option and the value when one is out of its range.
void validate_material(const Material& m);
// A pair override's own ranges (whether it keeps its materials' law is the Simulation's check).
void validate_pair(const PairParams& p);
// The run options a run reads (checked when a run starts).
void validate_options(const Options& o);

}  // namespace tsubu
