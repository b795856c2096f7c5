// The JSON API of `diffreg serve` over HTTP, against a server started in this process on a
// free loopback port: handles, drags and parameter changes reuse the factorizations as the
// paper's Fig. 5 says, bad requests get their 4xx and leave the session unchanged.
#include <diffreg/core/error.h>
#include <diffreg/mesh/io.h>
#include <diffreg/serve/api.h>
#include <diffreg/serve/server.h>

#include <httplib.h>
#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

using namespace diffreg;
using nlohmann::json;

namespace {

/// A server on 127.0.0.1:<free port> serving bar.obj (32 x 4 cells, 8 x 1).
struct Fixture {
  Fixture() : Fixture(readMesh(std::string(DIFFREG_SOURCE_DIR) + "/meshes/bar.obj")) {}
  explicit Fixture(Mesh mesh) {
    api = std::make_unique<Api>(std::make_unique<EditEngine>(std::move(mesh)), "bar.obj");
    server = std::make_unique<HttpServer>(*api);
    port = server->bind("127.0.0.1", 0);
    server->start();
    client = std::make_unique<httplib::Client>("127.0.0.1", port);
    client->set_connection_timeout(5);
    client->set_read_timeout(60);
  }
  ~Fixture() { server->stop(); }

  /// Sends a request and returns status and body.
  std::pair<int, std::string> send(const std::string& method, const std::string& path,
                                   const std::string& body = "") {
    httplib::Result r = method == "GET"     ? client->Get(path.c_str())
                        : method == "POST"  ? client->Post(path.c_str(), body, "application/json")
                        : method == "PUT"   ? client->Put(path.c_str(), body, "application/json")
                        : method == "PATCH" ? client->Patch(path.c_str(), body, "application/json")
                                            : client->Delete(path.c_str());
    REQUIRE(r);
    return {r->status, r->body};
  }
  json ok(const std::string& method, const std::string& path, const std::string& body = "") {
    const auto [status, text] = send(method, path, body);
    INFO(method << " " << path << " " << body << " -> " << status << " " << text);
    REQUIRE(status == 200);
    return json::parse(text);
  }
  Eigen::MatrixXd positions() {
    const json j = ok("GET", "/api/positions");
    const auto flat = j.at("positions").get<std::vector<double>>();
    Eigen::MatrixXd x(static_cast<Eigen::Index>(flat.size() / 3), 3);
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      for (int c = 0; c < 3; ++c) x(i, c) = flat[static_cast<size_t>(3 * i + c)];
    return x;
  }
  /// The counters of the last update for one system.
  static int count(const json& state, const std::string& system, const std::string& phase) {
    return state.at("update").at(system).at(phase).get<int>();
  }

  std::unique_ptr<Api> api;
  std::unique_ptr<HttpServer> server;
  std::unique_ptr<httplib::Client> client;
  int port = 0;
};

const std::string kLeft = R"({"vertices": [0, 33, 66, 99, 132], "name": "left"})";
const std::string kRight = R"({"vertices": [32, 65, 98, 131, 164], "name": "right"})";

}  // namespace

