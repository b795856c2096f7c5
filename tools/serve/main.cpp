// diffreg-serve: interactive editing in the browser, run as `diffreg serve ...` (which starts
// this executable from beside it) or directly. Its own executable so that the HTTP server and
// the TLS and compression libraries it links are loaded only here, not by every diffreg run.
//
//   diffreg-serve -i MESH [--handles H.json] [--port P] [--web DIR] [--quiet]
//
// Loads the mesh, serves the editing page and its JSON API on 127.0.0.1 (port 0: a free
// port), prints the address on stdout and serves until SIGINT or SIGTERM. Errors print one line
// "diffreg: error: ..." on stderr; the exit code is 2 for usage errors, else 1.

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/handles/handles.h>
#include <diffreg/mesh/io.h>
#include <diffreg/serve/api.h>
#include <diffreg/serve/server.h>
#include "cli.h"

#include <boost/program_options.hpp>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include <unistd.h>

namespace po = boost::program_options;

namespace diffreg {

namespace {

const char* kServeUsage =
    "Usage: diffreg serve -i MESH [--handles H.json] [--port 8080] [--quiet]\n"
    "\n"
    "Serves an interactive editor for MESH on http://127.0.0.1:PORT/ (loopback only; port 0\n"
    "picks a free port). Click vertices to make handles (shift-click adds to the current one),\n"
    "drag them, tune the energy, the regularization and the weights, and save the handles, the\n"
    "deformed mesh and a picture. The page's JSON API can be driven by scripts as well.\n"
    "Stops on Ctrl-C (SIGINT) or SIGTERM.\n";

int stopPipe[2] = {-1, -1};

extern "C" void onStopSignal(int) {
  const char c = 1;
  const ssize_t ignored = ::write(stopPipe[1], &c, 1);  // async-signal-safe
  (void)ignored;
}

void installStopHandler() {
  if (::pipe(stopPipe) != 0) throw IoError("serve: cannot create a pipe for the stop signal");
  struct sigaction action {};
  action.sa_handler = onStopSignal;
  sigemptyset(&action.sa_mask);
  action.sa_flags = SA_RESTART;
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

/// Returns once SIGINT or SIGTERM has arrived (now or before).
void waitForStop() {
  char c = 0;
  while (::read(stopPipe[0], &c, 1) < 0 && errno == EINTR) {
  }
}

int runServe(int argc, char** argv) {
  po::options_description visible("Options");
  visible.add_options()                                                                  //
      ("help,h", "show this help")                                                       //
      ("input,i", po::value<std::string>(), "mesh (obj, off, ply, om, mesh, node/ele)")  //
      ("handles", po::value<std::string>(), "initial handles (JSON handle file)")        //
      ("port,p", po::value<int>()->default_value(8080),
       "TCP port on 127.0.0.1; 0 = any free port")                                            //
      ("web", po::value<std::string>(), "directory of the page (default: the built-in one)")  //
      ("quiet,q", po::bool_switch(), "no warnings on stderr");
  po::variables_map vm;
  if (!parseCommandLine(argc, argv, kServeUsage, visible, vm)) return 0;
  requireOption(vm, "input", "serve", "-i MESH");
  const int port = vm["port"].as<int>();
  if (port < 0 || port > 65535)
    throw UsageError("serve: --port " + std::to_string(port) + " is outside [0, 65535]");

  // SIGINT and SIGTERM run a handler in whichever thread receives them (some, like BLAS's
  // workers, exist before main), so none of them kills the process; this thread then stops.
  installStopHandler();

  const std::string input = vm["input"].as<std::string>();
  Mesh mesh = readMesh(input);
  HandleSet handles;
  if (vm.count("handles")) handles = readHandles(vm["handles"].as<std::string>(), mesh);
  auto session = std::make_unique<EditEngine>(std::move(mesh));
  if (!handles.empty()) session->setHandles(handles);
  {  // the editor answers within its time budget and refines while idle
    EditState editor = session->state();
    editor.params.seconds = kEditorSeconds;
    editor.params.iterations = kEditorIterations;
    session->setState(std::move(editor));
  }
  Api api(std::move(session), std::filesystem::path(input).filename().string());

  ServerOptions options;
  if (vm.count("web")) options.webDir = vm["web"].as<std::string>();
  HttpServer server(api, options);
  const int bound = server.bind("127.0.0.1", port);

  server.start();
  std::cout << "diffreg serve: http://127.0.0.1:" << bound << "/" << std::endl;
  waitForStop();
  // Stop within a second even when a request is still running (a long solve): after that
  // the process ends without waiting for it.
  std::promise<void> stopped;
  std::future<void> done = stopped.get_future();
  std::thread stopper([&] {
    server.stop();
    stopped.set_value();
  });
  if (done.wait_for(std::chrono::milliseconds(900)) != std::future_status::ready) {
    info("serve: stopped (abandoning the requests still running)");
    std::cout.flush();
    std::_Exit(0);
  }
  stopper.join();
  info("serve: stopped");
  return 0;
}

}  // namespace
}  // namespace diffreg

int main(int argc, char** argv) {
  return diffreg::runCommand([&] { return diffreg::runServe(argc, argv); });
}
