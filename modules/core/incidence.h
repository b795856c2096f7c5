// Compressed incidence lists: which items (elements, triangles) name each key (a vertex, an
// unknown) in one of their slots.
#pragma once

#include <cstddef>
#include <vector>

namespace diffreg {

/// The entries of key v are entries[start[v] .. start[v + 1]), in the order of their items and,
/// within an item, of its slots. Built by incidenceOf.
struct Incidence {
  std::vector<int> start, entries;
  int begin(int v) const { return start[static_cast<std::size_t>(v)]; }
  int end(int v) const { return start[static_cast<std::size_t>(v) + 1]; }
};

/// The incidence of `count` keys in `items` items of `slots` slots each: slot s of item i names
/// the key keyOf(i, s), in [0, count), and is listed under it as valueOf(i, s) (the item, or
/// i * slots + s where the slot matters). A counting sort, O(count + items * slots).
template <class KeyOf, class ValueOf>
Incidence incidenceOf(int count, int items, int slots, const KeyOf& keyOf, const ValueOf& valueOf) {
  Incidence incidence;
  std::vector<int>& start = incidence.start;
  start.assign(static_cast<std::size_t>(count) + 1, 0);
  for (int s = 0; s < slots; ++s)  // slot by slot: column-major element matrices
    for (int i = 0; i < items; ++i) ++start[static_cast<std::size_t>(keyOf(i, s)) + 1];
  for (int v = 0; v < count; ++v)
    start[static_cast<std::size_t>(v) + 1] += start[static_cast<std::size_t>(v)];
  incidence.entries.resize(static_cast<std::size_t>(start.back()));
  std::vector<int> fill(start.begin(), start.end() - 1);
  for (int i = 0; i < items; ++i)
    for (int s = 0; s < slots; ++s)
      incidence.entries[static_cast<std::size_t>(fill[static_cast<std::size_t>(keyOf(i, s))]++)] =
          valueOf(i, s);
  return incidence;
}

}  // namespace diffreg
