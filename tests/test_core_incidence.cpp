// incidenceOf (modules/core/incidence.h): the items naming each key, as compressed lists.
#include <diffreg/core/incidence.h>

#include <array>
#include <catch2/catch.hpp>
#include <vector>

using diffreg::Incidence;
using diffreg::incidenceOf;

TEST_CASE("incidenceOf lists every slot under its key, in item then slot order", "[core]") {
  // Five triangles over seven keys; key 6 is named by none, key 2 twice by item 3.
  const std::vector<std::array<int, 3>> items = {
      {0, 1, 2}, {2, 1, 3}, {3, 4, 0}, {2, 5, 2}, {5, 4, 1}};
  const Incidence in = incidenceOf(
      7, 5, 3, [&items](int i, int s) { return items[static_cast<size_t>(i)][s]; },
      [](int i, int s) { return i * 3 + s; });
  REQUIRE(in.start.size() == 8u);
  CHECK(in.start.back() == 15);
  // The brute-force lists: scan the items in order.
  for (int key = 0; key < 7; ++key) {
    std::vector<int> expected;
    for (int i = 0; i < 5; ++i)
      for (int s = 0; s < 3; ++s)
        if (items[static_cast<size_t>(i)][s] == key) expected.push_back(i * 3 + s);
    const std::vector<int> listed(in.entries.begin() + in.begin(key),
                                  in.entries.begin() + in.end(key));
    CHECK(listed == expected);
  }
}

TEST_CASE("incidenceOf of no items gives empty lists", "[core]") {
  const Incidence in = incidenceOf(
      3, 0, 4, [](int, int) { return 0; }, [](int i, int) { return i; });
  CHECK(in.start == std::vector<int>(4, 0));
  CHECK(in.entries.empty());
}
