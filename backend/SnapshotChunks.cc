// Snapshot chunk streams: cutting and assembling. See SnapshotChunks.h.
#include "backend/SnapshotChunks.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace pflow::backend {
namespace {

using compute::GeometrySnapshot;
using compute::ScalarType;

std::size_t dtypeBytes(DType t) {
  switch (t) {
    case DType::kF64: case DType::kI64: case DType::kU64: return 8;
    case DType::kF32: case DType::kI32: case DType::kU32: return 4;
    case DType::kString: return 0;
  }
  return 0;
}

std::string shapeText(const std::vector<std::uint64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + ")";
}

// Cuts `rows` rows of `rowBytes` each into pieces.
Status cutRows(const std::string& name, DType dtype, std::vector<std::uint64_t> shape, const std::string& unit,
               const std::byte* data, std::uint64_t rows, std::uint64_t rowBytes, const PieceSink& sink) {
  const std::uint64_t per = rowsPerPiece(rowBytes);
  std::uint64_t first = 0;
  do {
    const std::uint64_t count = std::min(per, rows - first);
    ArrayPiece p{name, dtype, shape, first, count, unit, {}};
    p.data.assign(reinterpret_cast<const char*>(data) + first * rowBytes, count * rowBytes);
    if (Status st = sink(std::move(p)); !st) return st;
    first += count;
  } while (first < rows);
  return Status::ok();
}

Status cutStrings(const std::string& name, const std::vector<std::string>& values, const PieceSink& sink) {
  std::uint64_t first = 0;
  const std::vector<std::uint64_t> shape = {values.size()};
  while (first < values.size()) {
    ArrayPiece p{name, DType::kString, shape, first, 0, "", {}};
    std::uint64_t i = first;
    while (i < values.size() && (i == first || p.data.size() + 4 + values[i].size() <= kMaxChunkBytes)) {
      const auto len = static_cast<std::uint32_t>(values[i].size());
      const char le[4] = {char(len & 0xff), char((len >> 8) & 0xff), char((len >> 16) & 0xff), char(len >> 24)};
      p.data.append(le, 4);
      p.data.append(values[i]);
      ++i;
    }
    p.rows = i - first;
    if (Status st = sink(std::move(p)); !st) return st;
    first = i;
  }
  return Status::ok();
}

// The fixed type and columns of each /geometry array.
struct GeometryField {
  const char* name;
  DType dtype;
  int columns;
};
constexpr GeometryField kGeometryFields[] = {
    {"vertices", DType::kF64, 3},         {"triangles", DType::kU32, 3},     {"triangle_mesh", DType::kI32, 1},
    {"triangle_surface", DType::kI32, 1}, {"triangle_material", DType::kI32, 1}, {"mesh_names", DType::kString, 1},
    {"plane_point", DType::kF64, 3},      {"plane_normal", DType::kF64, 3},  {"plane_material", DType::kI32, 1},
    {"plane_names", DType::kString, 1},   {"plane_surface", DType::kI32, 1}, {"surface_names", DType::kString, 1},
};

const GeometryField* geometryField(const std::string& name) {
  for (const auto& f : kGeometryFields)
    if (name == f.name) return &f;
  return nullptr;
}

template <class T>
void assignFrom(const std::string& bytes, std::vector<T>& out) {
  out.resize(bytes.size() / sizeof(T));
  if (!out.empty()) std::memcpy(out.data(), bytes.data(), out.size() * sizeof(T));
}

}  // namespace

const char* sectionName(Section s) {
  switch (s) {
    case Section::kParticles: return "particles";
    case Section::kGeometry: return "geometry";
    case Section::kGrid: return "grid";
    case Section::kProbes: return "probes";
  }
  return "?";
}

const char* dtypeName(DType t) {
  switch (t) {
    case DType::kF64: return "f64";
    case DType::kF32: return "f32";
    case DType::kI32: return "i32";
    case DType::kU32: return "u32";
    case DType::kI64: return "i64";
    case DType::kU64: return "u64";
    case DType::kString: return "string";
  }
  return "?";
}

std::optional<ScalarType> storedTypeOf(DType t) {
  switch (t) {
    case DType::kF64: return ScalarType::kF64;
    case DType::kF32: return ScalarType::kF32;
    case DType::kI32: return ScalarType::kI32;
    case DType::kU32: return ScalarType::kU32;
    case DType::kU64: return ScalarType::kU64;
    case DType::kI64: case DType::kString: return std::nullopt;
  }
  return std::nullopt;
}

std::optional<DType> dtypeOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return DType::kF64;
    case ScalarType::kF32: return DType::kF32;
    case ScalarType::kI32: return DType::kI32;
    case ScalarType::kU32: return DType::kU32;
    case ScalarType::kU64: return DType::kU64;
    case ScalarType::kI8: return std::nullopt;
  }
  return std::nullopt;
}

