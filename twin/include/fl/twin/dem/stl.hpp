// STL reader and writer (binary and ASCII) for the DEM twin's meshes.
//
// STL stores unconnected triangles ("facets"); the reader welds corners that lie within a
// tolerance of each other into shared vertices so the result is an indexed mesh whose
// closedness can be checked (fl/twin/dem/mesh.hpp). The facet normals in the file are ignored:
// the winding order defines the orientation, as every STL consumer assumes. STL has no unit;
// the project's assets are in millimetres (StlReadOptions::scale = 1e-3 gives metres).
//
// Every failure throws StlError naming the source and what is wrong; no input crashes the
// reader. Format detection: a file whose size is exactly 84 + 50 x (the header's facet count)
// is binary (binary headers may start with "solid" too); otherwise a file starting with
// "solid" is ASCII; anything else is a binary file of the wrong size.
#pragma once

#include <cstddef>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

#include "fl/twin/dem/mesh.hpp"

namespace fl::dem {

enum class StlFormat { kBinary, kAscii };

enum class StlErrorKind {
  kCannotOpen,    // missing or unreadable file
  kTruncated,     // binary file shorter than its header's facet count needs
  kSizeMismatch,  // binary file longer than its facet count needs (or count absurd)
  kNonFinite,     // NaN or infinite coordinate
  kSyntax,        // ASCII grammar error (the message carries the line number)
  kEmpty,         // no facets
  kNotClosed,     // closed mesh required but the welded mesh is not a closed 2-manifold
  kCannotWrite,   // output file could not be written
};

class StlError : public std::runtime_error {
 public:
  StlError(StlErrorKind kind, const std::string& source, const std::string& what);
  StlErrorKind kind() const { return kind_; }

 private:
  StlErrorKind kind_;
};

struct StlReadOptions {
  // Corners closer than this (in file units, before `scale`) become one vertex. The first
  // corner seen keeps its exact coordinates, so welding never moves a vertex.
  double weld_tolerance = 1e-6;
  // Refuse meshes that are not closed 2-manifolds after welding (StlErrorKind::kNotClosed).
  bool require_closed = true;
  // Coordinates are multiplied by this after welding (1e-3: millimetre file -> metres).
  double scale = 1.0;
};

struct StlReadResult {
  TriangleMesh mesh;
  StlFormat format = StlFormat::kBinary;
  std::string solid_name;  // ASCII "solid <name>" or the binary header's printable text
  std::size_t facets_in_file = 0;
  // Facets whose corners welded together (zero area at the tolerance); they are dropped.
  std::size_t degenerate_facets_dropped = 0;
};

struct StlWriteOptions {
  StlFormat format = StlFormat::kBinary;
  // Coordinates are multiplied by this before writing (1e3: metres -> millimetre file).
  double scale = 1.0;
  std::string solid_name = "mesh";
};

// Reads a file. `source` in errors is the path.
StlReadResult read_stl(const std::filesystem::path& file, const StlReadOptions& options = {});
// Parses bytes already in memory; `source` names them in error messages.
StlReadResult parse_stl(std::string_view bytes, const std::string& source,
                        const StlReadOptions& options = {});

// Binary writes IEEE float32 little-endian coordinates, so it round-trips exactly only for
// coordinates that are float32 values. ASCII writes each coordinate as the shortest decimal
// that reads back as the same double, so doubles round-trip exactly.
std::string format_stl(const TriangleMesh& mesh, const StlWriteOptions& options = {});
void write_stl(const std::filesystem::path& file, const TriangleMesh& mesh,
               const StlWriteOptions& options = {});

}  // namespace fl::dem
