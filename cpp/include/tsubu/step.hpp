// The time loop: see engine/driver.hpp (kept so that code including step.hpp still builds).
#pragma once
#include "engine/driver.hpp"
