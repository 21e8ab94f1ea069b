// HDF5 snapshot files and their XDMF sidecar. Layout: see SnapshotFile.h.
#include "backend/store/SnapshotFile.h"

#include "backend/store/Hdf5Detail.h"
#include "backend/store/SnapshotXdmf.h"

#include <hdf5.h>

#include <cstdio>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <mutex>
#include <numeric>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <utility>


namespace pflow::backend {

// HDF5 is built without thread safety: every entry point holds this lock (ProbeSeries.cc too).
std::recursive_mutex& hdf5Mutex() {
  static std::recursive_mutex mutex;
  return mutex;
}

namespace fs = std::filesystem;
using namespace detail;

std::string xdmfPathFor(const std::string& h5Path) { return fs::path(h5Path).replace_extension(".xmf").string(); }

// ================================================================================================================
// SnapshotWriter

struct SnapshotWriter::Impl {
  std::string path;
  std::string xdmfPath;
  std::string h5Name;  // how the sidecar refers to the .h5: its bare file name
  Hid file;
  std::map<std::int64_t, GridInfo> grids;
  std::optional<GeometryInfo> geometry;
  hsize_t indexSize = 0;  // length of /xdmf/polyvertex_index
  bool closed = false;

  Status checkOpen() const {
    if (closed) return {StatusCode::kFailedPrecondition, path + ": snapshot writer is closed"};
    return Status::ok();
  }

  Status flushFile() {
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0) return h5Error(path, "cannot flush");
    return Status::ok();
  }

