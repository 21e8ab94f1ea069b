// SnapshotReader (SnapshotFile.h): opening a snapshot file, whole steps, row ranges, grids, geometry, probes.
#include "backend/store/SnapshotFile.h"

#include <hdf5.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "backend/store/Hdf5Detail.h"

namespace pflow::backend {

namespace fs = std::filesystem;
using namespace detail;

// ================================================================================================================
// SnapshotReader

struct SnapshotReader::Impl {
  std::string path;
  Hid file;
  std::vector<std::int64_t> steps;
  bool geometry = false;

  Result<SnapshotArray> readArray(hid_t group, const std::string& name, std::size_t n, const std::string& where) const {
    const std::string what = "'" + where + "/" + name + "'";
    Hid dset = datasetHid(H5Dopen2(group, name.c_str(), H5P_DEFAULT));
    if (!dset.valid()) return h5Error(path, "cannot open dataset " + what);
    Hid dtype = typeHid(H5Dget_type(dset.get()));
    if (!dtype.valid()) return h5Error(path, "cannot read the type of " + what);
    const auto type = scalarTypeOf(dtype.get());
    if (!type) return invalidArgument(path + ": dataset " + what + " has an unsupported element type");
    auto dims = datasetDims(dset.get(), path, what);
    if (!dims) return dims.status();
    const auto& d = dims.value();
    if (d.empty() || d.size() > 2 || (d.size() == 2 && (d[1] < 1 || d[1] > 4096)))
      return invalidArgument(path + ": dataset " + what + " is not shaped (n) or (n, components)");
    if (d[0] != n)
      return invalidArgument(path + ": dataset " + what + " has " + std::to_string(d[0]) + " rows, expected n = " +
                             std::to_string(n));
    SnapshotArray array;
    array.name = name;
    array.type = *type;
    array.components = d.size() == 2 ? static_cast<int>(d[1]) : 1;
    array.data.resize(n * static_cast<std::size_t>(array.components) * compute::scalarBytesOf(*type));
    if (!array.data.empty() &&
        H5Dread(dset.get(), memTypeOf(*type), H5S_ALL, H5S_ALL, H5P_DEFAULT, array.data.data()) < 0)
      return h5Error(path, "cannot read dataset " + what);
    const htri_t hasUnit = H5Aexists(dset.get(), "unit");
    if (hasUnit < 0) return h5Error(path, "cannot look up the unit of " + what);
    if (hasUnit > 0) {
      auto unit = readStringAttr(dset.get(), "unit", path, where + "/" + name);
      if (!unit) return unit.status();
      array.unit = std::move(unit.value());
    }
    return array;
  }
};

SnapshotReader::SnapshotReader(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}

SnapshotReader::~SnapshotReader() {
  std::lock_guard lock(hdf5Mutex());
  m_impl.reset();
}

Result<std::unique_ptr<SnapshotReader>> SnapshotReader::open(const std::string& h5Path) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  std::error_code ec;
  if (!fs::exists(h5Path, ec))
    return Status(StatusCode::kNotFound, h5Path + ": snapshot file does not exist");
  if (!fs::is_regular_file(h5Path, ec)) return invalidArgument(h5Path + ": not a regular file");
  const htri_t isHdf5 = H5Fis_hdf5(h5Path.c_str());
  if (isHdf5 < 0) return h5Error(h5Path, "cannot read the file");
  if (isHdf5 == 0) return invalidArgument(h5Path + ": not an HDF5 file");

  auto impl = std::make_unique<Impl>();
  impl->path = h5Path;
  auto fapl = makeFileAccess(h5Path);
  if (!fapl) return fapl.status();
  impl->file = fileHid(H5Fopen(h5Path.c_str(), H5F_ACC_RDONLY, fapl->get()));
  if (!impl->file.valid()) return h5Error(h5Path, "cannot open the snapshot file");
  const hid_t root = impl->file.get();

