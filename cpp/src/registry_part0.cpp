// Part 0 of the loop's instantiations (registry_parts.hpp).
#define TSUBU_REGISTRY_PART 0
#include "registry_part.inc"
