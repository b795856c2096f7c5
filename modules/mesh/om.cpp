#include <diffreg/mesh/om.h>

#include <diffreg/core/error.h>
#include <diffreg/core/log.h>
#include <diffreg/core/text.h>
#include <diffreg/mesh/parse.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

namespace diffreg {
namespace {

// The format: a 16-byte header ("OM", mesh kind T/Q/P, version (major << 5 | minor), then the
// vertex, face and edge counts as little-endian uint32), then chunks up to a sentinel. A chunk
// starts with a 16-bit descriptor (bit 1: named; bits 2-4: entity; 5-8: type; 10: float; 11-13:
// dimension - 1; 14-15: size code), then the property name (one length byte and the bytes) when
// named, then its data: one record per element of its entity.
enum Entity : unsigned { kVertex = 0, kMesh = 1, kFace = 2, kEdge = 4, kHalfedge = 6, kEnd = 7 };
enum Type : unsigned { kPosition = 0, kStatus = 3, kCustom = 6, kTopology = 7 };
constexpr int kVersion20 = 2 << 5, kVersion21 = (2 << 5) | 1, kVersion22 = (2 << 5) | 2;

struct Chunk {
  bool named = false, isFloat = false;
  unsigned entity = 0, type = 0, dim = 1, sizeCode = 0;
  size_t offset = 0;
  std::string name;

  explicit Chunk(std::uint16_t bits, size_t at)
      : named((bits >> 1) & 1),
        isFloat((bits >> 10) & 1),
        entity((bits >> 2) & 7),
        type((bits >> 5) & 15),
        dim(((bits >> 11) & 7) + 1),
        sizeCode((bits >> 14) & 3),
        offset(at) {}
  /// Bytes of one integer of a topology chunk (1, 2, 4 or 8).
  size_t integerBytes() const { return size_t(1) << sizeCode; }
  /// Bytes of one record of a normal, colour or texture-coordinate chunk.
  size_t recordBytes() const {
    return dim * (isFloat ? (size_t(4) << sizeCode) : (size_t(1) << sizeCode));
  }
};

/// A little-endian cursor that checks every read against the bytes left.
class Cursor {
 public:
  Cursor(std::string_view bytes, const std::string& source) : bytes_(bytes), source_(source) {}

  size_t offset() const { return at_; }
  bool done() const { return at_ >= bytes_.size(); }

  /// \throw InvalidMesh unless `count` records of `size` bytes follow.
  void need(std::uint64_t count, std::uint64_t size, const std::string& what) const {
    const std::uint64_t left = bytes_.size() - at_;
    if (size != 0 && count > left / size) {
      throw InvalidMesh(source_ + ": " + what + " needs " + std::to_string(count) + " x " +
                        std::to_string(size) + " bytes at byte " + std::to_string(at_) +
                        ", but only " + std::to_string(left) + " are left");
    }
  }
  void skip(std::uint64_t count, std::uint64_t size, const std::string& what) {
    need(count, size, what);
    at_ += count * size;
  }
  std::uint64_t unsignedOf(size_t size, const std::string& what) {
    need(1, size, what);
    std::uint64_t v = 0;
    for (size_t i = 0; i < size; ++i)
      v |= std::uint64_t(static_cast<unsigned char>(bytes_[at_ + i])) << (8 * i);
    at_ += size;
    return v;
  }
  /// A signed integer of `size` bytes (OpenMesh writes -1 for "no face" in any width).
  long long signedOf(size_t size, const std::string& what) {
    const std::uint64_t v = unsignedOf(size, what);
    if (size == 8) return static_cast<long long>(v);
    const std::uint64_t sign = std::uint64_t(1) << (8 * size - 1);
    return static_cast<long long>(v ^ sign) - static_cast<long long>(sign);
  }
  double real(bool isDouble, const std::string& what) {
    if (isDouble) {
      const std::uint64_t v = unsignedOf(8, what);
      double d;
      std::memcpy(&d, &v, 8);
      return d;
    }
    const auto v = static_cast<std::uint32_t>(unsignedOf(4, what));
    float f;
    std::memcpy(&f, &v, 4);
    return f;
  }
  std::string shortString(const std::string& what) {
    const size_t length = unsignedOf(1, what);
    need(length, 1, what);
    std::string s(bytes_.substr(at_, length));
    at_ += length;
    return s;
  }

