// The one discretization every operator is built on (docs/method.md, "Discretization"): per-element
// gradients G_e, measures a_e, element adjacency with facet weights c_kl, stiffness K and lumped
// mass M, for planar triangles (2D), surface triangles (3D thin shell) and tetrahedra. This is the
// only numerical code that knows mesh types.
#pragma once

#include <diffreg/core/incidence.h>
#include <diffreg/mesh/mesh.h>

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <array>
#include <memory>
#include <mutex>
#include <vector>

namespace diffreg {

using SparseMatrix = Eigen::SparseMatrix<double>;

/// An interior facet shared by elements k and l: an edge (triangles) or a triangle (tets).
struct Facet {
  int k = -1, l = -1;
  double c = 0.0;                 ///< rest edge length or rest triangle area
  std::array<int, 3> vertices{};  ///< the shared vertices
  int size = 0;                   ///< 2 for an edge, 3 for a triangle
};

/// The sizes a Discretization is built for: the bounding-box diagonal of the vertices that the
/// elements use lies in [kMinMeshSize, kMaxMeshSize]. Beyond them, products of four to six
/// coordinates (squared areas, volumes and their squares) leave double precision's range, and a
/// solve would end in infinities or zeros.
inline constexpr double kMinMeshSize = 1e-30, kMaxMeshSize = 1e30;

class Discretization {
 public:
  /// Builds everything from the rest mesh. On triangle meshes the neighbouring triangles are
  /// found by walking the OpenMesh mesh's edges (each interior edge's two half-edges give its
  /// two faces); on tet meshes by sorting the tets' facets.
  /// \throw InvalidMesh for a degenerate (zero-measure) element, naming it, and for a mesh whose
  ///        size is outside [kMinMeshSize, kMaxMeshSize].
  explicit Discretization(const Mesh& mesh);
  /// The same for `mesh`'s elements at other positions (n x 3), e.g. its rest shape after the
  /// mesh has been deformed.
  Discretization(const Mesh& mesh, const Eigen::MatrixXd& positions);
  /// Same, from raw arrays: positions n x 3 and elements m x 3 or m x 4. Triangles are put into
  /// an OpenMesh mesh first, so they must form an oriented edge-manifold (readMesh splits
  /// vertices where a file's triangles do not).
  /// \throw InvalidMesh also for a triangle that does not fit such a mesh, naming it, and for a
  ///        planar kind whose z is not constant (the same test as Mesh::kind()).
  Discretization(MeshKind kind, const Eigen::MatrixXd& positions, const Eigen::MatrixXi& elements);

  MeshKind kind() const { return kind_; }
  /// Coordinate dimension d of positions and gradients: 2 for planar, else 3.
  int dim() const { return dim_; }
  /// Dimension of the element measure: 2 for triangles, 3 for tets.
  int measureDim() const { return kind_ == MeshKind::Tet ? 3 : 2; }
  int numVertices() const { return static_cast<int>(rest_.rows()); }
  int numElements() const { return static_cast<int>(elements_.rows()); }
  int elementSize() const { return static_cast<int>(elements_.cols()); }

  /// Rest positions, n x d.
  const Eigen::MatrixXd& rest() const { return rest_; }
  const Eigen::MatrixXi& elements() const { return elements_; }
  /// a_e: area or volume, physical units.
  const Eigen::VectorXd& measures() const { return measures_; }
  /// Gradients of element e's hat functions: elementSize() x d, row i for local vertex i.
  /// Surfaces: tangential gradients in ambient 3D (orthogonal to the rest normal).
  Eigen::Block<const Eigen::MatrixXd> gradient(int e) const {
    return grads_.block(e * elementSize(), 0, elementSize(), dim_);
  }
  /// All gradients stacked: (m * elementSize()) x d.
  const Eigen::MatrixXd& gradients() const { return grads_; }
  /// Rest unit normals of surface triangles (m x 3); empty otherwise.
  const Eigen::MatrixXd& normals() const { return normals_; }
  /// Rest deformation gradient of the identity map for element e: I (planar, tet) or the
  /// tangent projector I - n n^T (surface).
  Eigen::MatrixXd restFrame(int e) const;

  /// Interior facets with their weights c_kl (physical units).
  const std::vector<Facet>& facets() const { return facets_; }
  /// Cotangent stiffness K = sum_e a_e G_e G_e^T (n x n, positive semidefinite). Assembled on
  /// the first call (the weights need it, a deformation does not), once, safely from any
  /// thread; copies (and those made by withElementOrder()) share it. Empty once moved from.
  const SparseMatrix& stiffness() const;
  /// Barycentric lumped mass (a_e / 3 or a_e / 4 to each vertex).
  const Eigen::VectorXd& lumpedMass() const { return mass_; }

  /// Vertices referenced by at least one element; the others are left out of every system.
  const std::vector<bool>& active() const { return active_; }
  /// Component id per vertex (elements sharing a vertex are connected); -1 when unreferenced.
  const std::vector<int>& component() const { return component_; }
  int numComponents() const { return numComponents_; }

  /// Mean rest edge length (the unit of docs/method.md, "The regularizer") and bounding-box
  /// diagonal.
  double meanEdgeLength() const { return meanEdge_; }
  double boundingBoxDiagonal() const { return diagonal_; }

  /// The thinnest element: the smallest measure over the longest edge's length to the power of
  /// the element's dimension (an equilateral triangle 0.43, a regular tet 0.118; a sliver near
  /// 0). For error messages: computed on each call.
  struct Thinnest {
    int element = -1;
    double ratio = 0.0;
  };
  Thinnest thinnestElement() const;

  /// This discretization with its elements stored in another order: element i of the copy is
  /// element order[i] of this one (elements, measures, gradients, normals), and each facet
  /// joins the same two elements under their new indices, in the same facet order. The vertex
  /// operators (K, M, components) are the same. \pre order is a permutation of the elements.
  /// \throw InvalidParameter when it has the wrong size.
  Discretization withElementOrder(const std::vector<int>& order) const;

 private:
  struct Stiffness;
  Discretization() = default;  // withElementOrder() fills the rest
  // `topology`: the triangles as an OpenMesh mesh (null for tets).
  void build(MeshKind kind, const Eigen::MatrixXd& positions, const Eigen::MatrixXi& elements,
             const TriMesh* topology);
  template <int K>
  void buildElements(const Eigen::MatrixXd& P3, double tinyMeasure);
  template <int K>
  SparseMatrix assembleStiffness(Stiffness& s) const;
  void buildComponents(const std::vector<unsigned char>& used);

  MeshKind kind_ = MeshKind::Surface;
  int dim_ = 3;
  Eigen::MatrixXd rest_;
  Eigen::MatrixXi elements_;
  Eigen::VectorXd measures_;
  Eigen::MatrixXd grads_;
  Eigen::MatrixXd normals_;
  std::vector<Facet> facets_;
  struct Stiffness {
    std::once_flag once;
    SparseMatrix K;
    // K's pattern, the vertex adjacency as compressed rows, and the elements around each
    // vertex, when build() made them already (tets: the mean edge length); released once K is
    // assembled.
    std::vector<int> start, adjacency;
    Incidence around;
  };
  std::shared_ptr<Stiffness> stiffness_ = std::make_shared<Stiffness>();
  Eigen::VectorXd mass_;
  std::vector<bool> active_;
  std::vector<int> component_;
  int numComponents_ = 0;
  double meanEdge_ = 0.0, diagonal_ = 0.0;
};

}  // namespace diffreg
