// Mesh types: an OpenMesh TriMesh (double precision) for planar and surface meshes, a plain
// TetMesh for solids, and Mesh, which holds either one together with its named properties.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace diffreg {

struct TriTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
  VertexAttributes(OpenMesh::Attributes::Status);
  FaceAttributes(OpenMesh::Attributes::Status);
  EdgeAttributes(OpenMesh::Attributes::Status);
};

/// Triangle mesh for planar (2D: the vertices its faces use share one z) and surface (3D thin
/// shell) meshes.
using TriMesh = OpenMesh::TriMesh_ArrayKernelT<TriTraits>;

/// Tetrahedral mesh: points and positively oriented tets (0-based indices).
struct TetMesh {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<int, 4>> tets;
};

enum class MeshKind { Planar, Surface, Tet };

/// Whether points whose bounding box spans `zSpread` in z and has diagonal `diagonal` lie in a
/// plane z = const as a planar mesh's must: the test Mesh decides its kind by.
inline bool planarSpread(double zSpread, double diagonal) {
  return zSpread == 0.0 || zSpread <= 1e-12 * diagonal;
}

/// Whether points with bounding box `box` lie in a plane z = const (planarSpread of its z extent
/// and its diagonal, which does not overflow). A mesh's kind and every later test of its plane
/// take the box of its referenced vertices: a vertex that no element uses decides nothing (a
/// mesh without faces is decided by all its vertices).
inline bool planarBox(const Eigen::AlignedBox3d& box) {
  if (box.isEmpty()) return true;
  const Eigen::Vector3d extent = box.sizes();
  return planarSpread(extent.z(), extent.stableNorm());
}

/// "planar", "surface" or "tet".
const char* toString(MeshKind kind);

/// Names of the properties operators exchange.
namespace prop {
inline constexpr const char* weight = "diffreg:weight";          ///< vertex, regularization weight
inline constexpr const char* distortion = "diffreg:distortion";  ///< element, D_k
inline constexpr const char* smoothness =
    "diffreg:smoothness";  ///< element, max facet ||e_k-e_l||^2
}  // namespace prop

/// A TriMesh on the heap with value semantics. OpenMesh's meshes declare destructors and so
/// have no move operations: std::move copies them with every property. Held through this, a
/// Mesh moves in O(1), without allocating (noexcept, so a growing std::vector<Mesh> moves its
/// meshes instead of copying them), and still copies deeply. A box without a mesh (default,
/// moved from, or a tet mesh's) reads as an empty mesh and makes one on its first write access.
class TriMeshBox {
 public:
  TriMeshBox() = default;
  /// Takes `mesh` over (null: an empty mesh).
  explicit TriMeshBox(std::unique_ptr<TriMesh> mesh) : mesh_(std::move(mesh)) {}
  TriMeshBox(const TriMeshBox& other)
      : mesh_(other.mesh_ ? std::make_unique<TriMesh>(*other.mesh_) : nullptr) {}
  TriMeshBox(TriMeshBox&& other) noexcept = default;
  TriMeshBox& operator=(const TriMeshBox& other) {
    if (this != &other) mesh_ = other.mesh_ ? std::make_unique<TriMesh>(*other.mesh_) : nullptr;
    return *this;
  }
  TriMeshBox& operator=(TriMeshBox&& other) noexcept = default;
  /// The mesh; an empty one is made on the first write access of an empty box.
  TriMesh& operator*() { return *get(); }
  const TriMesh& operator*() const { return mesh_ ? *mesh_ : empty(); }
  TriMesh* operator->() { return get(); }
  const TriMesh* operator->() const { return &**this; }

 private:
  TriMesh* get() {
    if (!mesh_) mesh_ = std::make_unique<TriMesh>();
    return mesh_.get();
  }
  static const TriMesh& empty();
  std::unique_ptr<TriMesh> mesh_;  // null: empty (a tet mesh's, a default one, or moved from)
};

