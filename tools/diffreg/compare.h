// diffreg compare: the paper's Fig. 6/7 comparison in one command.
#pragma once

namespace diffreg {

/// Runs `diffreg compare ...` (argv[0] is "compare"): the same edit without, with uniform and
/// with non-uniform (and optionally RBF-weighted) regularization; prints the Table-1 metrics as
/// Markdown on stdout and writes the picture, the JSON report and the Markdown file asked for.
/// \throw UsageError for bad options; the library's errors otherwise.
int runCompare(int argc, char** argv);

}  // namespace diffreg
