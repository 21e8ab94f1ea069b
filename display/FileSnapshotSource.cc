#include "display/FileSnapshotSource.h"

#include <algorithm>
#include <cstring>

#include "backend/store/SnapshotFile.h"
#include "display/ArrayFrames.h"

namespace pflow::display {
namespace {

using nlohmann::json;
using compute::ScalarType;

float valueAt(const std::byte* p, ScalarType t) {
  auto get = [p]<class T>(T) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    return static_cast<float>(v);
  };
  switch (t) {
    case ScalarType::kF64: return get(double{});
    case ScalarType::kF32: return get(float{});
    case ScalarType::kI32: return get(std::int32_t{});
    case ScalarType::kU64: return get(std::uint64_t{});
    case ScalarType::kU32: return get(std::uint32_t{});
    case ScalarType::kI8: return get(std::int8_t{});
  }
  return 0;
}

// Cuts rows x components values (any scalar type) into pieces of at most 1 MiB of float32.
bool sendRows(const std::string& section, const std::string& name, const std::string& unit, const std::byte* data, ScalarType type,
              std::uint64_t rows, std::uint64_t components, const std::optional<GridInfo>& grid,
              const std::function<bool(const ArrayPiece&)>& onPiece) {
  ArrayPiece piece;
  piece.section = section, piece.name = name, piece.unit = unit, piece.totalRows = rows, piece.components = components;
  piece.grid = grid;
  const std::size_t bytes = compute::scalarBytesOf(type);
  const std::uint64_t step = rowsPerPiece(components);
  for (std::uint64_t first = 0; first < rows; first += step) {
    piece.firstRow = first;
    piece.rows = std::min(step, rows - first);
    piece.values.resize(piece.rows * components);
    for (std::size_t k = 0; k < piece.values.size(); ++k) piece.values[k] = valueAt(data + (first * components + k) * bytes, type);
    if (!onPiece(piece)) return false;
  }
  return true;
}

bool sendDoubles(const std::string& section, const std::string& name, const std::string& unit, const std::vector<double>& v,
                 std::uint64_t rows, const std::optional<GridInfo>& grid, const std::function<bool(const ArrayPiece&)>& onPiece) {
  if (v.empty() || rows == 0) return true;
  return sendRows(section, name, unit, reinterpret_cast<const std::byte*>(v.data()), ScalarType::kF64, rows, v.size() / rows, grid, onPiece);
}

bool sendStrings(const std::string& name, const std::vector<std::string>& v, const std::function<bool(const ArrayPiece&)>& onPiece) {
  if (v.empty()) return true;
  ArrayPiece piece;
  piece.section = "geometry", piece.name = name, piece.strings = v;
  return onPiece(piece);
}

class FileSnapshotSource final : public SnapshotSource {
 public:
  FileSnapshotSource(std::string path, double cellSize) : m_path(std::move(path)), m_cellSize(cellSize) {}

  Result<json> listSnapshots(const std::string&, const std::string&) override {
    auto reader = backend::SnapshotReader::open(m_path);
    if (!reader) return reader.status();
    json snaps = json::array();
    for (std::int64_t step : reader.value()->steps()) {
      auto meta = reader.value()->meta(step);
      if (!meta) return meta.status();
      snaps.push_back({{"step", step}, {"time", meta->time}, {"particles", meta->n}});
    }
    return json{{"file", m_path}, {"snapshots", snaps}};
  }