/// A planar, surface or tet mesh with named scalar properties per vertex and per element.
/// For triangle meshes the properties live on the OpenMesh mesh itself (double vertex or face
/// properties with the same name), so a caller's OpenMesh code sees them.
class Mesh {
 public:
  Mesh() = default;
  /// A triangle mesh; kind is Planar when all z coordinates are equal, else Surface.
  explicit Mesh(TriMesh tri);
  /// The same, taking the mesh over without a copy (the readers build theirs on the heap).
  explicit Mesh(std::unique_ptr<TriMesh> tri);
  explicit Mesh(TetMesh tet);

  MeshKind kind() const { return kind_; }
  bool isTet() const { return kind_ == MeshKind::Tet; }
  /// The OpenMesh mesh. A reference to it lasts as long as this Mesh is not assigned to or
  /// moved from (the mesh lives on the heap and moves with the Mesh's value). A Mesh without
  /// one (a tet mesh, a default or moved-from Mesh) reads as a shared empty mesh: a const
  /// reference taken then does not follow the mesh that a later write access makes.
  TriMesh& tri() { return *tri_; }
  const TriMesh& tri() const { return *tri_; }
  TetMesh& tet() { return tet_; }
  const TetMesh& tet() const { return tet_; }

  int numVertices() const;
  int numElements() const;  ///< faces or tets
  /// Vertices per element: 3 or 4.
  int elementSize() const { return isTet() ? 4 : 3; }

  /// Vertex positions, n x 3 (planar meshes keep their constant z).
  Eigen::MatrixXd positions() const;
  /// The same positions without a copy: a read-only view of the mesh's own points (n rows of
  /// x, y, z). Valid while the mesh's vertices stay as they are: not after the Mesh is
  /// assigned to or the TriMesh (tri()) or TetMesh (tet()) gains, loses or collects vertices;
  /// moving the Mesh keeps it valid (the points stay where they are).
  using PointRows = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>;
  PointRows points() const;
  /// Sets all vertex positions from an n x 3 (or n x 2 for planar meshes, z kept) matrix.
  void setPositions(const Eigen::MatrixXd& positions);
  /// Element vertex indices, m x 3 or m x 4.
  Eigen::MatrixXi elements() const;
  /// True for each vertex referenced by at least one element.
  std::vector<bool> referenced() const;

  bool hasVertexScalar(const std::string& name) const;
  /// \throw MissingProperty when absent.
  Eigen::VectorXd vertexScalar(const std::string& name) const;
  void setVertexScalar(const std::string& name, const Eigen::VectorXd& values);
  bool hasElementScalar(const std::string& name) const;
  /// \throw MissingProperty when absent.
  Eigen::VectorXd elementScalar(const std::string& name) const;
  void setElementScalar(const std::string& name, const Eigen::VectorXd& values);
  /// Names of the vertex and element scalar properties set through this class.
  std::vector<std::string> vertexScalarNames() const;
  std::vector<std::string> elementScalarNames() const;

 private:
  MeshKind kind_ = MeshKind::Surface;
  TriMeshBox tri_;
  TetMesh tet_;
  // Tet meshes keep their properties here; triangle meshes on the OpenMesh mesh.
  std::map<std::string, Eigen::VectorXd> tetVertexProps_, tetElementProps_;
  std::vector<std::string> vertexNames_, elementNames_;
};

/// Bounds of the referenced vertices at their current positions, skipping non-finite ones
/// (an empty box for none). An unreferenced vertex, which no element moves or measures, never
/// widens them: frames, handle reach and the like take their size and centre from here.
/// Extend several of these to frame a series of panels alike.
Eigen::AlignedBox3d meshBounds(const Mesh& mesh);
/// The same for the mesh's vertices at `positions` (n x 3), e.g. its rest shape.
Eigen::AlignedBox3d meshBounds(const Mesh& mesh, const Eigen::MatrixXd& positions);
/// The same for the rows of `positions` (n x 3) that `used` flags (Mesh::referenced(),
/// Discretization::active()), for a caller that holds both already.
Eigen::AlignedBox3d meshBounds(const Eigen::MatrixXd& positions, const std::vector<bool>& used);

}  // namespace diffreg
