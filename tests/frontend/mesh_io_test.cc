// STL and OBJ files: round trips of meshes the project writes, a large binary STL read, and every
// malformed-file error with its message (and no crash on random bytes).
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <unistd.h>

#include "frontend/geometry/MeshIO.h"
#include "frontend/geometry/MeshOps.h"
#include "frontend/geometry/Primitives.h"
#include "tests/frontend/ExampleMeshes.h"

namespace pflow::frontend {
namespace {

namespace fs = std::filesystem;

class MeshIO : public ::testing::Test {
 protected:
  void SetUp() override {
    m_dir = fs::temp_directory_path() / ("pflow_mesh_io_" + std::to_string(::getpid()) + "_" +
                                         ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(m_dir);
  }
  void TearDown() override { fs::remove_all(m_dir); }

  std::string path(const std::string& name) const { return (m_dir / name).string(); }
  std::string write(const std::string& name, const std::string& content) const {
    std::ofstream(path(name), std::ios::binary) << content;
    return path(name);
  }
  // Expects an error whose message contains `part`.
  static void expectError(const Result<TriMesh>& r, const std::string& part) {
    ASSERT_FALSE(r.isOk()) << "expected an error containing: " << part;
    EXPECT_NE(r.status().message().find(part), std::string::npos) << "message: " << r.status().message() << "\nexpected: " << part;
  }

  fs::path m_dir;
};

TriMesh closedHopper() {
  HopperSpec s = examples::funnelSpec();
  s.openOrifice = s.openTop = false;
  return *tessellate(s, {0.01, 10 * std::numbers::pi / 180});
}

// Same triangles, corner by corner, within `tol` [m] (file readers may renumber vertices).
void expectSameTriangles(const TriMesh& a, const TriMesh& b, double tol) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t t = 0; t < a.size(); ++t) {
    for (int c = 0; c < 3; ++c) {
      ASSERT_LE(norm(a.vertices[a.triangles[t][c]] - b.vertices[b.triangles[t][c]]), tol) << "triangle " << t << " corner " << c;
    }
  }
}

std::string binaryStlBytes(const std::vector<std::array<float, 9>>& tris, std::uint32_t declared, const std::string& header = "") {
  std::string out(80, ' ');
  std::memcpy(out.data(), header.data(), std::min<std::size_t>(header.size(), 80));
  out.append(reinterpret_cast<const char*>(&declared), 4);
  for (const auto& t : tris) {
    const float normal[3] = {0, 0, 0};
    out.append(reinterpret_cast<const char*>(normal), 12);
    out.append(reinterpret_cast<const char*>(t.data()), 36);
    out.append(2, '\0');
  }
  return out;
}

const char* kAsciiTwoFacets =
    "solid two\n"
    "facet normal 0 0 1\n"
    " outer loop\n"
    "  vertex 0 0 0\n"
    "  vertex 1 0 0\n"
    "  vertex 0 1 0\n"
    " endloop\n"
    "endfacet\n"
    "facet normal 0 0 1\n"
    " outer loop\n"
    "  vertex 1 0 0\n"
    "  vertex 1 1 0\n"
    "  vertex 0 1 0\n"
    " endloop\n"
    "endfacet\n"
    "endsolid two\n";

// --- round trips ----------------------------------------------------------------------------------------------------------

TEST_F(MeshIO, BinaryStlRoundTrip) {
  const TriMesh m = closedHopper();
  ASSERT_TRUE(writeStlBinary(m, path("h.stl")).isOk());
  EXPECT_EQ(fs::file_size(path("h.stl")), 84 + 50 * m.size());
  auto r = readStl(path("h.stl"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->vertices.size(), m.vertices.size());  // welded back to shared vertices
  expectSameTriangles(m, *r, 1e-8);                   // float32 coordinates
  EXPECT_TRUE(checkClosed(*r).isOk());
  EXPECT_NEAR(signedVolume(*r), signedVolume(m), 1e-6 * signedVolume(m));
  EXPECT_EQ(r->surface, std::vector<std::int32_t>(m.size(), 0));
}

TEST_F(MeshIO, AsciiStlRoundTripIsExact) {
  const TriMesh m = closedHopper();
  ASSERT_TRUE(writeStlAscii(m, path("h.stl"), "hopper").isOk());
  auto r = readMeshFile(path("h.stl"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->vertices.size(), m.vertices.size());
  expectSameTriangles(m, *r, 0.0);
  EXPECT_TRUE(checkClosed(*r).isOk());
  EXPECT_EQ(r->surfaceNames, std::vector<std::string>{"hopper"});
}

TEST_F(MeshIO, ObjRoundTripKeepsVerticesTrianglesSurfaces) {
  const TriMesh m = closedHopper();
  ASSERT_TRUE(writeObj(m, path("h.obj")).isOk());
  auto r = readMeshFile(path("h.obj"));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  ASSERT_EQ(r->vertices.size(), m.vertices.size());
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    ASSERT_EQ(r->vertices[i].x, m.vertices[i].x);
    ASSERT_EQ(r->vertices[i].y, m.vertices[i].y);
    ASSERT_EQ(r->vertices[i].z, m.vertices[i].z);
  }
  EXPECT_EQ(r->triangles, m.triangles);
  EXPECT_EQ(r->surface, m.surface);
  EXPECT_EQ(r->surfaceNames, m.surfaceNames);
}

TEST_F(MeshIO, ExtensionIsCaseInsensitiveAndChecked) {
  const TriMesh m = closedHopper();
  ASSERT_TRUE(writeStlBinary(m, path("UPPER.STL")).isOk());
  EXPECT_TRUE(readMeshFile(path("UPPER.STL")).isOk());
  write("x.ply", "ply\n");
  expectError(readMeshFile(path("x.ply")), "unsupported mesh file extension '.ply' (expected .stl or .obj)");
}

// --- a large binary STL -------------------------------------------------------------------------------------------------

TEST_F(MeshIO, ReadsA100kTriangleBinaryStlFast) {
  // A unit box with 92 cells per edge: 12 * 92^2 = 101568 triangles.
  auto box = tessellate(BoxSpec{{0, 0, 0}, {1, 1, 1}, {}}, Tessellation{.maxEdge = std::sqrt(2.0) / 91.5});
  ASSERT_TRUE(box.isOk());
  ASSERT_EQ(box->size(), 101568u);
  ASSERT_TRUE(writeStlBinary(*box, path("big.stl")).isOk());
  const auto t0 = std::chrono::steady_clock::now();
  auto r = readStl(path("big.stl"));
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->size(), 101568u);
  EXPECT_EQ(r->vertices.size(), box->vertices.size());
  EXPECT_TRUE(checkClosed(*r).isOk());
  std::printf("read %zu-triangle binary STL in %.1f ms\n", r->size(), seconds * 1e3);
  RecordProperty("read_ms", std::to_string(seconds * 1e3));
  EXPECT_LT(seconds, 0.5);
}

// --- STL format detection and errors ---------------------------------------------------------------------------------------

TEST_F(MeshIO, BinaryStlWhoseHeaderSaysSolid) {
  const std::string bytes = binaryStlBytes({{0, 0, 0, 1, 0, 0, 0, 1, 0}}, 1, "solid but binary");
  auto r = readStl(write("s.stl", bytes));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->size(), 1u);
  // Truncated, it fails as ASCII and the message says why it is not binary either.
  expectError(readStl(write("t.stl", bytes.substr(0, bytes.size() - 3))),
              "(not a binary STL either: header declares 1 triangles, which needs 134 bytes, but the file has 131 bytes)");
}

