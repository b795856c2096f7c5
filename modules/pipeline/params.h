// Parameter tables: each filter declares its parameters once (name, type, default, range,
// help); the CLI, the help text and scripts are all generated from these tables.
#pragma once

#include <diffreg/core/names.h>
#include <diffreg/core/text.h>  // formatNumber, the canonical text of Float parameters

#include <map>
#include <set>
#include <string>
#include <vector>

namespace diffreg {

enum class ParamType { Float, Int, Bool, Enum, String };
const char* toString(ParamType type);

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::Float;
  std::string defaultValue;          ///< as text, e.g. "0.01", "true", "second"
  double min = -1e300, max = 1e300;  ///< inclusive range for Float and Int
  std::vector<std::string> choices;  ///< Enum values
  std::string help;
};

/// Table rows, one per parameter type; defaults are given as the text a user would type.
ParamSpec floatParam(const std::string& name, const std::string& defaultValue, double min,
                     double max, const std::string& help);
ParamSpec intParam(const std::string& name, const std::string& defaultValue, double min,
                   double max, const std::string& help);
ParamSpec boolParam(const std::string& name, bool defaultValue, const std::string& help);
ParamSpec enumParam(const std::string& name, const std::string& defaultValue,
                    const std::vector<std::string>& choices, const std::string& help);
ParamSpec stringParam(const std::string& name, const std::string& defaultValue,
                      const std::string& help);
/// An enum parameter whose choices are the enum's name table (core/names.h), optionally after
/// extra choices such as "auto".
template <class E>
ParamSpec enumParam(const std::string& name, E defaultValue, const std::string& help) {
  return enumParam(name, toString(defaultValue), enumNames<E>(), help);
}

/// Validated values of one filter invocation, every parameter present (defaults filled in).
class ParamMap {
 public:
  ParamMap() = default;
  /// Validates `values` (name -> text) against `specs` and fills in defaults.
  /// \throw InvalidParameter for an unknown name (listing the valid ones), a value of the wrong
  ///        type, out of range, or not among the choices — naming the filter and parameter.
  ParamMap(const std::string& filter, const std::vector<ParamSpec>& specs,
           const std::map<std::string, std::string>& values);

  /// Typed values. \throw std::logic_error for a name not in the filter's table (a bug in the
  /// filter, not a user error).
  double getFloat(const std::string& name) const;
  int getInt(const std::string& name) const;
  bool getBool(const std::string& name) const;
  std::string getString(const std::string& name) const;  ///< Enum and String
  /// The canonical text of every value (for reports and scripts).
  const std::map<std::string, std::string>& text() const { return text_; }
  /// Whether the caller chose `name`: gave it a value other than its default. (MeshLab's
  /// scripts spell out every parameter, defaults included.)
  bool given(const std::string& name) const { return given_.count(name) > 0; }

 private:
  const std::string& raw(const std::string& name) const;
  std::string filter_;
  std::map<std::string, std::string> text_;
  std::set<std::string> given_;
};

/// Whether a Float or Int parameter has a finite bound (min > -1e300 or max < 1e300).
bool hasRange(const ParamSpec& spec);
/// The range as text, "[1e-12, 1e6]" (Int bounds as whole numbers: "[1, 100000]").
std::string rangeText(const ParamSpec& spec);

/// Parses "name key=value key=value ..." into a filter name and its raw values.
/// Tokens are separated by whitespace; '...' or "..." keep whitespace inside a value.
/// \throw InvalidParameter for an empty spec, a token without '=', a key given twice or an
///        unterminated quote.
std::pair<std::string, std::map<std::string, std::string>> parseFilterSpec(const std::string& spec);

}  // namespace diffreg
