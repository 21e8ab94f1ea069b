// SnapshotWriter / SnapshotReader: round trips, the XDMF sidecar and error handling.
#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "backend/store/SnapshotFile.h"

namespace pflow::backend {
namespace {

namespace fs = std::filesystem;
using compute::GeometrySnapshot;
using compute::ParticleSnapshot;
using compute::ScalarType;
using compute::SnapshotArray;

template <class T>
SnapshotArray makeArray(const std::string& name, ScalarType type, int components, const std::string& unit,
                        const std::vector<T>& values) {
  SnapshotArray a{name, type, components, unit, {}};
  a.data.resize(values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(a.data.data(), values.data(), a.data.size());
  return a;
}

template <class T>
std::vector<T> values(const SnapshotArray& a) {
  std::vector<T> out(a.data.size() / sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), a.data.data(), a.data.size());
  return out;
}

// A snapshot with every scalar type, 1 and 3 components; values depend on step so snapshots differ.
ParticleSnapshot makeSnapshot(std::int64_t step, double time, std::size_t n) {
  ParticleSnapshot s;
  s.step = step;
  s.time = time;
  s.n = n;
  std::vector<std::uint64_t> id(n);
  std::vector<double> position(3 * n), angular(3 * n), radius(n);
  std::vector<float> velocity(3 * n);
  std::vector<std::int32_t> material(n);
  std::vector<std::uint32_t> contacts(n);
  std::vector<std::int8_t> flags(n);
  for (std::size_t i = 0; i < n; ++i) {
    id[i] = (std::uint64_t(1) << 40) + i;  // beyond 32 bits
    for (int c = 0; c < 3; ++c) {
      position[3 * i + c] = 0.1 * static_cast<double>(i) + c + 1e-3 * static_cast<double>(step);
      velocity[3 * i + c] = -0.5f * static_cast<float>(i + c);
      angular[3 * i + c] = 1e6 * static_cast<double>(step) + c;
    }
    radius[i] = 1e-3 * static_cast<double>(i + 1);
    material[i] = -static_cast<std::int32_t>(i);
    contacts[i] = 4000000000u - static_cast<std::uint32_t>(i);
    flags[i] = static_cast<std::int8_t>(-100 + static_cast<int>(i));
  }
  s.arrays.push_back(makeArray("id", ScalarType::kU64, 1, "", id));
  s.arrays.push_back(makeArray("position", ScalarType::kF64, 3, "m", position));
  s.arrays.push_back(makeArray("velocity", ScalarType::kF32, 3, "m/s", velocity));
  s.arrays.push_back(makeArray("angular_velocity", ScalarType::kF64, 3, "rad/s", angular));
  s.arrays.push_back(makeArray("radius", ScalarType::kF64, 1, "m", radius));
  s.arrays.push_back(makeArray("material", ScalarType::kI32, 1, "", material));
  s.arrays.push_back(makeArray("contacts", ScalarType::kU32, 1, "", contacts));
  s.arrays.push_back(makeArray("flags", ScalarType::kI8, 1, "", flags));
  return s;
}

GeometrySnapshot makeGeometry() {
  GeometrySnapshot g;
  g.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 2}};
  g.triangles = {0, 1, 2, 0, 2, 3, 1, 2, 4};
  g.triangleMesh = {0, 0, 1};
  g.triangleSurface = {3, 3, 7};
  g.triangleMaterial = {1, 1, 2};
  g.meshNames = {"hopper", "lid \xc3\xa9"};  // UTF-8 survives
  g.planePoints = {{0, 0, -1}, {5, 0, 0}};
  g.planeNormals = {{0, 0, 1}, {-1, 0, 0}};
  g.planeNames = {"floor", "side"};
  g.planeSurface = {3, 4};
  g.surfaceNames = {"hopper/cone", "hopper/cylinder", "lid", "floor", "side"};
  g.planeMaterial = {0, 4};
  return g;
}

