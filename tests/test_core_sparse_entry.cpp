// entryIndex (modules/core/sparse_entry.h): the place of an entry in a compressed column-major
// pattern.
#include <diffreg/core/sparse_entry.h>

#include <catch2/catch.hpp>
#include <vector>

TEST_CASE("entryIndex finds every entry of every column, of any length", "[core]") {
  // Columns of 0, 1, 2, 3, 5 and 8 rows, each sorted, with gaps between the rows.
  std::vector<int> outer = {0}, inner;
  for (int length : {0, 1, 2, 3, 5, 8}) {
    for (int i = 0; i < length; ++i) inner.push_back(3 * i + length);
    outer.push_back(static_cast<int>(inner.size()));
  }
  for (int col = 0; col + 1 < static_cast<int>(outer.size()); ++col)
    for (int at = outer[col]; at < outer[col + 1]; ++at)
      CHECK(diffreg::entryIndex(outer.data(), inner.data(), inner[at], col) == at);
}
