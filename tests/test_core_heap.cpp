// tuneHeapForBatchRun (modules/core/heap.h): after it, the arrays of a run come from the main
// heap, stay there when freed, and the heap's reserve is advised for transparent huge pages.
#include <diffreg/core/heap.h>

#include <catch2/catch.hpp>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#if defined(__GLIBC__)
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

}  // namespace

#if defined(__GLIBC__)
TEST_CASE("after tuneHeapForBatchRun large arrays come from the heap and stay there",
          "[core][heap]") {
  const diffreg::HeapTuning done = diffreg::tuneHeapForBatchRun();
  if (!done.thresholds) {  // another allocator in front of glibc's (a sanitizer, valgrind)
    WARN("glibc's malloc does not take the settings here: nothing to check");
    return;
  }
  // 16 MiB: mapped on its own by glibc's default (128 KiB threshold), from the heap after.
  constexpr std::size_t kSize = std::size_t(16) << 20;
  void* block = std::malloc(kSize);
  REQUIRE(block != nullptr);
  std::memset(block, 1, kSize);
  // Its middle: the advice starts at the first 2 MiB boundary of the reserve.
  const Mapping m = mappingOf(static_cast<const char*>(block) + kSize / 2);
  INFO(m.header);
  CHECK(m.header.find("[heap]") != std::string::npos);
  // Freed, it stays in the process: the heap does not shrink.
  const void* end = sbrk(0);
  std::free(block);
  void* small = std::malloc(64);  // a call into the allocator after the free
  CHECK(sbrk(0) == end);
  std::free(small);
  // Where the kernel has transparent huge pages, the heap's reserve is advised for them.
  if (std::filesystem::exists("/sys/kernel/mm/transparent_hugepage/enabled")) {
    CHECK(done.hugePages);
    INFO(m.flags);
    CHECK(m.flags.find(" hg") != std::string::npos);
  }
}
#endif
