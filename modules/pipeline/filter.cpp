#include <diffreg/pipeline/filter.h>

#include <diffreg/core/error.h>

#include <algorithm>
#include <set>
#include <stdexcept>

namespace diffreg {

void Registry::add(std::unique_ptr<Filter> filter) {
  if (!filter) throw std::logic_error("Registry::add: null filter");
  const std::string name = filter->name();
  if (name.empty() || name.find_first_of(" \t\n=") != std::string::npos)
    throw std::logic_error("Registry::add: invalid filter name '" + name + "'");
  if (has(name)) throw std::logic_error("Registry::add: filter " + name + " registered twice");
  // The table must be self-consistent: unique names and valid defaults.
  std::set<std::string> seen;
  for (const auto& spec : filter->params()) {
    if (!seen.insert(spec.name).second)
      throw std::logic_error("filter " + name + " declares parameter '" + spec.name + "' twice");
  }
  try {
    ParamMap(name, filter->params(), {});
  } catch (const InvalidParameter& e) {
    throw std::logic_error(std::string("invalid default value: ") + e.what());
  }
  filters_.push_back(std::move(filter));
}

bool Registry::has(const std::string& name) const {
  return std::any_of(filters_.begin(), filters_.end(),
                     [&](const auto& f) { return f->name() == name; });
}

const Filter& Registry::get(const std::string& name) const {
  for (const auto& f : filters_)
    if (f->name() == name) return *f;
  std::string list;
  for (const auto& n : names()) list += (list.empty() ? "" : ", ") + n;
  throw InvalidParameter("unknown filter '" + name + "' (filters: " +
                         (list.empty() ? std::string("none registered") : list) + ")");
}

std::vector<std::string> Registry::names() const {
  std::vector<std::string> out;
  for (const auto& f : filters_) out.push_back(f->name());
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace diffreg