TEST_F(MeshIO, StlErrors) {
  expectError(readStl(path("missing.stl")), "missing.stl': cannot open: no such file");
  expectError(readStl(m_dir.string()), "is a directory");
  expectError(readStl(write("empty.stl", "")), "the file is empty");
  expectError(readStl(write("short.stl", "abc")), "not an STL file: 3 bytes is too short");

  const std::string two = binaryStlBytes({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {1, 0, 0, 1, 1, 0, 0, 1, 0}}, 2);
  expectError(readStl(write("trunc.stl", two.substr(0, two.size() - 10))),
              "truncated or corrupt binary STL: header declares 2 triangles, which needs 184 bytes, but the file has 174 bytes");
  expectError(readStl(write("zero.stl", binaryStlBytes({}, 0))), "binary STL with no triangles");
  expectError(readStl(write("nan.stl", binaryStlBytes({{0, 0, 0, 1, NAN, 0, 0, 1, 0}}, 1))),
              "triangle 0, vertex 1: non-finite coordinate (nan)");
  expectError(readStl(write("degbin.stl", binaryStlBytes({{0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, 1, 0, 0, 2, 0, 0}}, 2))),
              "1 degenerate (zero-area) triangle; first: triangle 1");

  std::string missingVertex = kAsciiTwoFacets;
  missingVertex.erase(missingVertex.find("  vertex 0 1 0\n"), 15);
  expectError(readStl(write("a1.stl", missingVertex)), "line 6: expected 'vertex', got 'endloop' (a facet needs exactly 3 vertices)");
  std::string badNumber = kAsciiTwoFacets;
  badNumber.replace(badNumber.find("vertex 1 1 0"), 12, "vertex 1 x 0");
  expectError(readStl(write("a2.stl", badNumber)), "line 12: expected a vertex coordinate, got 'x'");
  std::string nan = kAsciiTwoFacets;
  nan.replace(nan.find("vertex 1 1 0"), 12, "vertex 1 nan 0");
  expectError(readStl(write("a3.stl", nan)), "line 12: a vertex coordinate is not finite: 'nan'");
  std::string cut = kAsciiTwoFacets;
  cut.resize(cut.find("endsolid"));
  expectError(readStl(write("a4.stl", cut)), "line 16: expected 'facet' or 'endsolid', got end of file");
  expectError(readStl(write("a5.stl", "solid empty\nendsolid empty\n")), "the file has no triangles");
  std::string degenerate = kAsciiTwoFacets;
  degenerate.replace(degenerate.find("vertex 1 1 0"), 12, "vertex 0 1 0");
  expectError(readStl(write("a6.stl", degenerate)), "1 degenerate (zero-area) triangle; first: facet at line 9");
  auto dropped = readStl(path("a6.stl"), {.dropDegenerate = true});
  ASSERT_TRUE(dropped.isOk());
  EXPECT_EQ(dropped->size(), 1u);
}

