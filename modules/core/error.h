// The exception hierarchy of diffreg. Every error a user can cause is one of these, with a
// one-line message that names the file, the element or the parameter at fault.
#pragma once

#include <stdexcept>
#include <string>

namespace diffreg {

/// Base of every diffreg error.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The mesh cannot be used: unreadable content, degenerate or inverted elements, bad indices.
class InvalidMesh : public Error {
 public:
  using Error::Error;
};

/// A parameter, a handle file entry or a filter argument is out of its domain.
class InvalidParameter : public Error {
 public:
  using Error::Error;
};

/// A linear system has no unique solution (e.g. a component without handles).
class SingularSystem : public Error {
 public:
  using Error::Error;
};

/// A solve or an energy came out not finite although the system factored: in practice a mesh of
/// nearly degenerate elements.
class NonFiniteSolution : public SingularSystem {
 public:
  using SingularSystem::SingularSystem;
};

/// A file could not be opened, read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// An operator needs a mesh property that nothing has produced yet.
class MissingProperty : public Error {
 public:
  using Error::Error;
};

}  // namespace diffreg