TEST_CASE("serve API: load, handles, drag and parameters reuse factorizations", "[serve]") {
  Fixture f;
  REQUIRE(f.port > 0);
  // The port is taken: a second server cannot bind it.
  HttpServer second(*f.api);
  CHECK_THROWS_AS(second.bind("127.0.0.1", f.port), IoError);
  const json mesh = f.ok("GET", "/api/mesh");
  CHECK(mesh.at("kind") == "planar");
  CHECK(mesh.at("vertices") == 293);
  CHECK(mesh.at("faces").size() == 3 * 512);
  const Eigen::MatrixXd rest = f.positions();
  REQUIRE(rest.rows() == 293);

  json state = f.ok("POST", "/api/handles", kLeft);
  CHECK(state.at("created") == 0);
  state = f.ok("POST", "/api/handles", kRight);
  CHECK(state.at("created") == 1);
  CHECK(state.at("handles").size() == 2);
  CHECK(state.at("update").at("solved") == true);
  CHECK(Fixture::count(state, "deformation", "symbolic") > 0);
  // The weights are m_j = 1 at the handles.
  const json weights = f.ok("GET", "/api/field?name=weight");
  CHECK(weights.at("values")[0].get<double>() == Approx(1.0));
  CHECK(weights.at("values")[32].get<double>() == Approx(1.0));
  // Handles at their rest positions: nothing moves.
  CHECK((f.positions() - rest).cwiseAbs().maxCoeff() < 1e-9);

  SECTION("a drag re-solves only") {
    state = f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2.5, 0]})");
    CHECK(Fixture::count(state, "deformation", "symbolic") == 0);
    CHECK(Fixture::count(state, "deformation", "numeric") == 0);
    CHECK(Fixture::count(state, "deformation", "solves") > 0);
    CHECK(state.at("update").at("weights_work") == "none");
    const Eigen::MatrixXd x = f.positions();
    CHECK(x(98, 1) == Approx(2.5));  // handle vertices sit at their targets
    CHECK(x(98, 0) == Approx(8.0));
    CHECK(x(146, 1) > 0.5);  // a free vertex half way (corner (14, 4)) follows upwards
    CHECK(state.at("metrics").at("d_max").get<double>() > 0.0);
    CHECK(!state.at("metrics").at("dist").is_null());

    // A second drag: again no factorization.
    state = f.ok("PATCH", "/api/handles/1", R"({"move_to": [7.5, 3, 0]})");
    CHECK(Fixture::count(state, "deformation", "numeric") == 0);
    CHECK(Fixture::count(state, "deformation", "solves") > 0);
    CHECK((f.positions() - x).cwiseAbs().maxCoeff() > 0.1);
  }

  SECTION("t and beta refactor numerically, a new handle analyzes again") {
    f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2.5, 0]})");
    state = f.ok("PATCH", "/api/params", R"({"t": 0.05})");
    CHECK(Fixture::count(state, "weights", "numeric") > 0);
    CHECK(Fixture::count(state, "weights", "symbolic") == 0);
    CHECK(Fixture::count(state, "deformation", "numeric") > 0);
    CHECK(Fixture::count(state, "deformation", "symbolic") == 0);

    // The direct second-order solve has another pattern than pcg's preconditioner.
    state = f.ok("PATCH", "/api/params", R"({"solve": "direct"})");
    CHECK(state.at("params").at("solve") == "direct");
    CHECK(Fixture::count(state, "weights", "symbolic") > 0);
    state = f.ok("PATCH", "/api/params", R"({"solve": "pcg"})");
    CHECK(Fixture::count(state, "weights", "symbolic") > 0);

    state = f.ok("PATCH", "/api/params", R"({"regularization": "uniform", "beta": 0.3})");
    CHECK(Fixture::count(state, "deformation", "numeric") > 0);
    CHECK(Fixture::count(state, "deformation", "symbolic") == 0);
    state = f.ok("PATCH", "/api/params", R"({"beta": 0.6})");
    CHECK(state.at("params").at("beta") == 0.6);
    CHECK(Fixture::count(state, "deformation", "numeric") > 0);
    CHECK(Fixture::count(state, "deformation", "symbolic") == 0);

    state = f.ok("PATCH", "/api/handles/1", R"({"range": 2.0})");
    CHECK(Fixture::count(state, "weights", "numeric") > 0);
    CHECK(Fixture::count(state, "weights", "symbolic") == 0);

    state = f.ok("POST", "/api/handles", R"({"vertices": [82]})");
    CHECK(Fixture::count(state, "deformation", "symbolic") > 0);
    CHECK(Fixture::count(state, "weights", "symbolic") > 0);

    // shift-click: a vertex added to an existing handle changes the vertex sets.
    state = f.ok("PATCH", "/api/handles/2", R"({"add_vertices": [83]})");
    CHECK(state.at("handles")[2].at("vertices").size() == 2);
    CHECK(Fixture::count(state, "deformation", "symbolic") > 0);

    state = f.ok("DELETE", "/api/handles/2");
    CHECK(state.at("handles").size() == 2);
    CHECK(Fixture::count(state, "deformation", "symbolic") > 0);
  }

  SECTION("energies and weight schemes switch") {
    f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2.5, 0]})");
    for (const char* energy : {"asap", "larap", "dirichlet", "arap"}) {
      state = f.ok("PATCH", "/api/params", json{{"energy", energy}}.dump());
      CHECK(state.at("update").at("solved") == true);
      CHECK(f.positions()(98, 1) == Approx(2.5));
    }
    state = f.ok("PATCH", "/api/params", R"({"scheme": "rbf", "sigma": 0.2})");
    CHECK(state.at("update").at("weights_work") == "evaluate");
    state = f.ok("PATCH", "/api/params", R"({"scheme": "diffusion", "order": "first"})");
    CHECK(state.at("params").at("order") == "first");
    state = f.ok("PATCH", "/api/params", R"({"regularization": "none"})");
    CHECK(state.at("metrics").at("dist").is_null() == false);
    CHECK(state.at("metrics").at("dist").get<double>() == Approx(0.0).margin(1e-12));
  }

  SECTION("saving: handles round trip, PLY and PNG") {
    f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2.5, 0]})");
    const Eigen::MatrixXd x = f.positions();
    const auto [status, handles] = f.send("GET", "/api/handles?download=1");
    REQUIRE(status == 200);
    f.ok("DELETE", "/api/handles");
    CHECK((f.positions() - rest).cwiseAbs().maxCoeff() < 1e-9);
    state = f.ok("PUT", "/api/handles", handles);
    CHECK(state.at("handles").size() == 2);
    CHECK((f.positions() - x).cwiseAbs().maxCoeff() < 1e-9);

    const auto [plyStatus, ply] = f.send("GET", "/api/export/mesh.ply");
    CHECK(plyStatus == 200);
    CHECK(ply.rfind("ply", 0) == 0);
    CHECK(ply.find("quality") != std::string::npos);
    const auto [pngStatus, png] =
        f.send("GET", "/api/export/image.png?field=distortion&width=300&height=200");
    CHECK(pngStatus == 200);
    CHECK(png.rfind("\x89PNG", 0) == 0);
  }
}

