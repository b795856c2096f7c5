#include "plugins.h"

namespace diffreg {

void registerBuiltinFilters(Registry& registry) {
  registerWeightsFilters(registry);
  registerDeformFilters(registry);
  registerRenderFilters(registry);
  registerMeshFilters(registry);
}

Registry& Registry::builtin() {
  static Registry registry = [] {
    Registry r;
    registerBuiltinFilters(r);
    return r;
  }();
  return registry;
}

}  // namespace diffreg