  // Rewrites the whole sidecar through a temporary file and a rename, so readers never see half of it.
  Status writeXdmf() const {
    const std::string text = buildXdmf(h5Name, grids, geometry, indexSize);
    const std::string tmp = xdmfPath + ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      out << text;
      out.close();
      if (!out) return ioError(tmp + ": cannot write the XDMF sidecar");
    }
    std::error_code ec;
    fs::rename(tmp, xdmfPath, ec);
    if (ec) return ioError(xdmfPath + ": cannot replace the XDMF sidecar: " + ec.message());
    return Status::ok();
  }

  // Grows /xdmf/polyvertex_index (u32 0, 1, ...) to at least n entries.
  Status ensureIndex(std::size_t n) {
    if (n <= indexSize) return Status::ok();
    const std::string what = std::string("'") + kIndexDataset + "'";
    Hid dset;
    if (indexSize == 0) {
      auto group = createGroup(file.get(), kXdmfGroup, false, path);
      if (!group) return group.status();
      const hsize_t dims[1] = {0};
      const hsize_t maxDims[1] = {H5S_UNLIMITED};
      const hsize_t chunk[1] = {std::clamp<hsize_t>(n, kMinIndexChunk, kMaxIndexChunk)};
      Hid space = spaceHid(H5Screate_simple(1, dims, maxDims));
      Hid dcpl = plistHid(H5Pcreate(H5P_DATASET_CREATE));
      if (!space.valid() || !dcpl.valid() || H5Pset_chunk(dcpl.get(), 1, chunk) < 0 ||
          H5Pset_obj_track_times(dcpl.get(), false) < 0)
        return h5Error(path, "cannot prepare dataset " + what);
      dset = datasetHid(
          H5Dcreate2(file.get(), kIndexDataset, H5T_STD_U32LE, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
      if (!dset.valid()) return h5Error(path, "cannot create dataset " + what);
    } else {
      dset = datasetHid(H5Dopen2(file.get(), kIndexDataset, H5P_DEFAULT));
      if (!dset.valid()) return h5Error(path, "cannot open dataset " + what);
    }
    const hsize_t newSize[1] = {static_cast<hsize_t>(n)};
    if (H5Dset_extent(dset.get(), newSize) < 0) return h5Error(path, "cannot extend dataset " + what);
    const hsize_t start[1] = {indexSize};
    const hsize_t count[1] = {static_cast<hsize_t>(n) - indexSize};
    std::vector<std::uint32_t> values(static_cast<std::size_t>(count[0]));
    std::iota(values.begin(), values.end(), static_cast<std::uint32_t>(indexSize));
    Hid fileSpace = spaceHid(H5Dget_space(dset.get()));
    Hid memSpace = spaceHid(H5Screate_simple(1, count, nullptr));
    if (!fileSpace.valid() || !memSpace.valid() ||
        H5Sselect_hyperslab(fileSpace.get(), H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
        H5Dwrite(dset.get(), H5T_NATIVE_UINT32, memSpace.get(), fileSpace.get(), H5P_DEFAULT, values.data()) < 0)
      return h5Error(path, "cannot write dataset " + what);
    if (dset.reset() < 0) return h5Error(path, "cannot close dataset " + what);
    indexSize = n;
    return Status::ok();
  }

  Status writeSnapshotGroup(hid_t group, const ParticleSnapshot& s, const std::string& where) {
    if (Status st = writeScalarAttr(group, "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, s.time, path, where); !st)
      return st;
    if (Status st = writeScalarAttr(group, "step", H5T_STD_I64LE, H5T_NATIVE_INT64, s.step, path, where); !st)
      return st;
    if (Status st = writeScalarAttr(group, "n", H5T_STD_U64LE, H5T_NATIVE_UINT64, static_cast<std::uint64_t>(s.n),
                                    path, where);
        !st)
      return st;
    for (const auto& a : s.arrays) {
      if (Status st = writeDataset(group, a.name, fileTypeOf(a.type), memTypeOf(a.type), a.data.data(), s.n,
                                   a.components, a.unit, path, where);
          !st)
        return st;
    }
    return Status::ok();
  }

  Status writeGeometryGroup(hid_t group, const GeometrySnapshot& g) {
    const std::string where = kGeometryGroup;
    const std::size_t nTri = g.triangles.size() / 3;
    auto vec3 = [&](const char* name, const std::vector<Vec3d>& v, const char* unit) -> Status {
      if (v.empty()) return Status::ok();
      return writeDataset(group, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, v.data(), v.size(), 3, unit, path, where);
    };
    auto ints = [&](const char* name, const std::vector<std::int32_t>& v) -> Status {
      if (v.empty()) return Status::ok();
      return writeDataset(group, name, H5T_STD_I32LE, H5T_NATIVE_INT32, v.data(), v.size(), 1, "", path, where);
    };
    auto strings = [&](const char* name, const std::vector<std::string>& v) -> Status {
      if (v.empty()) return Status::ok();
      return writeStringDataset(group, name, v, path, where);
    };
    if (Status st = vec3("vertices", g.vertices, "m"); !st) return st;
    if (nTri > 0) {
      if (Status st = writeDataset(group, "triangles", H5T_STD_U32LE, H5T_NATIVE_UINT32, g.triangles.data(), nTri, 3,
                                   "", path, where);
          !st)
        return st;
    }
    if (Status st = ints("triangle_mesh", g.triangleMesh); !st) return st;
    if (Status st = ints("triangle_surface", g.triangleSurface); !st) return st;
    if (Status st = ints("triangle_material", g.triangleMaterial); !st) return st;
    if (Status st = strings("mesh_names", g.meshNames); !st) return st;
    if (Status st = vec3("plane_point", g.planePoints, "m"); !st) return st;
    if (Status st = vec3("plane_normal", g.planeNormals, ""); !st) return st;
    if (Status st = ints("plane_material", g.planeMaterial); !st) return st;
    if (Status st = strings("plane_names", g.planeNames); !st) return st;
    if (Status st = ints("plane_surface", g.planeSurface); !st) return st;
    if (Status st = strings("surface_names", g.surfaceNames); !st) return st;
    return Status::ok();
  }
};

SnapshotWriter::SnapshotWriter(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}

SnapshotWriter::~SnapshotWriter() {
  if (m_impl) (void)close();
}

Result<std::unique_ptr<SnapshotWriter>> SnapshotWriter::create(const std::string& h5Path) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  if (h5Path.empty()) return invalidArgument("snapshot file path is empty");
  auto impl = std::make_unique<Impl>();
  impl->path = h5Path;
  impl->xdmfPath = xdmfPathFor(h5Path);
  impl->h5Name = fs::path(h5Path).filename().string();
  if (impl->h5Name.empty()) return invalidArgument(h5Path + ": snapshot file path names no file");
  if (fs::path(h5Path).extension() == ".xmf")
    return invalidArgument(h5Path + ": the snapshot file must not use the sidecar's extension .xmf");

  auto fapl = makeFileAccess(h5Path);
  if (!fapl) return fapl.status();
  auto fcpl = makeFileCreate(h5Path);
  if (!fcpl) return fcpl.status();
  impl->file = fileHid(H5Fcreate(h5Path.c_str(), H5F_ACC_TRUNC, fcpl->get(), fapl->get()));
  if (!impl->file.valid()) return h5Error(h5Path, "cannot create the snapshot file");

  const hid_t root = impl->file.get();
  if (Status st = writeStringAttr(root, "format", kSnapshotFormat, h5Path, "/"); !st) return st;
  if (Status st = writeScalarAttr(root, "format_version", H5T_STD_I32LE, H5T_NATIVE_INT32,
                                  static_cast<std::int32_t>(kSnapshotFormatVersion), h5Path, "/");
      !st)
    return st;
  if (Status st = writeStringAttr(root, "units", "SI", h5Path, "/"); !st) return st;
  auto snapshots = createGroup(root, kSnapshotsGroup, false, h5Path);
  if (!snapshots) return snapshots.status();
  snapshots->reset();
  if (Status st = impl->flushFile(); !st) return st;
  if (Status st = impl->writeXdmf(); !st) return st;
  return std::unique_ptr<SnapshotWriter>(new SnapshotWriter(std::move(impl)));
}

Status SnapshotWriter::writeGeometry(const compute::GeometrySnapshot& geometry) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  if (d.geometry) return {StatusCode::kFailedPrecondition, d.path + ": geometry was already written"};
  if (Status st = validateGeometry(geometry); !st) return {st.code(), d.path + ": " + st.message()};

  auto group = createGroup(d.file.get(), kGeometryGroup, true, d.path);
  if (!group) return group.status();
  Status st = d.writeGeometryGroup(group->get(), geometry);
  group->reset();
  if (!st) {
    H5Ldelete(d.file.get(), kGeometryGroup, H5P_DEFAULT);  // best effort: leave no half-written group behind
    hdf5Detail();
    return st;
  }
  GeometryInfo info;
  info.vertices = geometry.vertices.size();
  info.triangles = geometry.triangles.size() / 3;
  info.mesh = !geometry.triangleMesh.empty();
  info.surface = !geometry.triangleSurface.empty();
  info.material = !geometry.triangleMaterial.empty();
  d.geometry = info;
  if (Status fl = d.flushFile(); !fl) return fl;
  return d.writeXdmf();
}

Status SnapshotWriter::writeSnapshot(const compute::ParticleSnapshot& snapshot) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  if (Status st = validateSnapshot(snapshot); !st) return {st.code(), d.path + ": " + st.message()};
  if (d.grids.count(snapshot.step) != 0)
    return invalidArgument(d.path + ": snapshot step " + std::to_string(snapshot.step) + " was already written");

  const std::string where = stepGroupPath(snapshot.step);
  auto group = createGroup(d.file.get(), where, true, d.path);
  if (!group) return group.status();
  Status st = d.writeSnapshotGroup(group->get(), snapshot, where);
  group->reset();
  if (st) st = d.ensureIndex(snapshot.n);
  if (!st) {
    H5Ldelete(d.file.get(), where.c_str(), H5P_DEFAULT);  // best effort: leave no half-written step behind
    hdf5Detail();
    return st;
  }
  GridInfo info{snapshot.step, snapshot.time, snapshot.n, {}};
  for (const auto& a : snapshot.arrays) info.arrays.push_back({a.name, a.type, a.components});
  d.grids.emplace(snapshot.step, std::move(info));
  if (Status fl = d.flushFile(); !fl) return fl;
  return d.writeXdmf();
}

Status SnapshotWriter::flush() {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  if (Status st = d.flushFile(); !st) return st;
  return d.writeXdmf();
}

Result<std::uint64_t> SnapshotWriter::appendProbes(const ProbeSeries& samples) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  auto stored = appendProbeSeries(d.file.get(), samples, d.path);
  if (!stored) return stored.status();
  if (Status st = d.flushFile(); !st) return st;
  return stored.value();
}

