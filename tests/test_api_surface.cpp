// The public surface: <diffreg/diffreg.h> declares the documented levels (one-shot functions,
// sessions, the edit engine, pipelines) and none of the machinery behind them. Each probe
// below is true when the umbrella header leaves that name undeclared in namespace diffreg
// (even a forward declaration counts as exposing it).
#include <diffreg/diffreg.h>

#include <catch2/catch.hpp>

#include <type_traits>

// Stand-ins found by unqualified lookup from inside namespace diffreg only when diffreg
// itself declares no such name.
namespace surface_probe {
struct ResidualModel;
struct RegularizedSystem;
struct Regularizer;
struct EnergyModel;
struct LbfgsHistory;
struct AndersonMixer;
struct SpdSolver;
struct Partition;
struct EliminatedSolver;
}  // namespace surface_probe

namespace diffreg::probe {
using namespace ::surface_probe;
#define DIFFREG_HIDDEN(Name) \
  constexpr bool hidden##Name = std::is_same_v<Name, ::surface_probe::Name>;
DIFFREG_HIDDEN(ResidualModel)
DIFFREG_HIDDEN(RegularizedSystem)
DIFFREG_HIDDEN(Regularizer)
DIFFREG_HIDDEN(EnergyModel)
DIFFREG_HIDDEN(LbfgsHistory)
DIFFREG_HIDDEN(AndersonMixer)
DIFFREG_HIDDEN(SpdSolver)
DIFFREG_HIDDEN(Partition)
DIFFREG_HIDDEN(EliminatedSolver)
#undef DIFFREG_HIDDEN
}  // namespace diffreg::probe

TEST_CASE("the umbrella header declares no internal class", "[api]") {
  using namespace diffreg::probe;
  CHECK(hiddenResidualModel);
  CHECK(hiddenRegularizedSystem);
  CHECK(hiddenRegularizer);
  CHECK(hiddenEnergyModel);
  CHECK(hiddenLbfgsHistory);
  CHECK(hiddenAndersonMixer);
  CHECK(hiddenSpdSolver);
  CHECK(hiddenPartition);
  CHECK(hiddenEliminatedSolver);
}

TEST_CASE("the documented levels are declared by the umbrella header", "[api]") {
  // One name per level, so that the probe above cannot pass by an empty header.
  CHECK(std::is_class_v<diffreg::DeformationSession>);
  CHECK(std::is_class_v<diffreg::DiffusionWeights>);
  CHECK(std::is_class_v<diffreg::EditEngine>);
  CHECK(std::is_class_v<diffreg::Pipeline>);
  CHECK(std::is_class_v<diffreg::DeformationOptions>);
  CHECK(std::is_class_v<diffreg::SolverStats>);
}
