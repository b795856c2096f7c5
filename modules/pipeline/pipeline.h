// A pipeline: filters applied in order to a Document, with a JSON report.
#pragma once

#include <diffreg/pipeline/filter.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace diffreg {

struct Step {
  std::string filter;
  std::map<std::string, std::string> values;  ///< raw text values; defaults filled in on run
  /// Where the step was written ("script.mlx:12" for a script's <filter>; "" otherwise): the
  /// errors check() finds in it, and those its filter throws when it runs, start with this.
  std::string origin = {};
};

class Pipeline {
 public:
  explicit Pipeline(const Registry& registry = Registry::builtin()) : registry_(registry) {}
  Pipeline& add(const std::string& filter, const std::map<std::string, std::string>& values = {});
  Pipeline& add(Step step);
  const std::vector<Step>& steps() const { return steps_; }

  /// Checks every step before any work: known filters, valid parameters, handles present where
  /// needed, each filter's own checks (Filter::check), and each required property produced by
  /// the document or an earlier step.
  /// \throw InvalidParameter / MissingProperty naming the step, the property and the filter
  ///        that would provide it.
  void check(const Document& doc) const;
  /// check(), then applies every step. Returns the report: {"mesh": {...}, "filters": [...]}
  /// with per filter name, params, seconds, symbolic, numeric, solves and its data.
  nlohmann::json run(Document& doc) const;

 private:
  // check()'s work; `at` is the step being checked.
  void checkSteps(const Document& doc, size_t& at) const;

  const Registry& registry_;
  std::vector<Step> steps_;
};

}  // namespace diffreg
