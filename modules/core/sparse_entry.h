// Where an entry of a compressed sparse column matrix lives, for assemblies that add into a
// pattern built beforehand.
#pragma once

namespace diffreg {

/// The position of A(row, col) in A's values, for an entry in A's pattern (the column's rows
/// sorted, as `outer` and `inner` of a compressed column-major matrix hold them): a binary
/// search without data-dependent branches. Its steps depend on the column's length alone;
/// std::lower_bound's branches mispredicted about every other step and held about half of the
/// deformation system's assembly time.
inline int entryIndex(const int* outer, const int* inner, int row, int col) {
  const int* base = inner + outer[col];
  int len = outer[col + 1] - outer[col];
  while (len > 1) {
    const int half = len / 2;
    base = base[half] <= row ? base + half : base;
    len -= half;
  }
  return static_cast<int>(base - inner);
}

}  // namespace diffreg
