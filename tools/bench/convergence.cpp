// Convergence cases: how many iterations and how much time the regularized ARAP deformation
// needs to come within a relative energy gap of its minimum, plain local/global against the
// accelerated default (both with the exact local step), and CGAL's ARAP to its own minimum.
// Scenario (all meshes): the 5% at the low end of the longest axis held, the 5% at the high end
// pulled outwards along that axis by 15% of the bounding-box diagonal.
#include "bench.h"
#include <diffreg/core/timer.h>
#include <diffreg/deformation/deformer.h>
#include <diffreg/deformation/local_step.h>
#include <diffreg/discretization/discretization.h>
#include <diffreg/mesh/io.h>
#include <diffreg/mesh/shapes.h>
#include <diffreg/weights/diffusion.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace diffreg::bench {
namespace {

constexpr double kPull = 0.15;  // of the bounding-box diagonal
// The plain run ended at another shape than the accelerated one when their last shapes are
// more than this fraction of the bounding-box diagonal apart (root mean square) and its lowest
// energy is lower by more than this fraction.
constexpr double kElsewhere = 1e-2;

struct Scenario {
  std::string path;
  Mesh mesh;
  std::unique_ptr<Discretization> disc;
  std::vector<int> fixed, moved, handles;
  Eigen::MatrixXd targets;  // handles x d
  Eigen::VectorXd weights;  // diffused from both handles (eq. 8, default t)
};

// The energy after each reported iteration and the seconds since the solve began.
struct Trace {
  std::vector<double> energy, seconds;
  int iterations = 0;
  bool converged = false;
};

Prepared prepareScenario(Scenario& s, const std::string& file, const std::string& generated) {
  Prepared p;
  if (!generated.empty()) {
    s.mesh = makeSphere(1.0, 64, 40);
    s.path = generated;
  } else if (!sharedMesh(file, s.mesh, s.path)) {
    p.available = false;
    p.skipReason = s.path + " absent";
    return p;
  }
  s.disc = std::make_unique<Discretization>(s.mesh);
  std::tie(s.fixed, s.moved) = endHandles(s.disc->rest(), 0.05);
  s.handles = s.fixed;
  s.handles.insert(s.handles.end(), s.moved.begin(), s.moved.end());
  const Eigen::MatrixXd& rest = s.disc->rest();
  const Eigen::RowVectorXd lo = rest.colwise().minCoeff(), hi = rest.colwise().maxCoeff();
  int axis = 0;
  for (int a = 1; a < rest.cols(); ++a)
    if (hi(a) - lo(a) >= (hi(axis) - lo(axis)) * (1.0 - 1e-9)) axis = a;
  s.targets.resize(static_cast<Eigen::Index>(s.handles.size()), rest.cols());
  for (size_t i = 0; i < s.handles.size(); ++i)
    s.targets.row(static_cast<Eigen::Index>(i)) = rest.row(s.handles[i]);
  for (size_t i = s.fixed.size(); i < s.handles.size(); ++i)
    s.targets(static_cast<Eigen::Index>(i), axis) += kPull * s.disc->boundingBoxDiagonal();
  DiffusionWeights w(*s.disc);
  w.setHandles({s.fixed, s.moved}, {1.0, 1.0}, {0.5, 1.0});
  s.weights = w.solve();
  p.source = s.path;
  p.vertices = s.disc->numVertices();
  p.elements = s.disc->numElements();
  p.facts["handle_vertices"] = static_cast<double>(s.handles.size());
  return p;
}

DeformationOptions optionsFor(const Scenario& s, const std::string& reg) {
  DeformationOptions o;
  o.energy = Energy::Arap;
  o.regularization = parseEnum<Regularization>(reg);
  o.beta = 0.5;
  if (o.regularization == Regularization::Nonuniform) o.weights = s.weights;
  return o;
}

// A run to the default tolerance and, with `further` > 0, its continuation (resume) to a far
// tighter one, which stands in for the minimum. The trace holds both; `iterations`,
// `converged` and `seconds` are the default run's.
struct Run {
  Trace trace;
  int iterations = 0;
  bool converged = false;
  double seconds = 0.0;
  Eigen::MatrixXd last;  // the shape at the end of the trace
};

Run run(const Scenario& s, DeformationOptions o, int cap, double tolerance, int further) {
  Run out;
  Timer timer;
  double offset = 0.0;
  o.progress = [&](int, double energy, double) {
    out.trace.energy.push_back(energy);
    out.trace.seconds.push_back(offset + timer.seconds());
  };
  DeformationSession session(*s.disc, o);
  session.setHandles(s.handles);
  session.setTargets(s.targets);
  session.solve(1, 0.0);  // the factorizations, outside the timed solve
  out.trace = Trace();
  timer.reset();
  DeformationResult r = session.solve(cap, tolerance);
  out.iterations = r.iterations;
  out.converged = r.converged;
  out.seconds = timer.seconds();
  if (further > 0) {
    offset = out.seconds;
    timer.reset();
    r = session.resume(further, 1e-12);
  }
  out.last = std::move(r.positions);
  return out;
}

// The first iteration (1-based index into the trace) within `gap` of `best`, and its time.
std::pair<double, double> reach(const Trace& t, double best, double gap) {
  for (size_t i = 0; i < t.energy.size(); ++i)
    if (t.energy[i] - best <= gap * best)
      return {static_cast<double>(i + 1), t.seconds[i]};
  return {NAN, NAN};
}

// `cap`: the accelerated run's continuation past its default stop, and the plain run's cap
// unless `plainCap` > 0.
void addCase(std::vector<Case>& cases, const std::string& label, const std::string& file,
             const std::string& reg, int cap, int plainCap, const std::string& generated = "") {
  if (plainCap <= 0) plainCap = cap;
  auto state = std::make_shared<Scenario>();
  Case c;
  c.group = "converge";
  c.name = "converge/" + label + "/" + reg;
  c.maxRepeats = 1;  // long, and the iteration counts do not vary
  c.prepare = [state, file, generated] { return prepareScenario(*state, file, generated); };
  c.release = [state] { *state = Scenario(); };
  c.run = [state, reg, cap, plainCap] {
    const Scenario& s = *state;
    const DeformationOptions o = optionsFor(s, reg);
    // Accelerated to the default tolerance (capped at 3 x cap here), then on towards the
    // minimum.
    const Run accelerated = run(s, o, 3 * cap, kDefaultTolerance, cap);
    DeformationOptions plainOptions = o;
    plainOptions.acceleration = Acceleration::None;
    const Run plain = run(s, plainOptions, plainCap, 0.0, 0);
    // The minimum is the lowest energy either run reaches, unless the plain run, continued far
    // past convergence, ends at another shape (surface ARAP has no bending stiffness: from a
    // stretched shape that is a saddle, e.g. a symmetric one, rounding can lead it into
    // crumpled shapes of far lower energy): then both are measured against the shape the
    // default run converged to, the lowest energy of its continuation.
    const double apart = std::sqrt((plain.last - accelerated.last).squaredNorm() /
                                   static_cast<double>(plain.last.rows())) /
                         s.disc->boundingBoxDiagonal();
    const auto lowest = [](const Run& r) {
      return *std::min_element(r.trace.energy.begin(), r.trace.energy.end());
    };
    // Apart and lower: another shape. Apart and higher is a plain run not yet converged, whose
    // energies leave the minimum as it is.
    const bool elsewhere =
        apart > kElsewhere && lowest(plain) < lowest(accelerated) * (1.0 - kElsewhere);
    double minimum = lowest(accelerated);
    if (!elsewhere) minimum = std::min(minimum, lowest(plain));
    Sample sample;
    sample.emplace_back("plain_apart", apart);
    sample.emplace_back("plain_elsewhere", elsewhere ? 1.0 : 0.0);
    sample.emplace_back("plain_end_ratio", plain.trace.energy.back() / minimum);
    for (double gap : {1e-3, 1e-4, 1e-6}) {
      const std::string g = gap == 1e-3 ? "1e-3" : gap == 1e-4 ? "1e-4" : "1e-6";
      const auto [ai, as] = reach(accelerated.trace, minimum, gap);
      const auto [pi, ps] = reach(plain.trace, minimum, gap);
      sample.emplace_back("accelerated_iterations_" + g, ai);
      sample.emplace_back("accelerated_" + g, as);
      sample.emplace_back("plain_iterations_" + g, pi);
      sample.emplace_back("plain_" + g, ps);
    }
    const double atDefault = accelerated.trace.energy[static_cast<size_t>(
        std::min<int>(accelerated.iterations, static_cast<int>(accelerated.trace.energy.size())) - 1)];
    sample.emplace_back("default_iterations", accelerated.iterations);
    sample.emplace_back("default_converged", accelerated.converged ? 1.0 : 0.0);
    sample.emplace_back("default_gap", (atDefault - minimum) / minimum);
    sample.emplace_back("default", accelerated.seconds);
    sample.emplace_back("plain_cap_iterations", plainCap);
    sample.emplace_back("accelerated_cap_iterations", accelerated.iterations + cap);
    return sample;
  };
  cases.push_back(std::move(c));
}

// CGAL's ARAP on the same scenario (no regularization): its energy per iteration measured as
// our per-element ARAP energy of its shapes, the gap to the lowest value it reaches in `cap`
// iterations.
void addCgalCase(std::vector<Case>& cases, const std::string& label, const std::string& file,
                 int cap, const std::string& generated = "") {
  auto state = std::make_shared<Scenario>();
  Case c;
  c.group = "converge";
  c.name = "converge/" + label + "/cgal";
  c.maxRepeats = 1;
  c.prepare = [state, file, generated] { return prepareScenario(*state, file, generated); };
  c.release = [state] { *state = Scenario(); };
  c.run = [state, cap] {
    const Scenario& s = *state;
    const ResidualModel model(*s.disc, Energy::Arap);
    const RegularizationWeights none =
        makeRegularizationWeights(*s.disc, Regularization::None, 0.0);
    Trace t;
    traceCgalArap(s.mesh.positions(), s.mesh.elements(), s.handles, s.targets, cap,
                  [&](int, const Eigen::MatrixXd& X, double seconds) {
                    Stacked tt, e;
                    model.targets(X, tt);
                    model.residuals(X, tt, e);
                    t.energy.push_back(model.energy(e, none));
                    t.seconds.push_back(seconds);
                  });
    const double minimum = *std::min_element(t.energy.begin(), t.energy.end());
    Sample sample;
    for (double gap : {1e-3, 1e-4, 1e-6}) {
      const std::string g = gap == 1e-3 ? "1e-3" : gap == 1e-4 ? "1e-4" : "1e-6";
      const auto [i, sec] = reach(t, minimum, gap);
      sample.emplace_back("cgal_iterations_" + g, i);
      sample.emplace_back("cgal_" + g, sec);
    }
    sample.emplace_back("cgal_cap_iterations", cap);
    sample.emplace_back("cgal_300", t.seconds[std::min<size_t>(299, t.seconds.size() - 1)]);
    // Read + preprocess + 300 iterations from the file, as a one-shot tool would run it: in a
    // process of its own with the diffreg tool's heap settings (the target's figure), and in
    // this one.
    if (s.path.find('/') != std::string::npos) {
      const ScratchDirectory dir;
      const double own = cgalOneShotInChild(s.path, s.handles, s.targets, 300, dir.path());
      sample.emplace_back("cgal_read_300", own);
      sample.emplace_back("cgal_read_300_in_process",
                          cgalOneShot(s.path, s.handles, s.targets, 300));
    }
    return sample;
  };
  cases.push_back(std::move(c));
}

}  // namespace