TEST_F(MeshIO, AsciiStlWithSharedVerticesAndLeadingPlus) {
  std::string s = kAsciiTwoFacets;
  s.replace(s.find("vertex 1 1 0"), 12, "vertex +1 1.0e0 -0");
  auto r = readStl(write("p.stl", s));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  EXPECT_EQ(r->vertices.size(), 4u);  // 6 corners, 4 distinct points
  EXPECT_EQ(r->surfaceNames, std::vector<std::string>{"two"});
}

// --- OBJ ----------------------------------------------------------------------------------------------------------------

TEST_F(MeshIO, ObjFeatures) {
  const std::string obj =
      "# a unit square and a triangle\n"
      "mtllib x.mtl\n"
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0   # trailing comment\n"
      "vt 0 0\nvn 0 0 1\n"
      "g floor\n"
      "usemtl steel\ns off\n"
      "f 1/1/1 2/1/1 3//1 4\n"  // quad: two triangles
      "v 0 0 1\n"
      "o lid part\n"
      "f -5 -4 -1\n"  // relative: vertices 1, 2, 5
      "g floor\n"
      "f 1 \\\n 3 4\n";  // back to the first group, with a line continuation
  auto r = readObj(write("f.obj", obj));
  ASSERT_TRUE(r.isOk()) << r.status().message();
  ASSERT_EQ(r->size(), 4u);
  EXPECT_EQ(r->triangles[0], (std::array<std::uint32_t, 3>{0, 1, 2}));
  EXPECT_EQ(r->triangles[1], (std::array<std::uint32_t, 3>{0, 2, 3}));
  EXPECT_EQ(r->triangles[2], (std::array<std::uint32_t, 3>{0, 1, 4}));
  EXPECT_EQ(r->surface, (std::vector<std::int32_t>{0, 0, 1, 0}));
  EXPECT_EQ(r->surfaceNames, (std::vector<std::string>{"floor", "lid part"}));
}

