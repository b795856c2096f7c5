// The HTTP side of `diffreg serve`: cpp-httplib on a loopback address, /api/* answered by an
// Api, the page (index.html, app.js, style.css) from a web directory and three.js from
// Debian's libjs-three.
#pragma once

#include "serve/api.h"

#include <memory>
#include <string>
#include <thread>

namespace httplib {
class Server;
}

namespace diffreg {

struct ServerOptions {
  /// Directory with index.html, app.js and style.css ("" = defaultWebDir()).
  std::string webDir;
  /// three.module.js, served as /three/three.module.js.
  std::string threeModule = "/usr/share/javascript/three/build/three.module.js";
};

/// The web directory of this build (the source tree's web/ when present, else the installed
/// one).
std::string defaultWebDir();

class HttpServer {
 public:
  /// \throw IoError when the web directory has no index.html.
  HttpServer(Api& api, ServerOptions options = {});
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  /// Binds `host`:`port` (port 0: any free port) and returns the port bound.
  /// \throw IoError when the address cannot be bound (e.g. the port is in use).
  int bind(const std::string& host, int port);
  /// Serves until stop() (blocking). Needs bind() first.
  void run();
  /// Serves on a background thread until stop() or destruction.
  void start();
  /// Stops serving; returns once run() or the background thread has ended.
  void stop();

 private:
  Api& api_;
  ServerOptions options_;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  bool bound_ = false;
};

}  // namespace diffreg