void expectSameSnapshot(const ParticleSnapshot& want, const ParticleSnapshot& got) {
  EXPECT_EQ(got.step, want.step);
  EXPECT_EQ(got.time, want.time);
  EXPECT_EQ(got.n, want.n);
  ASSERT_EQ(got.arrays.size(), want.arrays.size());
  for (std::size_t i = 0; i < want.arrays.size(); ++i) {
    const auto& w = want.arrays[i];
    const auto& g = got.arrays[i];
    SCOPED_TRACE(w.name);
    EXPECT_EQ(g.name, w.name);  // write order is kept
    EXPECT_EQ(g.type, w.type);
    EXPECT_EQ(g.components, w.components);
    EXPECT_EQ(g.unit, w.unit);
    EXPECT_TRUE(g.data == w.data);
  }
}

bool sameVec(const std::vector<Vec3d>& a, const std::vector<Vec3d>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].x != b[i].x || a[i].y != b[i].y || a[i].z != b[i].z) return false;
  return true;
}

std::string readText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::size_t countOf(const std::string& text, const std::string& needle) {
  std::size_t count = 0;
  for (std::size_t pos = text.find(needle); pos != std::string::npos; pos = text.find(needle, pos + needle.size()))
    ++count;
  return count;
}

// A small XML structure check: tags balance and nest, attribute quotes close. Counts elements by name.
struct XmlScan {
  bool ok = true;
  std::string error;
  std::map<std::string, int> elements;
};

XmlScan scanXml(const std::string& text) {
  XmlScan scan;
  std::vector<std::string> open;
  std::size_t i = 0;
  while ((i = text.find('<', i)) != std::string::npos) {
    if (text.compare(i, 2, "<?") == 0 || text.compare(i, 2, "<!") == 0) {
      i = text.find('>', i);
      if (i == std::string::npos) return {false, "unterminated declaration", {}};
      continue;
    }
    std::size_t j = i + 1;
    char quote = 0;
    for (; j < text.size(); ++j) {
      if (quote != 0) {
        if (text[j] == quote) quote = 0;
      } else if (text[j] == '"' || text[j] == '\'') {
        quote = text[j];
      } else if (text[j] == '>') {
        break;
      }
    }
    if (j >= text.size()) return {false, "unterminated tag at " + std::to_string(i), {}};
    std::string tag = text.substr(i + 1, j - i - 1);
    if (!tag.empty() && tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (open.empty() || open.back() != name) return {false, "unexpected </" + name + ">", {}};
      open.pop_back();
    } else {
      const bool selfClosing = !tag.empty() && tag.back() == '/';
      const std::string name = tag.substr(0, tag.find_first_of(" \t\n/"));
      ++scan.elements[name];
      if (!selfClosing) open.push_back(name);
    }
    i = j + 1;
  }
  if (!open.empty()) return {false, "unclosed <" + open.back() + ">", {}};
  return scan;
}

class SnapshotFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    m_dir = fs::temp_directory_path() /
            ("pflow_snapshot_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(m_dir);
    fs::create_directories(m_dir);
  }
  void TearDown() override {
    // Every HDF5 file, group, dataset and attribute this library opened must be closed again.
    EXPECT_EQ(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL), 0);
    std::error_code ec;
    fs::remove_all(m_dir, ec);
  }
  std::string path(const std::string& name) const { return (m_dir / name).string(); }

  fs::path m_dir;
};

TEST_F(SnapshotFileTest, RoundTripsTwoSnapshotsWithEveryScalarType) {
  const ParticleSnapshot a = makeSnapshot(0, 0.0, 7);
  const ParticleSnapshot b = makeSnapshot(12345, 0.0123456789012345, 11);
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer) << writer.status().toString();
    ASSERT_TRUE(writer.value()->writeSnapshot(b));  // out of order on purpose
    ASSERT_TRUE(writer.value()->writeSnapshot(a));
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader) << reader.status().toString();
  EXPECT_EQ(reader.value()->steps(), (std::vector<std::int64_t>{0, 12345}));
  EXPECT_FALSE(reader.value()->hasGeometry());
  auto gotA = reader.value()->read(0);
  ASSERT_TRUE(gotA) << gotA.status().toString();
  expectSameSnapshot(a, gotA.value());
  auto gotB = reader.value()->read(12345);
  ASSERT_TRUE(gotB) << gotB.status().toString();
  expectSameSnapshot(b, gotB.value());
  EXPECT_EQ(values<std::uint64_t>(*gotB->find("id"))[10], (std::uint64_t(1) << 40) + 10);
  EXPECT_EQ(values<std::int8_t>(*gotB->find("flags"))[0], -100);
}