 private:
  std::string_view bytes_;
  const std::string& source_;
  size_t at_ = 0;
};

/// Everything read from the chunks, before the faces are built.
class OmReader {
 public:
  OmReader(std::string_view bytes, const std::string& source)
      : in_(bytes, source), src_(source), bytes_(bytes.size()) {}

  Mesh read() {
    readHeader();
    while (!in_.done()) {
      const size_t at = in_.offset();
      Chunk c(static_cast<std::uint16_t>(in_.unsignedOf(2, "a chunk descriptor")), at);
      if (c.entity == kEnd) break;
      if (c.named) c.name = in_.shortString(where(c) + "'s property name");
      readChunk(c);
    }
    return build();
  }

 private:
  std::string where(const Chunk& c) const {
    return "the chunk at byte " + std::to_string(c.offset);
  }

  void readHeader() {
    in_.need(1, 16, "the .om header");
    const char m0 = static_cast<char>(in_.unsignedOf(1, "")),
               m1 = static_cast<char>(in_.unsignedOf(1, ""));
    if (m0 != 'O' || m1 != 'M')
      throw InvalidMesh(src_ + ": not an OpenMesh .om file (no OM header)");
    kind_ = static_cast<char>(in_.unsignedOf(1, ""));
    version_ = static_cast<int>(in_.unsignedOf(1, ""));
    if (kind_ != 'T' && kind_ != 'Q' && kind_ != 'P') {
      throw InvalidMesh(src_ + ": unknown .om mesh kind (byte 2 is " +
                        std::to_string(static_cast<unsigned char>(kind_)) + ", not T, Q or P)");
    }
    if (version_ > kVersion22) {
      throw InvalidMesh(src_ + ": .om version " + std::to_string(version_ >> 5) + "." +
                        std::to_string(version_ & 31) + " is newer than the 2.2 diffreg reads");
    }
    numVertices_ = in_.unsignedOf(4, "");
    numFaces_ = in_.unsignedOf(4, "");
    numEdges_ = in_.unsignedOf(4, "");
    if (numVertices_ > 2000000000ULL || numFaces_ > 2000000000ULL || numEdges_ > 1000000000ULL) {
      throw InvalidMesh(src_ + ": the header's counts (" + std::to_string(numVertices_) +
                        " vertices, " + std::to_string(numFaces_) + " faces, " +
                        std::to_string(numEdges_) + " edges) are beyond what diffreg reads");
    }
    // At least 12 bytes a position, one a face and (version 2) six a pair of half-edges.
    const std::uint64_t least =
        12 * numVertices_ + numFaces_ + (version_ >= kVersion20 ? 6 * numEdges_ : 0);
    if (least > bytes_) {
      throw InvalidMesh(src_ + ": the header says " + std::to_string(numVertices_) + " vertices, " +
                        std::to_string(numFaces_) + " faces and " + std::to_string(numEdges_) +
                        " edges, more than its " + std::to_string(bytes_) + " bytes can hold");
    }
  }

  std::uint64_t countOf(const Chunk& c) const {
    switch (c.entity) {
      case kVertex:
        return numVertices_;
      case kMesh:
        return 1;
      case kFace:
        return numFaces_;
      case kEdge:
        return numEdges_;
      case kHalfedge:
        return 2 * numEdges_;
    }
    throw InvalidMesh(src_ + ": " + where(c) + " names an unknown entity (" +
                      std::to_string(c.entity) + ")");
  }