TEST_F(MeshIO, ObjErrors) {
  const std::string v = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  expectError(readObj(write("r.obj", v + "f 1 2 9\n")), "line 5: face vertex index 9 is out of range (the file has 4 vertices)");
  expectError(readObj(write("n.obj", v + "f 1 2 -7\n")), "line 5: relative vertex index -7 is out of range (4 vertices defined so far)");
  expectError(readObj(write("z.obj", v + "f 0 1 2\n")), "line 5: vertex index 0 is invalid (OBJ indices start at 1)");
  expectError(readObj(write("b.obj", v + "f 1 2 x/1\n")), "line 5: expected a vertex reference (i, i/j, i//k or i/j/k), got 'x/1'");
  expectError(readObj(write("two.obj", v + "f 1 2\n")), "line 5: a face needs at least 3 vertices, got 2");
  expectError(readObj(write("inf.obj", "v 0 0 0\nv 1 inf 0\n")), "line 2: a vertex coordinate is not finite: 'inf'");
  expectError(readObj(write("short.obj", "v 0 0\n")), "line 1: a vertex needs 3 coordinates, got 2");
  expectError(readObj(write("none.obj", v)), "the file has no triangles");
  expectError(readObj(write("deg.obj", v + "f 1 2 3\nf 1 2 2\n")), "1 degenerate (zero-area) triangle; first: triangle 1 (face at line 6)");
  expectError(readObj(write("curv.obj", v + "curv 0 1 1 2\n")), "line 5: free-form geometry ('curv') is not supported");
  expectError(readObj(write("what.obj", v + "xyz 1\n")), "line 5: unknown OBJ statement 'xyz'");
  expectError(readObj(path("nope.obj")), "cannot open: no such file");
}

// --- robustness ---------------------------------------------------------------------------------------------------------

TEST_F(MeshIO, RandomAndTruncatedFilesNeverCrash) {
  std::mt19937 rng(12345);
  const TriMesh m = closedHopper();
  ASSERT_TRUE(writeStlAscii(m, path("ok.stl")).isOk());
  ASSERT_TRUE(writeObj(m, path("ok.obj")).isOk());
  std::string ascii, obj;
  {
    std::ifstream a(path("ok.stl")), o(path("ok.obj"));
    ascii.assign(std::istreambuf_iterator<char>(a), {});
    obj.assign(std::istreambuf_iterator<char>(o), {});
  }
  for (int k = 0; k < 100; ++k) {
    std::string bytes(std::uniform_int_distribution<int>(0, 400)(rng), '\0');
    for (char& c : bytes) c = static_cast<char>(rng());
    if (k % 3 == 0) bytes = "solid " + bytes;
    EXPECT_FALSE(readStl(write("rand.stl", bytes)).isOk());
    EXPECT_FALSE(readObj(write("rand.obj", bytes)).isOk() && k % 3 == 0);
    // Cut valid files anywhere: each prefix either reads or fails cleanly.
    const std::size_t cutA = std::uniform_int_distribution<std::size_t>(0, ascii.size() - 30)(rng);
    EXPECT_FALSE(readStl(write("cut.stl", ascii.substr(0, cutA))).isOk());
    const std::size_t cutO = std::uniform_int_distribution<std::size_t>(0, obj.size() - 1)(rng);
    (void)readObj(write("cut.obj", obj.substr(0, cutO)));
  }
}

// --- committed example meshes ---------------------------------------------------------------------------------------------

TEST(ExampleMeshes, CommittedFilesMatchTheirSpecs) {
  const std::string dir = std::string(PFLOW_SOURCE_DIR) + "/examples/meshes/";
  auto funnel = readStl(dir + "funnel.stl");
  ASSERT_TRUE(funnel.isOk()) << funnel.status().message() << " (regenerate with make_example_meshes examples/meshes)";
  auto expected = tessellate(examples::funnelSpec());
  ASSERT_TRUE(expected.isOk());
  expectSameTriangles(*expected, *funnel, 1e-8);
  EXPECT_LT(fs::file_size(dir + "funnel.stl"), 100'000u);
  EXPECT_GT(signedVolume(*funnel), 0.0);  // an open skin, but its normals still point outward

  auto bin = readObj(dir + "bin.obj");
  ASSERT_TRUE(bin.isOk()) << bin.status().message();
  auto binExpected = tessellate(examples::binSpec(), examples::binTessellation());
  ASSERT_TRUE(binExpected.isOk());
  expectSameTriangles(*binExpected, *bin, 0.0);
  EXPECT_EQ(bin->surface, binExpected->surface);
  EXPECT_EQ(bin->surfaceNames, binExpected->surfaceNames);
}

}  // namespace
}  // namespace pflow::frontend