  const htri_t hasFormat = H5Aexists(root, "format");
  if (hasFormat < 0) return h5Error(h5Path, "cannot read the root attributes");
  if (hasFormat == 0) return invalidArgument(h5Path + ": not a pflow snapshot file (no root attribute 'format')");
  auto format = readStringAttr(root, "format", h5Path, "/");
  if (!format) return format.status();
  if (format.value() != kSnapshotFormat)
    return invalidArgument(h5Path + ": not a pflow snapshot file (format is '" + format.value() + "')");
  auto version = readScalarAttr<std::int64_t>(root, "format_version", H5T_NATIVE_INT64, h5Path, "/");
  if (!version) return version.status();
  if (version.value() < 1 || version.value() > kSnapshotFormatVersion)
    return invalidArgument(h5Path + ": unsupported format_version " + std::to_string(version.value()) +
                           " (this build reads " + std::to_string(kSnapshotFormatVersion) + ")");

  const htri_t hasSnapshots = H5Lexists(root, "snapshots", H5P_DEFAULT);
  if (hasSnapshots < 0) return h5Error(h5Path, "cannot look up '/snapshots'");
  if (hasSnapshots > 0) {
    Hid group = groupHid(H5Gopen2(root, kSnapshotsGroup, H5P_DEFAULT));
    if (!group.valid()) return h5Error(h5Path, "cannot open '/snapshots'");
    auto names = linkNames(group.get(), h5Path, kSnapshotsGroup);
    if (!names) return names.status();
    for (const auto& name : names.value())
      if (auto step = parseStep(name)) impl->steps.push_back(*step);
    std::sort(impl->steps.begin(), impl->steps.end());
  }
  const htri_t hasGeometry = H5Lexists(root, "geometry", H5P_DEFAULT);
  if (hasGeometry < 0) return h5Error(h5Path, "cannot look up '/geometry'");
  impl->geometry = hasGeometry > 0;
  return std::unique_ptr<SnapshotReader>(new SnapshotReader(std::move(impl)));
}

std::vector<std::int64_t> SnapshotReader::steps() const { return m_impl->steps; }

bool SnapshotReader::hasGeometry() const { return m_impl->geometry; }

const std::string& SnapshotReader::path() const { return m_impl->path; }

Result<compute::ParticleSnapshot> SnapshotReader::read(std::int64_t step) const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  if (!std::binary_search(d.steps.begin(), d.steps.end(), step))
    return Status(StatusCode::kNotFound, d.path + ": no snapshot for step " + std::to_string(step));
  const std::string where = stepGroupPath(step);
  Hid group = groupHid(H5Gopen2(d.file.get(), where.c_str(), H5P_DEFAULT));
  if (!group.valid()) return h5Error(d.path, "cannot open '" + where + "'");

  ParticleSnapshot snapshot;
  auto time = readScalarAttr<double>(group.get(), "time", H5T_NATIVE_DOUBLE, d.path, where);
  if (!time) return time.status();
  auto storedStep = readScalarAttr<std::int64_t>(group.get(), "step", H5T_NATIVE_INT64, d.path, where);
  if (!storedStep) return storedStep.status();
  if (storedStep.value() != step)
    return invalidArgument(d.path + ": '" + where + "' has attribute step = " + std::to_string(storedStep.value()));
  auto n = readScalarAttr<std::uint64_t>(group.get(), "n", H5T_NATIVE_UINT64, d.path, where);
  if (!n) return n.status();
  snapshot.step = step;
  snapshot.time = time.value();
  snapshot.n = static_cast<std::size_t>(n.value());

  auto names = linkNames(group.get(), d.path, where);
  if (!names) return names.status();
  for (const auto& name : names.value()) {
    Hid object = objectHid(H5Oopen(group.get(), name.c_str(), H5P_DEFAULT));
    if (!object.valid()) return h5Error(d.path, "cannot open '" + where + "/" + name + "'");
    if (H5Iget_type(object.get()) != H5I_DATASET) continue;  // tolerate foreign subgroups
    object.reset();
    auto array = d.readArray(group.get(), name, snapshot.n, where);
    if (!array) return array.status();
    snapshot.arrays.push_back(std::move(array.value()));
  }
  return snapshot;
}

