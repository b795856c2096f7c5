#include <diffreg/pipeline/pipeline.h>

#include <diffreg/core/error.h>
#include <diffreg/core/text.h>
#include <diffreg/core/timer.h>

#include <map>
#include <set>

namespace diffreg {

Pipeline& Pipeline::add(const std::string& filter,
                        const std::map<std::string, std::string>& values) {
  return add(Step{filter, values});
}

Pipeline& Pipeline::add(Step step) {
  steps_.push_back(std::move(step));
  return *this;
}

namespace {

// `e` again, as its own type E, with the origin of steps[at] in front (when it has one).
template <class E>
[[noreturn]] void rethrowFrom(const std::vector<Step>& steps, size_t at, const E& e) {
  if (at >= steps.size() || steps[at].origin.empty()) throw e;
  throw E(steps[at].origin + ": " + e.what());
}

// work(), with an error in step `at` (as work() leaves it) naming the script and the line that
// step was written at, as its own type.
template <class Work>
void namingTheStep(const std::vector<Step>& steps, const size_t& at, Work&& work) {
  try {
    work();
  } catch (const InvalidParameter& e) {
    rethrowFrom(steps, at, e);
  } catch (const MissingProperty& e) {
    rethrowFrom(steps, at, e);
  } catch (const IoError& e) {
    rethrowFrom(steps, at, e);
  } catch (const InvalidMesh& e) {
    rethrowFrom(steps, at, e);
  } catch (const NonFiniteSolution& e) {
    rethrowFrom(steps, at, e);
  } catch (const SingularSystem& e) {
    rethrowFrom(steps, at, e);
  }
}

}  // namespace

void Pipeline::check(const Document& doc) const {
  size_t at = 0;
  namingTheStep(steps_, at, [&] { checkSteps(doc, at); });
}

void Pipeline::checkSteps(const Document& doc, size_t& at) const {
  std::set<std::string> available, elementProperties;
  std::map<std::string, std::string> dropped;  // element property -> the step that removed it
  for (const auto& name : doc.mesh.vertexScalarNames()) available.insert(name);
  for (const auto& name : doc.mesh.elementScalarNames()) {
    available.insert(name);
    elementProperties.insert(name);
  }

  for (size_t i = 0; i < steps_.size(); ++i) {
    at = i;
    const Filter& filter = registry_.get(steps_[i].filter);
    const ParamMap params(filter.name(), filter.params(), steps_[i].values);
    if (filter.needsHandles() && doc.handles.empty())
      throw InvalidParameter(doc.missingHandles(filter.name()));
    filter.check(doc, params);
    for (const auto& property : filter.requires(params)) {
      if (available.count(property)) continue;
      std::string providers;
      for (const auto& name : registry_.names()) {
        const Filter& other = registry_.get(name);
        for (const auto& p : other.produces(ParamMap(name, other.params(), {}))) {
          if (p == property) providers += (providers.empty() ? "" : ", ") + name;
        }
      }
      throw MissingProperty("step " + std::to_string(i + 1) + " (filter " + filter.name() +
                            ") needs property '" + property +
                            "', which neither the mesh nor an earlier step provides" +
                            (dropped.count(property) ? " (" + dropped[property] + " removed it)"
                                                     : std::string()) +
                            (providers.empty() ? std::string(" (no filter produces it)")
                                               : "; run " + providers + " before it"));
    }
    if (filter.dropsElementProperties()) {
      for (const auto& property : elementProperties) {
        available.erase(property);
        dropped[property] = "step " + std::to_string(i + 1) + " (" + filter.name() + ")";
      }
      elementProperties.clear();
    }
    for (const auto& property : filter.produces(params)) {
      available.insert(property);
      // Every produced property but the weights lives on elements (mesh/mesh.h, prop).
      if (property != prop::weight) elementProperties.insert(property);
    }
  }
}

nlohmann::json Pipeline::run(Document& doc) const {
  check(doc);
  nlohmann::json report;
  report["mesh"] = {{"path", escapeNonUtf8(doc.path)},
                    {"kind", toString(doc.mesh.kind())},
                    {"vertices", doc.mesh.numVertices()},
                    {"elements", doc.mesh.numElements()}};
  report["filters"] = nlohmann::json::array();
  for (size_t at = 0; at < steps_.size(); ++at) {
    const Step& step = steps_[at];
    const Filter& filter = registry_.get(step.filter);
    const ParamMap params(filter.name(), filter.params(), step.values);
    Timer timer;
    FilterResult result;
    namingTheStep(steps_, at, [&] { result = filter.apply(doc, params); });
    const double seconds = timer.seconds();

    nlohmann::json entry = nlohmann::json::object();
    if (result.data.is_object()) {
      entry = result.data;
    } else if (!result.data.is_null()) {
      entry["data"] = result.data;
    }
    entry["name"] = filter.name();
    entry["params"] = params.text();
    entry["seconds"] = seconds;
    entry["symbolic"] = result.stats.symbolic;
    entry["numeric"] = result.stats.numeric;
    entry["solves"] = result.stats.solves;
    entry["symbolic_seconds"] = result.stats.symbolicSeconds;
    entry["numeric_seconds"] = result.stats.numericSeconds;
    entry["solve_seconds"] = result.stats.solveSeconds;
    report["filters"].push_back(std::move(entry));
  }
  return report;
}

}  // namespace diffreg