Status SnapshotWriter::close() {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (d.closed) return Status::ok();
  d.closed = true;
  if (d.file.reset() < 0) return h5Error(d.path, "cannot close the snapshot file");
  return Status::ok();
}

const std::string& SnapshotWriter::path() const { return m_impl->path; }
const std::string& SnapshotWriter::xdmfPath() const { return m_impl->xdmfPath; }

// ================================================================================================================
// Metadata

std::uint64_t ArrayMeta::rowElements() const {
  std::uint64_t e = 1;
  for (std::size_t i = 1; i < shape.size(); ++i) e *= shape[i];
  return e;
}

const ArrayMeta* StepMeta::find(const std::string& name) const {
  for (const auto& a : arrays)
    if (a.name == name) return &a;
  return nullptr;
}

// ================================================================================================================
// SnapshotStaging

struct SnapshotStaging::Impl {
  std::string path;
  Hid file;
  Hid particles;  // group "particles"
  Hid grid;       // group "grid", once a grid piece came
  StepMeta meta;
  struct Staged {
    std::uint64_t next = 0;  // rows written
    Hid dset;
  };
  std::map<std::string, Staged> particleArrays, gridArrays;
  std::uint64_t bytes = 0;

  ~Impl() {
    std::lock_guard lock(hdf5Mutex());
    particleArrays.clear();
    gridArrays.clear();
    particles.reset();
    grid.reset();
    file.reset();
    std::error_code ec;
    if (!path.empty()) fs::remove(path, ec);
  }

