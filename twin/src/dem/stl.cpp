#include "fl/twin/dem/stl.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <unordered_map>
#include <vector>

namespace fl::dem {
namespace {

constexpr std::size_t kBinaryHeaderBytes = 80;
constexpr std::size_t kBinaryPreambleBytes = kBinaryHeaderBytes + 4;  // header + facet count
constexpr std::size_t kBinaryFacetBytes = 50;  // normal + 3 corners (12 float32) + attribute

static_assert(std::numeric_limits<float>::is_iec559, "binary STL needs IEEE float32");

std::uint32_t read_u32_le(const char* bytes) {
  std::array<unsigned char, 4> raw{};
  std::memcpy(raw.data(), bytes, 4);
  return static_cast<std::uint32_t>(raw[0]) | (static_cast<std::uint32_t>(raw[1]) << 8U) |
         (static_cast<std::uint32_t>(raw[2]) << 16U) | (static_cast<std::uint32_t>(raw[3]) << 24U);
}

float read_f32_le(const char* bytes) { return std::bit_cast<float>(read_u32_le(bytes)); }

void append_u32_le(std::string& out, std::uint32_t value) {
  for (unsigned shift = 0; shift < 32; shift += 8) {
    out.push_back(static_cast<char>((value >> shift) & 0xFFU));
  }
}

void append_f32_le(std::string& out, double value) {
  append_u32_le(out, std::bit_cast<std::uint32_t>(static_cast<float>(value)));
}

std::string describe_coordinate(double value) {
  if (std::isnan(value)) return "NaN";
  return value > 0 ? "+infinity" : "-infinity";
}

// Joins facet corners that lie within the tolerance into one vertex: a hash grid with cells of
// the tolerance's size, searching the 27 cells around each corner.
class VertexWelder {
 public:
  explicit VertexWelder(double tolerance) : tolerance_(tolerance) {
    // A zero tolerance still needs a cell size; corners then merge only when bit-equal.
    cell_size_ = tolerance > 0.0 ? tolerance : 1e-12;
  }

  std::uint32_t add(const Eigen::Vector3d& corner) {
    const auto cell = cell_of(corner);
    const double tolerance_squared = tolerance_ * tolerance_;
    for (std::int64_t dx = -1; dx <= 1; ++dx) {
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        for (std::int64_t dz = -1; dz <= 1; ++dz) {
          const auto found = cells_.find(Cell{cell.x + dx, cell.y + dy, cell.z + dz});
          if (found == cells_.end()) continue;
          for (const auto index : found->second) {
            if ((vertices_[index] - corner).squaredNorm() <= tolerance_squared) return index;
          }
        }
      }
    }
    const auto index = static_cast<std::uint32_t>(vertices_.size());
    vertices_.push_back(corner);
    cells_[cell].push_back(index);
    return index;
  }

  std::vector<Eigen::Vector3d> take_vertices() { return std::move(vertices_); }

 private:
  struct Cell {
    std::int64_t x = 0, y = 0, z = 0;
    bool operator==(const Cell&) const = default;
  };
  struct CellHash {
    std::size_t operator()(const Cell& cell) const {
      auto mix = static_cast<std::uint64_t>(cell.x) * 0x9E3779B97F4A7C15ULL;
      mix ^= static_cast<std::uint64_t>(cell.y) * 0xC2B2AE3D27D4EB4FULL + (mix << 6U);
      mix ^= static_cast<std::uint64_t>(cell.z) * 0x165667B19E3779F9ULL + (mix >> 2U);
      return static_cast<std::size_t>(mix);
    }
  };

  Cell cell_of(const Eigen::Vector3d& corner) const {
    // Clamped so absurd coordinates share an edge cell instead of overflowing; the distance
    // test keeps the result right, only slower.
    auto index = [&](double value) {
      constexpr double kLimit = 4.0e18;
      const double scaled = std::clamp(std::floor(value / cell_size_), -kLimit, kLimit);
      return static_cast<std::int64_t>(scaled);
    };
    return Cell{index(corner.x()), index(corner.y()), index(corner.z())};
  }

  double tolerance_;
  double cell_size_;
  std::vector<Eigen::Vector3d> vertices_;
  std::unordered_map<Cell, std::vector<std::uint32_t>, CellHash> cells_;
};

// Collects facets, welds them, and applies the read options.
class MeshBuilder {
 public:
  MeshBuilder(const std::string& source, const StlReadOptions& options)
      : source_(source), options_(options), welder_(options.weld_tolerance) {}

