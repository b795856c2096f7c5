#include <diffreg/serve/api.h>

#include <diffreg/core/error.h>
#include <diffreg/core/json.h>
#include <diffreg/core/text.h>
#include <diffreg/mesh/boundary.h>
#include <diffreg/mesh/io.h>
#include <diffreg/render/image.h>
#include <diffreg/render/render.h>

#include <unistd.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <type_traits>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

namespace diffreg {

using nlohmann::json;
namespace fs = std::filesystem;

namespace {

/// A request the API refuses before touching the session.
struct RequestError : std::runtime_error {
  RequestError(int status, const std::string& message)
      : std::runtime_error(message), status(status) {}
  int status;
};

json parseBody(const std::string& body) {
  if (body.empty()) throw RequestError(400, "the request needs a JSON body");
  try {
    return parseJsonStrictly(body);
  } catch (const std::invalid_argument& e) {
    throw RequestError(400, std::string("malformed JSON: ") + e.what());
  }
}

json parseObject(const std::string& body) {
  json j = parseBody(body);
  if (!j.is_object()) throw RequestError(400, "the body must be a JSON object");
  return j;
}

void allowOnly(const json& j, const std::set<std::string>& keys, const std::string& what) {
  for (const auto& item : j.items())
    if (!keys.count(item.key())) {
      std::string list;
      for (const auto& k : keys) list += (list.empty() ? "" : ", ") + k;
      throw RequestError(400, what + ": unknown field '" + item.key() + "' (valid: " + list + ")");
    }
}

double number(const json& j, const std::string& key) {
  const json& v = j.at(key);
  if (!v.is_number()) throw RequestError(400, "'" + key + "' must be a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw InvalidParameter("'" + key + "' is not a finite number");
  return x;
}

int integer(const json& v, const std::string& what) {
  if (!v.is_number_integer()) throw RequestError(400, what + " must be an integer");
  const auto x = v.get<long long>();
  if (x < -2147483647LL || x > 2147483647LL)
    throw InvalidParameter(what + " = " + std::to_string(x) + " is out of range");
  return static_cast<int>(x);
}

std::string text(const json& j, const std::string& key) {
  const json& v = j.at(key);
  if (!v.is_string()) throw RequestError(400, "'" + key + "' must be a string");
  return v.get<std::string>();
}

bool boolean(const json& j, const std::string& key) {
  const json& v = j.at(key);
  if (!v.is_boolean()) throw RequestError(400, "'" + key + "' must be true or false");
  return v.get<bool>();
}

Eigen::Vector3d point(const json& v, const std::string& what) {
  if (!v.is_array() || v.size() != 3) throw RequestError(400, what + " must be [x, y, z]");
  Eigen::Vector3d p;
  for (int i = 0; i < 3; ++i) {
    if (!v[static_cast<size_t>(i)].is_number())
      throw RequestError(400, what + " must be [x, y, z]");
    p[i] = v[static_cast<size_t>(i)].get<double>();
  }
  if (!p.allFinite()) throw InvalidParameter(what + " is not a finite position");
  return p;
}

Eigen::MatrixXd points(const json& v, const std::string& what) {
  if (!v.is_array()) throw RequestError(400, what + " must be a list of [x, y, z]");
  Eigen::MatrixXd m(static_cast<Eigen::Index>(v.size()), 3);
  for (size_t i = 0; i < v.size(); ++i)
    m.row(static_cast<Eigen::Index>(i)) = point(v[i], what + "[" + std::to_string(i) + "]");
  return m;
}

std::vector<int> vertexList(const json& v, const std::string& what, int n) {
  if (!v.is_array()) throw RequestError(400, what + " must be a list of vertex ids");
  if (v.empty()) throw InvalidParameter(what + " is empty");
  std::vector<int> ids;
  for (const json& x : v) {
    const int id = integer(x, what + " entry");
    if (id < 0 || id >= n)
      throw InvalidParameter("vertex " + std::to_string(id) + " does not exist (the mesh has " +
                             std::to_string(n) + " vertices)");
    ids.push_back(id);
  }
  return ids;
}

json statsJson(const SolverStats& s) {
  return {{"symbolic", s.symbolic},
          {"numeric", s.numeric},
          {"solves", s.solves},
          {"symbolic_seconds", s.symbolicSeconds},
          {"numeric_seconds", s.numericSeconds},
          {"solve_seconds", s.solveSeconds}};
}

json paramsJson(const EditParams& p) {
  return {{"energy", toString(p.energy)},
          {"regularization", toString(p.regularization)},
          {"beta", p.beta},
          {"scheme", toString(p.scheme)},
          {"order", toString(p.diffusion.order)},
          {"t", p.diffusion.t},
          {"unit", toString(p.diffusion.unit)},
          {"steps", p.diffusion.steps},
          {"solve", toString(p.diffusion.solve)},
          {"iterations", p.iterations},
          {"tolerance", p.tolerance},
          {"seconds", p.seconds},
          {"local_step", toString(p.localStep)},
          {"acceleration", toString(p.acceleration)},
          {"sigma", p.rbf.sigma},
          {"rbf_distance", toString(p.rbf.distance)},
          {"reference", p.reference},
          {"continue_drags", p.continueDrags}};
}

json matrixRows(const Eigen::MatrixXd& m) {
  json rows = json::array();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index c = 0; c < m.cols(); ++c) row.push_back(m(i, c));
    rows.push_back(row);
  }
  return rows;
}

std::string float32(const Eigen::VectorXd& values) {
  std::string out(static_cast<size_t>(values.size()) * 4, '\0');
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const float f = static_cast<float>(values[i]);
    std::memcpy(&out[static_cast<size_t>(i) * 4], &f, 4);  // little-endian hosts
  }
  return out;
}

