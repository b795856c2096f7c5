// diffreg-bench: shared types of the benchmark cases (weights, deformation, the CGAL peer and
// the memory probe). Every case measures each metric once per repeat; the runner keeps medians.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace diffreg::bench {

/// One measured quantity of one repeat: seconds unless the name says otherwise.
using Sample = std::vector<std::pair<std::string, double>>;

/// A mesh together with how it was made (for the table and the JSON).
struct BenchMesh {
  std::string label;   ///< short name in case names, e.g. "sphere-10k"
  std::string source;  ///< "makeSphere(1, 128, 80)" or a file path
  Mesh mesh;
};

/// A generated UV sphere of radius 1 with about n vertices, labelled "sphere-<n>".
BenchMesh sphereNear(int n);

/// What a case's preparation built: the mesh facts, or why the case cannot run.
struct Prepared {
  bool available = true;
  std::string skipReason;  ///< when not available, e.g. "../shared/meshes/tet-bar.mesh absent"
  std::string source;      ///< how the mesh was made or where it was read
  int vertices = 0, elements = 0;
  std::map<std::string, double> facts;  ///< untimed extras worth printing (e.g. handle count)
};

/// One benchmark case: `run` performs one repeat and returns its metrics.
struct Case {
  std::string group;   ///< "weights", "deform", "peer", "memory"
  std::string name;    ///< unique, e.g. "weights/eq8/tet-21k"; --filter matches it
  std::string series;  ///< deformation: "planar", "surface", "tet" (for the exponent fit)
  int maxRepeats = 0;  ///< > 0: at most this many repeats (the largest meshes)
  /// Paper figures to print beside ours (metric -> seconds).
  std::map<std::string, double> paper;
  std::function<Prepared()> prepare;  ///< builds meshes and anything untimed, once
  std::function<Sample()> run;
  std::function<void()> release;  ///< frees what prepare() built
};

struct Sizes {
  bool quick = false;
  /// Iteration cap of the plain local/global runs of the convergence cases (0: each mesh's own).
  int plainCap = 0;
};

/// Where the shared test meshes are: setSharedMeshDirectory(), else $DIFFREG_SHARED_MESHES, else
/// ../shared/meshes beside the source tree.
void setSharedMeshDirectory(const std::string& dir);
std::string sharedMeshDirectory();
/// Reads a mesh from sharedMeshDirectory() when the file exists; false (and a note) when absent.
bool sharedMesh(const std::string& file, Mesh& mesh, std::string& path);

/// Runs `program` with `args` (argv, its own name first) in a child process, waits for it and
/// returns what it printed on stdout.
/// \throw Error beginning with `what` when it cannot start or does not exit with status 0.
std::string runProcess(const std::string& program, const std::vector<std::string>& args,
                       const std::string& what);
/// runProcess on this benchmark's own executable: `args` select a child mode (kMemoryFlag,
/// kCgalOneShotFlag). A child's resource usage is the parent's getrusage(RUSAGE_CHILDREN) after.
std::string runSelf(const std::vector<std::string>& args, const std::string& what);