TEST_F(SnapshotFileTest, RoundTripsNegativeStepsAndEmptySnapshots) {
  const ParticleSnapshot empty = makeSnapshot(-5, -1.5, 0);
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeSnapshot(empty));
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(3, 1.0, 2)));
    ASSERT_TRUE(writer.value()->close());
    EXPECT_TRUE(writer.value()->close());  // idempotent
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader.value()->steps(), (std::vector<std::int64_t>{-5, 3}));
  auto got = reader.value()->read(-5);
  ASSERT_TRUE(got) << got.status().toString();
  expectSameSnapshot(empty, got.value());
}

TEST_F(SnapshotFileTest, RoundTripsGeometry) {
  const GeometrySnapshot g = makeGeometry();
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeGeometry(g));
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(1, 0.1, 3)));
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  ASSERT_TRUE(reader.value()->hasGeometry());
  auto got = reader.value()->readGeometry();
  ASSERT_TRUE(got) << got.status().toString();
  EXPECT_TRUE(sameVec(got->vertices, g.vertices));
  EXPECT_EQ(got->triangles, g.triangles);
  EXPECT_EQ(got->triangleMesh, g.triangleMesh);
  EXPECT_EQ(got->triangleSurface, g.triangleSurface);
  EXPECT_EQ(got->triangleMaterial, g.triangleMaterial);
  EXPECT_EQ(got->meshNames, g.meshNames);
  EXPECT_TRUE(sameVec(got->planePoints, g.planePoints));
  EXPECT_TRUE(sameVec(got->planeNormals, g.planeNormals));
  EXPECT_EQ(got->planeNames, g.planeNames);
  EXPECT_EQ(got->planeSurface, g.planeSurface);
  EXPECT_EQ(got->surfaceNames, g.surfaceNames);
  EXPECT_EQ(got->planeMaterial, g.planeMaterial);
}

TEST_F(SnapshotFileTest, PartialGeometryKeepsTheGroup) {
  GeometrySnapshot planesOnly;
  planesOnly.planePoints = {{0, 0, 0}};
  planesOnly.planeNormals = {{0, 0, 1}};
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeGeometry(planesOnly));
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(0, 0, 1)));
    const std::string xmf = readText(writer.value()->xdmfPath());
    EXPECT_EQ(countOf(xmf, "Name=\"geometry\""), 0u);  // nothing drawable: no geometry grid
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  auto got = reader.value()->readGeometry();
  ASSERT_TRUE(got) << got.status().toString();
  EXPECT_TRUE(got->vertices.empty());
  EXPECT_TRUE(got->triangles.empty());
  EXPECT_TRUE(got->meshNames.empty());
  EXPECT_TRUE(got->planeMaterial.empty());
  EXPECT_TRUE(sameVec(got->planePoints, planesOnly.planePoints));
}

TEST_F(SnapshotFileTest, ReadGeometryIsNotFoundWithoutGeometry) {
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  EXPECT_TRUE(reader.value()->steps().empty());
  auto got = reader.value()->readGeometry();
  ASSERT_FALSE(got);
  EXPECT_EQ(got.status().code(), StatusCode::kNotFound);
}