Eigen::VectorXd flatten(const Eigen::MatrixXd& m) {
  Eigen::VectorXd v(m.size());
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index c = 0; c < m.cols(); ++c) v[i * m.cols() + c] = m(i, c);
  return v;
}

std::string readAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

/// A file name in the temporary directory, removed when this goes out of scope.
struct TempFile {
  explicit TempFile(const std::string& extension) {
    static std::atomic<long> counter{0};
    path = fs::temp_directory_path() / ("diffreg-serve-" + std::to_string(::getpid()) + "-" +
                                        std::to_string(counter++) + extension);
  }
  ~TempFile() {
    std::error_code ec;
    fs::remove(path, ec);
  }
  fs::path path;
};

int queryInt(const ApiRequest& r, const std::string& key, int fallback, int lo, int hi) {
  const auto it = r.query.find(key);
  if (it == r.query.end()) return fallback;
  try {
    size_t used = 0;
    const int v = std::stoi(it->second, &used);
    if (used == it->second.size() && v >= lo && v <= hi) return v;
  } catch (const std::exception&) {
  }
  throw InvalidParameter(key + " = '" + it->second + "' is not an integer in [" +
                         std::to_string(lo) + ", " + std::to_string(hi) + "]");
}

double queryDouble(const ApiRequest& r, const std::string& key, double fallback) {
  const auto it = r.query.find(key);
  if (it == r.query.end()) return fallback;
  try {
    size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (used == it->second.size() && std::isfinite(v) && std::abs(v) <= 360.0) return v;
  } catch (const std::exception&) {
  }
  throw InvalidParameter(key + " = '" + it->second + "' is not an angle in [-360, 360]");
}

ApiResponse jsonResponse(const json& j) {
  ApiResponse r;
  r.body = j.dump(-1, ' ', false, json::error_handler_t::replace);
  return r;
}

