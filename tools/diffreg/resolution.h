// diffreg resolution: the paper's resolution experiment (Fig. 9; docs/method.md, "Diffused weights"
// "Units of t").
#pragma once

namespace diffreg {

/// Runs `diffreg resolution ...` (argv[0] is "resolution"): subdivides the mesh 0..levels times
/// (handles carried along, handle regions growing with their edges), diffuses the weights on
/// every level with t in each of the three units (absolute, diagonal, mean_edge2; one physical
/// t on level 0), prints how far the weights at the original vertices move from level 0 as a
/// Markdown table on stdout, and writes the picture (rows: units, columns: levels), the JSON
/// report and the Markdown file asked for, all or none.
/// \throw UsageError for bad options; the library's errors (IoError, InvalidMesh,
///        InvalidParameter, ...) for bad input files.
int runResolution(int argc, char** argv);

}  // namespace diffreg