TEST_CASE("serve API: bad requests get a 4xx and leave the session unchanged", "[serve]") {
  Fixture f;
  f.ok("POST", "/api/handles", kLeft);
  f.ok("POST", "/api/handles", kRight);
  f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2, 0]})");
  const auto [status0, before] = f.send("GET", "/api/state");
  REQUIRE(status0 == 200);
  const Eigen::MatrixXd x0 = f.positions();

  struct Bad {
    std::string method, path, body;
    int status;
  };
  const std::vector<Bad> bad = {
      {"POST", "/api/handles", R"({"vertices": [99999]})", 422},  // unknown vertex
      {"POST", "/api/handles", R"({"vertices": [-1]})", 422},     // unknown vertex
      {"POST", "/api/handles", R"({"vertices": [33]})", 422},     // already in a handle
      {"POST", "/api/handles", R"({"vertices": []})", 422},       // empty
      {"POST", "/api/handles", R"({"vertices": ["a"]})", 400},    // wrong type
      {"POST", "/api/handles", R"({"vertices": [5], "magnitude": 1.5})", 422},
      {"POST", "/api/handles", R"({"vertices": [5], "colour": 1})", 400},  // unknown field
      {"PATCH", "/api/handles/1", R"({"move_to": ["NaN", 0, 0]})", 400},
      {"PATCH", "/api/handles/1", R"({"move_to": [1e999, 0, 0]})", 400},  // overflow
      {"PATCH", "/api/handles/1", R"({"move_to": [1e9, 0, 0]})", 422},    // too far away
      {"PATCH", "/api/handles/1", R"({"move_to": [1, 2]})", 400},
      {"PATCH", "/api/handles/1", R"({"range": 0})", 422},
      {"PATCH", "/api/handles/7", R"({"range": 1})", 404},  // unknown handle
      {"DELETE", "/api/handles/abc", "", 404},
      {"PATCH", "/api/params", R"({"beta": 2})", 422},
      {"PATCH", "/api/params", R"({"t": -1})", 422},
      {"PATCH", "/api/params", R"({"iterations": 0})", 422},
      {"PATCH", "/api/params", R"({"seconds": -0.5})", 422},
      {"PATCH", "/api/params", R"({"seconds": "fast"})", 400},
      {"PATCH", "/api/params", R"({"energy": "elastic"})", 422},
      {"PATCH", "/api/params", R"({"solve": "lu"})", 422},
      {"PATCH", "/api/params", R"({"beta": "high"})", 400},
      {"PATCH", "/api/params", "{not json", 400},                      // malformed JSON
      {"PATCH", "/api/params", R"({"beta": 0.2, "beta": 0.9})", 400},  // a key twice
      {"PATCH", "/api/params", std::string(R"({"beta": 0.2})") + '\0' + "x", 400},  // a NUL
      {"PATCH", "/api/params", "[1, 2]", 400},
      {"PATCH", "/api/params", "", 400},
      {"PUT", "/api/handles", R"({"handles": [{"vertices": [5000]}]})", 422},
      // The body is a handle file: beyond malformed JSON, its errors are --handles' own (422).
      {"PUT", "/api/handles", R"({"handles": [{"vertices": "all"}]})", 422},
      {"PUT", "/api/handles", R"({"handles": [{"vertices": [5], "colour": 1}]})", 422},
      {"PUT", "/api/handles", "{not json", 400},
      {"GET", "/api/field?name=colour", "", 422},
      {"GET", "/api/export/image.png?width=100000", "", 422},
      {"GET", "/api/nothing", "", 404},
      {"POST", "/api/state", "{}", 405},
      {"PATCH", "/api/params", std::string(6u << 20, ' '), 413},  // oversized body
  };
  for (const Bad& b : bad) {
    const auto [status, text] = f.send(b.method, b.path, b.body);
    INFO(b.method << " " << b.path << " " << b.body.substr(0, 60) << " -> " << status << " "
                  << text);
    CHECK(status == b.status);
    const json error = json::parse(text);
    CHECK(!error.at("error").get<std::string>().empty());
    CHECK(error.at("error").get<std::string>().find('\n') == std::string::npos);
    // Unchanged, and the next good request works.
    const auto [status1, after] = f.send("GET", "/api/state");
    CHECK(status1 == 200);
    CHECK(after == before);
  }
  CHECK((f.positions() - x0).cwiseAbs().maxCoeff() == 0.0);
  // An unknown choice is named by the field the request used, with the valid names.
  for (const auto& [field, start] :
       std::vector<std::pair<std::string, std::string>>{{"scheme", "scheme: unknown"},
                                                        {"unit", "unit: unknown"},
                                                        {"rbf_distance", "rbf_distance: unknown"}}) {
    const auto [status, text] = f.send("PATCH", "/api/params", "{\"" + field + "\": \"x\"}");
    CHECK(status == 422);
    const std::string message = json::parse(text).at("error").get<std::string>();
    CHECK(message.rfind(start, 0) == 0);
    CHECK(message.find("(valid: ") != std::string::npos);
  }
  const json state = f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 1, 0]})");
  CHECK(state.at("update").at("solved") == true);
  CHECK(f.positions()(98, 1) == Approx(1.0));
}