  Status write(bool isGrid, const ArrayMeta& a, std::uint64_t first, std::uint64_t rows, const void* data,
               std::size_t size) {
    const std::string what = std::string(isGrid ? "grid" : "particle") + " array '" + a.name + "'";
    if (!validArrayName(a.name)) return invalidArgument(what + ": not a valid array name");
    if (!isGrid && a.name == kGridGroupName) return invalidArgument(what + ": the name 'grid' is reserved");
    if (compute::scalarBytesOf(a.type) == 0) return invalidArgument(what + ": unknown scalar type");
    if (isGrid) {
      const auto& c = meta.grid->spec.cells;
      const bool ok = (a.shape.size() == 3 || (a.shape.size() == 4 && a.shape[3] == 3)) && a.shape[0] == c[0] &&
                      a.shape[1] == c[1] && a.shape[2] == c[2];
      if (!ok)
        return invalidArgument(what + ": shape " + shapeText(a.shape) + " does not match the grid's cells (" +
                               std::to_string(c[0]) + ", " + std::to_string(c[1]) + ", " + std::to_string(c[2]) +
                               ") or (..., 3)");
    } else {
      if (a.shape.empty() || a.shape.size() > 2 || a.shape[0] != meta.n ||
          (a.shape.size() == 2 && (a.shape[1] < 1 || a.shape[1] > 4096)))
        return invalidArgument(what + ": shape " + shapeText(a.shape) +
                               " is not (n) or (n, components <= 4096) with n = " + std::to_string(meta.n));
    }
    auto& arrays = isGrid ? gridArrays : particleArrays;
    auto& metas = isGrid ? meta.grid->arrays : meta.arrays;
    auto it = arrays.find(a.name);
    const ArrayMeta* known = nullptr;
    if (it != arrays.end()) {
      for (const auto& m : metas)
        if (m.name == a.name) known = &m;
      if (known->type != a.type || known->shape != a.shape || known->unit != a.unit)
        return invalidArgument(what + ": a piece declares " + compute::scalarName(a.type) + " " + shapeText(a.shape) +
                               " [" + a.unit + "] but earlier pieces declared " + compute::scalarName(known->type) +
                               " " + shapeText(known->shape) + " [" + known->unit + "]");
    }
    const std::uint64_t next = it != arrays.end() ? it->second.next : 0;
    if (first != next)
      return invalidArgument(what + ": piece starts at row " + std::to_string(first) + ", expected row " +
                             std::to_string(next) + " (pieces of an array must come in order, without gaps)");
    if (rows > a.shape[0] - first)
      return invalidArgument(what + ": rows [" + std::to_string(first) + ", " + std::to_string(first + rows) +
                             ") exceed its " + std::to_string(a.shape[0]) + " rows");
    const std::uint64_t expected = rows * a.rowBytes();
    if (size != expected)
      return invalidArgument(what + ": piece of " + std::to_string(rows) + " rows has " + std::to_string(size) +
                             " bytes, expected " + std::to_string(expected));
    if (it == arrays.end()) {
      if (isGrid && !grid.valid()) {
        auto g = createGroup(file.get(), kGridGroupName, true, path);
        if (!g) return g.status();
        grid = std::move(g.value());
        if (Status st = writeGridAttrs(grid.get(), meta.grid->spec, path, "/grid"); !st) return st;
      }
      auto dset = createNdDataset(isGrid ? grid.get() : particles.get(), a.name, fileTypeOf(a.type), a.shape, a.unit,
                                  path, isGrid ? "/grid" : "/particles");
      if (!dset) return dset.status();
      it = arrays.emplace(a.name, Staged{0, std::move(dset.value())}).first;
      metas.push_back(a);
    }
    if (Status st = writeRows(it->second.dset.get(), a.shape, first, rows, memTypeOf(a.type), data, path, what); !st)
      return st;
    it->second.next = first + rows;
    bytes += size;
    return Status::ok();
  }
};

