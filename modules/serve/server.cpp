#include <diffreg/serve/server.h>

#include <diffreg/core/error.h>
#include <diffreg/serve/connection.h>

#include <httplib.h>

#include <sys/socket.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#ifndef DIFFREG_WEB_DIR
#define DIFFREG_WEB_DIR ""
#endif
#ifndef DIFFREG_INSTALLED_WEB_DIR
#define DIFFREG_INSTALLED_WEB_DIR ""
#endif

namespace diffreg {

namespace fs = std::filesystem;

namespace {

bool readFile(const std::string& path, std::string& out) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  std::ostringstream buffer;
  buffer << in.rdbuf();
  out = buffer.str();
  return static_cast<bool>(in) || in.eof();
}

void send(const ApiResponse& a, httplib::Response& res) {
  res.status = a.status;
  for (const auto& [key, value] : a.headers) res.set_header(key.c_str(), value);
  if (!a.filename.empty())
    res.set_header("Content-Disposition", "attachment; filename=\"" + a.filename + "\"");
  res.set_header("Cache-Control", "no-store");
  res.set_content(a.body, a.contentType.c_str());
}

}  // namespace

std::string defaultWebDir() {
  for (const std::string& dir :
       {std::string(DIFFREG_WEB_DIR), std::string(DIFFREG_INSTALLED_WEB_DIR)})
    if (!dir.empty() && fs::exists(fs::path(dir) / "index.html")) return dir;
  return DIFFREG_WEB_DIR;
}

HttpServer::HttpServer(Api& api, ServerOptions options)
    : api_(api),
      options_(std::move(options)),
      server_(std::make_unique<DeadlineServer>(std::chrono::milliseconds(
          static_cast<long long>(std::max(0.001, options_.requestSeconds) * 1000.0)))) {
  if (options_.webDir.empty()) options_.webDir = defaultWebDir();
  if (!fs::exists(fs::path(options_.webDir) / "index.html"))
    throw IoError("web directory '" + options_.webDir + "' has no index.html");

  httplib::Server& svr = *server_;
  svr.set_payload_max_length(api_.options().maxBodyBytes);
  // Slow clients: a connection that sends nothing for a second is closed, one whose request has
  // not arrived within options_.requestSeconds too (DeadlineServer), idle keep-alive
  // connections after a second, and enough workers that a few stalled clients block no one.
  svr.set_read_timeout(1, 0);
  svr.set_write_timeout(5, 0);
  svr.set_keep_alive_timeout(1);
  svr.set_keep_alive_max_count(100);
  svr.new_task_queue = [] { return new httplib::ThreadPool(kWorkers); };
  // SO_REUSEADDR only: httplib's default SO_REUSEPORT would let a second server bind a port
  // that is in use and share its connections.
  svr.set_socket_options([](socket_t sock) {
    int yes = 1;
    setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof(yes));
  });
  auto apiHandler = [this](const httplib::Request& req, httplib::Response& res) {
    ApiRequest a;
    a.method = req.method;
    a.path = req.path;
    for (const auto& [key, value] : req.params) a.query[key] = value;
    a.body = req.body;
    send(api_.handle(a), res);
  };
  svr.set_pre_routing_handler(
      [this, apiHandler](const httplib::Request& req, httplib::Response& res) {
        const std::string refusal = refuse(req);
        if (refusal.empty()) {
          // A write without Content-Length or Transfer-Encoding has no body (RFC 9112, 6.3), e.g.
          // `curl -X POST .../api/refine`; httplib would wait for one until the connection ends
          // and answer 400.
          const bool write = req.method != "GET" && req.method != "HEAD";
          if (write && req.path.rfind("/api/", 0) == 0 && !req.has_header("Content-Length") &&
              !req.has_header("Transfer-Encoding")) {
            apiHandler(req, res);
            return httplib::Server::HandlerResponse::Handled;
          }
          return httplib::Server::HandlerResponse::Unhandled;
        }
        const int status = std::stoi(refusal.substr(0, 3));
        send(errorResponse(status, refusal.substr(4)), res);
        DeadlineServer::closeAfterResponse();  // its body, unread, is no next request
        return httplib::Server::HandlerResponse::Handled;
      });
  const std::string pattern = R"(/api/.*)";
  svr.Get(pattern, apiHandler);
  svr.Post(pattern, apiHandler);
  svr.Put(pattern, apiHandler);
  svr.Patch(pattern, apiHandler);
  svr.Delete(pattern, apiHandler);

  auto file = [this](const std::string& path, const char* type) {
    return [path, type](const httplib::Request&, httplib::Response& res) {
      std::string body;
      if (!readFile(path, body)) {
        send(errorResponse(404, "cannot read " + path), res);
        return;
      }
      res.set_header("Cache-Control", "no-cache");
      res.set_content(body, type);
    };
  };
  const fs::path web(options_.webDir);
  svr.Get("/", file((web / "index.html").string(), "text/html; charset=utf-8"));
  svr.Get("/index.html", file((web / "index.html").string(), "text/html; charset=utf-8"));
  svr.Get("/app.js", file((web / "app.js").string(), "text/javascript; charset=utf-8"));
  svr.Get("/style.css", file((web / "style.css").string(), "text/css; charset=utf-8"));
  svr.Get("/three/three.module.js", file(options_.threeModule, "text/javascript; charset=utf-8"));

  // Errors httplib answers itself (unknown path, body over the limit): the API's JSON form.
  const httplib::Server::HandlerWithResponse onError = [](const httplib::Request& req,
                                                          httplib::Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    std::string message = "no such page " + req.path;
    if (res.status == 413)
      message = "the request body is larger than the limit";
    else if (res.status != 404)
      message = "request failed (HTTP " + std::to_string(res.status) + ")";
    send(errorResponse(res.status, message), res);
    // httplib's own errors may leave a body unread (413 reads none of it): not a next request.
    DeadlineServer::closeAfterResponse();
    return httplib::Server::HandlerResponse::Handled;
  };
  svr.set_error_handler(onError);
  svr.set_exception_handler(
      [](const httplib::Request&, httplib::Response& res, std::exception_ptr ep) {
        std::string message = "internal error";
        try {
          if (ep) std::rethrow_exception(ep);
        } catch (const std::exception& e) {
          message = e.what();
        } catch (...) {
        }
        send(errorResponse(500, message), res);
      });
}

