// One name table per enum: printing (toString), parsing (with a one-line error that names the
// parameter and lists the valid names) and the filters' enum parameters all read it, so the
// names of an enum are written once. A table is a specialization of EnumTable next to its enum:
//
//     template <> struct EnumTable<Energy> {
//       static constexpr const char* parameter = "energy";  // the parameter it is given as
//       static constexpr const char* noun = "energy";       // what one value is called
//       static constexpr EnumName<Energy> names[] = {{Energy::Arap, "arap"}, ...};
//     };
#pragma once

#include <diffreg/core/error.h>

#include <string>
#include <type_traits>
#include <vector>

namespace diffreg {

template <class E>
struct EnumName {
  E value;
  const char* name;
};

template <class E>
struct EnumTable;  // specialized per enum

template <class E, class = void>
struct HasEnumTable : std::false_type {};
template <class E>
struct HasEnumTable<E, std::void_t<decltype(EnumTable<E>::names)>> : std::true_type {};

/// The name of an enumerator ("?" for a value outside the table).
template <class E, std::enable_if_t<HasEnumTable<E>::value, int> = 0>
const char* toString(E value) {
  for (const EnumName<E>& n : EnumTable<E>::names)
    if (n.value == value) return n.name;
  return "?";
}

/// Every name, in the table's order.
template <class E>
std::vector<std::string> enumNames() {
  std::vector<std::string> names;
  for (const EnumName<E>& n : EnumTable<E>::names) names.emplace_back(n.name);
  return names;
}

/// The enumerator called `name`.
/// \throw InvalidParameter "<parameter>: unknown <noun> '<name>' (valid: a, b, c)".
/// `parameter`: what the caller calls the value, when it is not the table's parameter name
/// (e.g. a JSON field of the editor's API).
template <class E>
E parseEnum(const std::string& name, const std::string& parameter = EnumTable<E>::parameter) {
  std::string valid;
  for (const EnumName<E>& n : EnumTable<E>::names) {
    if (name == n.name) return n.value;
    valid += (valid.empty() ? "" : ", ") + std::string(n.name);
  }
  throw InvalidParameter(parameter + ": unknown " + EnumTable<E>::noun + " '" + name +
                         "' (valid: " + valid + ")");
}

}  // namespace diffreg
