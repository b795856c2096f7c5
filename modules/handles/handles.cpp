#include <diffreg/handles/handles.h>
#include <diffreg/handles/vertex_search.h>

#include <diffreg/core/error.h>
#include <diffreg/core/file.h>
#include <diffreg/core/json.h>
#include <diffreg/core/text.h>
#include <diffreg/core/xml.h>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <unordered_map>

namespace diffreg {
namespace {

using json = nlohmann::json;

const std::vector<std::string> kHandleKeys = {"name",    "vertices",  "nearest",   "within",
                                              "picked",  "translate", "rotate",    "targets",
                                              "range",   "magnitude"};
const std::vector<std::string> kFromPickedKeys = {"file",   "names", "translate",
                                                  "rotate", "range", "magnitude"};

std::string join(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : ", ") + w;
  return out;
}

/// Parses one handle file against a mesh; every error names the source and the handle.
class Parser {
 public:
  Parser(const Mesh& mesh, std::string source, std::string baseDir, bool revealFiles)
      : source_(std::move(source)),
        baseDir_(std::move(baseDir)),
        revealFiles_(revealFiles),
        rest_(mesh.positions()),
        used_(mesh.referenced()),
        planar_(mesh.kind() == MeshKind::Planar),
        search_(rest_, used_),
        owner_(rest_.rows(), -1) {
    // A planar mesh's referenced vertices share their z (an unreferenced one may not).
    for (Eigen::Index v = 0; v < rest_.rows(); ++v)
      if (used_[static_cast<size_t>(v)]) {
        planeZ_ = rest_(v, 2);
        break;
      }
    // The referenced vertices' box: a far unreferenced vertex must not move the centre that a
    // target's reach is measured from, nor loosen the tolerances.
    const Eigen::AlignedBox3d box = meshBounds(rest_, used_);
    if (!box.isEmpty()) {
      const double diagonal = box.diagonal().norm();
      tol_ = 1e-9 * std::max(1.0, diagonal);
      center_ = box.center();
      reach_ = 1000.0 * std::max(diagonal, 1e-300);
    }
  }

  HandleSet parse(const std::string& text) {
    json root;
    try {
      root = parseJsonStrictly(text);
    } catch (const std::invalid_argument& e) {
      throw InvalidParameter(source_ + ": malformed JSON: " + e.what());
    }
    if (!root.is_object() || (!root.contains("handles") && !root.contains("handles_from_picked")) ||
        (root.contains("handles") && !root["handles"].is_array())) {
      throw InvalidParameter(source_ +
                             ": expected an object {\"handles\": [...]} at the top level (and/or "
                             "\"handles_from_picked\")");
    }
    for (const auto& item : root.items()) {
      if (item.key() != "handles" && item.key() != "handles_from_picked") {
        throw InvalidParameter(source_ + ": unknown key '" + item.key() +
                               "' (valid: handles, handles_from_picked)");
      }
    }
    HandleSet set;
    if (root.contains("handles")) {
      const json& list = root["handles"];
      for (size_t i = 0; i < list.size(); ++i) {
        set.handles.push_back(parseHandle(list[i], i));
        admit(set);
      }
    }
    if (root.contains("handles_from_picked")) {
      const json& from = root["handles_from_picked"];
      if (!from.is_object() && !from.is_array()) {
        throw InvalidParameter(source_ +
                               ": \"handles_from_picked\" must be an object {\"file\": ...} or a "
                               "list of them");
      }
      if (from.is_object()) {
        handlesFromPicked(from, 0, set);
      } else {
        for (size_t i = 0; i < from.size(); ++i) handlesFromPicked(from[i], i, set);
      }
    }
    return set;
  }