void addConvergenceCases(std::vector<Case>& cases, const Sizes& sizes) {
  const std::vector<std::string> regs{"none", "uniform", "nonuniform"};
  if (sizes.quick) {
    for (const std::string& reg : regs)
      addCase(cases, "sphere-2.5k", "", reg, 2000, sizes.plainCap, "sphere");
    addCgalCase(cases, "sphere-2.5k", "", 1000, "sphere");
    return;
  }
  // Caps: the plain runs stop there, and the accelerated one continues as far past its
  // default stop towards the minimum.
  for (const std::string& reg : regs)
    addCase(cases, "rocker-arm", "surface-rocker-arm.obj", reg, 1500, sizes.plainCap);
  addCgalCase(cases, "rocker-arm", "surface-rocker-arm.obj", 1500);
  for (const std::string& reg : regs)
    addCase(cases, "tet-monkey", "tet-monkey.mesh", reg, 1000, sizes.plainCap);
  for (const std::string& reg : regs)
    addCase(cases, "crocodile", "planar-crocodile.obj", reg, 1000, sizes.plainCap);
  for (const std::string& reg : regs)
    addCase(cases, "armadillo", "surface-armadillo.obj", reg, 400, sizes.plainCap);
  addCgalCase(cases, "armadillo", "surface-armadillo.obj", 400);
}

}  // namespace diffreg::bench