TEST_F(SnapshotFileTest, WritesXdmfSidecarReferencingTheH5ByName) {
  auto writer = SnapshotWriter::create(path("my run.h5"));
  ASSERT_TRUE(writer);
  SnapshotWriter& w = *writer.value();
  EXPECT_EQ(w.xdmfPath(), path("my run.xmf"));
  ASSERT_TRUE(fs::exists(w.xdmfPath()));  // written at once, before any snapshot
  EXPECT_TRUE(scanXml(readText(w.xdmfPath())).ok);

  ASSERT_TRUE(w.writeSnapshot(makeSnapshot(0, 0.0, 4)));
  std::string xmf = readText(w.xdmfPath());
  XmlScan scan = scanXml(xmf);
  ASSERT_TRUE(scan.ok) << scan.error << "\n" << xmf;
  EXPECT_EQ(scan.elements["Xdmf"], 1);
  EXPECT_EQ(scan.elements["Time"], 1);
  EXPECT_EQ(scan.elements["Attribute"], 7);  // every array but position
  EXPECT_EQ(countOf(xmf, "CollectionType=\"Spatial\""), 0u);

  ASSERT_TRUE(w.writeGeometry(makeGeometry()));
  ASSERT_TRUE(w.writeSnapshot(makeSnapshot(50, 0.5, 9)));
  xmf = readText(w.xdmfPath());
  scan = scanXml(xmf);
  ASSERT_TRUE(scan.ok) << scan.error << "\n" << xmf;
  EXPECT_EQ(scan.elements["Time"], 2);
  EXPECT_EQ(countOf(xmf, "CollectionType=\"Temporal\""), 1u);
  EXPECT_EQ(countOf(xmf, "CollectionType=\"Spatial\""), 2u);
  EXPECT_EQ(countOf(xmf, "<Grid Name=\"particles\" GridType=\"Uniform\">"), 2u);
  EXPECT_EQ(countOf(xmf, "<Grid Name=\"geometry\" GridType=\"Uniform\">"), 2u);
  EXPECT_EQ(scan.elements["Attribute"], 2 * 7 + 2 * 3);  // particles + 3 triangle cell arrays per step
  EXPECT_EQ(countOf(xmf, "<Time Value=\"0.5\"/>"), 1u);
  EXPECT_EQ(countOf(xmf, "TopologyType=\"Polyvertex\" NumberOfElements=\"9\""), 1u);
  EXPECT_EQ(countOf(xmf, "TopologyType=\"Triangle\" NumberOfElements=\"3\""), 2u);
  // References are relative to the .xmf, with the exact precision of each array.
  EXPECT_EQ(countOf(xmf, ">my run.h5:/snapshots/50/position<"), 1u);
  auto item = [](const std::string& dims, const std::string& type, int precision, const std::string& ref) {
    return "<DataItem Dimensions=\"" + dims + "\" NumberType=\"" + type + "\" Precision=\"" +
           std::to_string(precision) + "\" Format=\"HDF\">my run.h5:" + ref + "</DataItem>";
  };
  EXPECT_EQ(countOf(xmf, item("9 3", "Float", 4, "/snapshots/50/velocity")), 1u);
  EXPECT_EQ(countOf(xmf, item("9", "UInt", 8, "/snapshots/50/id")), 1u);
  EXPECT_EQ(countOf(xmf, item("4", "Int", 4, "/snapshots/0/material")), 1u);
  EXPECT_EQ(countOf(xmf, "NumberType=\"Char\" Precision=\"1\" Format=\"HDF\">my run.h5:/snapshots/0/flags<"), 1u);
  EXPECT_EQ(countOf(xmf, "NumberType=\"UInt\" Precision=\"4\" Format=\"HDF\">my run.h5:/snapshots/0/contacts<"), 1u);
  EXPECT_EQ(countOf(xmf, "<Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">"), 2u);
  EXPECT_EQ(countOf(xmf, "<Attribute Name=\"radius\" AttributeType=\"Scalar\" Center=\"Node\">"), 2u);
  EXPECT_EQ(countOf(xmf, "my run.h5:/geometry/triangles<"), 2u);
  EXPECT_EQ(countOf(xmf, "Center=\"Cell\""), 6u);
  EXPECT_EQ(countOf(xmf, m_dir.string()), 0u);  // no absolute paths
  EXPECT_FALSE(fs::exists(w.xdmfPath() + ".tmp"));
}

TEST_F(SnapshotFileTest, RejectsDuplicateStep) {
  auto writer = SnapshotWriter::create(path("run.h5"));
  ASSERT_TRUE(writer);
  ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(10, 1.0, 3)));
  Status st = writer.value()->writeSnapshot(makeSnapshot(10, 2.0, 5));
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(st.message().find("step 10"), std::string::npos) << st.message();
  ASSERT_TRUE(writer.value()->close());
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  auto got = reader.value()->read(10);
  ASSERT_TRUE(got);
  EXPECT_EQ(got->n, 3u);  // the first write stands
}