 private:
  /// Checks the newest handle of `set` against the earlier ones as soon as it is parsed: a
  /// name or a vertex taken twice ends the parse there, so a file of many overlapping handles
  /// costs no more than the vertices of the mesh.
  void admit(const HandleSet& set) {
    const size_t i = set.handles.size() - 1;
    const Handle& h = set.handles[i];
    if (!names_.insert(h.name).second) {
      throw InvalidParameter(source_ + ": two handles are named '" + h.name + "'");
    }
    for (int v : h.vertices) {
      if (owner_[v] >= 0) {
        throw InvalidParameter(source_ + ": vertex " + std::to_string(v) + " is in handles '" +
                               set.handles[owner_[v]].name + "' and '" + h.name + "'");
      }
      owner_[v] = static_cast<int>(i);
    }
  }

  [[noreturn]] void fail(const std::string& message) const {
    throw InvalidParameter(source_ + ": " + label_ + ": " + message);
  }

  double number(const json& j, const std::string& what) const {
    if (!j.is_number()) fail(what + " must be a number");
    const double v = j.get<double>();
    if (!std::isfinite(v)) fail(what + " is not finite");
    return v;
  }

  /// A 3-vector, or a 2-vector on a planar mesh (z = `z2`).
  Eigen::Vector3d vec(const json& j, const std::string& what, double z2) const {
    const bool size2 = j.is_array() && j.size() == 2;
    if (!j.is_array() || (j.size() != 3 && !size2)) {
      fail(what + " must be [x, y, z]" + (planar_ ? " or [x, y]" : ""));
    }
    if (size2 && !planar_) fail(what + " needs 3 entries (2 only on planar meshes)");
    Eigen::Vector3d v(0, 0, z2);
    for (size_t c = 0; c < j.size(); ++c) v[c] = number(j[c], what);
    return v;
  }

  /// The referenced vertex nearest to p (the lowest id among equidistant ones).
  int nearest(const Eigen::Vector3d& p) const {
    const int best = search_.nearest(p);
    if (best < 0) fail("the mesh has no referenced vertices");
    return best;
  }

  void checkPlanar(const Eigen::Vector3d& target, const std::string& what) const {
    if (planar_ && std::abs(target[2] - planeZ_) > tol_) {
      fail(what + " leaves the plane of the planar mesh (z must be " + formatNumber(planeZ_) + ")");
    }
  }

  std::vector<int> select(const json& h) const {
    std::vector<int> ids;
    if (h.contains("vertices")) {
      const json& list = h["vertices"];
      if (!list.is_array()) fail("\"vertices\" must be an array of vertex ids");
      for (const json& id : list) {
        if (!id.is_number_integer()) fail("vertex ids must be integers, got " + id.dump());
        const bool huge = id.is_number_unsigned() && id.get<unsigned long long>() > 1u << 31;
        const long long v = huge ? -1 : id.get<long long>();
        if (v < 0 || v >= rest_.rows()) {
          fail("vertex id " + id.dump() + " out of range 0.." + std::to_string(rest_.rows() - 1));
        }
        if (!used_[v]) fail("vertex " + std::to_string(v) + " is not part of any element");
        ids.push_back(static_cast<int>(v));
      }
    } else if (h.contains("nearest")) {
      const json& n = h["nearest"];
      if (!n.is_array()) fail("\"nearest\" must be a point or a list of points");
      const bool many = !n.empty() && n[0].is_array();
      for (size_t i = 0; i < (many ? n.size() : (n.empty() ? 0 : 1)); ++i) {
        ids.push_back(nearest(vec(many ? n[i] : n, "\"nearest\" point", planeZ_)));
      }
    } else if (h.contains("picked")) {
      ids = selectPicked(h["picked"]);
    } else {
      const json& w = h["within"];
      if (!w.is_object()) fail("\"within\" must be {\"center\": [..], \"radius\": r}");
      for (const auto& item : w.items()) {
        if (item.key() != "center" && item.key() != "radius") {
          fail("unknown key '" + item.key() + "' in \"within\" (valid: center, radius)");
        }
      }
      if (!w.contains("center") || !w.contains("radius")) {
        fail("\"within\" needs both \"center\" and \"radius\"");
      }
      const Eigen::Vector3d c = vec(w["center"], "\"within\" center", planeZ_);
      const double r = number(w["radius"], "\"within\" radius");
      if (!(r > 0.0)) fail("\"within\" radius must be > 0");
      ids = search_.within(c, r);
      if (ids.empty()) fail("no vertex lies within radius " + formatNumber(r) + " of the center");
    }
    if (ids.empty()) fail("empty handle (no vertices selected)");
    std::vector<int> sorted = ids;
    std::sort(sorted.begin(), sorted.end());
    const auto dup = std::adjacent_find(sorted.begin(), sorted.end());
    if (dup != sorted.end()) fail("vertex " + std::to_string(*dup) + " is selected twice");
    return ids;
  }