HttpServer::~HttpServer() { stop(); }

std::string HttpServer::refuse(const httplib::Request& req) const {
  const auto lower = [](std::string t) {
    for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return t;
  };
  const std::string port = std::to_string(port_);
  // Each of these once: a second copy must not slip past the check of the first.
  for (const char* name :
       {"Host", "Origin", "Content-Length", "Content-Type", "Transfer-Encoding", "Sec-Fetch-Site"})
    if (req.get_header_value_count(name) > 1)
      return std::string("400 the request has more than one ") + name + " header";
  const std::string host = lower(req.get_header_value("Host"));
  // DNS rebinding: a foreign name that resolves to 127.0.0.1 still carries its own Host.
  if (host != "127.0.0.1:" + port && host != "localhost:" + port)
    return "403 the Host header does not name this server (127.0.0.1:" + port + ")";
  // Another site's page: browsers send Origin with every write and with scripted reads, and
  // Sec-Fetch-Site with every request (an <img> of /api/export/image.png included); scripts
  // (curl, tests) usually send neither. The page itself may be reached from anywhere (a link
  // on another site); the API only from the page.
  const bool write = req.method != "GET" && req.method != "HEAD";
  const bool api = req.path.rfind("/api/", 0) == 0;
  if ((write || api) && req.has_header("Origin")) {
    const std::string origin = lower(req.get_header_value("Origin"));
    if (origin != "http://127.0.0.1:" + port && origin != "http://localhost:" + port)
      return "403 requests are accepted from this server's own page only";
  }
  if (api && req.has_header("Sec-Fetch-Site")) {
    const std::string site = lower(req.get_header_value("Sec-Fetch-Site"));
    if (site != "same-origin" && site != "none")
      return "403 requests are accepted from this server's own page only";
  }
  if (!write) return "";
  if (req.has_header("Content-Length") && req.has_header("Transfer-Encoding"))
    return "400 the request has both Content-Length and Transfer-Encoding";
  const std::string length = req.get_header_value("Content-Length");
  if (req.has_header("Content-Length")) {
    if (length.empty() || length.find_first_not_of("0123456789") != std::string::npos)
      return "400 Content-Length must be a decimal byte count";
    if (length.size() > 18) return "413 the request body is larger than the limit";
  }
  const bool body = std::strtoull(length.c_str(), nullptr, 10) > 0 ||
                    req.has_header("Transfer-Encoding");
  // The media type itself, without parameters such as "; charset=utf-8".
  std::string type = lower(req.get_header_value("Content-Type"));
  type = type.substr(0, type.find(';'));
  type.erase(type.find_last_not_of(" \t") + 1);
  if (body && type != "application/json")
    return "415 request bodies must be Content-Type: application/json";
  return "";
}

int HttpServer::bind(const std::string& host, int port) {
  if (port < 0 || port > 65535)
    throw InvalidParameter("port " + std::to_string(port) + " is outside [0, 65535]");
  int bound = port;
  if (port == 0) {
    bound = server_->bind_to_any_port(host);
    if (bound <= 0) throw IoError("cannot bind " + host + " to a free port");
  } else if (!server_->bind_to_port(host, port)) {
    throw IoError("cannot bind " + host + ":" + std::to_string(port) + " (in use, or not allowed)");
  }
  bound_ = true;
  port_ = bound;
  return bound;
}

void HttpServer::run() {
  if (!bound_) throw InvalidParameter("HttpServer::run() needs bind() first");
  server_->listen_after_bind();
}

void HttpServer::start() {
  if (!bound_) throw InvalidParameter("HttpServer::start() needs bind() first");
  thread_ = std::thread([this] { server_->listen_after_bind(); });
}

void HttpServer::stop() {
  if (server_) server_->stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace diffreg