SnapshotStaging::SnapshotStaging(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}
SnapshotStaging::~SnapshotStaging() = default;

Result<std::unique_ptr<SnapshotStaging>> SnapshotStaging::create(const std::string& scratchPath, std::int64_t step,
                                                                 double time, std::uint64_t n) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  if (!std::isfinite(time)) return invalidArgument("snapshot step " + std::to_string(step) + ": time is not finite");
  if (n > std::numeric_limits<std::uint32_t>::max())
    return invalidArgument("snapshot step " + std::to_string(step) + ": n = " + std::to_string(n) +
                           " exceeds the supported 4294967295 particles");
  auto impl = std::make_unique<Impl>();
  auto fapl = makeFileAccess(scratchPath);
  if (!fapl) return fapl.status();
  auto fcpl = makeFileCreate(scratchPath);
  if (!fcpl) return fcpl.status();
  impl->file = fileHid(H5Fcreate(scratchPath.c_str(), H5F_ACC_TRUNC, fcpl->get(), fapl->get()));
  if (!impl->file.valid()) {
    std::remove(scratchPath.c_str());  // a create that failed part-way (a full disk) may have left the file
    return h5Error(scratchPath, "cannot create the staging file");
  }
  impl->path = scratchPath;  // from here on the destructor removes it
  auto group = createGroup(impl->file.get(), "particles", true, scratchPath);
  if (!group) return group.status();
  impl->particles = std::move(group.value());
  impl->meta.step = step;
  impl->meta.time = time;
  impl->meta.n = n;
  return std::unique_ptr<SnapshotStaging>(new SnapshotStaging(std::move(impl)));
}