  Eigen::MatrixXd move(const json& h, const std::vector<int>& ids) const {
    const int k = static_cast<int>(ids.size());
    Eigen::MatrixXd targets(k, 3);
    for (int i = 0; i < k; ++i) targets.row(i) = rest_.row(ids[i]);
    if (h.contains("translate")) {
      const Eigen::Vector3d d = vec(h["translate"], "\"translate\"", 0.0);
      checkPlanar(Eigen::Vector3d(0, 0, planeZ_ + d[2]), "\"translate\"");
      targets.rowwise() += d.transpose();
    } else if (h.contains("rotate")) {
      const json& r = h["rotate"];
      if (!r.is_object()) fail("\"rotate\" must be {\"center\", \"axis\", \"degrees\"}");
      for (const auto& item : r.items()) {
        if (item.key() != "center" && item.key() != "axis" && item.key() != "degrees") {
          fail("unknown key '" + item.key() + "' in \"rotate\" (valid: center, axis, degrees)");
        }
      }
      if (!r.contains("degrees")) fail("\"rotate\" needs \"degrees\"");
      const double degrees = number(r["degrees"], "\"rotate\" degrees");
      // Default centre: the centroid of the handle's rest positions.
      Eigen::Vector3d center = targets.colwise().mean().transpose();
      if (r.contains("center")) center = vec(r["center"], "\"rotate\" center", planeZ_);
      Eigen::Vector3d axis(0, 0, 1);
      if (r.contains("axis")) {
        axis = vec(r["axis"], "\"rotate\" axis", 1.0);
      } else if (!planar_) {
        fail("\"rotate\" needs an \"axis\" on a non-planar mesh");
      }
      // Scaled by its largest component first: [1e300, 0, 0] must not overflow to inf.
      const double largest = axis.cwiseAbs().maxCoeff();
      if (largest == 0.0) fail("\"rotate\" axis is zero");
      axis = (axis / largest).normalized();
      if (planar_ && std::abs(std::abs(axis[2]) - 1.0) > 1e-12) {
        fail("on a planar mesh the \"rotate\" axis must be the z axis");
      }
      const Eigen::Matrix3d R = Eigen::AngleAxisd(degrees * M_PI / 180.0, axis).toRotationMatrix();
      for (int i = 0; i < k; ++i) {
        const Eigen::Vector3d p = targets.row(i).transpose();
        targets.row(i) = (center + R * (p - center)).transpose();
      }
      if (planar_) targets.col(2).setConstant(planeZ_);
    } else if (h.contains("targets")) {
      const json& t = h["targets"];
      if (!t.is_array()) fail("\"targets\" must be a list of points");
      if (static_cast<int>(t.size()) != k) {
        fail(std::to_string(t.size()) + " targets for " + std::to_string(k) + " selected vertices");
      }
      for (int i = 0; i < k; ++i) {
        const Eigen::Vector3d p = vec(t[i], "target " + std::to_string(i), rest_(ids[i], 2));
        checkPlanar(p, "target " + std::to_string(i));
        targets.row(i) = p.transpose();
      }
    }
    return targets;
  }

