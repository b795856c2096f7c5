// diffreg serve against hostile clients: foreign Host (DNS rebinding) and Origin, writes that
// are not JSON, picked-points files that are devices or missing, stalled connections, file
// names that are not UTF-8.
#include <diffreg/core/error.h>
#include <diffreg/mesh/io.h>
#include <diffreg/serve/api.h>
#include <diffreg/serve/server.h>

#include <httplib.h>
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <poll.h>

#include <chrono>
#include <memory>
#include <thread>
#include <string>
#include <vector>

using namespace diffreg;
using nlohmann::json;

namespace {

struct Server {
  explicit Server(const std::string& name = "bar.obj", ServerOptions options = {}) {
    Mesh mesh = readMesh(std::string(DIFFREG_SOURCE_DIR) + "/meshes/bar.obj");
    api = std::make_unique<Api>(std::make_unique<EditEngine>(std::move(mesh)), name);
    server = std::make_unique<HttpServer>(*api, options);
    port = server->bind("127.0.0.1", 0);
    server->start();
    client = std::make_unique<httplib::Client>("127.0.0.1", port);
    client->set_read_timeout(60);
  }
  ~Server() { server->stop(); }
  int handles() {
    auto r = client->Get("/api/handles");
    REQUIRE(r);
    return static_cast<int>(json::parse(r->body).at("handles").size());
  }
  std::unique_ptr<Api> api;
  std::unique_ptr<HttpServer> server;
  std::unique_ptr<httplib::Client> client;
  int port = 0;