Status SnapshotStaging::writeParticleRows(const ArrayMeta& meta, std::uint64_t firstRow, std::uint64_t rows,
                                          const void* data, std::size_t bytes) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  return m_impl->write(false, meta, firstRow, rows, data, bytes);
}

Status SnapshotStaging::writeGridRows(const GridSpec& spec, const ArrayMeta& meta, std::uint64_t firstRow,
                                      std::uint64_t rows, const void* data, std::size_t bytes) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = validateGridSpec(spec); !st) return st;
  if (!d.meta.grid) {
    d.meta.grid = GridMeta{spec, {}};
  } else {
    const GridSpec& g = d.meta.grid->spec;
    if (g.cells != spec.cells || g.cellSize != spec.cellSize || g.origin.x != spec.origin.x ||
        g.origin.y != spec.origin.y || g.origin.z != spec.origin.z)
      return invalidArgument("grid array '" + meta.name + "': its grid differs from the grid of earlier pieces");
  }
  return d.write(true, meta, firstRow, rows, data, bytes);
}

Status SnapshotStaging::checkComplete() const {
  const Impl& d = *m_impl;
  auto check = [](const std::vector<ArrayMeta>& metas, const std::map<std::string, Impl::Staged>& arrays,
                  const char* kind) -> Status {
    for (const auto& m : metas) {
      const auto next = arrays.at(m.name).next;
      if (next != m.rows())
        return invalidArgument(std::string(kind) + " array '" + m.name + "' is incomplete: " + std::to_string(next) +
                               " of " + std::to_string(m.rows()) + " rows arrived");
    }
    return Status::ok();
  };
  if (Status st = check(d.meta.arrays, d.particleArrays, "particle"); !st) return st;
  if (d.meta.grid) return check(d.meta.grid->arrays, d.gridArrays, "grid");
  return Status::ok();
}

Status SnapshotStaging::readParticleRowsF64(const std::string& name, std::uint64_t firstRow, std::uint64_t rows,
                                            std::vector<double>& out) const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  auto it = d.particleArrays.find(name);
  if (it == d.particleArrays.end()) return notFound("no staged particle array '" + name + "'");
  const ArrayMeta* meta = d.meta.find(name);
  out.resize(rows * meta->rowElements());
  return readRowsOf(it->second.dset.get(), firstRow, rows, H5T_NATIVE_DOUBLE, out.data(), d.path,
                    "staged array '" + name + "'");
}

const StepMeta& SnapshotStaging::meta() const { return m_impl->meta; }
std::uint64_t SnapshotStaging::bytes() const { return m_impl->bytes; }

// ================================================================================================================
// SnapshotWriter: appending, grids, staged commits