  /// Every target finite and within 1000 mesh diagonals of the mesh (as diffreg serve).
  void checkTargets(const Handle& h) const {
    for (Eigen::Index i = 0; i < h.targets.rows(); ++i) {
      const Eigen::Vector3d p = h.targets.row(i).transpose();
      const auto which = [&] { return "the target of vertex " + std::to_string(h.vertices[i]); };
      if (!p.allFinite()) fail(which() + " is not finite (the motion overflows)");
      if ((p - center_).norm() > reach_) fail(which() + " is more than 1000 mesh diagonals away");
    }
  }

  Handle parseHandle(const json& h, size_t index, const std::string& origin = "") {
    label_ = "handle #" + std::to_string(index) + origin;
    if (!h.is_object()) fail("must be an object");
    Handle out;
    out.name = "handle" + std::to_string(index);
    if (h.contains("name")) {
      if (!h["name"].is_string()) fail("\"name\" must be a string");
      out.name = h["name"].get<std::string>();
    }
    label_ = "handle '" + out.name + "' (#" + std::to_string(index) + origin + ")";
    for (const auto& item : h.items()) {
      if (std::find(kHandleKeys.begin(), kHandleKeys.end(), item.key()) == kHandleKeys.end()) {
        fail("unknown key '" + item.key() + "' (valid: " + join(kHandleKeys) + ")");
      }
    }
    const int selections = h.contains("vertices") + h.contains("nearest") + h.contains("within") +
                           h.contains("picked");
    if (selections != 1) {
      fail(std::string(selections == 0 ? "no" : "more than one") +
           " selection: give exactly one of \"vertices\", \"nearest\", \"within\", \"picked\"");
    }
    const int motions = h.contains("translate") + h.contains("rotate") + h.contains("targets");
    if (motions > 1) fail("give at most one of \"translate\", \"rotate\", \"targets\"");

    if (h.contains("range")) out.range = number(h["range"], "\"range\"");
    if (h.contains("magnitude")) out.magnitude = number(h["magnitude"], "\"magnitude\"");
    if (!(out.range >= kMinHandleRange && out.range <= kMaxHandleRange)) {
      fail("\"range\" must be in [1e-6, 1e6], got " + formatNumber(out.range));
    }
    if (!(out.magnitude >= 0.0 && out.magnitude <= 1.0)) {
      fail("\"magnitude\" must be >= 0 and <= 1, got " + formatNumber(out.magnitude));
    }
    out.vertices = select(h);
    out.targets = move(h, out.vertices);
    checkTargets(out);
    return out;
  }

  /// A .pp path from the handle file, resolved against the handle file's directory.
  std::string resolve(const std::string& file) const {
    std::filesystem::path path(file);
    if (path.is_relative() && !baseDir_.empty()) path = std::filesystem::path(baseDir_) / path;
    return path.lexically_normal().string();
  }

  /// The points of a resolved .pp path, read once per file.
  const std::vector<PickedPoint>& loadPicked(const std::string& path) const {
    const auto it = picked_.find(path);
    if (it != picked_.end()) return it->second;
    try {
      return picked_.emplace(path, readPickedPoints(path)).first->second;
    } catch (const Error& e) {
      const std::string where = source_ + ": " + label_ + ": ";
      if (!revealFiles_) throw IoError(where + "a picked points file cannot be read");
      if (dynamic_cast<const IoError*>(&e)) throw IoError(where + e.what());
      throw InvalidParameter(where + e.what());
    }
  }