  void readChunk(const Chunk& c) {
    const std::uint64_t n = countOf(c);
    if (c.type == kCustom) return readCustom(c, n);
    if (c.type == kTopology) return readTopology(c);
    if (c.entity == kVertex && c.type == kPosition) return readPositions(c);
    // Normals, colours, texture coordinates, status (a 32-bit word per element): skipped.
    const size_t record = c.type == kStatus ? 4 : c.recordBytes();
    in_.skip(n, record, where(c));
  }

  void readPositions(const Chunk& c) {
    if (hasPoints_) throw InvalidMesh(src_ + ": " + where(c) + " repeats the positions");
    if (c.dim != 3 || !c.isFloat || c.sizeCode > 1) {
      throw InvalidMesh(src_ + ": " + where(c) +
                        " holds positions that are not 3 floats or doubles");
    }
    const bool isDouble = c.sizeCode == 1;
    in_.need(numVertices_, isDouble ? 24 : 12, where(c) + " (positions)");
    points_.resize(numVertices_);
    for (auto& p : points_)
      for (int k = 0; k < 3; ++k) p[k] = in_.real(isDouble, "");
    hasPoints_ = true;
  }

  long long index(const Chunk& c, long long lo, std::uint64_t end, const std::string& what) {
    const long long v = in_.signedOf(c.integerBytes(), what);
    if (v < lo || (v >= 0 && static_cast<std::uint64_t>(v) >= end)) {
      throw InvalidMesh(src_ + ": " + what + " is " + std::to_string(v) + ", out of range " +
                        std::to_string(lo) + ".." +
                        std::to_string(static_cast<long long>(end) - 1));
    }
    return v;
  }

  void readTopology(const Chunk& c) {
    const size_t w = c.integerBytes();
    if (c.entity == kVertex) return in_.skip(numVertices_, w, where(c));  // outgoing half-edges
    if (c.entity == kHalfedge) {
      if (!next_.empty()) throw InvalidMesh(src_ + ": " + where(c) + " repeats the half-edges");
      const std::uint64_t nh = 2 * numEdges_;
      in_.need(nh, 3 * w, where(c) + " (half-edges)");
      next_.resize(nh);
      toVertex_.resize(nh);
      face_.resize(nh);
      for (std::uint64_t h = 0; h < nh; ++h) {
        const std::string what = "half-edge " + std::to_string(h);
        next_[h] = static_cast<int>(index(c, 0, nh, what + "'s next half-edge"));
        toVertex_[h] = static_cast<int>(index(c, 0, numVertices_, what + "'s vertex"));
        face_[h] = static_cast<int>(index(c, -1, numFaces_, what + "'s face"));
      }
      return;
    }
    if (c.entity != kFace) return in_.skip(countOf(c), w, where(c));
    if (!faceHalfedge_.empty() || !raw_.faces.empty()) {
      throw InvalidMesh(src_ + ": " + where(c) + " repeats the faces");
    }
    if (version_ >= kVersion20) {
      in_.need(numFaces_, w, where(c) + " (faces)");
      faceHalfedge_.resize(numFaces_);
      for (std::uint64_t f = 0; f < numFaces_; ++f)
        faceHalfedge_[f] = static_cast<int>(
            index(c, 0, 2 * numEdges_, "face " + std::to_string(f) + "'s half-edge"));
      return;
    }
    // Before version 2.0: each face as its vertex ids (a 16-bit count first for polygons).
    in_.need(numFaces_, kind_ == 'P' ? 2 : w, where(c) + " (faces)");
    for (std::uint64_t f = 0; f < numFaces_; ++f) {
      const std::string what = "face " + std::to_string(f);
      const std::uint64_t corners = kind_ == 'T'   ? 3
                                    : kind_ == 'Q' ? 4
                                                   : in_.unsignedOf(2, what + "'s corner count");
      in_.need(corners, w, what);
      RawFace face;
      for (std::uint64_t j = 0; j < corners; ++j)
        face.ids.push_back(index(c, 0, numVertices_, what + "'s vertex"));
      raw_.faces.push_back(std::move(face));
    }
  }

