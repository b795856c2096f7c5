// Filter deform: variational deformation with the handles as hard constraints, ARAP / ASAP /
// lARAP / Dirichlet, without, with uniform or with diffusion-weighted regularization.
#pragma once

#include <diffreg/deformation/deformer.h>
#include <diffreg/pipeline/filter.h>

namespace diffreg {

/// Parameters: energy (arap|asap|larap|dirichlet), regularization (none|uniform|nonuniform),
/// beta (uniform only), iterations, tolerance. Needs handles, and diffreg:weight for
/// nonuniform. Moves the mesh to the deformed positions (always solved from the rest shape the
/// pipeline loaded) and writes diffreg:distortion and diffreg:smoothness per element. Report
/// data: energy, regularization, beta, initial_guess, iterations, converged, energies.
/// Records the edit in Document::state (keys "deform.*") for the measure filter.
/// The deformation options the deform filter's parameters say (energy, regularization, beta,
/// local_step, acceleration, iterations, tolerance); weights and progress are the caller's.
DeformationOptions deformationOptionsOf(const ParamMap& params);
/// Warns (one line each) about deform parameters given other than their defaults
/// (ParamMap::given) that the others leave without effect
/// on a mesh of `kind`: beta without regularization=uniform, acceleration with the reference
/// local step, the iteration's parameters for an energy solved in one linear step.
void warnInapplicable(const ParamMap& params, MeshKind kind);

class DeformFilter : public Filter {
 public:
  std::string name() const override { return "deform"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  std::vector<std::string> requires(const ParamMap& params) const override;
  std::vector<std::string> produces(const ParamMap&) const override;
  bool needsHandles() const override { return true; }
  /// \throw InvalidParameter (weights outside [0, 1]), SingularSystem (a component without
  ///        enough handle points).
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
