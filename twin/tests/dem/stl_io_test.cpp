// STL round trips (binary and ASCII) and refusal of malformed files with a clear message.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "fl/twin/dem/stl.hpp"

namespace fl::dem {
namespace {

// Rounds to float32 precision. The volatile is needed: GCC 12.2's SLP vectorizer drops the
// double -> float -> double round trip in a loop over Vector3d coefficients at -O2/-O3
// (seen here; -fno-tree-slp-vectorize or -O1 round correctly).
double to_float_precision(double value) {
  volatile float narrowed = static_cast<float>(value);
  return narrowed;
}

// Coordinates rounded to float32 so binary STL (float32) can round-trip them bit-exactly.
TriangleMesh float_exact(TriangleMesh mesh) {
  for (auto& v : mesh.vertices) {
    for (Eigen::Index axis = 0; axis < 3; ++axis) v[axis] = to_float_precision(v[axis]);
  }
  return mesh;
}

// Welding assigns vertex indices in first-seen order, so compare geometry facet by facet.
void expect_same_facets(const TriangleMesh& expected, const TriangleMesh& actual) {
  ASSERT_EQ(expected.triangles.size(), actual.triangles.size());
  ASSERT_EQ(expected.vertices.size(), actual.vertices.size());
  for (std::size_t t = 0; t < expected.triangles.size(); ++t) {
    for (std::size_t corner = 0; corner < 3; ++corner) {
      const auto& a = expected.vertices[expected.triangles[t][corner]];
      const auto& b = actual.vertices[actual.triangles[t][corner]];
      for (Eigen::Index axis = 0; axis < 3; ++axis) {
        // Bit-exact, not approximately equal.
        ASSERT_EQ(std::bit_cast<std::uint64_t>(a[axis]), std::bit_cast<std::uint64_t>(b[axis]))
            << "facet " << t << " corner " << corner;
      }
    }
  }
}

// Runs `parse` and returns the StlError it throws (fails the test if none).
template <typename Parse>
StlError expect_stl_error(Parse parse, StlErrorKind kind) {
  try {
    parse();
  } catch (const StlError& error) {
    EXPECT_EQ(error.kind(), kind) << error.what();
    return error;
  }
  ADD_FAILURE() << "no StlError thrown";
  return StlError(kind, "", "");
}

std::string binary_of(const TriangleMesh& mesh) {
  return format_stl(mesh, StlWriteOptions{StlFormat::kBinary, 1.0, "t"});
}

const std::string kAsciiTriangleFacet =
    "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n"
    "      vertex 0 1 0\n    endloop\n  endfacet\n";

TEST(StlIo, BinaryRoundTripIsBitExact) {
  // An icosphere with irrational coordinates, rounded to float32 once.
  const auto mesh = float_exact(make_icosphere(0.0371, 3));
  const auto bytes = binary_of(mesh);
  EXPECT_EQ(bytes.size(), 84U + 50U * mesh.triangles.size());
  const auto read = parse_stl(bytes, "memory");
  EXPECT_EQ(read.format, StlFormat::kBinary);
  EXPECT_EQ(read.facets_in_file, mesh.triangles.size());
  EXPECT_EQ(read.degenerate_facets_dropped, 0U);
  expect_same_facets(mesh, read.mesh);
  EXPECT_TRUE(is_closed_outward(read.mesh));
}

TEST(StlIo, AsciiRoundTripIsBitExactForDoubles) {
  // Shortest round-trip decimal output: doubles survive without the float32 rounding.
  const auto mesh = make_icosphere(0.0371, 3);
  const auto text = format_stl(mesh, StlWriteOptions{StlFormat::kAscii, 1.0, "ico sphere"});
  const auto read = parse_stl(text, "memory");
  EXPECT_EQ(read.format, StlFormat::kAscii);
  EXPECT_EQ(read.solid_name, "ico sphere");
  expect_same_facets(mesh, read.mesh);
}

TEST(StlIo, FileRoundTripWithUnitScaling) {
  const auto path = std::filesystem::temp_directory_path() / "fl_stl_io_test_box.stl";
  // Metres written as millimetres and read back as metres. 250 mm is exact in float32; the
  // factor 1e-3 is not exact in binary, so metres come back within a few ulp.
  const auto box = make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.25, 0.5, 0.125));
  write_stl(path, box, StlWriteOptions{StlFormat::kBinary, 1e3, "box"});
  const auto in_mm = read_stl(path);
  EXPECT_DOUBLE_EQ(bounding_box(in_mm.mesh).max.x(), 250.0);
  EXPECT_EQ(in_mm.solid_name, "fl binary STL box");
  StlReadOptions to_metres;
  to_metres.scale = 1e-3;
  const auto in_m = read_stl(path, to_metres);
  EXPECT_TRUE(bounding_box(in_m.mesh).max.isApprox(Eigen::Vector3d(0.25, 0.5, 0.125), 1e-15));
  EXPECT_NEAR(signed_volume(in_m.mesh), signed_volume(box), signed_volume(box) * 1e-14);
  std::filesystem::remove(path);
}