std::uint64_t rowsPerPiece(std::uint64_t rowBytes) {
  return rowBytes == 0 ? kMaxChunkBytes : std::max<std::uint64_t>(1, kMaxChunkBytes / rowBytes);
}

Status particlePieces(const compute::SnapshotArray& a, std::size_t n, const PieceSink& sink) {
  const auto dtype = dtypeOf(a.type);
  if (!dtype) return invalidArgument("array '" + a.name + "' is " + compute::scalarName(a.type) +
                                     ", which the snapshot protocol cannot carry");
  if (a.components < 1) return invalidArgument("array '" + a.name + "' has no components");
  const std::uint64_t rowBytes = std::uint64_t(a.components) * compute::scalarBytesOf(a.type);
  if (a.data.size() != n * rowBytes)
    return invalidArgument("array '" + a.name + "' has " + std::to_string(a.data.size()) + " bytes, expected " +
                           std::to_string(n * rowBytes));
  std::vector<std::uint64_t> shape = {n};
  if (a.components > 1) shape.push_back(std::uint64_t(a.components));
  return cutRows(a.name, *dtype, shape, a.unit, a.data.data(), n, rowBytes, sink);
}

Status geometryPieces(const GeometrySnapshot& g, const PieceSink& sink) {
  auto numeric = [&](const char* name, DType dtype, const void* data, std::size_t rows, int cols,
                     const char* unit) -> Status {
    if (rows == 0) return Status::ok();
    std::vector<std::uint64_t> shape = {rows};
    if (cols > 1) shape.push_back(std::uint64_t(cols));
    return cutRows(name, dtype, shape, unit, static_cast<const std::byte*>(data), rows,
                   std::uint64_t(cols) * dtypeBytes(dtype), sink);
  };
  auto strings = [&](const char* name, const std::vector<std::string>& v) -> Status {
    return v.empty() ? Status::ok() : cutStrings(name, v, sink);
  };
  if (Status st = numeric("vertices", DType::kF64, g.vertices.data(), g.vertices.size(), 3, "m"); !st) return st;
  if (Status st = numeric("triangles", DType::kU32, g.triangles.data(), g.triangles.size() / 3, 3, ""); !st) return st;
  if (Status st = numeric("triangle_mesh", DType::kI32, g.triangleMesh.data(), g.triangleMesh.size(), 1, ""); !st)
    return st;
  if (Status st = numeric("triangle_surface", DType::kI32, g.triangleSurface.data(), g.triangleSurface.size(), 1, "");
      !st)
    return st;
  if (Status st =
          numeric("triangle_material", DType::kI32, g.triangleMaterial.data(), g.triangleMaterial.size(), 1, "");
      !st)
    return st;
  if (Status st = strings("mesh_names", g.meshNames); !st) return st;
  if (Status st = numeric("plane_point", DType::kF64, g.planePoints.data(), g.planePoints.size(), 3, "m"); !st)
    return st;
  if (Status st = numeric("plane_normal", DType::kF64, g.planeNormals.data(), g.planeNormals.size(), 3, ""); !st)
    return st;
  if (Status st = numeric("plane_material", DType::kI32, g.planeMaterial.data(), g.planeMaterial.size(), 1, ""); !st)
    return st;
  if (Status st = strings("plane_names", g.planeNames); !st) return st;
  if (Status st = numeric("plane_surface", DType::kI32, g.planeSurface.data(), g.planeSurface.size(), 1, ""); !st)
    return st;
  return strings("surface_names", g.surfaceNames);
}

// --- GeometryAssembler ------------------------------------------------------------------------------------------

