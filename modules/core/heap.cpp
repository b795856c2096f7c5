#include <diffreg/core/heap.h>

#include <cstdint>
#include <cstdlib>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace diffreg {

HeapTuning tuneHeapForBatchRun() {
  HeapTuning done;
#if defined(__GLIBC__)
  constexpr std::size_t kMiB = std::size_t(1) << 20;
  // 32 MiB is glibc's largest mmap threshold on 64-bit systems; a trim threshold above the pad
  // keeps the advised reserve (giving it back and growing again would lose the advice).
  done.thresholds = mallopt(M_MMAP_THRESHOLD, static_cast<int>(32 * kMiB)) == 1 &&
                    mallopt(M_TRIM_THRESHOLD, static_cast<int>(1024 * kMiB)) == 1 &&
                    mallopt(M_TOP_PAD, static_cast<int>(256 * kMiB)) == 1;
#if defined(MADV_HUGEPAGE)
  if (!done.thresholds) return done;
  // A block larger than the heap at start makes the heap grow by it and the pad; the reserve is
  // then everything from the block to the heap's end.
  char* const before = static_cast<char*>(sbrk(0));
  void* const probe = std::malloc(4 * kMiB);
  char* const end = static_cast<char*>(sbrk(0));
  const auto at = reinterpret_cast<std::uintptr_t>(probe);
  const auto top = reinterpret_cast<std::uintptr_t>(end);
  constexpr std::uintptr_t kHuge = 2 * kMiB;  // x86-64 and arm64 (4 KiB pages) huge page size
  const std::uintptr_t from = (at + kHuge - 1) & ~(kHuge - 1), to = top & ~(kHuge - 1);
  const bool inHeap = probe != nullptr && end != before && at < top && top - at < 2048 * kMiB;
  if (inHeap && from < to)
    done.hugePages = madvise(reinterpret_cast<void*>(from), to - from, MADV_HUGEPAGE) == 0;
  std::free(probe);
  // Past the reserve the heap grows as by default (glibc's 128 KiB pad), in address space that
  // is not advised.
  mallopt(M_TOP_PAD, static_cast<int>(kMiB / 8));
#endif
#endif
  return done;
}

}  // namespace diffreg
