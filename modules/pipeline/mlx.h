// MeshLab FilterScripts (.mlx): reading a script into pipeline steps and writing steps as a
// script, with the parameter types mapped through the filters' own parameter tables.
//
//   <!DOCTYPE FilterScript>
//   <FilterScript>
//    <filter name="deform">
//     <Param name="energy" type="RichEnum" value="0" enum_cardinality="4" enum_val0="arap" .../>
//     <Param name="beta" type="RichAbsPerc" value="0.5" min="0" max="1" .../>
//    </filter>
//   </FilterScript>
//
// Types: Float <-> RichFloat (RichAbsPerc with min/max when both bounds are finite; reading also
// accepts RichDynamicFloat), Int <-> RichInt, Bool <-> RichBool ("true"/"false"), Enum <->
// RichEnum (the value is the index into the choices; enum_valN name them), String <->
// RichString.
#pragma once

#include <diffreg/pipeline/pipeline.h>

#include <string>
#include <vector>

namespace diffreg {

/// The MeshLab type name written for a parameter ("RichFloat", "RichAbsPerc", "RichInt",
/// "RichBool", "RichEnum", "RichString").
std::string mlxType(const ParamSpec& spec);

/// Parses a FilterScript into steps, one per <filter>, in order. Each step holds the canonical
/// text of the parameters the script gives (Enum indices turned into choice names); parameters
/// the script leaves out take their defaults when the step runs. `source` names the text in
/// messages (usually the file path).
/// \throw InvalidParameter "source:line: ..." for malformed XML, a root other than
///        <FilterScript>, an element other than <filter>/<Param>, an unknown filter (listing the
///        registered ones), an unknown parameter (listing the filter's), a parameter given twice,
///        a Rich type that does not match the parameter's type (naming the expected one), a
///        value that does not parse, is out of range or is not among the choices (listing them).
std::vector<Step> parseFilterScript(const std::string& text, const std::string& source,
                                    const Registry& registry = Registry::builtin());

/// Reads a FilterScript file (see parseFilterScript).
/// \throw IoError missing or unreadable file; InvalidParameter as parseFilterScript.
std::vector<Step> readFilterScript(const std::string& path,
                                   const Registry& registry = Registry::builtin());

/// Writes `steps` as a FilterScript in MeshLab's format, every parameter of every filter
/// present (defaults filled in), with descriptions and tooltips from the parameter tables.
/// parseFilterScript reads it back to the same canonical values.
/// \throw InvalidParameter for an unknown filter or an invalid value in `steps`.
std::string writeFilterScript(const std::vector<Step>& steps,
                              const Registry& registry = Registry::builtin());

/// A FilterScript with every registered filter (in name order) and every parameter at its
/// default: the template `diffreg filters --mlx` prints.
std::string defaultFilterScript(const Registry& registry = Registry::builtin());

}  // namespace diffreg