Status GeometryAssembler::add(const ArrayPiece& p) {
  const std::string what = "geometry array '" + p.name + "'";
  const GeometryField* field = geometryField(p.name);
  if (field == nullptr) return invalidArgument(what + ": not a geometry array name");
  if (p.dtype != field->dtype)
    return invalidArgument(what + ": dtype " + dtypeName(p.dtype) + ", expected " + dtypeName(field->dtype));
  const bool shapeOk = field->columns == 1 ? p.shape.size() == 1
                                           : p.shape.size() == 2 && p.shape[1] == std::uint64_t(field->columns);
  if (!shapeOk) return invalidArgument(what + ": shape " + shapeText(p.shape) + " is not (rows" +
                                       (field->columns == 1 ? "" : ", " + std::to_string(field->columns)) + ")");
  auto it = std::find_if(m_arrays.begin(), m_arrays.end(), [&](const Array& a) { return a.first.name == p.name; });
  if (it == m_arrays.end()) {
    Array a;
    a.first = ArrayPiece{p.name, p.dtype, p.shape, 0, 0, p.unit, {}};
    m_arrays.push_back(std::move(a));
    it = m_arrays.end() - 1;
  } else if (it->first.shape != p.shape) {
    return invalidArgument(what + ": shape " + shapeText(p.shape) + " differs from earlier pieces' " +
                           shapeText(it->first.shape));
  }
  if (p.firstRow != it->next)
    return invalidArgument(what + ": piece starts at row " + std::to_string(p.firstRow) + ", expected row " +
                           std::to_string(it->next));
  if (p.rows > p.shape[0] - p.firstRow)
    return invalidArgument(what + ": rows beyond its " + std::to_string(p.shape[0]) + " rows");
  m_bytes += p.data.size();
  if (m_bytes > kMaxGeometryBytes)
    return resourceExhausted("geometry exceeds " + std::to_string(kMaxGeometryBytes >> 20) + " MiB");
  if (p.dtype == DType::kString) {
    std::size_t pos = 0;
    for (std::uint64_t i = 0; i < p.rows; ++i) {
      if (p.data.size() - pos < 4) return invalidArgument(what + ": string data ends inside a length prefix");
      const auto* b = reinterpret_cast<const unsigned char*>(p.data.data() + pos);
      const std::uint32_t len = b[0] | (b[1] << 8) | (b[2] << 16) | (std::uint32_t(b[3]) << 24);
      pos += 4;
      if (p.data.size() - pos < len) return invalidArgument(what + ": string data ends inside a string");
      it->strings.emplace_back(p.data.data() + pos, len);
      pos += len;
    }
    if (pos != p.data.size()) return invalidArgument(what + ": string data has bytes after its " +
                                                     std::to_string(p.rows) + " strings");
  } else {
    const std::uint64_t expected = p.rows * std::uint64_t(field->columns) * dtypeBytes(p.dtype);
    if (p.data.size() != expected)
      return invalidArgument(what + ": piece of " + std::to_string(p.rows) + " rows has " +
                             std::to_string(p.data.size()) + " bytes, expected " + std::to_string(expected));
    it->bytes += p.data;
  }
  it->next += p.rows;
  return Status::ok();
}

Status GeometryAssembler::checkComplete() const {
  for (const auto& a : m_arrays)
    if (a.next != a.first.shape[0])
      return invalidArgument("geometry array '" + a.first.name + "' is incomplete: " + std::to_string(a.next) +
                             " of " + std::to_string(a.first.shape[0]) + " rows arrived");
  return Status::ok();
}

Result<GeometrySnapshot> GeometryAssembler::take() {
  if (Status st = checkComplete(); !st) return st;
  GeometrySnapshot g;
  for (auto& a : m_arrays) {
    const std::string& n = a.first.name;
    if (n == "vertices") assignFrom(a.bytes, g.vertices);
    else if (n == "triangles") assignFrom(a.bytes, g.triangles);
    else if (n == "triangle_mesh") assignFrom(a.bytes, g.triangleMesh);
    else if (n == "triangle_surface") assignFrom(a.bytes, g.triangleSurface);
    else if (n == "triangle_material") assignFrom(a.bytes, g.triangleMaterial);
    else if (n == "mesh_names") g.meshNames = std::move(a.strings);
    else if (n == "plane_point") assignFrom(a.bytes, g.planePoints);
    else if (n == "plane_normal") assignFrom(a.bytes, g.planeNormals);
    else if (n == "plane_material") assignFrom(a.bytes, g.planeMaterial);
    else if (n == "plane_names") g.planeNames = std::move(a.strings);
    else if (n == "plane_surface") assignFrom(a.bytes, g.planeSurface);
    else if (n == "surface_names") g.surfaceNames = std::move(a.strings);
  }
  m_arrays.clear();
  m_bytes = 0;
  return g;
}

// --- ChunkAssembler ---------------------------------------------------------------------------------------------

Result<std::unique_ptr<ChunkAssembler>> ChunkAssembler::create(const std::string& scratchPath, const Chunk& first) {
  auto staging = SnapshotStaging::create(scratchPath, first.step, first.time, first.particles);
  if (!staging) return staging.status();
  auto a = std::unique_ptr<ChunkAssembler>(new ChunkAssembler());
  a->m_staging = std::move(staging.value());
  a->m_jobId = first.jobId;
  a->m_step = first.step;
  a->m_time = first.time;
  a->m_n = first.particles;
  return a;
}