TEST_F(SnapshotFileTest, RejectsWrongArraySizesAndWritesNothing) {
  auto writer = SnapshotWriter::create(path("run.h5"));
  ASSERT_TRUE(writer);
  ParticleSnapshot s = makeSnapshot(1, 0.0, 4);
  s.arrays[4].data.pop_back();  // radius one byte short
  Status st = writer.value()->writeSnapshot(s);
  EXPECT_EQ(st.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(st.message().find("'radius'"), std::string::npos) << st.message();
  EXPECT_NE(st.message().find("expected 32"), std::string::npos) << st.message();

  s = makeSnapshot(1, 0.0, 4);
  s.arrays[2].components = 2;  // velocity declared with the wrong component count
  EXPECT_EQ(writer.value()->writeSnapshot(s).code(), StatusCode::kInvalidArgument);

  s = makeSnapshot(1, 0.0, 4);
  s.arrays[3].name = "velocity";
  EXPECT_EQ(writer.value()->writeSnapshot(s).code(), StatusCode::kInvalidArgument);  // duplicate name

  s = makeSnapshot(1, 0.0, 4);
  s.arrays[3].name = "a/b";
  EXPECT_EQ(writer.value()->writeSnapshot(s).code(), StatusCode::kInvalidArgument);

  s = makeSnapshot(1, 0.0, 4);
  s.arrays.erase(s.arrays.begin() + 1);  // no position
  EXPECT_EQ(writer.value()->writeSnapshot(s).code(), StatusCode::kInvalidArgument);

  s = makeSnapshot(1, std::numeric_limits<double>::quiet_NaN(), 4);
  EXPECT_EQ(writer.value()->writeSnapshot(s).code(), StatusCode::kInvalidArgument);

  ASSERT_TRUE(writer.value()->close());
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  EXPECT_TRUE(reader.value()->steps().empty());
}

TEST_F(SnapshotFileTest, RejectsBadGeometryAndASecondGeometry) {
  auto writer = SnapshotWriter::create(path("run.h5"));
  ASSERT_TRUE(writer);
  GeometrySnapshot g = makeGeometry();
  g.triangles[4] = 5;  // only 5 vertices
  EXPECT_EQ(writer.value()->writeGeometry(g).code(), StatusCode::kInvalidArgument);
  g = makeGeometry();
  g.triangleSurface.pop_back();
  EXPECT_EQ(writer.value()->writeGeometry(g).code(), StatusCode::kInvalidArgument);
  g = makeGeometry();
  g.planeNormals.pop_back();
  EXPECT_EQ(writer.value()->writeGeometry(g).code(), StatusCode::kInvalidArgument);
  ASSERT_TRUE(writer.value()->writeGeometry(makeGeometry()));
  EXPECT_EQ(writer.value()->writeGeometry(makeGeometry()).code(), StatusCode::kFailedPrecondition);
}

TEST_F(SnapshotFileTest, WritesAfterCloseFail) {
  auto writer = SnapshotWriter::create(path("run.h5"));
  ASSERT_TRUE(writer);
  ASSERT_TRUE(writer.value()->close());
  EXPECT_EQ(writer.value()->writeSnapshot(makeSnapshot(0, 0, 1)).code(), StatusCode::kFailedPrecondition);
  EXPECT_EQ(writer.value()->flush().code(), StatusCode::kFailedPrecondition);
}

TEST_F(SnapshotFileTest, CreateTruncatesAnExistingFile) {
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(5, 0, 2)));
  }
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(6, 0, 2)));
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader.value()->steps(), (std::vector<std::int64_t>{6}));
}