  /// The active points of the .pp file `path`: all of them, or those named in `names`.
  std::vector<const PickedPoint*> choosePicked(const std::string& path, const json* names) const {
    const std::vector<PickedPoint>& points = loadPicked(path);
    std::vector<const PickedPoint*> chosen;
    if (!names) {
      for (const PickedPoint& p : points)
        if (p.active) chosen.push_back(&p);
      if (points.empty()) fail(path + " has no points");
      if (chosen.empty()) {
        fail(path + " has no active points (all " + std::to_string(points.size()) +
             " are inactive)");
      }
      return chosen;
    }
    if (!names->is_array() || names->empty()) {
      fail("\"names\" must be a non-empty list of point names");
    }
    const std::unordered_map<std::string, std::vector<size_t>>& byName = pickedNames(path);
    // Every name is checked first, in order; then the points are chosen. A name given twice
    // chooses its first point again, which is nearest to the same vertex (or names the same
    // handle) as before: that is an error, so the list ends there.
    for (const json& n : *names) {
      if (!n.is_string()) fail("point names must be strings, got " + n.dump());
      const std::string name = n.get<std::string>();
      const auto it = byName.find(name);
      const bool found = it != byName.end();
      bool active = false;
      if (found) {
        for (size_t k : it->second) active = active || points[k].active;
      }
      if (!found) {
        std::vector<std::string> all;
        for (const PickedPoint& p : points) {
          if (all.size() == 20) {
            all.push_back("...");
            break;
          }
          all.push_back("'" + p.name + "'");
        }
        fail("no point named '" + name + "' in " + path +
             (all.empty() ? std::string(" (it has no points)") : " (names: " + join(all) + ")"));
      }
      if (!active) fail("point '" + name + "' in " + path + " is not active");
    }
    std::set<std::string> seen;
    for (const json& n : *names) {
      const std::vector<size_t>& all = byName.at(n.get_ref<const std::string&>());
      const bool again = !seen.insert(n.get<std::string>()).second;
      for (size_t k : all) {
        if (!points[k].active) continue;
        chosen.push_back(&points[k]);
        if (again) return chosen;
      }
    }
    return chosen;
  }

  /// The points of the .pp file `path` (already loaded) by name, in file order.
  const std::unordered_map<std::string, std::vector<size_t>>& pickedNames(
      const std::string& path) const {
    const auto it = pickedNames_.find(path);
    if (it != pickedNames_.end()) return it->second;
    const std::vector<PickedPoint>& points = loadPicked(path);
    std::unordered_map<std::string, std::vector<size_t>> byName;
    for (size_t k = 0; k < points.size(); ++k) byName[points[k].name].push_back(k);
    return pickedNames_.emplace(path, std::move(byName)).first->second;
  }

  /// "picked": "f.pp" or {"file": "f.pp", "names": [...]}: the vertex nearest to each chosen
  /// active point.
  std::vector<int> selectPicked(const json& p) const {
    std::string file;
    const json* names = nullptr;
    if (p.is_string()) {
      file = p.get<std::string>();
    } else if (p.is_object()) {
      for (const auto& item : p.items()) {
        if (item.key() != "file" && item.key() != "names") {
          fail("unknown key '" + item.key() + "' in \"picked\" (valid: file, names)");
        }
      }
      if (!p.contains("file") || !p["file"].is_string()) {
        fail("\"picked\" needs \"file\": the name of a MeshLab .pp file");
      }
      file = p["file"].get<std::string>();
      if (p.contains("names")) names = &p["names"];
    } else {
      fail("\"picked\" must be a .pp file name or {\"file\": \"f.pp\", \"names\": [...]}");
    }
    if (file.empty()) fail("\"picked\" file name is empty");
    const std::string path = resolve(file);
    std::vector<int> ids;
    std::map<int, const PickedPoint*> owner;
    for (const PickedPoint* point : choosePicked(path, names)) {
      const int v = nearest(point->position);
      const auto [it, fresh] = owner.emplace(v, point);
      if (!fresh) {
        fail("picked points '" + it->second->name + "' (line " + std::to_string(it->second->line) +
             ") and '" + point->name + "' (line " + std::to_string(point->line) + ") of " + path +
             " are both nearest to vertex " + std::to_string(v));
      }
      ids.push_back(v);
    }
    return ids;
  }