  void add_facet(const std::array<Eigen::Vector3d, 3>& corners) {
    ++facets_;
    IndexedTriangle triangle{};
    for (std::size_t corner = 0; corner < 3; ++corner) {
      triangle[corner] = welder_.add(corners[corner]);
    }
    if (triangle[0] == triangle[1] || triangle[1] == triangle[2] || triangle[0] == triangle[2]) {
      ++degenerate_;
      return;
    }
    triangles_.push_back(triangle);
  }

  StlReadResult finish(StlFormat format, std::string solid_name) {
    if (facets_ == 0) throw StlError(StlErrorKind::kEmpty, source_, "the file holds no facets");
    StlReadResult result;
    result.format = format;
    result.solid_name = std::move(solid_name);
    result.facets_in_file = facets_;
    result.degenerate_facets_dropped = degenerate_;
    result.mesh.vertices = welder_.take_vertices();
    result.mesh.triangles = std::move(triangles_);
    if (options_.require_closed) {
      const auto topology = check_topology(result.mesh);
      if (!topology.closed_manifold()) {
        std::ostringstream what;
        what << "the mesh is not closed after welding corners within " << options_.weld_tolerance
             << ": " << topology.describe();
        throw StlError(StlErrorKind::kNotClosed, source_, what.str());
      }
    }
    if (options_.scale != 1.0) {
      for (auto& vertex : result.mesh.vertices) vertex *= options_.scale;
    }
    return result;
  }

 private:
  const std::string& source_;
  const StlReadOptions& options_;
  VertexWelder welder_;
  std::vector<IndexedTriangle> triangles_;
  std::size_t facets_ = 0;
  std::size_t degenerate_ = 0;
};

StlReadResult parse_binary(std::string_view bytes, const std::string& source,
                           const StlReadOptions& options) {
  if (bytes.size() < kBinaryPreambleBytes) {
    throw StlError(StlErrorKind::kTruncated, source,
                   "truncated binary STL: the file has " + std::to_string(bytes.size()) +
                       " bytes, the 80-byte header and facet count need 84");
  }
  const std::uint64_t facet_count = read_u32_le(bytes.data() + kBinaryHeaderBytes);
  const std::uint64_t expected_bytes = kBinaryPreambleBytes + facet_count * kBinaryFacetBytes;
  if (bytes.size() != expected_bytes) {
    const bool shorter = bytes.size() < expected_bytes;
    throw StlError(shorter ? StlErrorKind::kTruncated : StlErrorKind::kSizeMismatch, source,
                   std::string(shorter ? "truncated binary STL" : "binary STL size mismatch") +
                       ": the header says " + std::to_string(facet_count) + " facets (" +
                       std::to_string(expected_bytes) + " bytes) but the file has " +
                       std::to_string(bytes.size()) + " bytes");
  }

  // Header text up to the first NUL, trimmed, as the solid name (informational only).
  std::string solid_name(bytes.substr(0, kBinaryHeaderBytes));
  solid_name = solid_name.substr(0, solid_name.find('\0'));
  std::replace_if(
      solid_name.begin(), solid_name.end(), [](char c) { return c < 0x20 || c > 0x7E; }, ' ');
  solid_name.erase(solid_name.find_last_not_of(' ') + 1);

  MeshBuilder builder(source, options);
  for (std::uint64_t facet = 0; facet < facet_count; ++facet) {
    const char* record = bytes.data() + kBinaryPreambleBytes + facet * kBinaryFacetBytes;
    std::array<Eigen::Vector3d, 3> corners;
    for (std::size_t corner = 0; corner < 3; ++corner) {
      for (std::size_t axis = 0; axis < 3; ++axis) {
        // Skip the 12-byte normal; corner coordinates follow as float32.
        const double value = read_f32_le(record + 12 + 12 * corner + 4 * axis);
        if (!std::isfinite(value)) {
          throw StlError(StlErrorKind::kNonFinite, source,
                         "facet " + std::to_string(facet) + " corner " + std::to_string(corner) +
                             " has a " + describe_coordinate(value) + " coordinate");
        }
        corners[corner][static_cast<Eigen::Index>(axis)] = value;
      }
    }
    builder.add_facet(corners);
  }
  return builder.finish(StlFormat::kBinary, solid_name);
}

// Whitespace-separated tokens with the line each starts on.
class AsciiLexer {
 public:
  explicit AsciiLexer(std::string_view text) : text_(text) {}

  struct Token {
    std::string_view text;  // empty at end of input
    std::size_t line = 0;
  };

  Token next() {
    skip_space();
    const auto start = position_;
    while (position_ < text_.size() && !is_space(text_[position_])) ++position_;
    return Token{text_.substr(start, position_ - start), line_};
  }

