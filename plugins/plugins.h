// Registration of every built-in filter. Each plugin file defines one register function and
// plugins.cpp calls them all; Registry::builtin() is defined there.
#pragma once

#include <diffreg/pipeline/filter.h>

namespace diffreg {

void registerWeightsFilters(Registry& registry);  // plugins/weights
void registerDeformFilters(Registry& registry);   // plugins/deform
void registerRenderFilters(Registry& registry);   // plugins/render
void registerMeshFilters(Registry& registry);     // plugins/mesh
void registerBuiltinFilters(Registry& registry);  // all of the above

}  // namespace diffreg
