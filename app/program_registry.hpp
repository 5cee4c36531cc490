#pragma once
// Everything the program registers (core/registry.hpp), in one function shared by `twill`
// (app/main.cpp) and the registry-driven tests, so a part registered here is listed by
// `twill list`, selectable in configs and covered by the generic tests
// (tests/discretizations/test_every_discretization.cpp) the day it is added.
#include "core/registry.hpp"

namespace twill {

/// Registers every module's implementations in `registry`: one call per module or part folder.
void register_program(Registry& registry);

}  // namespace twill
