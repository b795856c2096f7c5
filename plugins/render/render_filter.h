// Filter render: a PNG picture of the current mesh coloured by a property, with a colour bar,
// optional wireframe and the handles marked. (Named render_filter so that "render/render.h"
// stays the renderer of modules/render.)
#pragma once

#include <diffreg/pipeline/filter.h>

namespace diffreg {

/// Parameters: file (PNG path, required, relative to the working directory), property
/// (weight|distortion|smoothness|none), scale_max, colormap (auto|viridis|turbo|coolwarm),
/// wireframe, handles, width, height, view (auto|top|orbit), yaw, pitch, up (auto|x|y|z),
/// title. Requires the chosen property. Reads the document only; writes the file atomically
/// (temporary file renamed into place). Report data: file, property, scale_min, scale_max.
class RenderFilter : public Filter {
 public:
  std::string name() const override { return "render"; }
  std::string description() const override;
  std::vector<ParamSpec> params() const override;
  std::vector<std::string>
  requires(const ParamMap& params) const override;
  /// \throw InvalidParameter (file empty or not *.png), MissingProperty (the property is
  ///        absent), IoError (the file's directory does not exist or is not writable, or
  ///        writing failed; no file is left behind).
  /// The file parameter: given, a .png, in an existing directory.
  void check(const Document& doc, const ParamMap& params) const override;
  FilterResult apply(Document& doc, const ParamMap& params) const override;
};

}  // namespace diffreg