/// GET /api/mesh: the rest mesh and the triangles the page draws (a tet mesh's boundary), each
/// with the element it shows.
ApiResponse meshResponse(const EditEngine& s, const std::string& meshName) {
  const Mesh& mesh = s.restMesh();
  json faces = json::array(), faceElement = json::array();
  if (mesh.isTet()) {
    const BoundaryFaces boundary = tetBoundary(mesh.tet());
    for (size_t f = 0; f < boundary.faces.size(); ++f) {
      for (int c = 0; c < 3; ++c) faces.push_back(boundary.faces[f][static_cast<size_t>(c)]);
      faceElement.push_back(boundary.element[f]);
    }
  } else {
    const Eigen::MatrixXi e = mesh.elements();
    for (Eigen::Index k = 0; k < e.rows(); ++k) {
      for (int c = 0; c < 3; ++c) faces.push_back(e(k, c));
      faceElement.push_back(k);
    }
  }
  const Eigen::VectorXd rest = flatten(mesh.positions());
  return jsonResponse({{"name", meshName},
                       {"kind", toString(mesh.kind())},
                       {"vertices", s.numVertices()},
                       {"elements", mesh.numElements()},
                       {"dim", s.discretization().dim()},
                       {"diagonal", s.discretization().boundingBoxDiagonal()},
                       {"rest", std::vector<double>(rest.data(), rest.data() + rest.size())},
                       {"faces", faces},
                       {"face_element", faceElement}});
}

/// ?format=f32: `values` as raw float32 with the version of the results they belong to.
ApiResponse float32Response(const Eigen::VectorXd& values, long version) {
  ApiResponse out;
  out.contentType = "application/octet-stream";
  out.body = float32(values);
  out.headers.push_back({"X-Diffreg-Version", std::to_string(version)});
  return out;
}

/// GET /api/positions: the current positions, flattened.
ApiResponse positionsResponse(const EditEngine& s, const std::string& format) {
  const Eigen::VectorXd x = flatten(s.positions());
  if (format == "f32") return float32Response(x, s.computedVersion());
  return jsonResponse({{"version", s.computedVersion()},
                       {"positions", std::vector<double>(x.data(), x.data() + x.size())}});
}

/// GET /api/field?name=: the weights (per vertex), the distortion or the smoothness (per
/// element) with their range.
ApiResponse fieldResponse(const EditEngine& s, const ApiRequest& r, const std::string& format) {
  const std::string name = r.query.count("name") ? r.query.at("name") : "";
  const Eigen::VectorXd* values = nullptr;
  std::string site = "element";
  if (name == "weight") {
    values = &s.weights();
    site = "vertex";
  } else if (name == "distortion") {
    values = &s.distortion();
  } else if (name == "smoothness") {
    values = &s.smoothness();
  } else {
    throw InvalidParameter("field name = '" + name +
                           "' is not one of: weight, distortion, smoothness");
  }
  // The range of what is drawn: a weight at a vertex that no element uses colours nothing.
  double lo = 0.0, hi = 0.0;
  const std::vector<bool>& active = s.discretization().active();
  bool any = false;
  for (Eigen::Index i = 0; i < values->size(); ++i) {
    if (site == "vertex" && !active[static_cast<size_t>(i)]) continue;
    const double v = (*values)(i);
    lo = any ? std::min(lo, v) : v;
    hi = any ? std::max(hi, v) : v;
    any = true;
  }
  if (format == "f32") {
    ApiResponse out = float32Response(*values, s.computedVersion());
    out.headers.push_back({"X-Diffreg-Site", site});
    return out;
  }
  return jsonResponse(
      {{"name", name},
       {"site", site},
       {"version", s.computedVersion()},
       {"min", lo},
       {"max", hi},
       {"values", std::vector<double>(values->data(), values->data() + values->size())}});
}

/// GET /api/handles: the handle file; ?download as an attachment named after the mesh `stem`.
ApiResponse handlesResponse(const EditEngine& s, const ApiRequest& r, const std::string& stem) {
  ApiResponse out;
  out.body = handlesToJson(s.handleSet());
  if (r.query.count("download")) out.filename = stem + "-handles.json";
  return out;
}

/// GET /api/export/mesh.ply: the deformed mesh as the tool writes it.
ApiResponse meshExport(const EditEngine& s, const std::string& stem) {
  TempFile file(".ply");
  writeMesh(file.path.string(), s.resultMesh());
  ApiResponse out;
  out.contentType = "application/octet-stream";
  out.body = readAll(file.path);
  out.filename = stem + "-deformed.ply";
  return out;
}

