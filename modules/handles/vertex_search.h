// Nearest-vertex and within-radius queries over a mesh's referenced vertices, for the handle
// selectors ("nearest", "within", "picked"). A handle file may hold hundreds of thousands of
// points, so after a few queries a kd-tree (CGAL's spatial searching) answers them; the answers
// are those of a scan over every vertex, ties and rounding included.
#pragma once

#include <Eigen/Core>

#include <memory>
#include <vector>

namespace diffreg {

class VertexSearch {
 public:
  enum class Mode {
    Adaptive,  ///< scan for the first few queries, then build the kd-tree
    Scan,      ///< always scan (the reference)
    Tree,      ///< the kd-tree from the first query
  };

  /// Queries over the rows v of `points` (n x 3) with `referenced[v]`; both are referenced, not
  /// copied, and must outlive this object. Non-finite coordinates make every query a scan.
  VertexSearch(const Eigen::MatrixXd& points, const std::vector<bool>& referenced,
               Mode mode = Mode::Adaptive);
  ~VertexSearch();
  VertexSearch(const VertexSearch&) = delete;
  VertexSearch& operator=(const VertexSearch&) = delete;

  /// The referenced vertex nearest to `p`: the smallest squared distance
  /// (x_v - p_x)^2 + (y_v - p_y)^2 + (z_v - p_z)^2 as computed in double (left to right, so an
  /// overflow to inf ties with every other inf), the lowest id among equals; -1 when no vertex
  /// is referenced.
  int nearest(const Eigen::Vector3d& p);

  /// The referenced vertices whose distance to `c` (the square root of that squared distance)
  /// is at most `r`, in increasing id order.
  std::vector<int> within(const Eigen::Vector3d& c, double r);

  /// Whether the kd-tree has been built (for tests).
  bool indexed() const { return tree_ != nullptr; }

 private:
  bool useTree();

  struct Tree;
  const Eigen::MatrixXd& points_;
  const std::vector<bool>& referenced_;
  Mode mode_;
  bool finite_ = true;  ///< every referenced coordinate is finite (else the tree is never used)
  int queries_ = 0;
  std::unique_ptr<Tree> tree_;
};

}  // namespace diffreg