  // The rest of the current line (after one separating space), for "solid <name>".
  std::string_view rest_of_line() {
    const auto start = position_;
    while (position_ < text_.size() && text_[position_] != '\n') ++position_;
    auto rest = text_.substr(start, position_ - start);
    while (!rest.empty() && is_space(rest.front())) rest.remove_prefix(1);
    while (!rest.empty() && is_space(rest.back())) rest.remove_suffix(1);
    return rest;
  }

  bool at_end() {
    skip_space();
    return position_ >= text_.size();
  }
  std::size_t line() const { return line_; }

 private:
  static bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
  }
  void skip_space() {
    while (position_ < text_.size() && is_space(text_[position_])) {
      if (text_[position_] == '\n') ++line_;
      ++position_;
    }
  }

  std::string_view text_;
  std::size_t position_ = 0;
  std::size_t line_ = 1;
};

bool equals_ignoring_case(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) ==
                  std::tolower(static_cast<unsigned char>(y));
         });
}

class AsciiParser {
 public:
  AsciiParser(std::string_view text, const std::string& source, const StlReadOptions& options)
      : lexer_(text), source_(source), builder_(source, options) {}

  StlReadResult parse() {
    std::string solid_name;
    bool first_solid = true;
    // Some exporters put several solids in one file; their facets form one mesh.
    do {
      expect("solid");
      const auto name = lexer_.rest_of_line();
      if (first_solid) solid_name = std::string(name);
      first_solid = false;
      parse_facets_until_endsolid();
    } while (!lexer_.at_end());
    return builder_.finish(StlFormat::kAscii, solid_name);
  }

 private:
  [[noreturn]] void fail(std::size_t line, const std::string& what) const {
    throw StlError(StlErrorKind::kSyntax, source_, "line " + std::to_string(line) + ": " + what);
  }

  static std::string shown(std::string_view token) {
    if (token.empty()) return "the end of the file";
    constexpr std::size_t kMaxShown = 40;
    return "'" + std::string(token.substr(0, kMaxShown)) +
           (token.size() > kMaxShown ? "...'" : "'");
  }

  AsciiLexer::Token expect(std::string_view keyword) {
    const auto token = lexer_.next();
    if (!equals_ignoring_case(token.text, keyword)) {
      fail(token.line, "expected '" + std::string(keyword) + "' but found " + shown(token.text));
    }
    return token;
  }

  double number(std::string_view what) {
    const auto token = lexer_.next();
    auto text = token.text;
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);  // from_chars refuses '+'
    double value = 0.0;
    const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || error != std::errc() || end != text.data() + text.size()) {
      fail(token.line,
           "expected a number (" + std::string(what) + ") but found " + shown(token.text));
    }
    if (!std::isfinite(value)) {
      throw StlError(StlErrorKind::kNonFinite, source_,
                     "line " + std::to_string(token.line) + ": " + std::string(what) + " is " +
                         describe_coordinate(value));
    }
    return value;
  }

  void parse_facets_until_endsolid() {
    while (true) {
      const auto token = lexer_.next();
      if (equals_ignoring_case(token.text, "endsolid")) {
        lexer_.rest_of_line();  // optional name
        return;
      }
      if (!equals_ignoring_case(token.text, "facet")) {
        fail(token.line, "expected 'facet' or 'endsolid' but found " + shown(token.text));
      }
      expect("normal");
      for (int axis = 0; axis < 3; ++axis) number("normal component");  // ignored, see header
      expect("outer");
      expect("loop");
      std::array<Eigen::Vector3d, 3> corners;
      for (auto& corner : corners) {
        expect("vertex");
        for (Eigen::Index axis = 0; axis < 3; ++axis) corner[axis] = number("vertex coordinate");
      }
      const auto after_corners = lexer_.next();
      if (equals_ignoring_case(after_corners.text, "vertex")) {
        fail(after_corners.line, "a facet has more than 3 vertices");
      }
      if (!equals_ignoring_case(after_corners.text, "endloop")) {
        fail(after_corners.line, "expected 'endloop' but found " + shown(after_corners.text));
      }
      expect("endfacet");
      builder_.add_facet(corners);
    }
  }

  AsciiLexer lexer_;
  const std::string& source_;
  MeshBuilder builder_;
};

bool starts_with_solid(std::string_view bytes) {
  const auto first = bytes.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos) return false;
  return equals_ignoring_case(bytes.substr(first, 5), "solid");
}

bool binary_size_matches(std::string_view bytes) {
  if (bytes.size() < kBinaryPreambleBytes) return false;
  const std::uint64_t facet_count = read_u32_le(bytes.data() + kBinaryHeaderBytes);
  return bytes.size() == kBinaryPreambleBytes + facet_count * kBinaryFacetBytes;
}

void append_shortest(std::string& out, double value) {
  std::array<char, 32> buffer{};
  const auto [end, error] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), end);
}

}  // namespace

