#include <diffreg/pipeline/mlx.h>

#include <diffreg/core/error.h>
#include <diffreg/core/xml.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>

namespace diffreg {
namespace {

std::string join(const std::vector<std::string>& items, const char* separator = ", ") {
  std::string out;
  for (size_t i = 0; i < items.size(); ++i) out += (i ? separator : "") + items[i];
  return out;
}

/// "0 = arap, 1 = asap, ..." for messages about enum indices.
std::string indexedChoices(const ParamSpec& spec) {
  std::vector<std::string> items;
  for (size_t i = 0; i < spec.choices.size(); ++i)
    items.push_back(std::to_string(i) + " = " + spec.choices[i]);
  return join(items);
}

/// The Rich types a script may give for a parameter of `spec`'s type.
std::vector<std::string> acceptedTypes(const ParamSpec& spec) {
  switch (spec.type) {
    case ParamType::Float:
      return {"RichFloat", "RichAbsPerc", "RichDynamicFloat"};
    case ParamType::Int:
      return {"RichInt"};
    case ParamType::Bool:
      return {"RichBool"};
    case ParamType::Enum:
      return {"RichEnum"};
    case ParamType::String:
      return {"RichString"};
  }
  return {};
}

/// The parameter's type as `diffreg filters` shows it: "int in [1, 100000]", "enum: a | b".
std::string typeText(const ParamSpec& spec) {
  std::string type = toString(spec.type);
  if (spec.type == ParamType::Enum) type += ": " + join(spec.choices, " | ");
  if (hasRange(spec)) type += " in " + rangeText(spec);
  return type;
}

/// Parses a whole-string number; false when `text` is not one.
bool parseDouble(const std::string& text, double* value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return *end == '\0' && std::isfinite(*value);
}

bool parseIndex(const std::string& text, long* value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  char* end = nullptr;
  errno = 0;
  *value = std::strtol(text.c_str(), &end, 10);
  return *end == '\0' && errno == 0;
}

class ScriptReader {
 public:
  ScriptReader(const std::string& source, const Registry& registry)
      : source_(source), registry_(registry) {}

  std::vector<Step> read(const XmlDocument& doc) {
    line_ = doc.root.line;
    if (doc.root.name != "FilterScript") {
      fail("the root element is <" + doc.root.name +
           ">; a MeshLab filter script has <FilterScript> (with <filter> elements inside)");
    }
    std::vector<Step> steps;
    for (const XmlElement& element : doc.root.children) {
      line_ = element.line;
      if (element.name == "xmlfilter") {
        fail("<xmlfilter> (MeshLab's XML-plugin filters) is not supported; use <filter>");
      }
      if (element.name != "filter") {
        fail("unexpected <" + element.name + "> inside <FilterScript> (expected <filter>)");
      }
      steps.push_back(readFilter(element));
    }
    return steps;
  }

 private:
  [[noreturn]] void fail(const std::string& message) const {
    throw InvalidParameter(source_ + ":" + std::to_string(line_) + ": " + message);
  }

  Step readFilter(const XmlElement& element) {
    const std::string* name = element.attribute("name");
    if (!name) fail("<filter> without a name attribute");
    const Filter* filter = nullptr;
    try {
      filter = &registry_.get(*name);
    } catch (const InvalidParameter& e) {
      fail(e.what());
    }
    const std::vector<ParamSpec> specs = filter->params();
    Step step;
    step.filter = *name;
    step.origin = source_ + ":" + std::to_string(element.line);
    for (const XmlElement& param : element.children) {
      line_ = param.line;
      if (param.name != "Param") {
        fail("unexpected <" + param.name + "> inside <filter name=\"" + *name +
             "\"> (expected <Param>)");
      }
      const auto [key, value] = readParam(*name, specs, param);
      if (!step.values.emplace(key, value).second) {
        fail("filter " + *name + ": parameter '" + key + "' given twice");
      }
    }
    return step;
  }