Result<compute::GeometrySnapshot> SnapshotReader::readGeometry() const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  if (!d.geometry) return Status(StatusCode::kNotFound, d.path + ": the file has no geometry");
  const std::string where = kGeometryGroup;
  Hid group = groupHid(H5Gopen2(d.file.get(), kGeometryGroup, H5P_DEFAULT));
  if (!group.valid()) return h5Error(d.path, "cannot open '" + where + "'");
  const hid_t g = group.get();
  GeometrySnapshot geo;
  const auto& p = d.path;
  if (Status st = readOptionalArray(g, "vertices", H5T_NATIVE_DOUBLE, 3, 3, geo.vertices, p, where); !st) return st;
  if (Status st = readOptionalArray(g, "triangles", H5T_NATIVE_UINT32, 3, 1, geo.triangles, p, where); !st) return st;
  if (Status st = readOptionalArray(g, "triangle_mesh", H5T_NATIVE_INT32, 1, 1, geo.triangleMesh, p, where); !st)
    return st;
  if (Status st = readOptionalArray(g, "triangle_surface", H5T_NATIVE_INT32, 1, 1, geo.triangleSurface, p, where);
      !st)
    return st;
  if (Status st = readOptionalArray(g, "triangle_material", H5T_NATIVE_INT32, 1, 1, geo.triangleMaterial, p, where);
      !st)
    return st;
  if (Status st = readOptionalStrings(g, "mesh_names", geo.meshNames, p, where); !st) return st;
  if (Status st = readOptionalArray(g, "plane_point", H5T_NATIVE_DOUBLE, 3, 3, geo.planePoints, p, where); !st)
    return st;
  if (Status st = readOptionalArray(g, "plane_normal", H5T_NATIVE_DOUBLE, 3, 3, geo.planeNormals, p, where); !st)
    return st;
  if (Status st = readOptionalArray(g, "plane_material", H5T_NATIVE_INT32, 1, 1, geo.planeMaterial, p, where); !st)
    return st;
  if (Status st = readOptionalStrings(g, "plane_names", geo.planeNames, p, where); !st) return st;
  if (Status st = readOptionalArray(g, "plane_surface", H5T_NATIVE_INT32, 1, 1, geo.planeSurface, p, where); !st)
    return st;
  if (Status st = readOptionalStrings(g, "surface_names", geo.surfaceNames, p, where); !st) return st;
  return geo;
}



// ================================================================================================================
// SnapshotReader: metadata and partial reads

Result<StepMeta> SnapshotReader::meta(std::int64_t step) const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  if (!std::binary_search(d.steps.begin(), d.steps.end(), step))
    return notFound(d.path + ": no snapshot for step " + std::to_string(step));
  return readStepMeta(d.file.get(), d.path, step);
}