  /// A raw TCP connection to the server (for clients that misbehave below HTTP).
  int connectRaw() const {
    const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<uint16_t>(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    REQUIRE(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
    return fd;
  }
};

const std::string kHandle = R"({"vertices": [0, 33], "name": "left"})";

}  // namespace

TEST_CASE("serve refuses foreign hosts, foreign origins and non-JSON writes", "[serve][hostile]") {
  Server s;
  SECTION("a Host that is not 127.0.0.1:PORT (DNS rebinding)") {
    auto r = s.client->Get("/api/state", {{"Host", "attacker.example:" + std::to_string(s.port)}});
    REQUIRE(r);
    CHECK(r->status == 403);
    auto w =
        s.client->Post("/api/handles", {{"Host", "attacker.example"}}, kHandle, "application/json");
    REQUIRE(w);
    CHECK(w->status == 403);
  }
  SECTION("a write from another site's page, even as text/plain") {
    auto r = s.client->Post("/api/handles", {{"Origin", "http://attacker.example"}}, kHandle,
                            "text/plain");
    REQUIRE(r);
    CHECK(r->status == 403);
    auto t = s.client->Post("/api/handles", kHandle, "text/plain");
    REQUIRE(t);
    CHECK(t->status == 415);
  }
  CHECK(s.handles() == 0);
  SECTION("the page's own origin and JSON are accepted") {
    auto r =
        s.client->Post("/api/handles", {{"Origin", "http://127.0.0.1:" + std::to_string(s.port)}},
                       kHandle, "application/json");
    REQUIRE(r);
    CHECK(r->status == 200);
    CHECK(s.handles() == 1);
  }
}

namespace {

/// Sends `request` on a raw connection and returns everything the server sends until it closes
/// the connection (after Connection: close, a refusal, or a second of silence).
std::string replyTo(const Server& s, const std::string& request) {
  const int fd = s.connectRaw();
  REQUIRE(::send(fd, request.data(), request.size(), MSG_NOSIGNAL) ==
          static_cast<ssize_t>(request.size()));
  std::string reply;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;)
    reply.append(buffer, static_cast<size_t>(n));
  ::close(fd);
  return reply;
}

/// The status line of replyTo(s, request).
std::string statusOf(const Server& s, const std::string& request) {
  const std::string reply = replyTo(s, request);
  return reply.substr(0, reply.find("\r\n"));
}

}  // namespace

TEST_CASE("serve: headers given twice, and requests from other sites' pages", "[serve][hostile]") {
  Server s;
  const std::string host = "Host: 127.0.0.1:" + std::to_string(s.port) + "\r\n";
  const std::string own = "http://127.0.0.1:" + std::to_string(s.port);
  const std::string close = "Connection: close\r\n";
  const auto post = [&](const std::string& headers) {
    return "POST /api/handles HTTP/1.1\r\n" + headers + close +
           "Content-Length: " + std::to_string(kHandle.size()) + "\r\n\r\n" + kHandle;
  };
  const std::string json = "Content-Type: application/json\r\n";
  // A second copy of a checked header must not slip past the check of the first.
  CHECK(statusOf(s, "GET /api/state HTTP/1.1\r\n" + host + "Host: evil.example\r\n" + close +
                        "\r\n") == "HTTP/1.1 400 Bad Request");
  CHECK(statusOf(s, post(host + json + "Origin: " + own + "\r\nOrigin: http://evil.example\r\n")) ==
        "HTTP/1.1 400 Bad Request");
  CHECK(statusOf(s, post(host + json + json)) == "HTTP/1.1 400 Bad Request");
  CHECK(statusOf(s, "POST /api/handles HTTP/1.1\r\n" + host + json + close +
                        "Content-Length: 5\r\nTransfer-Encoding: chunked\r\n\r\n" + "0\r\n\r\n") ==
        "HTTP/1.1 400 Bad Request");
  // A byte count is digits (httplib read "-5" as a huge count).
  CHECK(statusOf(s, "POST /api/handles HTTP/1.1\r\n" + host + json + close +
                        "Content-Length: -5\r\n\r\n" + kHandle) == "HTTP/1.1 400 Bad Request");
  // Only application/json itself (with parameters) is JSON.
  CHECK(statusOf(s, post(host + "Content-Type: application/jsonx\r\n")) ==
        "HTTP/1.1 415 Unsupported Media Type");
  CHECK(s.handles() == 0);
  // Reads from another site's page: an <img> of an export, a fetch with its Origin.
  CHECK(statusOf(s, "GET /api/export/image.png HTTP/1.1\r\n" + host + close +
                        "Sec-Fetch-Site: cross-site\r\n\r\n") == "HTTP/1.1 403 Forbidden");
  CHECK(statusOf(s, "GET /api/state HTTP/1.1\r\n" + host + close +
                        "Sec-Fetch-Site: same-site\r\n\r\n") == "HTTP/1.1 403 Forbidden");
  CHECK(statusOf(s, "GET /api/state HTTP/1.1\r\n" + host + close +
                        "Origin: http://evil.example\r\n\r\n") == "HTTP/1.1 403 Forbidden");
  // The page itself may be opened from a link on another site; its API may not.
  CHECK(statusOf(s, "GET / HTTP/1.1\r\n" + host + close + "Sec-Fetch-Site: cross-site\r\n\r\n") ==
        "HTTP/1.1 200 OK");
  // The page's own requests, and a typed address, are answered.
  CHECK(statusOf(s, "GET /api/state HTTP/1.1\r\n" + host + close +
                        "Sec-Fetch-Site: same-origin\r\nOrigin: " + own + "\r\n\r\n") ==
        "HTTP/1.1 200 OK");
  CHECK(statusOf(s, "GET /api/state HTTP/1.1\r\n" + host + close +
                        "Sec-Fetch-Site: none\r\n\r\n") == "HTTP/1.1 200 OK");
  CHECK(statusOf(s, post(host + "Content-Type: application/json; charset=utf-8\r\nOrigin: " + own +
                         "\r\nSec-Fetch-Site: same-origin\r\n")) == "HTTP/1.1 200 OK");
  CHECK(s.handles() == 1);
}

TEST_CASE("serve: a refused request's body is not read as a request", "[serve][hostile]") {
  // Another site's page may send any bytes as a text/plain body; refused for its Origin, the
  // request must take its body with it, or the body would be answered as a request of its own
  // (with this server's Host and no Origin).
  Server s;
  const std::string host = "Host: 127.0.0.1:" + std::to_string(s.port) + "\r\n";
  const std::string inner =
      "POST /api/handles HTTP/1.1\r\n" + host +
      "Content-Type: application/json\r\nContent-Length: " + std::to_string(kHandle.size()) +
      "\r\n\r\n" + kHandle;
  for (const std::string& refusal :
       {std::string("Origin: http://evil.example\r\n"),
        std::string("Sec-Fetch-Site: cross-site\r\n"), host}) {  // the last: Host given twice
    const std::string outer =
        "POST /api/handles HTTP/1.1\r\n" + host + refusal +
        "Content-Type: text/plain\r\nContent-Length: " + std::to_string(inner.size()) + "\r\n\r\n" +
        inner;
    const std::string reply = replyTo(s, outer);
    INFO(reply);
    CHECK(reply.rfind("HTTP/1.1 40", 0) == 0);
    CHECK(reply.find("HTTP/1.1 200") == std::string::npos);
  }
  CHECK(s.handles() == 0);
}

TEST_CASE("serve: requests sent together on one connection are all answered", "[serve]") {
  Server s;
  const std::string get =
      "GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(s.port) + "\r\n\r\n";
  const std::string both = get + get.substr(0, get.size() - 2) + "Connection: close\r\n\r\n";
  const std::string reply = replyTo(s, both);
  size_t answers = 0;
  for (size_t at = reply.find("HTTP/1.1 200"); at != std::string::npos;
       at = reply.find("HTTP/1.1 200", at + 1))
    ++answers;
  CHECK(answers == 2);
}

TEST_CASE("serve: a client that trickles header lines is closed at the deadline",
          "[serve][hostile]") {
  ServerOptions options;
  options.requestSeconds = 1.0;
  Server s("bar.obj", options);
  const int fd = s.connectRaw();
  const std::string head =
      "GET /api/state HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(s.port) + "\r\n";
  REQUIRE(::send(fd, head.data(), head.size(), MSG_NOSIGNAL) > 0);
  // A whole header line every 0.2 s for up to 10 s: the request is answered 400 at its
  // deadline, and the connection must end there rather than read the lines that follow as
  // further requests.
  bool ended = false;
  std::string reply;
  for (int i = 0; i < 50 && !ended; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    if (::send(fd, "X-A: b\r\n", 8, MSG_NOSIGNAL) <= 0) ended = true;
    char buffer[4096];
    for (ssize_t n; !ended && (n = ::recv(fd, buffer, sizeof buffer, MSG_DONTWAIT)) != -1;) {
      if (n == 0)
        ended = true;
      else
        reply.append(buffer, static_cast<size_t>(n));
    }
  }
  ::close(fd);
  INFO("reply: " << reply);
  CHECK(ended);
  CHECK(reply.rfind("HTTP/1.1 400", 0) == 0);
}

TEST_CASE("serve: a write without Content-Length has an empty body", "[serve]") {
  // curl -X POST .../api/refine sends neither Content-Length nor a body.
  Server s;
  auto added = s.client->Post("/api/handles", kHandle, "application/json");
  REQUIRE(added);
  REQUIRE(s.handles() == 1);
  const auto ask = [&](const std::string& requestLine) {
    return statusOf(s, requestLine + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(s.port) +
                           "\r\nConnection: close\r\n\r\n");
  };
  CHECK(ask("POST /api/refine") == "HTTP/1.1 200 OK");
  CHECK(ask("DELETE /api/handles") == "HTTP/1.1 200 OK");
  CHECK(s.handles() == 0);
  // The writes that need a body still say so.
  CHECK(ask("PATCH /api/params") == "HTTP/1.1 400 Bad Request");
}

TEST_CASE("serve: picked-points files that are devices or missing get one 4xx",
          "[serve][hostile]") {
  Server s;
  std::vector<std::string> bodies;
  for (const char* path : {"/dev/zero", "/nonexistent/x.pp", "/etc", "/etc/passwd"})
    bodies.push_back(json{{"handles", {{{"picked", path}}}}}.dump());
  std::string first;
  for (const auto& body : bodies) {
    auto r = s.client->Put("/api/handles", body, "application/json");
    REQUIRE(r);
    INFO(body << " -> " << r->body);
    CHECK(r->status >= 400);
    CHECK(r->status < 500);
    const std::string message = json::parse(r->body).at("error");
    CHECK(message.find("/etc") == std::string::npos);
    CHECK(message.find("/nonexistent") == std::string::npos);
    if (first.empty()) first = message;
    CHECK(message == first);  // the same for all: nothing about the file is revealed
  }
  auto r = s.client->Get("/api/state");
  REQUIRE(r);
  CHECK(r->status == 200);
}

TEST_CASE("serve: stalled connections do not block other clients", "[serve][hostile]") {
  Server s;
  std::vector<int> stalled;
  for (int i = 0; i < 12; ++i) {
    const int fd = s.connectRaw();
    const char partial[] = "GET /api/state HTTP/1.1\r\nHo";
    REQUIRE(::send(fd, partial, sizeof partial - 1, 0) > 0);
    stalled.push_back(fd);
  }
  for (int i = 0; i < 3; ++i) {
    auto r = s.client->Get("/api/state");
    REQUIRE(r);
    CHECK(r->status == 200);
  }
  for (int fd : stalled) ::close(fd);
}

TEST_CASE("serve: a client that trickles its request is cut off at the deadline",
          "[serve][hostile]") {
  ServerOptions options;
  options.requestSeconds = 1.0;
  Server s("bar.obj", options);
  const int fd = s.connectRaw();
  const std::string head = "GET /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: ";
  REQUIRE(::send(fd, head.data(), head.size(), MSG_NOSIGNAL) > 0);
  // One byte every 0.2 s (each read well within httplib's one-second read timeout) for up to
  // 10 s: the server must close the connection (a send fails or the socket reads end of file).
  bool cut = false;
  for (int i = 0; i < 50 && !cut; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    cut = ::send(fd, "a", 1, MSG_NOSIGNAL) <= 0;
    pollfd p{fd, POLLIN, 0};
    if (!cut && ::poll(&p, 1, 0) > 0) {
      char c;
      cut = ::recv(fd, &c, 1, MSG_DONTWAIT) <= 0;
    }
  }
  ::close(fd);
  CHECK(cut);
  auto r = s.client->Get("/api/state");  // and the server still answers
  REQUIRE(r);
  CHECK(r->status == 200);
}

TEST_CASE("serve: a mesh file name that is not UTF-8", "[serve][hostile]") {
  Server s("bar\xff\xfe.obj");
  auto state = s.client->Get("/api/state");
  REQUIRE(state);
  CHECK(state->status == 200);
  auto mesh = s.client->Get("/api/mesh");
  REQUIRE(mesh);
  REQUIRE(mesh->status == 200);
  CHECK(json::parse(mesh->body).at("name") == "bar\\xff\\xfe.obj");
}
