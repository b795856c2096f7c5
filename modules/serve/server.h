// The HTTP side of `diffreg serve`: cpp-httplib on a loopback address, /api/* answered by an
// Api, the page (index.html, app.js, style.css) from a web directory and three.js from
// Debian's libjs-three.
#pragma once

#include <diffreg/serve/api.h>

#include <memory>
#include <string>
#include <thread>

namespace httplib {
class Server;
struct Request;
}

namespace diffreg {

struct ServerOptions {
  /// Directory with index.html, app.js and style.css ("" = defaultWebDir()).
  std::string webDir;
  /// three.module.js, served as /three/three.module.js.
  std::string threeModule = "/usr/share/javascript/three/build/three.module.js";
  /// A request's line, headers and body must arrive within this time of its first byte (a
  /// client that trickles bytes is cut off; computing the answer is not limited).
  double requestSeconds = 10.0;
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

  /// Worker threads: more than the few connections a page keeps open, so that stalled clients
  /// (each cut after a second of silence or ServerOptions::requestSeconds) block no one.
  static constexpr size_t kWorkers = 32;

 private:
  /// "" when `req` may be answered; else "STATUS message": 400 for a security-relevant header
  /// given twice or a write with both Content-Length and Transfer-Encoding, 403 for a Host that
  /// is not this server's loopback address and port (DNS rebinding) or a request from another
  /// site's page (its Origin, or Sec-Fetch-Site other than same-origin or none), 415 for a
  /// write with a body that is not application/json.
  std::string refuse(const httplib::Request& req) const;

  Api& api_;
  ServerOptions options_;
  std::unique_ptr<httplib::Server> server_;
  std::thread thread_;
  bool bound_ = false;
  int port_ = 0;
};

}  // namespace diffreg