Result<std::unique_ptr<SnapshotWriter>> SnapshotWriter::openOrCreate(const std::string& h5Path) {
  std::error_code ec;
  if (!fs::exists(h5Path, ec)) return create(h5Path);
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  if (fs::path(h5Path).extension() == ".xmf")
    return invalidArgument(h5Path + ": the snapshot file must not use the sidecar's extension .xmf");
  if (!fs::is_regular_file(h5Path, ec)) return invalidArgument(h5Path + ": not a regular file");
  const htri_t isHdf5 = H5Fis_hdf5(h5Path.c_str());
  if (isHdf5 <= 0) return invalidArgument(h5Path + ": not an HDF5 file");
  auto impl = std::make_unique<Impl>();
  impl->path = h5Path;
  impl->xdmfPath = xdmfPathFor(h5Path);
  impl->h5Name = fs::path(h5Path).filename().string();
  auto fapl = makeFileAccess(h5Path);
  if (!fapl) return fapl.status();
  impl->file = fileHid(H5Fopen(h5Path.c_str(), H5F_ACC_RDWR, fapl->get()));
  if (!impl->file.valid()) return h5Error(h5Path, "cannot open the snapshot file for writing");
  const hid_t root = impl->file.get();
  if (Status st = checkFormat(root, h5Path); !st) return st;

  const htri_t hasSnapshots = H5Lexists(root, "snapshots", H5P_DEFAULT);
  if (hasSnapshots < 0) return h5Error(h5Path, "cannot look up '/snapshots'");
  if (hasSnapshots == 0) {
    auto snapshots = createGroup(root, kSnapshotsGroup, false, h5Path);
    if (!snapshots) return snapshots.status();
  } else {
    Hid group = groupHid(H5Gopen2(root, kSnapshotsGroup, H5P_DEFAULT));
    if (!group.valid()) return h5Error(h5Path, "cannot open '/snapshots'");
    auto names = linkNames(group.get(), h5Path, kSnapshotsGroup);
    if (!names) return names.status();
    for (const auto& name : names.value()) {
      const auto step = parseStep(name);
      if (!step) continue;
      auto meta = readStepMeta(root, h5Path, *step);
      if (!meta) return meta.status();
      GridInfo info{*step, meta->time, static_cast<std::size_t>(meta->n), {}};
      for (const auto& a : meta->arrays)
        info.arrays.push_back({a.name, a.type, a.shape.size() == 2 ? static_cast<int>(a.shape[1]) : 1});
      impl->grids.emplace(*step, std::move(info));
    }
  }
  const htri_t hasGeometry = H5Lexists(root, "geometry", H5P_DEFAULT);
  if (hasGeometry < 0) return h5Error(h5Path, "cannot look up '/geometry'");
  if (hasGeometry > 0) {
    Hid group = groupHid(H5Gopen2(root, kGeometryGroup, H5P_DEFAULT));
    if (!group.valid()) return h5Error(h5Path, "cannot open '/geometry'");
    GeometryInfo info;
    auto rowsOf = [&](const char* name) -> std::size_t {
      if (H5Lexists(group.get(), name, H5P_DEFAULT) <= 0) return 0;
      auto meta = datasetMeta(group.get(), name, h5Path, kGeometryGroup);
      return meta ? static_cast<std::size_t>(meta->rows()) : 0;
    };
    info.vertices = rowsOf("vertices");
    info.triangles = rowsOf("triangles");
    info.mesh = rowsOf("triangle_mesh") > 0;
    info.surface = rowsOf("triangle_surface") > 0;
    info.material = rowsOf("triangle_material") > 0;
    impl->geometry = info;
  }
  if (H5Lexists(root, "xdmf", H5P_DEFAULT) > 0 && H5Lexists(root, kIndexDataset, H5P_DEFAULT) > 0) {
    Hid dset = datasetHid(H5Dopen2(root, kIndexDataset, H5P_DEFAULT));
    auto dims = datasetDims(dset.get(), h5Path, kIndexDataset);
    if (!dims) return dims.status();
    impl->indexSize = dims->empty() ? 0 : (*dims)[0];
  }
  hdf5Detail();
  if (Status st = impl->writeXdmf(); !st) return st;
  return std::unique_ptr<SnapshotWriter>(new SnapshotWriter(std::move(impl)));
}

bool SnapshotWriter::hasStep(std::int64_t step) const {
  std::lock_guard lock(hdf5Mutex());
  return m_impl->grids.count(step) != 0;
}

bool SnapshotWriter::hasGeometry() const {
  std::lock_guard lock(hdf5Mutex());
  return m_impl->geometry.has_value();
}

std::vector<std::int64_t> SnapshotWriter::steps() const {
  std::lock_guard lock(hdf5Mutex());
  std::vector<std::int64_t> out;
  for (const auto& [step, info] : m_impl->grids) out.push_back(step);
  return out;
}

