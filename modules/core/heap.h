// The C library's allocator, set up for a batch run: a process that reads a mesh, builds its
// arrays once, writes the result and exits (the diffreg tool).
#pragma once

namespace diffreg {

/// What tuneHeapForBatchRun() did.
struct HeapTuning {
  bool thresholds = false;  ///< arrays up to 32 MiB come from the heap and stay there when freed
  bool hugePages = false;   ///< the heap reserved ahead was advised for transparent huge pages
};

/// With glibc: arrays up to 32 MiB are taken from the main heap and kept there when freed
/// (rather than mapped and unmapped each time), the heap reserves 256 MiB ahead (address space
/// only: memory is committed when touched, 2 MiB at a time where huge pages are granted), and
/// that reserve is advised for transparent huge pages (MADV_HUGEPAGE; the kernel's default
/// "madvise" mode grants them only on request). The advice starts at the first 2 MiB boundary
/// that the tuning itself touched no page beyond; the 4-6 MiB of heap below it stay out of use
/// (address space only), so that the run's first arrays come from huge pages too.
/// Past the reserve the heap grows as glibc's default would.
/// A fresh page costs a fault and a clearing on first touch; a one-shot deformation of a 10K
/// mesh takes 7,500 of them with 4 KiB pages and about 420 with this (docs/benchmarks.md).
/// Meant for the start of main() of short-lived processes: memory freed is not given back to
/// the system before exit, and under an address-space limit (ulimit -v) the reserve counts
/// against it. Elsewhere (another C library, no huge pages) it does what it can and
/// says so in the result; it never fails.
HeapTuning tuneHeapForBatchRun();

}  // namespace diffreg