TEST_F(SnapshotFileTest, ReaderSeesFlushedSnapshotsOfALiveWriter) {
  auto writer = SnapshotWriter::create(path("run.h5"));
  ASSERT_TRUE(writer);
  ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(0, 0, 2)));
  ASSERT_TRUE(writer.value()->flush());
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader) << reader.status().toString();
  EXPECT_EQ(reader.value()->steps(), (std::vector<std::int64_t>{0}));
  auto got = reader.value()->read(0);
  ASSERT_TRUE(got) << got.status().toString();
  EXPECT_EQ(got->n, 2u);
}

TEST_F(SnapshotFileTest, OpeningAMissingFileIsNotFound) {
  auto reader = SnapshotReader::open(path("nope.h5"));
  ASSERT_FALSE(reader);
  EXPECT_EQ(reader.status().code(), StatusCode::kNotFound);
  EXPECT_NE(reader.status().message().find("nope.h5"), std::string::npos);
  EXPECT_NE(reader.status().message().find("does not exist"), std::string::npos);
}

TEST_F(SnapshotFileTest, OpeningAForeignFileFails) {
  { std::ofstream(path("text.h5")) << "not hdf5\n"; }
  auto reader = SnapshotReader::open(path("text.h5"));
  ASSERT_FALSE(reader);
  EXPECT_EQ(reader.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(reader.status().message().find("not an HDF5 file"), std::string::npos) << reader.status().message();

  // A valid HDF5 file that is not ours.
  hid_t file = H5Fcreate(path("other.h5").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  H5Fclose(file);
  reader = SnapshotReader::open(path("other.h5"));
  ASSERT_FALSE(reader);
  EXPECT_EQ(reader.status().code(), StatusCode::kInvalidArgument);
  EXPECT_NE(reader.status().message().find("not a pflow snapshot file"), std::string::npos);
}

TEST_F(SnapshotFileTest, ReadingAnUnknownStepIsNotFound) {
  {
    auto writer = SnapshotWriter::create(path("run.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeSnapshot(makeSnapshot(1, 0, 1)));
  }
  auto reader = SnapshotReader::open(path("run.h5"));
  ASSERT_TRUE(reader);
  auto got = reader.value()->read(2);
  ASSERT_FALSE(got);
  EXPECT_EQ(got.status().code(), StatusCode::kNotFound);
}

TEST_F(SnapshotFileTest, CreatingInAMissingDirectoryIsAnIoErrorNamingThePath) {
  const std::string bad = path("no/such/dir/run.h5");
  auto writer = SnapshotWriter::create(bad);
  ASSERT_FALSE(writer);
  EXPECT_EQ(writer.status().code(), StatusCode::kIo);
  EXPECT_NE(writer.status().message().find(bad), std::string::npos) << writer.status().message();
}

TEST_F(SnapshotFileTest, WritesAMillionParticles) {
  const std::size_t n = 1000000;
  ParticleSnapshot s = makeSnapshot(7, 1.0, n);
  const auto start = std::chrono::steady_clock::now();
  {
    auto writer = SnapshotWriter::create(path("big.h5"));
    ASSERT_TRUE(writer);
    ASSERT_TRUE(writer.value()->writeSnapshot(s));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %zu particles (%.1f MB) in %.3f s\n", n, static_cast<double>(fs::file_size(path("big.h5"))) / 1e6,
              seconds);
  auto reader = SnapshotReader::open(path("big.h5"));
  ASSERT_TRUE(reader);
  auto got = reader.value()->read(7);
  ASSERT_TRUE(got);
  expectSameSnapshot(s, got.value());
}

}  // namespace
}  // namespace pflow::backend