Status SnapshotWriter::writeGrid(std::int64_t step, const GridFields& grid) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  if (d.grids.count(step) == 0) return notFound(d.path + ": no snapshot for step " + std::to_string(step));
  const std::string where = stepGroupPath(step);
  Hid group = groupHid(H5Gopen2(d.file.get(), where.c_str(), H5P_DEFAULT));
  if (!group.valid()) return h5Error(d.path, "cannot open '" + where + "'");
  const htri_t exists = H5Lexists(group.get(), kGridGroupName, H5P_DEFAULT);
  if (exists < 0) return h5Error(d.path, "cannot look up '" + where + "/grid'");
  if (exists > 0) return alreadyExists(d.path + ": snapshot step " + std::to_string(step) + " already has a grid");
  Status st = writeGridGroup(group.get(), grid, d.path, where);
  if (!st) {
    H5Ldelete(group.get(), kGridGroupName, H5P_DEFAULT);
    hdf5Detail();
    return st;
  }
  group.reset();
  return d.flushFile();
}

Status SnapshotWriter::commit(const SnapshotStaging& staged, const GridFields* grid) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  const SnapshotStaging::Impl& s = *staged.m_impl;
  const StepMeta& m = s.meta;
  const std::string stepText = "snapshot step " + std::to_string(m.step);
  if (Status st = d.checkOpen(); !st) return st;
  if (d.grids.count(m.step) != 0) return alreadyExists(d.path + ": " + stepText + " is already stored");
  if (Status st = staged.checkComplete(); !st) return {st.code(), stepText + ": " + st.message()};
  const ArrayMeta* position = m.find(kPositionName);
  if (position == nullptr) return invalidArgument(stepText + ": no 'position' array (the XDMF sidecar needs it)");
  if (position->shape.size() != 2 || position->shape[1] != 3 ||
      (position->type != ScalarType::kF64 && position->type != ScalarType::kF32))
    return invalidArgument(stepText + ": 'position' must have 3 components of f64 or f32");

  const std::string where = stepGroupPath(m.step);
  auto group = createGroup(d.file.get(), where, true, d.path);
  if (!group) return group.status();
  auto fill = [&]() -> Status {
    const hid_t g = group->get();
    if (Status st = writeScalarAttr(g, "time", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, m.time, d.path, where); !st)
      return st;
    if (Status st = writeScalarAttr(g, "step", H5T_STD_I64LE, H5T_NATIVE_INT64, m.step, d.path, where); !st) return st;
    if (Status st = writeScalarAttr(g, "n", H5T_STD_U64LE, H5T_NATIVE_UINT64, m.n, d.path, where); !st) return st;
    for (const auto& a : m.arrays)
      if (H5Ocopy(s.particles.get(), a.name.c_str(), g, a.name.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0)
        return h5Error(d.path, "cannot copy staged array '" + a.name + "' into '" + where + "'");
    if (grid != nullptr) return writeGridGroup(g, *grid, d.path, where);
    if (m.grid && s.grid.valid() &&
        H5Ocopy(s.file.get(), kGridGroupName, g, kGridGroupName, H5P_DEFAULT, H5P_DEFAULT) < 0)
      return h5Error(d.path, "cannot copy the staged grid into '" + where + "'");
    return Status::ok();
  };
  Status st = fill();
  group->reset();
  if (st) st = d.ensureIndex(static_cast<std::size_t>(m.n));
  if (!st) {
    H5Ldelete(d.file.get(), where.c_str(), H5P_DEFAULT);  // leave no half-written step behind
    hdf5Detail();
    return st;
  }
  GridInfo info{m.step, m.time, static_cast<std::size_t>(m.n), {}};
  for (const auto& a : m.arrays)
    info.arrays.push_back({a.name, a.type, a.shape.size() == 2 ? static_cast<int>(a.shape[1]) : 1});
  d.grids.emplace(m.step, std::move(info));
  if (Status fl = d.flushFile(); !fl) return fl;
  return d.writeXdmf();
}

}  // namespace pflow::backend