namespace {
Status readRowsAt(hid_t file, const std::string& path, const std::string& groupPath, const std::string& name,
                  std::uint64_t first, std::uint64_t count, std::string& out) {
  const std::string what = "'" + groupPath + "/" + name + "'";
  if (!validArrayName(name)) return invalidArgument(path + ": '" + name + "' is not an array name");
  const htri_t exists = H5Lexists(file, (groupPath + "/" + name).c_str(), H5P_DEFAULT);
  if (exists <= 0) {
    hdf5Detail();
    return notFound(path + ": no array " + what);
  }
  Hid dset = datasetHid(H5Dopen2(file, (groupPath + "/" + name).c_str(), H5P_DEFAULT));
  if (!dset.valid()) return h5Error(path, "cannot open " + what);
  Hid dtype = typeHid(H5Dget_type(dset.get()));
  const auto type = dtype.valid() ? scalarTypeOf(dtype.get()) : std::nullopt;
  if (!type) return invalidArgument(path + ": " + what + " has an unsupported element type");
  auto dims = datasetDims(dset.get(), path, what);
  if (!dims) return dims.status();
  std::uint64_t rowBytes = compute::scalarBytesOf(*type);
  for (std::size_t i = 1; i < dims->size(); ++i) rowBytes *= (*dims)[i];
  if (dims->empty() || first > (*dims)[0] || count > (*dims)[0] - first)
    return invalidArgument(path + ": rows [" + std::to_string(first) + ", " + std::to_string(first + count) +
                           ") are beyond the " + std::to_string(dims->empty() ? 0 : (*dims)[0]) + " rows of " + what);
  out.resize(count * rowBytes);
  return readRowsOf(dset.get(), first, count, memTypeOf(*type), out.data(), path, what);
}
}  // namespace

Status SnapshotReader::readRows(std::int64_t step, const std::string& name, std::uint64_t first, std::uint64_t count,
                                std::string& out) const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  if (!std::binary_search(d.steps.begin(), d.steps.end(), step))
    return notFound(d.path + ": no snapshot for step " + std::to_string(step));
  if (name == kGridGroupName) return notFound(d.path + ": 'grid' is not a particle array");
  return readRowsAt(d.file.get(), d.path, stepGroupPath(step), name, first, count, out);
}

Status SnapshotReader::readGridRows(std::int64_t step, const std::string& name, std::uint64_t first,
                                    std::uint64_t count, std::string& out) const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  const Impl& d = *m_impl;
  if (!std::binary_search(d.steps.begin(), d.steps.end(), step))
    return notFound(d.path + ": no snapshot for step " + std::to_string(step));
  return readRowsAt(d.file.get(), d.path, stepGroupPath(step) + "/" + kGridGroupName, name, first, count, out);
}

Result<GridFields> SnapshotReader::readGrid(std::int64_t step) const {
  auto m = meta(step);
  if (!m) return m.status();
  if (!m->grid) return notFound(m_impl->path + ": snapshot step " + std::to_string(step) + " has no grid");
  GridFields g;
  g.spec = m->grid->spec;
  if (Status st = validateGridSpec(g.spec); !st) return Status(st.code(), m_impl->path + ": " + st.message());
  std::string bytes;
  auto load = [&](const char* name, std::vector<double>& out, std::size_t per) -> Status {
    const std::uint64_t rows = g.spec.cells[0];
    if (Status st = readGridRows(step, name, 0, rows, bytes); !st) return st;
    if (bytes.size() != g.spec.cellCount() * per * sizeof(double))
      return invalidArgument(m_impl->path + ": grid array '" + name + "' does not match its grid");
    out.resize(g.spec.cellCount() * per);
    std::memcpy(out.data(), bytes.data(), bytes.size());
    return Status::ok();
  };
  auto has = [&](const char* name) {
    return std::any_of(m->grid->arrays.begin(), m->grid->arrays.end(), [&](const ArrayMeta& a) { return a.name == name; });
  };
  g.fluid = has(kFluidFractionName);
  if (Status st = load(g.fluid ? kFluidFractionName : kSolidFractionName, g.solidFraction, 1); !st) return st;
  if (Status st = load(kMeanVelocityName, g.meanVelocity, 3); !st) return st;
  if (!g.fluid)
    if (Status st = load(kGranularTemperatureName, g.granularTemperature, 1); !st) return st;
  if (has(kMeanPressureName))
    if (Status st = load(kMeanPressureName, g.meanPressure, 1); !st) return st;
  return g;
}

Result<ProbeSeries> SnapshotReader::readProbes() const {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  return readProbeSeries(m_impl->file.get(), m_impl->path);
}


}  // namespace pflow::backend
