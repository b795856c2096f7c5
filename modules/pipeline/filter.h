// Filters (operators): a name, a description with its citation, a parameter table, the
// properties they need and produce, and apply(). Registered in a Registry.
#pragma once

#include <diffreg/pipeline/document.h>
#include <diffreg/pipeline/params.h>
#include <diffreg/solver/backend.h>

#include <nlohmann/json.hpp>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

/// What one filter application adds to the report.
struct FilterResult {
  nlohmann::json data = nlohmann::json::object();  ///< filter-specific results
  SolverStats stats;                               ///< solver work done by this filter
};

class Filter {
 public:
  virtual ~Filter() = default;
  virtual std::string name() const = 0;
  /// Long description with the citation of the method.
  virtual std::string description() const = 0;
  virtual std::vector<ParamSpec> params() const = 0;
  /// Vertex/element properties that must exist before apply (e.g. "diffreg:weight"); may depend
  /// on the parameters (e.g. only for regularization=nonuniform).
  virtual std::vector<std::string> requires(const ParamMap&) const { return {}; }
  virtual std::vector<std::string> produces(const ParamMap&) const { return {}; }
  /// Whether apply() removes every element property (e.g. filters that change the elements),
  /// so that later steps needing one must run a producer again.
  virtual bool dropsElementProperties() const { return false; }
  /// Whether the filter needs a handle set on the document.
  virtual bool needsHandles() const { return false; }
  /// Checks that need the document or the file system (e.g. that an output's directory
  /// exists), run by Pipeline::check before any step does work.
  /// \throw InvalidParameter / IoError naming the filter and the parameter.
  virtual void check(const Document&, const ParamMap&) const {}
  virtual FilterResult apply(Document& doc, const ParamMap& params) const = 0;
};

class Registry {
 public:
  void add(std::unique_ptr<Filter> filter);
  /// \throw InvalidParameter for an unknown name, listing the registered ones.
  const Filter& get(const std::string& name) const;
  bool has(const std::string& name) const;
  std::vector<std::string> names() const;
  /// The registry with every built-in filter (plugins/plugins.h fills it).
  static Registry& builtin();

 private:
  std::vector<std::unique_ptr<Filter>> filters_;
};

}  // namespace diffreg