/// The picture GET /api/export/image.png asks for: size and view from the query, `field`
/// coloured on its usual scale, the handles marked.
RenderOptions imageOptions(const EditEngine& s, const ApiRequest& r, const std::string& field,
                           const std::string& stem) {
  RenderOptions options;
  options.width = queryInt(r, "width", 1200, 64, 4096);
  options.height = queryInt(r, "height", 800, 64, 4096);
  options.yaw = queryDouble(r, "yaw", options.yaw);
  options.pitch = queryDouble(r, "pitch", options.pitch);
  if (field == "weight") {
    options.property = prop::weight;
    options.colormap = Colormap::Viridis;
    options.rangeMin = 0.0;
    options.rangeMax = 1.0;
  } else if (field == "distortion" || field == "smoothness") {
    options.property = field == "distortion" ? prop::distortion : prop::smoothness;
    options.colormap = Colormap::Turbo;
    options.rangeMin = 0.0;
  } else if (field != "none") {
    throw InvalidParameter("field = '" + field +
                           "' is not one of: weight, distortion, smoothness, none");
  }
  for (const EditHandle& h : s.state().handles)
    options.handles.insert(options.handles.end(), h.vertices.begin(), h.vertices.end());
  options.wireframe = s.restMesh().numElements() <= 5000;
  options.title = stem + (field == "none" ? "" : " - " + field);
  return options;
}

/// GET /api/export/image.png?field=: the deformed mesh from the software renderer.
ApiResponse imageExport(const EditEngine& s, const ApiRequest& r, const std::string& stem) {
  const std::string field = r.query.count("field") ? r.query.at("field") : "weight";
  const RenderOptions options = imageOptions(s, r, field, stem);
  TempFile file(".png");
  writePng(file.path.string(), renderMesh(s.resultMesh(), options));
  ApiResponse out;
  out.contentType = "image/png";
  out.body = readAll(file.path);
  out.filename = stem + "-" + field + ".png";
  return out;
}

/// Applies the fields of a PATCH /api/params body to `q`.
/// \throw RequestError for an unknown field or one of the wrong type.
void applyParams(const json& body, EditParams& q) {
  allowOnly(body,
            {"energy", "regularization", "beta", "scheme", "order", "t", "unit", "steps", "solve",
             "iterations", "seconds", "tolerance", "local_step", "acceleration", "sigma",
             "rbf_distance",
             "reference", "continue_drags"},
            "params");
  // An enum field, its error naming the field as the API calls it.
  const auto choice = [&body](const char* field, auto& value) {
    if (body.contains(field))
      value = parseEnum<std::decay_t<decltype(value)>>(text(body, field), field);
  };
  choice("energy", q.energy);
  choice("regularization", q.regularization);
  if (body.contains("beta")) q.beta = number(body, "beta");
  choice("scheme", q.scheme);
  if (q.scheme == WeightScheme::Given)
    throw RequestError(400, "scheme: 'given' takes weights from the caller; the editor makes "
                            "them (diffusion or rbf)");
  choice("order", q.diffusion.order);
  if (body.contains("t")) q.diffusion.t = number(body, "t");
  choice("unit", q.diffusion.unit);
  if (body.contains("steps")) q.diffusion.steps = integer(body.at("steps"), "'steps'");
  choice("solve", q.diffusion.solve);
  if (body.contains("iterations")) q.iterations = integer(body.at("iterations"), "'iterations'");
  if (body.contains("seconds")) q.seconds = number(body, "seconds");
  if (body.contains("tolerance")) q.tolerance = number(body, "tolerance");
  choice("local_step", q.localStep);
  choice("acceleration", q.acceleration);
  if (body.contains("sigma")) q.rbf.sigma = number(body, "sigma");
  choice("rbf_distance", q.rbf.distance);
  if (body.contains("reference")) q.reference = boolean(body, "reference");
  if (body.contains("continue_drags")) q.continueDrags = boolean(body, "continue_drags");
}

