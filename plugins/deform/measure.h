// Filter measure: the paper's Table-1 metrics of the current deformation (docs/method.md,
// "Metrics").
#pragma once

#include <diffreg/pipeline/filter.h>

namespace diffreg {

/// Parameters: energy (auto = the deform filter's), reference (mesh file; default: the same
/// edit solved without regularization), rest (mesh file; default: the positions the pipeline
/// loaded). Writes diffreg:distortion and diffreg:smoothness per element. Report data:
/// "metrics" with D_max, D_ave, D_dev, dist (null when there is nothing to compare with),
/// inverted, energy; and dist_reference saying what dist was measured against.
class MeasureFilter : public Filter {
 public:
  std::string name() const override { return "measure"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  std::vector<std::string> produces(const ParamMap&) const override;
  /// \throw IoError / InvalidMesh for an unreadable reference or rest mesh,
  ///        InvalidParameter when it does not match the document's mesh.
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
