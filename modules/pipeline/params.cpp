#include <diffreg/pipeline/params.h>

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>

#include <cctype>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace diffreg {

namespace {

ParamSpec row(const std::string& name, ParamType type, const std::string& defaultValue,
              const std::string& help) {
  ParamSpec spec;
  spec.name = name;
  spec.type = type;
  spec.defaultValue = defaultValue;
  spec.help = help;
  return spec;
}

}  // namespace

ParamSpec floatParam(const std::string& name, const std::string& defaultValue, double min,
                     double max, const std::string& help) {
  ParamSpec spec = row(name, ParamType::Float, defaultValue, help);
  spec.min = min;
  spec.max = max;
  return spec;
}

ParamSpec intParam(const std::string& name, const std::string& defaultValue, double min,
                   double max, const std::string& help) {
  ParamSpec spec = row(name, ParamType::Int, defaultValue, help);
  spec.min = min;
  spec.max = max;
  return spec;
}

ParamSpec boolParam(const std::string& name, bool defaultValue, const std::string& help) {
  return row(name, ParamType::Bool, defaultValue ? "true" : "false", help);
}

ParamSpec enumParam(const std::string& name, const std::string& defaultValue,
                    const std::vector<std::string>& choices, const std::string& help) {
  ParamSpec spec = row(name, ParamType::Enum, defaultValue, help);
  spec.choices = choices;
  return spec;
}

ParamSpec stringParam(const std::string& name, const std::string& defaultValue,
                      const std::string& help) {
  return row(name, ParamType::String, defaultValue, help);
}

const char* toString(ParamType type) {
  switch (type) {
    case ParamType::Float:
      return "float";
    case ParamType::Int:
      return "int";
    case ParamType::Bool:
      return "bool";
    case ParamType::Enum:
      return "enum";
    case ParamType::String:
      return "string";
  }
  return "?";
}

bool hasRange(const ParamSpec& spec) {
  return (spec.type == ParamType::Float || spec.type == ParamType::Int) &&
         (spec.min > -1e300 || spec.max < 1e300);
}

std::string rangeText(const ParamSpec& spec) {
  auto bound = [&](double v) {
    if (spec.type == ParamType::Int && std::abs(v) < 1e18) return std::to_string(std::llround(v));
    return formatNumber(v);
  };
  return "[" + bound(spec.min) + ", " + bound(spec.max) + "]";
}

namespace {

std::string join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Canonical text of `value` for `spec`, or throws InvalidParameter naming filter and parameter.
std::string canonical(const std::string& filter, const ParamSpec& spec, const std::string& value) {
  const std::string culprit =
      "filter " + filter + ": parameter '" + spec.name + "' = '" + value + "' ";
  const bool blank = value.empty() || std::isspace(static_cast<unsigned char>(value.front())) ||
                     std::isspace(static_cast<unsigned char>(value.back()));
  auto checkRange = [&](double v) {
    if (v < spec.min || v > spec.max)
      throw InvalidParameter(culprit + "is out of range " + rangeText(spec));
  };
  switch (spec.type) {
    case ParamType::Float: {
      char* end = nullptr;
      const double v = blank ? 0.0 : std::strtod(value.c_str(), &end);
      if (blank || *end != '\0') throw InvalidParameter(culprit + "is not a number");
      if (!std::isfinite(v)) throw InvalidParameter(culprit + "is not a finite number");
      checkRange(v);
      return formatNumber(v);
    }
    case ParamType::Int: {
      char* end = nullptr;
      errno = 0;
      const long long v = blank ? 0 : std::strtoll(value.c_str(), &end, 10);
      if (blank || *end != '\0') throw InvalidParameter(culprit + "is not an integer");
      if (errno == ERANGE || v < INT_MIN || v > INT_MAX) {
        throw InvalidParameter(culprit + "is out of range " + rangeText(spec));
      }
      checkRange(static_cast<double>(v));
      return std::to_string(v);
    }
    case ParamType::Bool: {
      const std::string v = lower(value);
      if (v == "true" || v == "1" || v == "yes") return "true";
      if (v == "false" || v == "0" || v == "no") return "false";
      throw InvalidParameter(culprit + "is not one of: true, false, 1, 0, yes, no");
    }
    case ParamType::Enum:
      for (const auto& choice : spec.choices)
        if (choice == value) return value;
      throw InvalidParameter(culprit + "is not one of: " + join(spec.choices, ", "));
    case ParamType::String:
      return value;
  }
  return value;
}

}  // namespace