TEST(StlIo, WeldingJoinsCornersWithinTolerance) {
  // A cube written as ASCII with one corner copy displaced by 1e-7 (< default 1e-6): still
  // closed after welding, and the first-seen coordinates are kept.
  auto text = format_stl(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()),
                         StlWriteOptions{StlFormat::kAscii, 1.0, "cube"});
  const auto last_vertex = text.rfind("vertex 1 1 1");
  ASSERT_NE(last_vertex, std::string::npos);
  text.replace(last_vertex, 12, "vertex 1.0000001 1 1");
  const auto read = parse_stl(text, "memory");
  EXPECT_EQ(read.mesh.vertices.size(), 8U);
  EXPECT_TRUE(is_closed_outward(read.mesh));
  EXPECT_EQ(bounding_box(read.mesh).max, Eigen::Vector3d::Ones());

  // With a tolerance below the displacement, the copy stays apart and the mesh has a hole.
  StlReadOptions strict;
  strict.weld_tolerance = 1e-8;
  const auto error =
      expect_stl_error([&] { parse_stl(text, "cube.stl", strict); }, StlErrorKind::kNotClosed);
  EXPECT_NE(std::string(error.what()).find("cube.stl: the mesh is not closed"), std::string::npos)
      << error.what();
  EXPECT_NE(std::string(error.what()).find("boundary edges"), std::string::npos) << error.what();
  strict.require_closed = false;
  EXPECT_EQ(parse_stl(text, "cube.stl", strict).mesh.vertices.size(), 9U);
}