  std::pair<std::string, std::string> readParam(const std::string& filter,
                                                const std::vector<ParamSpec>& specs,
                                                const XmlElement& param) {
    for (const char* required : {"name", "type", "value"}) {
      if (!param.attribute(required)) {
        fail("filter " + filter + ": <Param> without a " + required + " attribute");
      }
    }
    const std::string& name = *param.attribute("name");
    const std::string& type = *param.attribute("type");
    const std::string& value = *param.attribute("value");
    const ParamSpec* spec = nullptr;
    for (const auto& s : specs)
      if (s.name == name) spec = &s;
    if (!spec) {
      std::vector<std::string> names;
      for (const auto& s : specs) names.push_back(s.name);
      fail("filter " + filter + " has no parameter '" + name + "' (" +
           (names.empty() ? std::string("it takes no parameters")
                          : "parameters: " + join(names)) +
           ")");
    }
    const auto accepted = acceptedTypes(*spec);
    if (std::find(accepted.begin(), accepted.end(), type) == accepted.end()) {
      fail("filter " + filter + ": parameter '" + name + "' has type " + type + "; expected " +
           join(accepted, " or ") + " (" + typeText(*spec) + ")");
    }
    const std::string culprit = "filter " + filter + ": parameter '" + name + "' = '" + value + "' ";

    std::string text = value;
    if (spec->type == ParamType::Float && type != "RichFloat") {
      // RichAbsPerc / RichDynamicFloat carry their own [min, max]; the value must respect it.
      double v = 0.0, lo = -INFINITY, hi = INFINITY;
      for (const auto& [attr, bound] : {std::pair{"min", &lo}, std::pair{"max", &hi}}) {
        if (const std::string* b = param.attribute(attr)) {
          if (!parseDouble(*b, bound)) {
            fail(culprit + "has " + attr + "=\"" + *b + "\", which is not a number");
          }
        }
      }
      if (parseDouble(value, &v) && (v < lo || v > hi)) {
        fail(culprit + "is outside the script's own range [" + formatNumber(lo) + ", " +
             formatNumber(hi) + "]");
      }
    } else if (spec->type == ParamType::Enum) {
      long index = 0;
      if (!parseIndex(value, &index)) {
        fail(culprit + "is not an index of the choices (" + indexedChoices(*spec) + ")");
      }
      // MeshLab writes how many choices the script lists: the index must be one of them.
      if (const std::string* count = param.attribute("enum_cardinality")) {
        long n = 0;
        if (!parseIndex(*count, &n) || n < 1)
          fail(culprit + "has enum_cardinality=\"" + *count + "\", which is not a count");
        if (index < 0 || index >= n)
          fail(culprit + "is not an index below its enum_cardinality " + *count);
      }
      if (const std::string* label = param.attribute("enum_val" + std::to_string(index))) {
        // The script names its choice: take it by name, so a script whose list is ordered
        // differently still means what it says.
        if (std::find(spec->choices.begin(), spec->choices.end(), *label) == spec->choices.end()) {
          fail(culprit + "names the choice '" + *label + "' (enum_val" + std::to_string(index) +
               "), which is not one of: " + join(spec->choices));
        }
        text = *label;
      } else {
        if (index < 0 || index >= static_cast<long>(spec->choices.size())) {
          fail(culprit + "is not an index of the choices (" + indexedChoices(*spec) + ")");
        }
        text = spec->choices[static_cast<size_t>(index)];
      }
    }
    try {
      const ParamMap checked(filter, specs, {{name, text}});
      return {name, checked.text().at(name)};
    } catch (const InvalidParameter& e) {
      fail(e.what());
    }
  }

  std::string source_;
  const Registry& registry_;
  int line_ = 0;
};

}  // namespace

std::string mlxType(const ParamSpec& spec) {
  switch (spec.type) {
    case ParamType::Float:
      return spec.min > -1e300 && spec.max < 1e300 ? "RichAbsPerc" : "RichFloat";
    case ParamType::Int:
      return "RichInt";
    case ParamType::Bool:
      return "RichBool";
    case ParamType::Enum:
      return "RichEnum";
    case ParamType::String:
      return "RichString";
  }
  return "RichString";
}

std::vector<Step> parseFilterScript(const std::string& text, const std::string& source,
                                    const Registry& registry) {
  return ScriptReader(source, registry).read(parseXml(text, source));
}

std::vector<Step> readFilterScript(const std::string& path, const Registry& registry) {
  return ScriptReader(path, registry).read(readXml(path, "filter script"));
}

std::string writeFilterScript(const std::vector<Step>& steps, const Registry& registry) {
  std::string out = "<!DOCTYPE FilterScript>\n<FilterScript>\n";
  for (const Step& step : steps) {
    const Filter& filter = registry.get(step.filter);
    const std::vector<ParamSpec> specs = filter.params();
    const ParamMap params(filter.name(), specs, step.values);
    out += " <filter name=\"" + xmlEscape(filter.name()) + "\">\n";
    for (const ParamSpec& spec : specs) {
      const std::string type = mlxType(spec);
      std::string value = params.text().at(spec.name);
      std::string extra;
      if (spec.type == ParamType::Enum) {
        const auto it = std::find(spec.choices.begin(), spec.choices.end(), value);
        value = std::to_string(it - spec.choices.begin());
        extra += " enum_cardinality=\"" + std::to_string(spec.choices.size()) + "\"";
        for (size_t i = 0; i < spec.choices.size(); ++i) {
          extra += " enum_val" + std::to_string(i) + "=\"" + xmlEscape(spec.choices[i]) + "\"";
        }
      } else if (type == "RichAbsPerc") {
        extra += " min=\"" + formatNumber(spec.min) + "\" max=\"" + formatNumber(spec.max) + "\"";
      }
      out += "  <Param name=\"" + xmlEscape(spec.name) + "\" type=\"" + type + "\" value=\"" +
             xmlEscape(value) + "\"" + extra + " description=\"" + xmlEscape(spec.name) +
             "\" tooltip=\"" + xmlEscape(spec.help) + "\"/>\n";
    }
    out += " </filter>\n";
  }
  out += "</FilterScript>\n";
  return out;
}

std::string defaultFilterScript(const Registry& registry) {
  std::vector<Step> steps;
  for (const auto& name : registry.names()) steps.push_back({name, {}});
  return writeFilterScript(steps, registry);
}

}  // namespace diffreg
