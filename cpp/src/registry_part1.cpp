// Part 1 of the loop's instantiations (registry_parts.hpp).
#define TSUBU_REGISTRY_PART 1
#include "registry_part.inc"