  void readCustom(const Chunk& c, std::uint64_t n) {
    std::string typeName;
    if (version_ > kVersion21) typeName = in_.shortString(where(c) + "'s type name");
    const std::uint64_t block = in_.unsignedOf(4, where(c) + "'s size");
    in_.need(block, 1, where(c));
    const bool wanted = (c.entity == kVertex || c.entity == kFace) && c.named &&
                        typeName == "double" && block == 8 * n;
    if (!wanted) return in_.skip(block, 1, where(c));
    if (!printableAscii(c.name)) {
      warn(src_ + ": skipped a property whose name is not printable ASCII");
      return in_.skip(block, 1, where(c));
    }
    auto& kept = c.entity == kVertex ? raw_.vertexValues : raw_.faceValues;
    if (kept.size() >= static_cast<size_t>(kMaxNamedProperties)) {
      if (!skippedMany_)  // said once
        warn(src_ + ": " + (c.entity == kVertex ? "vertex" : "face") + " property '" + c.name +
             "' and any later ones are skipped: at most " + std::to_string(kMaxNamedProperties) +
             " of each are kept");
      skippedMany_ = true;
      return in_.skip(block, 1, where(c));
    }
    std::vector<double> values(static_cast<size_t>(n));
    const char* element = c.entity == kVertex ? "vertex " : "face ";
    for (std::uint64_t i = 0; i < n; ++i) {
      values[i] = in_.real(true, "");
      if (!std::isfinite(values[i])) {
        throw InvalidMesh(src_ + ": property '" + c.name + "' of " + element + std::to_string(i) +
                          " (0-based) is not finite");
      }
    }
    kept.push_back({c.name, std::move(values)});
  }

  // The faces of a version 2 file: the half-edge loop of each, every half-edge in one face.
  void facesFromHalfedges() {
    if (numFaces_ > 0 && (next_.empty() || faceHalfedge_.empty())) {
      throw InvalidMesh(src_ + ": the file has " + std::to_string(numFaces_) +
                        " faces but not their half-edge and face topology chunks");
    }
    std::vector<bool> used(next_.size(), false);
    raw_.faces.reserve(numFaces_);
    for (std::uint64_t f = 0; f < numFaces_; ++f) {
      RawFace face;
      int h = faceHalfedge_[f];
      do {
        if (used[h] || face_[h] != static_cast<int>(f)) {
          throw InvalidMesh(src_ + ": face " + std::to_string(f) +
                            ": its half-edge loop does not close (half-edge " + std::to_string(h) +
                            (used[h] ? " is already used)" : " belongs to another face)"));
        }
        used[h] = true;
        face.ids.push_back(toVertex_[h]);
        h = next_[h];
      } while (h != faceHalfedge_[f]);
      raw_.faces.push_back(std::move(face));
    }
  }

  Mesh build() {
    if (numVertices_ > 0 && !hasPoints_) {
      throw InvalidMesh(src_ + ": the file has no vertex positions chunk");
    }
    if (version_ >= kVersion20) facesFromHalfedges();
    if (raw_.faces.size() != numFaces_) {
      throw InvalidMesh(src_ + ": the header says " + std::to_string(numFaces_) +
                        " faces, the file holds " + std::to_string(raw_.faces.size()));
    }
    raw_.points = std::move(points_);
    return buildMesh(std::move(raw_), src_);
  }

  Cursor in_;
  const std::string& src_;
  std::uint64_t bytes_;
  char kind_ = 'T';
  int version_ = 0;
  std::uint64_t numVertices_ = 0, numFaces_ = 0, numEdges_ = 0;
  bool hasPoints_ = false;
  std::vector<Eigen::Vector3d> points_;
  std::vector<int> next_, toVertex_, face_, faceHalfedge_;
  RawMesh raw_;  // the named values in its vertexValues and faceValues
  bool skippedMany_ = false;  // properties past kMaxNamedProperties were skipped
};

}  // namespace

Mesh parseOm(std::string_view bytes, const std::string& source) {
  return OmReader(bytes, source).read();
}

}  // namespace diffreg