/// A new directory of its own under the system's temporary directory (diffreg-bench-XXXXXX,
/// mkdtemp), for the files a case hands a child process; removed with its contents when
/// destroyed. \throw IoError when it cannot be created.
class ScratchDirectory {
 public:
  ScratchDirectory();
  ~ScratchDirectory();
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// The files of a run of the diffreg tool in a process of its own: the tool beside this
/// benchmark, the input mesh, the handle file, the output and the report (all but the tool and
/// a shared mesh in `dir`, removed with it).
struct ToolRun {
  std::unique_ptr<ScratchDirectory> dir;
  std::string tool, mesh, handles, output, report;
};
/// The tool beside this benchmark, a scratch directory and the paths of the handle file, the
/// output (PLY) and the report in it; false (and `run` empty) when the tool is not there.
bool prepareToolRun(ToolRun& run);
/// `TOOL -i MESH --handles H --filter FILTER -o OUT --quiet --report R` in a child process.
/// \throw Error beginning with `what` when it does not exit with status 0.
void runToolFilter(const ToolRun& run, const std::string& filter, const std::string& what);
/// The report that the last runToolFilter() wrote.
nlohmann::json toolReport(const ToolRun& run);

/// Appends the cases of each group.
void addWeightCases(std::vector<Case>& cases, const Sizes& sizes);
void addDeformationCases(std::vector<Case>& cases, const Sizes& sizes);
void addPeerCases(std::vector<Case>& cases, const Sizes& sizes);

/// The memory probe's session (run in a child process): a surface sphere with about `vertices`
/// vertices, diffused weights, a nonuniform ARAP session and one handle move of 5 iterations.
void runMemorySession(int vertices);
/// The option that makes this benchmark that process: VERTICES.
inline constexpr const char* kMemoryFlag = "--memory-case";

/// Handles used by the deformation and peer cases: a fixed region at the low end of the
/// longest bounding-box axis and a moved region at the high end, each `fraction` of its
/// length deep. Returns {fixed, moved} vertex lists.
std::pair<std::vector<int>, std::vector<int>> endHandles(const Eigen::MatrixXd& rest,
                                                         double fraction);
/// Targets of a handle move: the fixed handle at rest, the moved one translated by `offset`
/// along the longest axis and slightly sideways (rows in the order fixed then moved).
Eigen::MatrixXd moveTargets(const Eigen::MatrixXd& rest, const std::vector<int>& fixed,
                            const std::vector<int>& moved, double offset, int dim);

/// The CGAL peer on a surface mesh (positions n x 3, triangles m x 3): Surface_mesh_deformation
/// (ARAP, spokes and rims, CGAL's default Eigen SparseLU) with the whole mesh as region of
/// interest and `handles` as control vertices. Returns setup (construction + ROI + control +
/// preprocess), deform(1) latency and deform(1 + extra) latency after set_target_position.
struct PeerTimes {
  double preprocess = 0.0, latency1 = 0.0, latencyMore = 0.0;
};
PeerTimes runCgalArap(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles,
                      const std::vector<int>& handles, const Eigen::MatrixXd& targets,
                      int extraIterations);
/// "Eigen::SparseLU<COLAMDOrdering> (CGAL 5.5 default), spokes-and-rims ARAP".
std::string cgalDescription();

/// The CGAL peer run for `iterations` single deform(1) steps after preprocess with the targets
/// set, calling `step(iteration, positions, seconds)` after each with the positions (n x 3) and
/// the seconds spent in CGAL so far (preprocess excluded; the callback's own time excluded).
void traceCgalArap(const Eigen::MatrixXd& positions, const Eigen::MatrixXi& triangles,
                   const std::vector<int>& handles, const Eigen::MatrixXd& targets,
                   int iterations,
                   const std::function<void(int, const Eigen::MatrixXd&, double)>& step);
/// Read + preprocess + `iterations` iterations of the CGAL peer on a mesh file (the one-shot
/// comparison): returns the wall seconds.
double cgalOneShot(const std::string& path, const std::vector<int>& handles,
                   const Eigen::MatrixXd& targets, int iterations);

/// Convergence: iterations and time to a relative energy gap, plain vs accelerated, and CGAL.
void addConvergenceCases(std::vector<Case>& cases, const Sizes& sizes);
/// oneshot/<mesh>: the diffreg tool from reading to writing against CGAL read + 1 iteration.
void addOneShotCases(std::vector<Case>& cases, const Sizes& sizes);
/// cgalOneShot in a process of its own with the diffreg tool's heap settings (cgal_child.cpp),
/// timed inside it; `scratchDir` takes the file that hands it the targets.
double cgalOneShotInChild(const std::string& path, const std::vector<int>& handles,
                          const Eigen::MatrixXd& targets, int iterations,
                          const std::filesystem::path& scratchDir);
/// The option that makes this benchmark that process: PATH TARGET_FILE ITERATIONS.
inline constexpr const char* kCgalOneShotFlag = "--cgal-oneshot-case";
/// That process: cgalOneShot on PATH with the handles and targets of TARGET_FILE, its seconds
/// printed on stdout.
int runCgalOneShotChild(const std::string& path, const std::string& targetFile, int iterations);
/// editor/<mesh>: a drag step of the edit engine with the editor's time budget and without.
void addEditorCases(std::vector<Case>& cases, const Sizes& sizes);

}  // namespace diffreg::bench