/// POST /api/handles: a new handle with the next id of `want`; its targets default to the
/// current `positions` of its vertices (of `n`).
EditHandle newHandle(const json& body, EditState& want, const Eigen::MatrixXd& positions, int n) {
  allowOnly(body, {"vertices", "name", "range", "magnitude", "targets"}, "handle");
  if (!body.contains("vertices")) throw RequestError(400, "handle: 'vertices' is missing");
  EditHandle h;
  h.id = want.nextId++;
  h.vertices = vertexList(body.at("vertices"), "'vertices'", n);
  if (body.contains("name")) h.name = text(body, "name");
  if (body.contains("range")) h.range = number(body, "range");
  if (body.contains("magnitude")) h.magnitude = number(body, "magnitude");
  if (body.contains("targets")) {
    h.targets = points(body.at("targets"), "'targets'");
  } else {
    h.targets.resize(static_cast<Eigen::Index>(h.vertices.size()), 3);
    for (size_t i = 0; i < h.vertices.size(); ++i)
      h.targets.row(static_cast<Eigen::Index>(i)) = positions.row(h.vertices[i]);
  }
  return h;
}

/// The handle of `handles` whose id is `idText` (from /api/handles/ID).
/// \throw RequestError 404 when there is none.
std::vector<EditHandle>::iterator findHandle(std::vector<EditHandle>& handles,
                                             const std::string& idText) {
  int id = -1;
  try {
    size_t used = 0;
    id = std::stoi(idText, &used);
    if (used != idText.size()) id = -1;
  } catch (const std::exception&) {
  }
  auto it = std::find_if(handles.begin(), handles.end(),
                         [&](const EditHandle& h) { return h.id == id && id >= 0; });
  if (it == handles.end()) throw RequestError(404, "no handle with id '" + idText + "'");
  return it;
}

/// PATCH /api/handles/ID: applies the body to handle `h`; added vertices start at their
/// current `positions`.
void changeHandle(const json& body, EditHandle& h, const std::string& idText,
                  const Eigen::MatrixXd& positions, int n) {
  allowOnly(body, {"add_vertices", "move_to", "targets", "range", "magnitude", "name"},
            "handle " + idText);
  if (body.contains("add_vertices")) {
    for (int v : vertexList(body.at("add_vertices"), "'add_vertices'", n)) {
      h.vertices.push_back(v);
      h.targets.conservativeResize(h.targets.rows() + 1, 3);
      h.targets.row(h.targets.rows() - 1) = positions.row(v);
    }
  }
  if (body.contains("targets")) h.targets = points(body.at("targets"), "'targets'");
  if (body.contains("move_to")) {
    const Eigen::Vector3d to = point(body.at("move_to"), "'move_to'");
    const Eigen::RowVector3d centroid = h.targets.colwise().mean();
    h.targets.rowwise() += to.transpose() - centroid;
  }
  if (body.contains("range")) h.range = number(body, "range");
  if (body.contains("magnitude")) h.magnitude = number(body, "magnitude");
  if (body.contains("name")) h.name = text(body, "name");
}

/// Applies one edit request (parsed `body`, the PUT's `replacement` handles) to the session.
/// Returns the id of a handle it created, else -1.
int applyEdit(EditEngine& s, const ApiRequest& r, const json& body,
              const std::optional<HandleSet>& replacement) {
  const std::string& p = r.path;
  if (p == "/api/handles" && r.method == "PUT") {
    s.setHandles(*replacement);
    return -1;
  }
  EditState want = s.state();
  int created = -1;
  if (p == "/api/params") {
    applyParams(body, want.params);
  } else if (p == "/api/handles" && r.method == "DELETE") {
    want.handles.clear();
  } else if (p == "/api/handles") {  // POST: a new handle
    EditHandle h = newHandle(body, want, s.positions(), s.numVertices());
    created = h.id;
    want.handles.push_back(std::move(h));
  } else {  // /api/handles/ID
    const std::string idText = p.substr(std::strlen("/api/handles/"));
    auto it = findHandle(want.handles, idText);
    if (r.method == "DELETE")
      want.handles.erase(it);
    else
      changeHandle(body, *it, idText, s.positions(), s.numVertices());
  }
  s.setState(std::move(want));
  return created;
}

}  // namespace