Status ChunkAssembler::add(const Chunk& c) {
  if (c.jobId != m_jobId)
    return invalidArgument("chunk for job '" + c.jobId + "' in a stream for job '" + m_jobId + "'");
  if (c.step != m_step)
    return invalidArgument("chunk for step " + std::to_string(c.step) + " in a stream for step " +
                           std::to_string(m_step));
  if (c.time != m_time && !(std::isnan(c.time) && std::isnan(m_time)))
    return invalidArgument("chunk with time " + std::to_string(c.time) + " s in a stream with time " +
                           std::to_string(m_time) + " s");
  if (c.particles != m_n)
    return invalidArgument("chunk for " + std::to_string(c.particles) + " particles in a stream for " +
                           std::to_string(m_n));
  const ArrayPiece& p = c.array;
  m_bytes += p.data.size();
  if (c.section == Section::kGeometry) return m_geometry.add(p);
  if (c.section == Section::kProbes) return invalidArgument("probe array '" + p.name + "': probes are sent with AppendProbes, not in a snapshot");
  const auto type = storedTypeOf(p.dtype);
  if (!type)
    return invalidArgument(std::string(sectionName(c.section)) + " array '" + p.name + "': dtype " +
                           dtypeName(p.dtype) + " cannot be stored (use f64, f32, i32, u32 or u64)");
  ArrayMeta meta{p.name, *type, p.shape, p.unit};
  if (c.section == Section::kGrid) {
    if (!c.grid) return invalidArgument("grid array '" + p.name + "': the chunk has no grid spec");
    return m_staging->writeGridRows(*c.grid, meta, p.firstRow, p.rows, p.data.data(), p.data.size());
  }
  return m_staging->writeParticleRows(meta, p.firstRow, p.rows, p.data.data(), p.data.size());
}

Status ChunkAssembler::checkComplete() const {
  if (m_staging->meta().arrays.empty()) return invalidArgument("the stream holds no particle arrays");
  if (Status st = m_staging->checkComplete(); !st) return st;
  return m_geometry.checkComplete();
}

Status snapshotChunks(const std::string& jobId, const compute::ParticleSnapshot& s,
                      const compute::GeometrySnapshot* geometryOrNull, const ChunkSink& sink) {
  auto send = [&](Section section) {
    return [&, section](ArrayPiece&& p) {
      return sink(Chunk{jobId, s.step, s.time, std::uint64_t(s.n), section, std::move(p), std::nullopt});
    };
  };
  for (const auto& a : s.arrays)
    if (Status st = particlePieces(a, s.n, send(Section::kParticles)); !st) return st;
  if (geometryOrNull != nullptr) return geometryPieces(*geometryOrNull, send(Section::kGeometry));
  return Status::ok();
}

std::string SnapshotFileSink::probesCsvPath() const { return probesCsvPathFor(m_output); }

// "time" then one array per probe, each in row order (FileCursor in SnapshotStore.cc sends them so).
Status SnapshotFileSink::addProbes(const Chunk& c) {
  const ArrayPiece& p = c.array;
  if (p.dtype != DType::kF64 || p.shape.size() != 1 || p.data.size() != p.rows * sizeof(double))
    return invalidArgument("probe array '" + p.name + "' must be f64 of shape (k) with whole rows");
  std::vector<double>* target = nullptr;
  if (p.name == "time") {
    target = &m_probes.time;
  } else {
    if (m_probes.names.empty() || m_probes.names.back() != p.name) {
      m_probes.names.push_back(p.name);
      m_probes.units.push_back(p.unit);
      m_probes.points.push_back(c.point.value_or(Vec3d{0, 0, 0}));
      m_probes.values.emplace_back();
    }
    target = &m_probes.values.back();
  }
  if (p.firstRow != target->size()) return invalidArgument("probe array '" + p.name + "': pieces out of order");
  const std::size_t at = target->size();
  target->resize(at + p.rows);
  std::memcpy(target->data() + at, p.data.data(), p.data.size());
  return Status::ok();
}

Status SnapshotFileSink::add(const Chunk& chunk) {
  if (chunk.section == Section::kProbes) return addProbes(chunk);
  if (!m_assembler) {
    auto a = ChunkAssembler::create(m_output + ".part", chunk);
    if (!a) return a.status();
    m_assembler = std::move(a.value());
  }
  return m_assembler->add(chunk);
}

Status SnapshotFileSink::finish() {
  if (!m_assembler) return invalidArgument(m_output + ": no snapshot data arrived");
  if (Status st = m_assembler->checkComplete(); !st) return st;
  auto writer = SnapshotWriter::create(m_output);
  if (!writer) return writer.status();
  if (!m_assembler->geometry().empty()) {
    auto g = m_assembler->geometry().take();
    if (!g) return g.status();
    if (Status st = writer.value()->writeGeometry(g.value()); !st) return st;
  }
  if (Status st = writer.value()->commit(m_assembler->staging(), nullptr); !st) return st;
  if (Status st = writer.value()->close(); !st) return st;
  m_assembler.reset();
  if (m_probes.names.empty()) return Status::ok();
  for (const auto& v : m_probes.values)
    if (v.size() != m_probes.time.size()) return invalidArgument(m_output + ": the probe series arrived incomplete");
  return writeProbeFiles(m_output, m_probes);
}

}  // namespace pflow::backend