  /// A "handles_from_picked" entry: one handle per chosen active point of a .pp file, named
  /// after the point, with the entry's motion, range and magnitude.
  void handlesFromPicked(const json& e, size_t index, HandleSet& set) {
    label_ = "handles_from_picked #" + std::to_string(index);
    if (!e.is_object()) fail("must be an object {\"file\": \"f.pp\", ...}");
    for (const auto& item : e.items()) {
      if (std::find(kFromPickedKeys.begin(), kFromPickedKeys.end(), item.key()) ==
          kFromPickedKeys.end()) {
        fail("unknown key '" + item.key() + "' (valid: " + join(kFromPickedKeys) + ")");
      }
    }
    if (!e.contains("file") || !e["file"].is_string() || e["file"].get<std::string>().empty()) {
      fail("needs \"file\": the name of a MeshLab .pp file");
    }
    if (e.contains("translate") && e.contains("rotate")) {
      fail("give at most one of \"translate\", \"rotate\"");
    }
    const std::string path = resolve(e["file"].get<std::string>());
    const std::vector<const PickedPoint*> chosen =
        choosePicked(path, e.contains("names") ? &e["names"] : nullptr);
    const PickedPoint* first = loadPicked(path).data();
    for (const PickedPoint* point : chosen) {
      json h = json::object();
      h["name"] = point->name.empty() ? "picked" + std::to_string(point - first) : point->name;
      h["nearest"] = {point->position[0], point->position[1], point->position[2]};
      for (const char* key : {"translate", "rotate", "range", "magnitude"})
        if (e.contains(key)) h[key] = e[key];
      set.handles.push_back(parseHandle(h, set.handles.size(), ", from " + path));
      admit(set);
      label_ = "handles_from_picked #" + std::to_string(index);
    }
  }

  std::string source_;
  std::string baseDir_;
  bool revealFiles_ = true;  ///< messages may say why a picked points file cannot be used
  mutable std::map<std::string, std::vector<PickedPoint>> picked_;  ///< .pp files read so far
  /// Their points by name, built when a handle first chooses points of the file by name.
  mutable std::map<std::string, std::unordered_map<std::string, std::vector<size_t>>> pickedNames_;
  Eigen::MatrixXd rest_;
  std::vector<bool> used_;
  bool planar_;
  double planeZ_ = 0.0;
  double tol_ = 1e-9;
  Eigen::Vector3d center_ = Eigen::Vector3d::Zero();
  double reach_ = 1e300;  ///< targets farther than this from center_ are refused
  mutable VertexSearch search_;  ///< nearest and within queries (after rest_ and used_)
  std::set<std::string> names_;  ///< names of the handles admitted so far
  std::vector<int> owner_;       ///< per vertex, the admitted handle holding it, or -1
  std::string label_;
};

}  // namespace

std::vector<int> HandleSet::allVertices() const {
  std::vector<int> out;
  for (const Handle& h : handles) out.insert(out.end(), h.vertices.begin(), h.vertices.end());
  return out;
}

Eigen::MatrixXd HandleSet::allTargets() const {
  Eigen::Index rows = 0;
  for (const Handle& h : handles) {
    if (h.targets.rows() != static_cast<Eigen::Index>(h.vertices.size()) || h.targets.cols() != 3)
      throw InvalidParameter("handle '" + h.name + "': " + std::to_string(h.vertices.size()) +
                             " vertices need as many target rows of 3 coordinates, got " +
                             std::to_string(h.targets.rows()) + " x " +
                             std::to_string(h.targets.cols()));
    rows += h.targets.rows();
  }
  Eigen::MatrixXd out(rows, 3);
  Eigen::Index row = 0;
  for (const Handle& h : handles) {
    out.middleRows(row, h.targets.rows()) = h.targets;
    row += h.targets.rows();
  }
  return out;
}

