// The JSON API of `diffreg serve`, independent of HTTP: a request in, a response out. Every
// request is checked before it touches the editing session; a bad one gets a 4xx response with
// {"error": "one-line message", "status": code} and leaves the session unchanged.
//
// Endpoints (all under /api; JSON bodies, UTF-8):
//
//   GET    /api/mesh         the rest mesh: {"name", "kind": "planar"|"surface"|"tet",
//                            "vertices": n, "elements": m, "dim": 2|3, "diagonal",
//                            "rest": [x0, y0, z0, x1, ...] (3 n), "faces": [a, b, c, ...]
//                            (3 f: the triangles, or a tet mesh's boundary triangles, outwards),
//                            "face_element": [k, ...] (f: the element of each face)}
//   GET    /api/state        the state document (below)
//   GET    /api/positions    {"version", "positions": [3 n]}; ?format=f32: the same as raw
//                            little-endian float32 (application/octet-stream, header
//                            X-Diffreg-Version)
//   GET    /api/field?name=weight|distortion|smoothness
//                            {"name", "site": "vertex"|"element", "values": [...], "min",
//                            "max", "version"}; ?format=f32 as for positions
//   PATCH  /api/params       any subset of {"energy": "arap"|"asap"|"larap"|"dirichlet",
//                            "regularization": "none"|"uniform"|"nonuniform", "beta": [0, 1],
//                            "scheme": "diffusion"|"rbf", "order": "first"|"second"|
//                            "implicit_euler", "t": [1e-12, 1e6], "unit": "absolute"|"diagonal"|
//                            "mean_edge2", "steps": [1, 1e5], "solve": "pcg"|"direct",
//                            "iterations": [1, 1e5] (per update), "seconds": [0, 3600] (per
//                            update, 0: no limit), "tolerance": [0, 1] (stationarity),
//                            "local_step": "exact"|"reference", "acceleration":
//                            "lbfgs"|"anderson"|"none", "sigma": [1e-12, 1e6], "rbf_distance":
//                            "euclidean"|"geodesic", "reference": bool, "continue_drags": bool
//                            (EditParams::continueDrags)}
//   POST   /api/handles      add a handle {"vertices": [ids], "name"? (unique), "range"? [1e-6,
//                            1e6], "magnitude"? [0, 1], "targets"? [[x, y, z], ...]}; targets
//                            default to the vertices' current (deformed) positions. The state
//                            document then has "created": the new handle's id.
//   PATCH  /api/handles/ID   change one handle: {"add_vertices": [ids] (at their current
//                            positions), "move_to": [x, y, z] (translates the targets so that
//                            their centroid is there; absolute, so repeating it is harmless),
//                            "targets": [[x, y, z], ...], "range", "magnitude", "name"}
//   POST   /api/refine       continue an unconverged deformation (and reference) from the
//                            current shapes for another "iterations" (the page sends it while
//                            idle until "converged"); a no-op when converged or an edit waits;
//                            no fields (an empty body or {})
//   DELETE /api/handles/ID   remove one handle
//   PUT    /api/handles      replace all handles by a handle file (the `--handles` JSON format)
//   DELETE /api/handles      remove all handles
//   GET    /api/handles      the handles as a handle file (JSON); ?download=1 as an attachment
//   GET    /api/export/mesh.ply   the deformed mesh, PLY with vertex quality = weight (and
//                            colours) and face quality = distortion (tet meshes: the boundary)
//   GET    /api/export/image.png?field=weight|distortion|smoothness|none&width=&height=
//                            &yaw=&pitch=   a picture from the software renderer (PNG)
//
// The state document: {"version" (accepted edits), "computed_version" (the edit the results
// belong to), "params" (as PATCH /api/params), "handles": [{"id", "name", "vertices",
// "targets", "range", "magnitude"}], "metrics": {"d_max", "d_ave", "d_dev", "dist" (null
// without a reference), "inverted", "energy", "energy_relaxed" (true: "energy" is eq. 3 with
// the targets relaxed at this shape; false: an unconverged run's own energy, an upper bound)},
// "update": the last update {"solved", "message",
// "seconds", "weights_seconds", "deformation_seconds", "reference_seconds",
// "metrics_seconds", "iterations", "converged", "criterion" (how far from converged:
// DeformationResult::criterion; null after a first global step alone), "weights_work",
// "deformation_work", "reference_work" ("none"|"solve"|"numeric"|"analysis"|"evaluate"; the weights
// also "superpose": a new magnitude under the same matrix, no solve), "weights", "deformation",
// "reference": counters {"symbolic", "numeric", "solves"} of that update}, "totals": the counters
// summed over the session, "mesh": {"name", "kind", "vertices"}}. Edit responses add "coalesced":
// true when a newer edit was waiting, so this one did not solve (the newer one brings the results),
// and "created" after POST /api/handles.
//
// Status codes: 200 success; 400 malformed JSON, a field of the wrong type or an unknown field;
// 404 unknown endpoint or handle id; 405 method not allowed on an endpoint; 413 body larger than
// ApiOptions::maxBodyBytes; 422 a value the session rejects (vertex id out of range or in
// another handle, non-finite or far-away position, parameter out of its range, unknown name)
// or a picked points file named by PUT /api/handles that cannot be read (one message for every
// cause, read before the session is locked). PUT /api/handles reads its body as `--handles`
// reads a handle file: malformed JSON is 400, every other error in it (a field of the wrong
// type or unknown, as well as a bad value) is 422 with the message `--handles` gives; 500 an
// unexpected internal failure, without its text (the session is kept). HttpServer adds 403 (foreign
// Host or Origin) and 415 (a write body that is not application/json) before a request reaches the
// Api. A state whose weights or deformation cannot be computed (e.g. a component without handles)
// is accepted: "update" then says "solved": false with the reason, and the previous results stay.
//
// Thread-safe: edits are serialized; an edit that finds a newer edit waiting skips its own
// update (coalescing), so a fast drag never queues stale solves.
#pragma once

