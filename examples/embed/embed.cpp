// Embedding diffreg: a program's own OpenMesh mesh, with its own data on it, gets diffused
// weights and a non-uniformly regularized ARAP deformation through the installed package.
//   embed MESH HANDLES.json      e.g. embed meshes/bar.obj meshes/bar-bend.json
#include <diffreg/diffreg.h>

// Every header of the package lives under <diffreg/...>; none is a top-level include.
#if __has_include(<core/error.h>) || __has_include(<deformation/deformer.h>)
#error "diffreg's module headers must be reachable only as <diffreg/<module>/...>"
#endif

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>

#include <iostream>

using MyMesh = OpenMesh::TriMesh_ArrayKernelT<>;  // OpenMesh's defaults: float points

int main(int argc, char** argv) try {
  if (argc != 3) return std::cerr << "usage: embed MESH HANDLES.json\n", 2;
  MyMesh mesh;
  if (!OpenMesh::IO::read_mesh(mesh, argv[1])) throw diffreg::IoError("cannot read mesh");
  OpenMesh::VPropHandleT<int> label;  // the program's own data, which diffreg leaves alone
  mesh.add_property(label, "my:label");
  for (auto v : mesh.vertices()) mesh.property(label, v) = v.idx() % 7;

  const diffreg::HandleSet handles = diffreg::readHandles(argv[2], mesh);
  diffreg::computeDiffusedWeights(mesh, handles);  // vertex property diffreg:weight
  diffreg::DeformationOptions options;             // ARAP
  options.regularization = diffreg::Regularization::Nonuniform;  // beta_k from diffreg:weight
  const auto result = diffreg::deform(mesh, handles, options);   // points, diffreg:distortion

  OpenMesh::FPropHandleT<double> distortion;
  mesh.get_property_handle(distortion, diffreg::prop::distortion);
  double dMax = 0.0;
  for (auto f : mesh.faces()) dMax = std::max(dMax, mesh.property(distortion, f));
  for (auto v : mesh.vertices())
    if (mesh.property(label, v) != v.idx() % 7) return std::cerr << "label changed\n", 1;
  std::cout << "diffreg " << DIFFREG_VERSION_STRING << ": " << result.iterations
            << " iterations, D_max " << dMax << "\n";
  return 0;
} catch (const diffreg::Error& e) {
  std::cerr << "embed: error: " << e.what() << "\n";
  return 1;
}