ParamMap::ParamMap(const std::string& filter, const std::vector<ParamSpec>& specs,
                   const std::map<std::string, std::string>& values)
    : filter_(filter) {
  for (const auto& [name, value] : values) {
    // A NUL would end the number (strtod) and every message there: what follows would be lost.
    if (name.find('\0') != std::string::npos || value.find('\0') != std::string::npos)
      throw InvalidParameter("filter " + filter + ": parameter '" + nulShown(name) + "' = '" +
                             nulShown(value) + "' has a NUL byte");
    bool known = false;
    for (const auto& spec : specs) known = known || spec.name == name;
    if (!known) {
      std::vector<std::string> names;
      for (const auto& spec : specs) names.push_back(spec.name);
      throw InvalidParameter("filter " + filter + " has no parameter '" + name + "' (" +
                             (names.empty() ? std::string("it takes no parameters")
                                            : "parameters: " + join(names, ", ")) +
                             ")");
    }
  }
  for (const auto& spec : specs) {
    const auto it = values.find(spec.name);
    text_[spec.name] = canonical(filter, spec, it != values.end() ? it->second : spec.defaultValue);
    if (it != values.end() && text_[spec.name] != canonical(filter, spec, spec.defaultValue))
      given_.insert(spec.name);
  }
}

const std::string& ParamMap::raw(const std::string& name) const {
  const auto it = text_.find(name);
  if (it == text_.end())
    throw std::logic_error("filter " + filter_ + " reads undeclared parameter '" + name + "'");
  return it->second;
}

double ParamMap::getFloat(const std::string& name) const {
  return std::strtod(raw(name).c_str(), nullptr);
}

int ParamMap::getInt(const std::string& name) const {
  return static_cast<int>(std::strtol(raw(name).c_str(), nullptr, 10));
}

bool ParamMap::getBool(const std::string& name) const { return raw(name) == "true"; }

std::string ParamMap::getString(const std::string& name) const { return raw(name); }

std::pair<std::string, std::map<std::string, std::string>> parseFilterSpec(
    const std::string& spec) {
  // A NUL would end every message (and every number) there: what follows it would be lost.
  if (spec.find('\0') != std::string::npos)
    throw InvalidParameter("filter '" + nulShown(spec) + "': the specification has a NUL byte");
  // Split on whitespace; '...' or "..." keep whitespace inside a token and are removed.
  std::vector<std::string> tokens;
  std::string token;
  bool inToken = false;
  char quote = 0;
  for (const char c : spec) {
    if (quote) {
      if (c == quote) {
        quote = 0;
      } else {
        token += c;
      }
    } else if (c == '\'' || c == '"') {
      quote = c;
      inToken = true;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      if (inToken) tokens.push_back(token);
      token.clear();
      inToken = false;
    } else {
      token += c;
      inToken = true;
    }
  }
  if (quote) throw InvalidParameter("filter '" + spec + "': unterminated quote");
  if (inToken) tokens.push_back(token);

  if (tokens.empty()) throw InvalidParameter("empty filter specification");
  std::pair<std::string, std::map<std::string, std::string>> result;
  result.first = tokens[0];
  if (result.first.find('=') != std::string::npos)
    throw InvalidParameter("filter '" + spec + "' does not start with a filter name");
  for (size_t i = 1; i < tokens.size(); ++i) {
    const auto eq = tokens[i].find('=');
    if (eq == std::string::npos || eq == 0) {
      throw InvalidParameter("filter " + result.first + ": '" + tokens[i] +
                             "' is not of the form key=value");
    }
    const std::string key = tokens[i].substr(0, eq);
    if (!result.second.emplace(key, tokens[i].substr(eq + 1)).second)
      throw InvalidParameter("filter " + result.first + ": parameter '" + key + "' given twice");
  }
  return result;
}

}  // namespace diffreg