std::vector<int> HandleSet::handleOfVertex(int numVertices) const {
  std::vector<int> out(std::max(0, numVertices), -1);
  for (size_t i = 0; i < handles.size(); ++i) {
    for (int v : handles[i].vertices) {
      if (v < 0 || v >= numVertices) {
        throw InvalidParameter("handle '" + handles[i].name + "': vertex " + std::to_string(v) +
                               " out of range for a mesh with " + std::to_string(numVertices) +
                               " vertices");
      }
      out[v] = static_cast<int>(i);
    }
  }
  return out;
}

std::vector<PickedPoint> parsePickedPoints(const std::string& xmlText, const std::string& source) {
  const XmlDocument doc = parseXml(xmlText, source);
  auto fail = [&](int line, const std::string& message) {
    throw InvalidParameter(source + ":" + std::to_string(line) + ": " + message);
  };
  if (doc.root.name != "PickedPoints") {
    fail(doc.root.line, "the root element is <" + doc.root.name +
                            ">; a MeshLab picked points file has <PickedPoints>");
  }
  std::vector<PickedPoint> points;
  for (const XmlElement& e : doc.root.children) {
    if (e.name != "point") continue;  // <DocumentData> and the like
    PickedPoint p;
    p.line = e.line;
    if (const std::string* name = e.attribute("name")) p.name = escapeNonUtf8(*name);
    const std::string what = "point" + (p.name.empty() ? std::string() : " '" + p.name + "'");
    const char* axes[] = {"x", "y", "z"};
    for (int c = 0; c < 3; ++c) {
      const std::string* text = e.attribute(axes[c]);
      if (!text) fail(e.line, what + " has no " + axes[c] + " attribute");
      char* end = nullptr;
      const double v = text->empty() ? 0.0 : std::strtod(text->c_str(), &end);
      if (text->empty() || std::isspace(static_cast<unsigned char>((*text)[0])) || *end != '\0' ||
          !std::isfinite(v)) {
        fail(e.line, what + ": " + axes[c] + "=\"" + *text + "\" is not a finite number");
      }
      p.position[c] = v;
    }
    if (const std::string* active = e.attribute("active")) {
      if (*active == "1" || *active == "true") {
        p.active = true;
      } else if (*active == "0" || *active == "false") {
        p.active = false;
      } else {
        fail(e.line, what + ": active=\"" + *active + "\" is not one of 1, 0, true, false");
      }
    }
    points.push_back(std::move(p));
  }
  return points;
}

std::vector<PickedPoint> readPickedPoints(const std::string& path) {
  return parsePickedPoints(readFileLimited(path, "picked points file", limits::textBytes), path);
}

HandleSet readHandles(const std::string& path, const Mesh& mesh) {
  const std::string text = readFileLimited(path, "handle file", limits::textBytes);
  return parseHandles(text, mesh, path, std::filesystem::path(path).parent_path().string());
}

HandleSet parseHandles(const std::string& jsonText, const Mesh& mesh, const std::string& source,
                       const std::string& baseDir, bool revealFiles) {
  return Parser(mesh, source, baseDir, revealFiles).parse(jsonText);
}

std::string handlesToJson(const HandleSet& handles) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Handle& h : handles.handles) {
    nlohmann::ordered_json targets = nlohmann::ordered_json::array();
    for (int i = 0; i < h.targets.rows(); ++i) {
      targets.push_back({h.targets(i, 0), h.targets(i, 1), h.targets(i, 2)});
    }
    nlohmann::ordered_json item;
    item["name"] = h.name;
    item["vertices"] = h.vertices;
    item["targets"] = targets;
    item["range"] = h.range;
    item["magnitude"] = h.magnitude;
    list.push_back(item);
  }
  nlohmann::ordered_json root;
  root["handles"] = list;
  return root.dump(2) + "\n";
}

}  // namespace diffreg