ApiResponse errorResponse(int status, const std::string& message) {
  ApiResponse r;
  r.status = status;
  r.body = json{{"error", message}, {"status", status}}.dump(-1, ' ', false,
                                                            json::error_handler_t::replace);
  return r;
}

Api::Api(std::unique_ptr<EditEngine> session, std::string meshName, ApiOptions options)
    : session_(std::move(session)), meshName_(escapeNonUtf8(meshName)), options_(options) {
  if (!session_) throw InvalidParameter("the API needs an editing session");
  session_->update();
}

Api::~Api() = default;

ApiResponse Api::handle(const ApiRequest& request) {
  try {
    if (request.body.size() > options_.maxBodyBytes)
      return errorResponse(413, "the request body has " + std::to_string(request.body.size()) +
                                    " bytes, more than the limit of " +
                                    std::to_string(options_.maxBodyBytes));
    return route(request);
  } catch (const RequestError& e) {
    return errorResponse(e.status, e.what());
  } catch (const json::exception& e) {
    std::string what = e.what();  // "[json.exception.type_error.302] type must be ..."
    const auto close = what.find("] ");
    if (close != std::string::npos) what = what.substr(close + 2);
    return errorResponse(400, "bad JSON value: " + what);
  } catch (const InvalidParameter& e) {
    return errorResponse(422, e.what());
  } catch (const InvalidMesh& e) {
    return errorResponse(422, e.what());
  } catch (const IoError&) {
    // One answer whatever the cause: the reply must not tell which paths exist.
    return errorResponse(422, "a file named in the request cannot be read (the server reads "
                              "only regular MeshLab picked points files of at most 16 MiB)");
  } catch (const Error& e) {
    return errorResponse(422, e.what());
  } catch (const std::exception&) {
    return errorResponse(500, "internal error");
  }
}

ApiResponse Api::route(const ApiRequest& r) {
  const std::string& p = r.path;
  const std::string& m = r.method;
  auto methods = [&](std::initializer_list<const char*> allowed) {
    for (const char* a : allowed)
      if (m == a) return;
    std::string list;
    for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    throw RequestError(405, m + " is not allowed on " + p + " (allowed: " + list + ")");
  };
  if (p == "/api/mesh" || p == "/api/state" || p == "/api/positions" || p == "/api/field" ||
      p == "/api/export/mesh.ply" || p == "/api/export/image.png") {
    methods({"GET"});
    return read(r);
  }
  if (p == "/api/params") {
    methods({"PATCH"});
    return edit(r);
  }
  if (p == "/api/handles") {
    methods({"GET", "POST", "PUT", "DELETE"});
    return m == "GET" ? read(r) : edit(r);
  }
  if (p.rfind("/api/handles/", 0) == 0) {
    methods({"PATCH", "DELETE"});
    return edit(r);
  }
  if (p == "/api/refine") {
    methods({"POST"});
    return refine(r);
  }
  throw RequestError(404, "no endpoint " + p);
}

ApiResponse Api::read(const ApiRequest& r) {
  std::lock_guard<std::mutex> lock(mutex_);
  const EditEngine& s = *session_;
  const std::string& p = r.path;
  const auto format = r.query.count("format") ? r.query.at("format") : std::string("json");
  if (format != "json" && format != "f32")
    throw InvalidParameter("format = '" + format + "' is not one of: json, f32");
  if (p == "/api/state") {
    ApiResponse out;
    out.body = stateJson(false, -1);
    return out;
  }
  if (p == "/api/mesh") return meshResponse(s, meshName_);
  if (p == "/api/positions") return positionsResponse(s, format);
  if (p == "/api/field") return fieldResponse(s, r, format);
  const std::string stem = fs::path(meshName_).stem().string();
  if (p == "/api/handles") return handlesResponse(s, r, stem);
  if (p == "/api/export/mesh.ply") return meshExport(s, stem);
  return imageExport(s, r, stem);  // /api/export/image.png
}