StlError::StlError(StlErrorKind kind, const std::string& source, const std::string& what)
    : std::runtime_error(source + ": " + what), kind_(kind) {}

StlReadResult parse_stl(std::string_view bytes, const std::string& source,
                        const StlReadOptions& options) {
  if (!(options.weld_tolerance >= 0.0) || !std::isfinite(options.weld_tolerance) ||
      !std::isfinite(options.scale) || options.scale == 0.0) {
    throw std::invalid_argument(
        "StlReadOptions: weld_tolerance must be >= 0, scale finite and non-zero");
  }
  if (bytes.empty()) throw StlError(StlErrorKind::kEmpty, source, "the file is empty");
  // ASCII STL never contains NUL bytes; a "solid" header with NULs is a binary file.
  const bool has_nul = bytes.find('\0') != std::string_view::npos;
  if (binary_size_matches(bytes) || !starts_with_solid(bytes) || has_nul) {
    return parse_binary(bytes, source, options);
  }
  return AsciiParser(bytes, source, options).parse();
}

StlReadResult read_stl(const std::filesystem::path& file, const StlReadOptions& options) {
  std::ifstream stream(file, std::ios::binary);
  if (!stream) {
    std::error_code error;
    const bool exists = std::filesystem::exists(file, error);
    throw StlError(StlErrorKind::kCannotOpen, file.string(),
                   exists ? "cannot open the file for reading" : "no such file");
  }
  std::string bytes((std::istreambuf_iterator<char>(stream)), std::istreambuf_iterator<char>());
  if (stream.bad()) throw StlError(StlErrorKind::kCannotOpen, file.string(), "read error");
  return parse_stl(bytes, file.string(), options);
}

std::string format_stl(const TriangleMesh& mesh, const StlWriteOptions& options) {
  const auto facet_normal = [&](const IndexedTriangle& t) -> Eigen::Vector3d {
    const auto& a = mesh.vertices[t[0]];
    const Eigen::Vector3d normal = (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
    const double length = normal.norm();
    return length > 0.0 ? Eigen::Vector3d(normal / length) : Eigen::Vector3d::Zero();
  };
  for (const auto& t : mesh.triangles) {
    for (const auto index : t) {
      if (index >= mesh.vertices.size()) {
        throw std::invalid_argument("format_stl: triangle index out of range");
      }
    }
  }
  if (mesh.triangles.size() > std::numeric_limits<std::uint32_t>::max()) {
    throw std::invalid_argument("format_stl: too many triangles for STL");
  }

  std::string out;
  if (options.format == StlFormat::kBinary) {
    // A binary header must not start with "solid", or readers may take it for ASCII.
    std::string header = "fl binary STL " + options.solid_name;
    header.resize(kBinaryHeaderBytes, '\0');
    out.reserve(kBinaryPreambleBytes + mesh.triangles.size() * kBinaryFacetBytes);
    out += header;
    append_u32_le(out, static_cast<std::uint32_t>(mesh.triangles.size()));
    for (const auto& t : mesh.triangles) {
      const auto normal = facet_normal(t);
      for (Eigen::Index axis = 0; axis < 3; ++axis) append_f32_le(out, normal[axis]);
      for (const auto index : t) {
        for (Eigen::Index axis = 0; axis < 3; ++axis) {
          append_f32_le(out, mesh.vertices[index][axis] * options.scale);
        }
      }
      out += std::string(2, '\0');  // attribute byte count, unused
    }
    return out;
  }

  auto append_triple = [&](const Eigen::Vector3d& v, double scale) {
    for (Eigen::Index axis = 0; axis < 3; ++axis) {
      out += ' ';
      append_shortest(out, v[axis] * scale);
    }
    out += '\n';
  };
  out += "solid " + options.solid_name + "\n";
  for (const auto& t : mesh.triangles) {
    out += "  facet normal";
    append_triple(facet_normal(t), 1.0);
    out += "    outer loop\n";
    for (const auto index : t) {
      out += "      vertex";
      append_triple(mesh.vertices[index], options.scale);
    }
    out += "    endloop\n  endfacet\n";
  }
  out += "endsolid " + options.solid_name + "\n";
  return out;
}

void write_stl(const std::filesystem::path& file, const TriangleMesh& mesh,
               const StlWriteOptions& options) {
  const auto bytes = format_stl(mesh, options);
  std::ofstream stream(file, std::ios::binary | std::ios::trunc);
  if (!stream) throw StlError(StlErrorKind::kCannotWrite, file.string(), "cannot open for writing");
  stream.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  stream.close();
  if (!stream) throw StlError(StlErrorKind::kCannotWrite, file.string(), "write failed");
}

}  // namespace fl::dem