  Status readSnapshot(const std::string&, const SnapshotRequest& r, const std::function<void(std::int64_t, double)>& onHeader,
                      const std::function<bool(const ArrayPiece&)>& onPiece) override {
    auto reader = backend::SnapshotReader::open(m_path);
    if (!reader) return reader.status();
    const auto steps = reader.value()->steps();
    if (steps.empty()) return notFound(m_path + " has no snapshots");
    const std::int64_t step = r.step.value_or(steps.back());
    if (!std::binary_search(steps.begin(), steps.end(), step)) {
      std::string have;
      for (std::size_t i = 0; i < steps.size() && i < 20; ++i) have += (i ? ", " : "") + std::to_string(steps[i]);
      return notFound(m_path + " has no snapshot at step " + std::to_string(step) + " (it has " + have + (steps.size() > 20 ? ", ..." : "") + ")");
    }
    auto snap = reader.value()->read(step);
    if (!snap) return snap.status();
    for (const auto& f : r.fields)
      if (!snap->find(f)) {
        std::string have;
        for (const auto& a : snap->arrays) have += (have.empty() ? "" : ", ") + a.name;
        return invalidArgument(m_path + " step " + std::to_string(step) + " has no field '" + f + "' (it has: " + have + ")");
      }
    onHeader(step, snap->time);
    for (const auto& a : snap->arrays) {
      if (!r.particles) break;
      if (!r.fields.empty() && std::find(r.fields.begin(), r.fields.end(), a.name) == r.fields.end()) continue;
      if (!sendRows("particles", a.name, a.unit, a.data.data(), a.type, snap->n, std::uint64_t(a.components), std::nullopt, onPiece))
        return Status::ok();
    }
    if (r.grid && snap->n > 0) {
      auto grid = reader.value()->readGrid(step);
      if (!grid && grid.status().code() == StatusCode::kNotFound) grid = backend::computeGridFields(snap.value(), m_cellSize);
      if (!grid) return grid.status();
      const backend::GridFields& g = grid.value();
      GridInfo info;
      for (int k = 0; k < 3; ++k) info.cells[k] = g.spec.cells[k];
      info.origin[0] = g.spec.origin.x, info.origin[1] = g.spec.origin.y, info.origin[2] = g.spec.origin.z;
      info.cellSize = g.spec.cellSize;
      const std::uint64_t nx = g.spec.cells[0];
      if (!sendDoubles("grid", g.fluid ? "fluid_fraction" : "solid_fraction", "", g.solidFraction, nx, info, onPiece) ||
          !sendDoubles("grid", "mean_velocity", "m/s", g.meanVelocity, nx, info, onPiece) ||
          !sendDoubles("grid", "granular_temperature", "m^2/s^2", g.granularTemperature, nx, info, onPiece) ||
          !sendDoubles("grid", "mean_pressure", "Pa", g.meanPressure, nx, info, onPiece))
        return Status::ok();
    }
    if (r.geometry && reader.value()->hasGeometry()) {
      auto geo = reader.value()->readGeometry();
      if (!geo) return geo.status();
      const auto& g = geo.value();
      auto ints = [](const std::vector<std::int32_t>& v) { return std::vector<double>(v.begin(), v.end()); };
      auto vecs = [](const std::vector<Vec3d>& v) {
        std::vector<double> out;
        for (const auto& p : v) out.insert(out.end(), {p.x, p.y, p.z});
        return out;
      };
      const std::uint64_t tris = g.triangles.size() / 3;
      const bool ok = sendDoubles("geometry", "vertices", "m", vecs(g.vertices), g.vertices.size(), std::nullopt, onPiece) &&
                      sendDoubles("geometry", "triangles", "", std::vector<double>(g.triangles.begin(), g.triangles.end()), tris, std::nullopt, onPiece) &&
                      sendDoubles("geometry", "triangle_mesh", "", ints(g.triangleMesh), tris, std::nullopt, onPiece) &&
                      sendDoubles("geometry", "triangle_surface", "", ints(g.triangleSurface), tris, std::nullopt, onPiece) &&
                      sendDoubles("geometry", "triangle_material", "", ints(g.triangleMaterial), tris, std::nullopt, onPiece) &&
                      sendStrings("mesh_names", g.meshNames, onPiece) &&
                      sendDoubles("geometry", "plane_point", "m", vecs(g.planePoints), g.planePoints.size(), std::nullopt, onPiece) &&
                      sendDoubles("geometry", "plane_normal", "", vecs(g.planeNormals), g.planeNormals.size(), std::nullopt, onPiece) &&
                      sendDoubles("geometry", "plane_material", "", ints(g.planeMaterial), g.planeMaterial.size(), std::nullopt, onPiece) &&
                      sendStrings("plane_names", g.planeNames, onPiece) &&
                      sendDoubles("geometry", "plane_surface", "", ints(g.planeSurface), g.planeSurface.size(), std::nullopt, onPiece) &&
                      sendStrings("surface_names", g.surfaceNames, onPiece);
      if (!ok) return Status::ok();
    }
    if (r.probes) {
      auto series = reader.value()->readProbes();
      if (!series && series.status().code() != StatusCode::kNotFound) return series.status();
      if (series) {
        const auto& s = series.value();
        const std::uint64_t k = s.time.size();
        if (!sendDoubles("probes", "time", "s", s.time, k, std::nullopt, onPiece)) return Status::ok();
        for (std::size_t p = 0; p < s.names.size(); ++p)
          if (!sendDoubles("probes", s.names[p], s.units[p], s.values[p], k, std::nullopt, onPiece)) return Status::ok();
      }
    }
    return Status::ok();
  }

 private:
  std::string m_path;
  double m_cellSize;
};

}  // namespace

std::unique_ptr<SnapshotSource> makeFileSnapshotSource(const std::string& h5Path, double gridCellSize) {
  return std::make_unique<FileSnapshotSource>(h5Path, gridCellSize);
}

}  // namespace pflow::display