ApiResponse Api::edit(const ApiRequest& r) {
  // Parse before waiting for the session: a malformed request never delays anything.
  json body;
  const bool needsBody = !(r.method == "DELETE");
  if (needsBody) body = r.method == "PUT" ? parseBody(r.body) : parseObject(r.body);
  // A handle file may name picked-points files: read them before taking the lock (the rest
  // mesh never changes), so a slow or refused file delays no other request.
  std::optional<HandleSet> replacement;
  if (r.path == "/api/handles" && r.method == "PUT")
    replacement = parseHandles(body.dump(), session_->restMesh(), "request body", "", false);

  ++waiting_;
  std::unique_lock<std::mutex> lock(mutex_);
  --waiting_;
  int created = -1;
  try {
    created = applyEdit(*session_, r, body, replacement);
  } catch (...) {
    finish();  // an earlier edit that skipped its update because of this one
    throw;
  }
  const bool coalesced = !finish();
  ApiResponse out;
  out.body = stateJson(coalesced, created);
  return out;
}

ApiResponse Api::refine(const ApiRequest& r) {
  // It takes no fields: an empty body or {}, checked before the lock as every body.
  if (r.body.find_first_not_of(" \t\r\n") != std::string::npos && !parseObject(r.body).empty())
    throw RequestError(400, "POST /api/refine takes no fields (an empty body or {})");
  std::lock_guard<std::mutex> lock(mutex_);
  // An edit waiting for the lock brings newer results; an idle refinement yields to it.
  if (waiting_.load() == 0 && session_->refine()) session_->update();
  ApiResponse out;
  out.body = stateJson(false, -1);
  return out;
}

bool Api::finish() {
  if (waiting_.load() > 0) return false;  // a newer edit follows and brings the results
  if (session_->computedVersion() != session_->version()) session_->update();
  return true;
}

std::string Api::stateJson(bool coalesced, int created) const {
  const EditEngine& s = *session_;
  json handles = json::array();
  const std::vector<std::string> names = handleNames(s.state());
  for (size_t j = 0; j < s.state().handles.size(); ++j) {
    const EditHandle& h = s.state().handles[j];
    handles.push_back({{"id", h.id},
                       {"name", names[j]},
                       {"vertices", h.vertices},
                       {"targets", matrixRows(h.targets)},
                       {"range", h.range},
                       {"magnitude", h.magnitude}});
  }
  const DeformationMetrics& m = s.metrics();
  const UpdateReport& u = s.lastUpdate();
  json doc = {{"version", s.version()},
              {"computed_version", s.computedVersion()},
              {"mesh",
               {{"name", meshName_},
                {"kind", toString(s.restMesh().kind())},
                {"vertices", s.numVertices()}}},
              {"params", paramsJson(s.state().params)},
              {"handles", handles},
              {"metrics",
               {{"d_max", m.dMax},
                {"d_ave", m.dAve},
                {"d_dev", m.dDev},
                {"dist", m.dist ? json(*m.dist) : json(nullptr)},
                {"inverted", m.inverted},
                {"energy", m.energy},
                {"energy_relaxed", m.relaxed}}},
              {"update",
               {{"solved", u.solved},
                {"message", u.message},
                {"seconds", u.seconds},
                {"weights_seconds", u.weightsSeconds},
                {"deformation_seconds", u.deformationSeconds},
                {"reference_seconds", u.referenceSeconds},
                {"metrics_seconds", u.metricsSeconds},
                {"iterations", u.iterations},
                {"converged", u.converged},
                {"criterion", u.criterion},
                {"weights_work", u.weightsWork},
                {"deformation_work", u.deformationWork},
                {"reference_work", u.referenceWork},
                {"weights", statsJson(u.weights)},
                {"deformation", statsJson(u.deformation)},
                {"reference", statsJson(u.reference)}}},
              {"totals",
               {{"weights", statsJson(s.weightStats())},
                {"deformation", statsJson(s.deformationStats())},
                {"reference", statsJson(s.referenceStats())}}}};
  if (coalesced) doc["coalesced"] = true;
  if (created >= 0) doc["created"] = created;
  return doc.dump(-1, ' ', false, json::error_handler_t::replace);
}

}  // namespace diffreg