TEST(StlIo, SolidHeaderBinaryIsReadAsBinary) {
  // Some exporters start binary headers with "solid"; the exact size decides.
  auto bytes = binary_of(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  std::memcpy(bytes.data(), "solid exported", 14);
  EXPECT_EQ(parse_stl(bytes, "memory").format, StlFormat::kBinary);
}

TEST(StlIo, TruncatedBinaryIsRefused) {
  const auto bytes = binary_of(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  // 12 facets = 684 bytes; cut inside the last facet.
  const auto error = expect_stl_error(
      [&] { parse_stl(bytes.substr(0, bytes.size() - 7), "cube.stl"); }, StlErrorKind::kTruncated);
  EXPECT_STREQ(error.what(),
               "cube.stl: truncated binary STL: the header says 12 facets (684 bytes) but the "
               "file has 677 bytes");
  const auto short_error = expect_stl_error([&] { parse_stl(bytes.substr(0, 50), "cube.stl"); },
                                            StlErrorKind::kTruncated);
  EXPECT_STREQ(short_error.what(),
               "cube.stl: truncated binary STL: the file has 50 bytes, the 80-byte header and "
               "facet count need 84");
}

TEST(StlIo, FacetCountNotMatchingSizeIsRefused) {
  auto bytes = binary_of(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  bytes[80] = 10;  // header claims 10 facets, the file holds 12
  const auto error =
      expect_stl_error([&] { parse_stl(bytes, "cube.stl"); }, StlErrorKind::kSizeMismatch);
  EXPECT_STREQ(error.what(),
               "cube.stl: binary STL size mismatch: the header says 10 facets (584 bytes) but "
               "the file has 684 bytes");
  // An absurd count (4 billion facets) is a size problem, not an allocation.
  bytes[80] = bytes[81] = bytes[82] = bytes[83] = static_cast<char>(0xFF);
  expect_stl_error([&] { parse_stl(bytes, "cube.stl"); }, StlErrorKind::kTruncated);
}

TEST(StlIo, NanInBinaryIsRefused) {
  auto bytes = binary_of(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  // Facet 2, corner 1, y: 84 + 2 x 50 + 12 (normal) + 12 (corner 0) + 4.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(bytes.data() + 84 + 100 + 12 + 12 + 4, &nan, 4);
  const auto error =
      expect_stl_error([&] { parse_stl(bytes, "cube.stl"); }, StlErrorKind::kNonFinite);
  EXPECT_STREQ(error.what(), "cube.stl: facet 2 corner 1 has a NaN coordinate");
}

TEST(StlIo, NanAndInfinityInAsciiAreRefusedWithLine) {
  auto text = "solid t\n" + kAsciiTriangleFacet + "endsolid t\n";
  auto with_nan = text;
  with_nan.replace(with_nan.find("vertex 1 0 0"), 12, "vertex 1 nan 0");
  auto error = expect_stl_error([&] { parse_stl(with_nan, "t.stl"); }, StlErrorKind::kNonFinite);
  EXPECT_STREQ(error.what(), "t.stl: line 5: vertex coordinate is NaN");
  auto with_inf = text;
  with_inf.replace(with_inf.find("vertex 0 1 0"), 12, "vertex 0 1 -inf");
  error = expect_stl_error([&] { parse_stl(with_inf, "t.stl"); }, StlErrorKind::kNonFinite);
  EXPECT_STREQ(error.what(), "t.stl: line 6: vertex coordinate is -infinity");
}

TEST(StlIo, AsciiSyntaxErrorsNameTheLine) {
  const std::string head = "solid t\n";
  struct Case {
    std::string text;
    std::string message;
  };
  const Case cases[] = {
      {head + "  facet normal 0 0 1\n    outer loop\n      vertx 0 0 0\n",
       "t.stl: line 4: expected 'vertex' but found 'vertx'"},
      {head + "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 zero\n",
       "t.stl: line 4: expected a number (vertex coordinate) but found 'zero'"},
      {head + "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 1.5e\n",
       "t.stl: line 4: expected a number (vertex coordinate) but found '1.5e'"},
      {head + kAsciiTriangleFacet,
       "t.stl: line 9: expected 'facet' or 'endsolid' but found "
       "the end of the file"},
      {head + "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n"
              "      vertex 0 1 0\n      vertex 1 1 0\n",
       "t.stl: line 7: a facet has more than 3 vertices"},
      {head + "  facet normal 0 0 1\n    outer loop\n      vertex 0 0 0\n      vertex 1 0 0\n"
              "    endloop\n",
       "t.stl: line 6: expected 'vertex' but found 'endloop'"},
      {head + "  outer loop\n", "t.stl: line 2: expected 'facet' or 'endsolid' but found 'outer'"},
  };
  for (const auto& c : cases) {
    const auto error = expect_stl_error([&] { parse_stl(c.text, "t.stl"); }, StlErrorKind::kSyntax);
    EXPECT_EQ(std::string(error.what()), c.message);
  }
}

TEST(StlIo, EmptyAndFacetlessAndMissingFilesAreRefused) {
  auto error = expect_stl_error([&] { parse_stl("", "e.stl"); }, StlErrorKind::kEmpty);
  EXPECT_STREQ(error.what(), "e.stl: the file is empty");
  error =
      expect_stl_error([&] { parse_stl("solid x\nendsolid x\n", "e.stl"); }, StlErrorKind::kEmpty);
  EXPECT_STREQ(error.what(), "e.stl: the file holds no facets");
  const auto missing = std::filesystem::temp_directory_path() / "fl_no_such_file.stl";
  error = expect_stl_error([&] { read_stl(missing); }, StlErrorKind::kCannotOpen);
  EXPECT_EQ(std::string(error.what()), missing.string() + ": no such file");
  // Text that is not ASCII STL is taken for binary; "xxxx" as a facet count is far too many.
  expect_stl_error([&] { parse_stl(std::string(100, 'x'), "x.stl"); }, StlErrorKind::kTruncated);
}

TEST(StlIo, OpenAsciiMeshIsRefusedWhenClosedIsRequired) {
  const auto text = "solid t\n" + kAsciiTriangleFacet + "endsolid t\n";
  const auto error = expect_stl_error([&] { parse_stl(text, "t.stl"); }, StlErrorKind::kNotClosed);
  EXPECT_STREQ(error.what(),
               "t.stl: the mesh is not closed after welding corners within 1e-06: 3 boundary "
               "edges");
  StlReadOptions open_ok;
  open_ok.require_closed = false;
  EXPECT_EQ(parse_stl(text, "t.stl", open_ok).mesh.triangles.size(), 1U);
}

TEST(StlIo, DegenerateFacetsAreDroppedAndCounted) {
  // A facet whose three corners weld into two vertices has no area: dropped, counted.
  const auto text = "solid t\n" + kAsciiTriangleFacet +
                    "facet normal 0 0 1 outer loop vertex 0 0 0 vertex 0 0 0 vertex 1 0 0 "
                    "endloop endfacet\nendsolid t\n";
  StlReadOptions open_ok;
  open_ok.require_closed = false;
  const auto read = parse_stl(text, "t.stl", open_ok);
  EXPECT_EQ(read.facets_in_file, 2U);
  EXPECT_EQ(read.degenerate_facets_dropped, 1U);
  EXPECT_EQ(read.mesh.triangles.size(), 1U);
}

TEST(StlIo, RandomGarbageNeverCrashes) {
  // Deterministic pseudo-random bytes and mutated valid files: every outcome is a mesh or an
  // StlError, nothing else.
  const auto valid_ascii = format_stl(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()),
                                      StlWriteOptions{StlFormat::kAscii, 1.0, "cube"});
  const auto valid_binary = binary_of(make_box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones()));
  std::uint32_t state = 12345;
  auto next = [&] {
    state = state * 1664525U + 1013904223U;  // Numerical Recipes LCG
    return state >> 8U;
  };
  for (int trial = 0; trial < 400; ++trial) {
    std::string bytes = (trial % 2 == 0) ? valid_ascii : valid_binary;
    const auto mutations = 1 + next() % 4;
    for (std::uint32_t m = 0; m < mutations; ++m) {
      const auto at = next() % bytes.size();
      switch (next() % 3) {
        case 0:
          bytes[at] = static_cast<char>(next() & 0xFFU);
          break;
        case 1:
          bytes.erase(at, 1 + next() % 16);
          break;
        default:
          bytes.resize(at);
          break;
      }
      if (bytes.empty()) break;
    }
    try {
      parse_stl(bytes, "fuzz");
    } catch (const StlError&) {
    }
  }
  SUCCEED();
}

}  // namespace
}  // namespace fl::dem
