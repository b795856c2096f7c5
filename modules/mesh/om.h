// Reader of OpenMesh's binary .om format (versions up to 2.2, the one OpenMesh 9 writes), written
// for files nobody vouches for: every chunk is checked against the bytes left before anything is
// allocated, every index against its range, and the face loops against the half-edge records,
// so a corrupt file is an InvalidMesh naming the chunk or element, never an assertion inside
// OpenMesh. The faces then go through buildTriMesh like those of every other format.
#pragma once

#include <diffreg/mesh/mesh.h>

#include <string>
#include <string_view>

namespace diffreg {

/// The triangle mesh of an .om file: positions (float or double), the faces (from the half-edge
/// topology of version 2 files, from vertex lists before), and the persistent `double` vertex
/// and face properties (the `diffreg:` ones diffreg writes). Normals, colours, texture
/// coordinates, status and other custom properties are skipped.
/// \throw InvalidMesh "source: ..." for anything that is not such a file.
Mesh parseOm(std::string_view bytes, const std::string& source);

}  // namespace diffreg
