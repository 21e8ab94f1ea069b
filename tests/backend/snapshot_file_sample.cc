// Writes a small sample run (geometry, three snapshots with every scalar type, one of them empty) and prints the
// sidecar's path. Used by the h5py and ParaView checks in tests/backend/*.py.
//   --no-geometry  skip writeGeometry
//   --hold-open    keep the writer open after the last snapshot until a line (or EOF) arrives on stdin
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "backend/store/SnapshotFile.h"

namespace {

using pflow::compute::ScalarType;
using pflow::compute::SnapshotArray;

template <class T>
SnapshotArray makeArray(const std::string& name, ScalarType type, int components, const std::string& unit,
                        const std::vector<T>& values) {
  SnapshotArray a{name, type, components, unit, {}};
  a.data.resize(values.size() * sizeof(T));
  if (!values.empty()) std::memcpy(a.data.data(), values.data(), a.data.size());
  return a;
}

pflow::compute::ParticleSnapshot makeSnapshot(std::int64_t step, double time, std::size_t n) {
  pflow::compute::ParticleSnapshot s;
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
    id[i] = 1000 + i;
    for (int c = 0; c < 3; ++c) {
      position[3 * i + c] = 0.01 * static_cast<double>(i) + 0.1 * c + 1e-3 * static_cast<double>(step);
      velocity[3 * i + c] = static_cast<float>(c) - 0.5f * static_cast<float>(i);
      angular[3 * i + c] = 0.25 * static_cast<double>(c * static_cast<int>(i));
    }
    radius[i] = 0.001 + 1e-5 * static_cast<double>(i);
    material[i] = static_cast<std::int32_t>(i % 3) - 1;
    contacts[i] = static_cast<std::uint32_t>(i % 5);
    flags[i] = static_cast<std::int8_t>(static_cast<int>(i % 7) - 3);
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

pflow::compute::GeometrySnapshot makeGeometry() {
  pflow::compute::GeometrySnapshot g;
  g.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}};
  g.triangles = {0, 1, 2, 0, 2, 3, 0, 1, 4};
  g.triangleMesh = {0, 0, 1};
  g.triangleSurface = {1, 1, 2};
  g.triangleMaterial = {0, 0, 1};
  g.meshNames = {"floor", "wall"};
  g.planePoints = {{0, 0, -1}};
  g.planeNormals = {{0, 0, 1}};
  g.planeNames = {"ground"};
  g.planeMaterial = {2};
  return g;
}

}  // namespace

int main(int argc, char** argv) {
  std::string out;
  bool geometry = true, holdOpen = false;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--no-geometry") {
      geometry = false;
    } else if (arg == "--hold-open") {
      holdOpen = true;
    } else if (out.empty() && arg.rfind("--", 0) != 0) {
      out = arg;
    } else {
      out.clear();
      break;
    }
  }
  if (out.empty()) {
    std::fprintf(stderr, "usage: %s OUT.h5 [--no-geometry] [--hold-open]\n", argv[0]);
    return 2;
  }
  auto writer = pflow::backend::SnapshotWriter::create(out);
  if (!writer) {
    std::fprintf(stderr, "%s\n", writer.status().toString().c_str());
    return 1;
  }
  auto& w = *writer.value();
  std::vector<pflow::Status> results;
  if (geometry) results.push_back(w.writeGeometry(makeGeometry()));
  results.push_back(w.writeSnapshot(makeSnapshot(0, 0.0, 10)));
  results.push_back(w.writeSnapshot(makeSnapshot(100, 1e-3, 25)));
  results.push_back(w.writeSnapshot(makeSnapshot(200, 2e-3, 0)));
  for (const auto& st : results) {
    if (!st) {
      std::fprintf(stderr, "%s\n", st.toString().c_str());
      return 1;
    }
  }
  std::printf("%s\n", w.xdmfPath().c_str());
  std::fflush(stdout);
  if (holdOpen) {
    char line[16];
    (void)std::fgets(line, sizeof line, stdin);
  }
  if (pflow::Status st = w.close(); !st) {
    std::fprintf(stderr, "%s\n", st.toString().c_str());
    return 1;
  }
  return 0;
}
