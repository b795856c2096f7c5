// tuneHeapForBatchRun (modules/core/heap.h): after it, the arrays of a run come from the main
// heap, stay there when freed, and the heap's reserve is advised for transparent huge pages.
#include <diffreg/core/heap.h>

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#if defined(__GLIBC__)
#include <sys/resource.h>
#include <unistd.h>
#endif

namespace {

// The mapping of /proc/self/smaps that holds the address: its header line and its VmFlags.
struct Mapping {
  std::string header, flags;
};

Mapping mappingOf(const void* address) {
  const auto at = reinterpret_cast<std::uintptr_t>(address);
  std::ifstream smaps("/proc/self/smaps");
  Mapping found;
  bool inside = false;
  for (std::string line; std::getline(smaps, line);) {
    unsigned long long lo = 0, hi = 0;
    if (std::sscanf(line.c_str(), "%llx-%llx ", &lo, &hi) == 2 && line.find(':') > line.find(' ')) {
      inside = lo <= at && at < hi;
      if (inside) found.header = line;
    } else if (inside && line.rfind("VmFlags:", 0) == 0) {
      found.flags = line;
    }
  }
  return found;
}

// The kernel's count of huge page faults that fell back to small pages (0 where it has none).
long thpFallbacks() {
  std::ifstream vmstat("/proc/vmstat");
  std::string name;
  long value = 0;
  while (vmstat >> name >> value)
    if (name == "thp_fault_fallback") return value;
  return 0;
}

}  // namespace

#if defined(__GLIBC__)
TEST_CASE("after tuneHeapForBatchRun large arrays come from the heap and stay there",
          "[core][heap]") {
  const diffreg::HeapTuning done = diffreg::tuneHeapForBatchRun();
  if (!done.thresholds) {  // another allocator in front of glibc's (a sanitizer, valgrind)
    WARN("glibc's malloc does not take the settings here: nothing to check");
    return;
  }
  std::ifstream mode("/sys/kernel/mm/transparent_hugepage/enabled");
  const std::string thp((std::istreambuf_iterator<char>(mode)), std::istreambuf_iterator<char>());
  const bool hugePages = !thp.empty() && thp.find("[never]") == std::string::npos;
  // The first large block, fresh from the heap's reserve: 8 MiB take 2,048 faults in 4 KiB
  // pages and about 5 in huge pages. A 2 MiB block that some page was touched in before the
  // advice (the heap's top header, written past the probe) takes its 512 pages one fault each.
  {
    constexpr std::size_t kSize = std::size_t(8) << 20;
    char* block = static_cast<char*>(std::malloc(kSize));
    REQUIRE(block != nullptr);
    const Mapping m = mappingOf(block);
    INFO(m.header << "\n" << m.flags);
    CHECK(m.header.find("[heap]") != std::string::npos);
    const auto faults = [] {
      rusage usage{};
      getrusage(RUSAGE_SELF, &usage);
      return usage.ru_minflt;
    };
    const long fallbacks = thpFallbacks(), before = faults();
    std::memset(block, 1, kSize);
    const long taken = faults() - before;
    std::free(block);
    if (hugePages) {
      // Advised from its first byte on: the stretch below the advice is kept out of use.
      CHECK(done.hugePages);
      CHECK(m.flags.find(" hg") != std::string::npos);
      // A kernel short of free huge pages falls back to small ones and counts it; a block with
      // a page table already is not even tried, and is not counted.
      if (thpFallbacks() == fallbacks)
        CHECK(taken < 256);
      else
        WARN("the kernel had no free huge page: the fault count is not checked");
    }
  }
  // 16 MiB: mapped on its own by glibc's default (128 KiB threshold), from the heap after.
  constexpr std::size_t kSize = std::size_t(16) << 20;
  void* block = std::malloc(kSize);
  REQUIRE(block != nullptr);
  std::memset(block, 1, kSize);
  const Mapping m = mappingOf(block);
  INFO(m.header);
  CHECK(m.header.find("[heap]") != std::string::npos);
  // Freed, it stays in the process: the heap does not shrink.
  const void* end = sbrk(0);
  std::free(block);
  void* small = std::malloc(64);  // a call into the allocator after the free
  CHECK(sbrk(0) == end);
  std::free(small);
}
#endif
