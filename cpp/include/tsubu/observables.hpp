// What a Simulation reports of its state (simulation.hpp): the energy of a scene and one
// current contact.
#pragma once
#include "types.hpp"

namespace tsubu {

struct Energy {
  double translational = 0, rotational = 0, gravitational = 0, elastic = 0, dissipated = 0;
  // Symplectic Euler conserves, for linear springs, not total() but total() + step_correction:
  // (dt/2) sum v.F over gravity and the normal springs (forces of the positions), minus the same
  // over the tangential springs (forces of this step's displacement, one velocity later).
  // Filled by energy_now() only.
  double step_correction = 0;
  double kinetic() const { return translational + rotational; }
  // Mechanical energy; with fixed walls, total() + dissipated stays constant.
  double total() const { return translational + rotational + gravitational + elastic; }
};

// One current contact, as evaluated at the start of the last step.
struct ContactInfo {
  Id i;           // particle id
  Id j;           // partner particle id, or -1 for a wall
  int wall;       // wall index, or -1 for a particle pair
  int element;    // a mesh wall's triangle (0 for a plane), or -1 for a particle pair
  double overlap; // m
  Vec3 force;     // total contact force on i, N
  Vec3 torque_i;  // torque on i from this contact, N m
  Vec3 tangential_displacement;  // stored history xi, m (zero without friction)
  double reduced_radius;  // R* = r_i r_j / (r_i + r_j); a wall: r_i
  double contact_radius;  // a = sqrt(R* delta) as the Mindlin history keeps it; 0 otherwise
  Vec3 wall_point = Vec3::Zero();  // a wall contact: the point of the wall nearest i's centre now
  Vec3 branch = Vec3::Zero();  // a pair: x_j - x_i now, to j's image nearest i (periodic boxes)
};

}  // namespace tsubu