TEST_CASE("serve API: concurrent drags end with the latest state solved", "[serve]") {
  Fixture f;
  f.ok("POST", "/api/handles", kLeft);
  f.ok("POST", "/api/handles", kRight);
  const int threads = 4, moves = 10;
  std::vector<std::thread> workers;
  std::vector<int> failures(threads, 0);
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      httplib::Client c("127.0.0.1", f.port);
      c.set_read_timeout(60);
      for (int i = 0; i < moves; ++i) {
        const double y = 0.5 + 0.1 * (t * moves + i);
        const std::string body = json{{"move_to", {8.0, y, 0.0}}}.dump();
        auto r = c.Patch("/api/handles/1", body, "application/json");
        if (!r || r->status != 200) ++failures[static_cast<size_t>(t)];
      }
    });
  }
  for (auto& w : workers) w.join();
  for (int failed : failures) CHECK(failed == 0);
  const json state = f.ok("GET", "/api/state");
  CHECK(state.at("computed_version") == state.at("version"));
  // The results belong to the last accepted target, whichever thread sent it.
  const double target = state.at("handles")[1].at("targets")[2][1].get<double>();
  CHECK(f.positions()(98, 1) == Approx(target));
}

TEST_CASE("serve API: POST /api/refine continues an unconverged deformation", "[serve]") {
  Fixture f;
  f.ok("PATCH", "/api/params", R"({"iterations": 2, "local_step": "exact", "acceleration": "lbfgs"})");
  f.ok("POST", "/api/handles", kLeft);
  f.ok("POST", "/api/handles", kRight);
  json state = f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 1.5, 0]})");
  CHECK(state.at("params").at("local_step") == "exact");
  CHECK_FALSE(state.at("update").at("converged").get<bool>());
  const double criterion = state.at("update").at("criterion").get<double>();
  CHECK(criterion > state.at("params").at("tolerance").get<double>());
  int rounds = 0;
  while (!state.at("update").at("converged").get<bool>() && rounds < 2000) {
    state = f.ok("POST", "/api/refine", "{}");
    ++rounds;
  }
  CHECK(state.at("update").at("converged").get<bool>());
  // Converged: refining again changes nothing.
  const json again = f.ok("POST", "/api/refine", "{}");
  CHECK(again.at("metrics").at("energy").get<double>() ==
        Approx(state.at("metrics").at("energy").get<double>()).epsilon(1e-12));
  CHECK(state.at("metrics").at("energy_relaxed").get<bool>());  // converged: relaxed
  CHECK(f.send("GET", "/api/refine").first == 405);
  // It takes no fields: a malformed or non-empty body is refused, an empty one is fine.
  CHECK(f.send("POST", "/api/refine", "{").first == 400);
  CHECK(f.send("POST", "/api/refine", "[1]").first == 400);
  const auto fields = f.send("POST", "/api/refine", R"({"iterations": 10})");
  CHECK(fields.first == 400);
  CHECK(fields.second.find("takes no fields") != std::string::npos);
  CHECK(f.send("POST", "/api/refine", "").first == 200);
  // A time budget per update: the edit answers with its shape so far and says so.
  json budget = f.ok("PATCH", "/api/params", R"({"seconds": 1e-9, "iterations": 5000})");
  CHECK(budget.at("params").at("seconds").get<double>() == 1e-9);
  budget = f.ok("PATCH", "/api/handles/1", R"({"move_to": [8, 2.5, 0]})");
  CHECK_FALSE(budget.at("update").at("converged").get<bool>());
  CHECK_FALSE(budget.at("metrics").at("energy_relaxed").get<bool>());
  CHECK(f.send("PATCH", "/api/params", R"({"local_step": "foo"})").first == 422);
}

TEST_CASE("serve API: a field's range leaves out the vertices that no element uses", "[serve]") {
  TriMesh bar = readMesh(std::string(DIFFREG_SOURCE_DIR) + "/meshes/bar.obj").tri();
  bar.add_vertex({100.0, 0.0, 0.0});  // vertex 293, in no triangle: its weight is 0
  Fixture f{Mesh(bar)};
  f.ok("PATCH", "/api/params", R"({"t": 0.5})");  // weights well above 0 all along the bar
  f.ok("POST", "/api/handles", kLeft);
  f.ok("POST", "/api/handles", kRight);
  const json field = f.ok("GET", "/api/field?name=weight");
  const auto values = field.at("values").get<std::vector<double>>();
  REQUIRE(values.size() == 294);
  CHECK(values[293] == 0.0);
  const double lowest = *std::min_element(values.begin(), values.end() - 1);
  REQUIRE(lowest > 0.01);
  CHECK(field.at("min").get<double>() == lowest);
  CHECK(field.at("max").get<double>() == Approx(1.0));
}
