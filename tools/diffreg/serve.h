// diffreg serve: interactive editing in the browser.
#pragma once

namespace diffreg {

/// Runs `diffreg serve -i MESH [--handles H.json] [--port P]` (argv[0] is "serve"): loads the
/// mesh, serves the editing page and its JSON API on 127.0.0.1 (port 0: a free port), prints
/// the address on stdout and serves until SIGINT or SIGTERM.
/// \throw UsageError for bad options; IoError when the port cannot be bound; the library's
///        errors for a bad mesh or handle file.
int runServe(int argc, char** argv);

}  // namespace diffreg