#include <diffreg/engine/edit_engine.h>

#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

namespace diffreg {

/// One HTTP request as the API sees it.
struct ApiRequest {
  std::string method;                        ///< GET, POST, PUT, PATCH or DELETE
  std::string path;                          ///< "/api/..."
  std::map<std::string, std::string> query;  ///< decoded query parameters
  std::string body;
};

/// The answer to an ApiRequest.
struct ApiResponse {
  int status = 200;
  std::string contentType = "application/json";
  std::string body;
  /// Non-empty: offered as a download under this file name (Content-Disposition).
  std::string filename;
  std::vector<std::pair<std::string, std::string>> headers;
};

struct ApiOptions {
  /// Larger request bodies get 413.
  size_t maxBodyBytes = 4u << 20;
};

class Api {
 public:
  /// Takes the session (not null); `meshName` names the mesh in responses and downloads.
  /// Brings the session's results up to date.
  Api(std::unique_ptr<EditEngine> session, std::string meshName, ApiOptions options = {});
  ~Api();

  /// Answers one request. Never throws: every failure becomes a 4xx/5xx response.
  ApiResponse handle(const ApiRequest& request);

  const ApiOptions& options() const { return options_; }

 private:
  ApiResponse route(const ApiRequest& request);
  ApiResponse edit(const ApiRequest& request);
  // POST /api/refine: continues an unconverged deformation for another `iterations`.
  ApiResponse refine(const ApiRequest& r);
  ApiResponse read(const ApiRequest& request);
  /// Runs the update unless a newer edit is waiting; true when this call left results for
  /// the session's current version.
  bool finish();
  std::string stateJson(bool coalesced, int created) const;

  std::mutex mutex_;
  std::atomic<int> waiting_{0};  // edits received but not yet applied
  std::unique_ptr<EditEngine> session_;
  std::string meshName_;
  ApiOptions options_;
};

/// {"error": message, "status": status} as a response.
ApiResponse errorResponse(int status, const std::string& message);

}  // namespace diffreg
