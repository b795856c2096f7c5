#include <diffreg/core/heap.h>

#include <cstdint>
#include <cstdlib>

#if defined(__GLIBC__)
#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>
#endif

namespace diffreg {

#if defined(__GLIBC__)
namespace {
// The heap below the advised reserve, kept out of use (volatile: the block is never read,
// and an allocation that is never read may be left out).
void* volatile g_unadvised = nullptr;
}  // namespace
#endif

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
  constexpr std::size_t kProbe = 4 * kMiB;
  void* const probe = std::malloc(kProbe);
  char* const end = static_cast<char*>(sbrk(0));
  const auto at = reinterpret_cast<std::uintptr_t>(probe);
  const auto top = reinterpret_cast<std::uintptr_t>(end);
  constexpr std::uintptr_t kHuge = 2 * kMiB;  // x86-64 and arm64 (4 KiB pages) huge page size
  // Allocating the probe wrote the heap's new top header just past it, before any advice: the
  // 4 KiB page it touched gave its 2 MiB block a page table, and a block with one takes no
  // huge page on a later fault (each of its pages faults on its own). The reserve is
  // advised from the first boundary past that header.
  const std::uintptr_t past = at + kProbe + 4 * sizeof(std::size_t);
  const std::uintptr_t from = (past + kHuge - 1) & ~(kHuge - 1), to = top & ~(kHuge - 1);
  const bool inHeap = probe != nullptr && end != before && at < top && top - at < 2048 * kMiB;
  if (inHeap && from < to)
    done.hugePages = madvise(reinterpret_cast<void*>(from), to - from, MADV_HUGEPAGE) == 0;
  std::free(probe);
  // The stretch from the probe to `from` (4 to 6 MiB) is heap without the advice, where the
  // run's first blocks (the input file's text, the first arrays) would each take a fault per
  // 4 KiB page. A block that is never freed covers it, so that the next block from the heap's
  // top starts at `from`: address space only, never touched past its header. The probe's chunk
  // merged back into the top, so a block of `from - at` bytes less one header ends at `from`
  // less one header.
  if (done.hugePages) g_unadvised = std::malloc(from - at - sizeof(std::size_t));
  // Past the reserve the heap grows as by default (glibc's 128 KiB pad), in address space that
  // is not advised.
  mallopt(M_TOP_PAD, static_cast<int>(kMiB / 8));
#endif
#endif
  return done;
}

}  // namespace diffreg
