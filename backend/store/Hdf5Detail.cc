#include "backend/store/Hdf5Detail.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <numeric>
#include <set>
#include <sstream>

namespace pflow::backend::detail {

namespace fs = std::filesystem;

std::string hdf5Detail() {
  std::string detail;
  auto walk = [](unsigned n, const H5E_error2_t* err, void* data) -> herr_t {
    if (n == 0 && err != nullptr && err->desc != nullptr) *static_cast<std::string*>(data) = err->desc;
    return 0;
  };
  H5Ewalk2(H5E_DEFAULT, H5E_WALK_UPWARD, walk, &detail);
  H5Eclear2(H5E_DEFAULT);
  return detail;
}

Status h5Error(const std::string& file, const std::string& what) {
  const std::string detail = hdf5Detail();
  return ioError(file + ": " + what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
}

hid_t fileTypeOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return H5T_IEEE_F64LE;
    case ScalarType::kF32: return H5T_IEEE_F32LE;
    case ScalarType::kI32: return H5T_STD_I32LE;
    case ScalarType::kU64: return H5T_STD_U64LE;
    case ScalarType::kU32: return H5T_STD_U32LE;
    case ScalarType::kI8: return H5T_STD_I8LE;
  }
  return kInvalidHid;
}

hid_t memTypeOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return H5T_NATIVE_DOUBLE;
    case ScalarType::kF32: return H5T_NATIVE_FLOAT;
    case ScalarType::kI32: return H5T_NATIVE_INT32;
    case ScalarType::kU64: return H5T_NATIVE_UINT64;
    case ScalarType::kU32: return H5T_NATIVE_UINT32;
    case ScalarType::kI8: return H5T_NATIVE_INT8;
  }
  return kInvalidHid;
}

std::optional<ScalarType> scalarTypeOf(hid_t dtype) {
  const H5T_class_t cls = H5Tget_class(dtype);
  const std::size_t size = H5Tget_size(dtype);
  if (cls == H5T_FLOAT) {
    if (size == 8) return ScalarType::kF64;
    if (size == 4) return ScalarType::kF32;
  } else if (cls == H5T_INTEGER) {
    const bool isSigned = H5Tget_sign(dtype) == H5T_SGN_2;
    if (isSigned && size == 4) return ScalarType::kI32;
    if (isSigned && size == 1) return ScalarType::kI8;
    if (!isSigned && size == 8) return ScalarType::kU64;
    if (!isSigned && size == 4) return ScalarType::kU32;
  }
  return std::nullopt;
}

std::optional<std::int64_t> parseStep(std::string_view s) {
  std::int64_t v = 0;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || s.empty()) return std::nullopt;
  if (std::to_string(v) != s) return std::nullopt;  // "007" or "+7" are not ours
  return v;
}

Result<Hid> makeFileAccess(const std::string& file) {
  Hid fapl = plistHid(H5Pcreate(H5P_FILE_ACCESS));
  if (!fapl.valid()) return h5Error(file, "cannot create file access properties");
  if (H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V18, H5F_LIBVER_V18) < 0 ||
      H5Pset_fclose_degree(fapl.get(), H5F_CLOSE_STRONG) < 0)
    return h5Error(file, "cannot set file access properties");
#ifdef PFLOW_HDF5_HAS_FILE_LOCKING
  if (H5Pset_file_locking(fapl.get(), false, true) < 0) return h5Error(file, "cannot disable file locking");
#endif
  return fapl;
}

Result<Hid> makeFileCreate(const std::string& file) {
  Hid fcpl = plistHid(H5Pcreate(H5P_FILE_CREATE));
  if (!fcpl.valid() || H5Pset_obj_track_times(fcpl.get(), false) < 0) return h5Error(file, "cannot set file creation properties");
  return fcpl;
}

Result<Hid> makeGroupCreate(const std::string& file, bool trackOrder) {
  Hid gcpl = plistHid(H5Pcreate(H5P_GROUP_CREATE));
  if (!gcpl.valid()) return h5Error(file, "cannot create group properties");
  if (H5Pset_obj_track_times(gcpl.get(), false) < 0) return h5Error(file, "cannot set group properties");
  if (trackOrder && H5Pset_link_creation_order(gcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED) < 0)
    return h5Error(file, "cannot set group link order");
  return gcpl;
}

Result<Hid> createGroup(hid_t loc, const std::string& path, bool trackOrder, const std::string& file) {
  auto gcpl = makeGroupCreate(file, trackOrder);
  if (!gcpl) return gcpl.status();
  Hid group = groupHid(H5Gcreate2(loc, path.c_str(), H5P_DEFAULT, gcpl->get(), H5P_DEFAULT));
  if (!group.valid()) return h5Error(file, "cannot create group '" + path + "'");
  return group;
}

Result<Hid> utf8StringType(const std::string& file) {
  Hid type = typeHid(H5Tcopy(H5T_C_S1));
  if (!type.valid() || H5Tset_size(type.get(), H5T_VARIABLE) < 0 || H5Tset_cset(type.get(), H5T_CSET_UTF8) < 0)
    return h5Error(file, "cannot make a string type");
  return type;
}

Status writeStringAttr(hid_t obj, const char* name, const std::string& value, const std::string& file,
                       const std::string& where) {
  auto type = utf8StringType(file);
  if (!type) return type.status();
  Hid space = spaceHid(H5Screate(H5S_SCALAR));
  Hid attr = attributeHid(H5Acreate2(obj, name, type->get(), space.get(), H5P_DEFAULT, H5P_DEFAULT));
  const char* text = value.c_str();
  if (!attr.valid() || H5Awrite(attr.get(), type->get(), &text) < 0 || attr.reset() < 0)
    return h5Error(file, "cannot write attribute '" + std::string(name) + "' of '" + where + "'");
  return Status::ok();
}

Result<Hid> openScalarAttr(hid_t obj, const char* name, const std::string& file, const std::string& where) {
  const htri_t exists = H5Aexists(obj, name);
  if (exists < 0) return h5Error(file, "cannot look up attribute '" + std::string(name) + "' of '" + where + "'");
  if (exists == 0) return invalidArgument(file + ": '" + where + "' has no attribute '" + name + "'");
  Hid attr = attributeHid(H5Aopen(obj, name, H5P_DEFAULT));
  if (!attr.valid()) return h5Error(file, "cannot open attribute '" + std::string(name) + "' of '" + where + "'");
  Hid space = spaceHid(H5Aget_space(attr.get()));
  if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != 1)
    return invalidArgument(file + ": attribute '" + name + "' of '" + where + "' is not a single value");
  return attr;
}

Result<std::string> readStringAttr(hid_t obj, const char* name, const std::string& file, const std::string& where) {
  auto attr = openScalarAttr(obj, name, file, where);
  if (!attr) return attr.status();
  const std::string what = "attribute '" + std::string(name) + "' of '" + where + "'";
  Hid fileType = typeHid(H5Aget_type(attr->get()));
  if (!fileType.valid()) return h5Error(file, "cannot read the type of " + what);
  if (H5Tget_class(fileType.get()) != H5T_STRING) return invalidArgument(file + ": " + what + " is not a string");
  if (H5Tis_variable_str(fileType.get()) > 0) {
    Hid memType = typeHid(H5Tcopy(H5T_C_S1));
    if (!memType.valid() || H5Tset_size(memType.get(), H5T_VARIABLE) < 0 ||
        H5Tset_cset(memType.get(), H5Tget_cset(fileType.get())) < 0)
      return h5Error(file, "cannot make a string type for " + what);
    char* text = nullptr;
    if (H5Aread(attr->get(), memType.get(), &text) < 0) return h5Error(file, "cannot read " + what);
    std::string value = text != nullptr ? text : "";
    H5free_memory(text);
    return value;
  }
  const std::size_t size = H5Tget_size(fileType.get());
  std::string value(size, '\0');
  if (size > 0 && H5Aread(attr->get(), fileType.get(), value.data()) < 0) return h5Error(file, "cannot read " + what);
  value.resize(std::strlen(value.c_str()));  // fixed-length strings are NUL- or space-padded
  while (!value.empty() && value.back() == ' ') value.pop_back();
  return value;
}

Status writeDataset(hid_t loc, const std::string& name, hid_t fileType, hid_t memType, const void* data,
                    std::size_t rows, int cols, const std::string& unit, const std::string& file,
                    const std::string& where) {
  const std::string what = "'" + where + "/" + name + "'";
  std::vector<std::uint64_t> shape{rows};
  if (cols != 1) shape.push_back(std::uint64_t(cols));
  auto dset = createNdDataset(loc, name, fileType, shape, unit, file, where);
  if (!dset) return dset.status();
  if (rows > 0 && H5Dwrite(dset->get(), memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    return h5Error(file, "cannot write dataset " + what);
  if (dset->reset() < 0) return h5Error(file, "cannot close dataset " + what);
  return Status::ok();
}

Status writeStringDataset(hid_t loc, const std::string& name, const std::vector<std::string>& values,
                          const std::string& file, const std::string& where) {
  const std::string what = "'" + where + "/" + name + "'";
  auto type = utf8StringType(file);
  if (!type) return type.status();
  std::vector<const char*> pointers;
  pointers.reserve(values.size());
  for (const auto& v : values) pointers.push_back(v.c_str());
  const hsize_t dims[1] = {values.size()};
  Hid space = spaceHid(H5Screate_simple(1, dims, nullptr));
  Hid dcpl = plistHid(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !dcpl.valid() || H5Pset_obj_track_times(dcpl.get(), false) < 0)
    return h5Error(file, "cannot prepare dataset " + what);
  Hid dset = datasetHid(H5Dcreate2(loc, name.c_str(), type->get(), space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot create dataset " + what);
  if (!values.empty() && H5Dwrite(dset.get(), type->get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, pointers.data()) < 0)
    return h5Error(file, "cannot write dataset " + what);
  if (dset.reset() < 0) return h5Error(file, "cannot close dataset " + what);
  return Status::ok();
}

Result<std::vector<hsize_t>> datasetDims(hid_t dset, const std::string& file, const std::string& what) {
  Hid space = spaceHid(H5Dget_space(dset));
  if (!space.valid()) return h5Error(file, "cannot read the shape of " + what);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  if (rank < 0) return h5Error(file, "cannot read the shape of " + what);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0 && H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr) < 0)
    return h5Error(file, "cannot read the shape of " + what);
  return dims;
}

Result<hsize_t> checkShape(hid_t dset, int cols, const std::string& file, const std::string& what) {
  auto dims = datasetDims(dset, file, what);
  if (!dims) return dims.status();
  const auto& d = dims.value();
  const bool ok = (cols == 1 && d.size() == 1) || (d.size() == 2 && d[1] == static_cast<hsize_t>(cols));
  if (!ok) {
    std::string shape;
    for (auto v : d) shape += (shape.empty() ? "" : " x ") + std::to_string(v);
    return invalidArgument(file + ": " + what + " has shape (" + shape + "), expected (rows" +
                           (cols == 1 ? std::string() : " x " + std::to_string(cols)) + ")");
  }
  return d[0];
}

Status readOptionalStrings(hid_t group, const char* name, std::vector<std::string>& out, const std::string& file,
                           const std::string& where) {
  out.clear();
  const std::string what = "'" + where + "/" + name + "'";
  const htri_t exists = H5Lexists(group, name, H5P_DEFAULT);
  if (exists < 0) return h5Error(file, "cannot look up " + what);
  if (exists == 0) return Status::ok();
  Hid dset = datasetHid(H5Dopen2(group, name, H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot open dataset " + what);
  Hid fileType = typeHid(H5Dget_type(dset.get()));
  if (!fileType.valid() || H5Tget_class(fileType.get()) != H5T_STRING || H5Tis_variable_str(fileType.get()) <= 0)
    return invalidArgument(file + ": " + what + " is not a variable-length string dataset");
  auto rows = checkShape(dset.get(), 1, file, what);
  if (!rows) return rows.status();
  auto memType = utf8StringType(file);
  if (!memType) return memType.status();
  std::vector<char*> pointers(static_cast<std::size_t>(rows.value()), nullptr);
  if (!pointers.empty() && H5Dread(dset.get(), memType->get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, pointers.data()) < 0)
    return h5Error(file, "cannot read dataset " + what);
  out.reserve(pointers.size());
  for (char* p : pointers) {
    out.emplace_back(p != nullptr ? p : "");
    H5free_memory(p);
  }
  return Status::ok();
}

Result<std::vector<std::string>> linkNames(hid_t group, const std::string& file, const std::string& where) {
  H5_index_t index = H5_INDEX_NAME;
  {
    Hid gcpl = plistHid(H5Gget_create_plist(group));
    unsigned flags = 0;
    if (gcpl.valid() && H5Pget_link_creation_order(gcpl.get(), &flags) >= 0 &&
        (flags & H5P_CRT_ORDER_TRACKED) != 0 && (flags & H5P_CRT_ORDER_INDEXED) != 0)
      index = H5_INDEX_CRT_ORDER;
  }
  H5G_info_t info;
  if (H5Gget_info(group, &info) < 0) return h5Error(file, "cannot list '" + where + "'");
  std::vector<std::string> names;
  names.reserve(info.nlinks);
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    const ssize_t len = H5Lget_name_by_idx(group, ".", index, H5_ITER_INC, i, nullptr, 0, H5P_DEFAULT);
    if (len < 0) return h5Error(file, "cannot list '" + where + "'");
    std::string name(static_cast<std::size_t>(len) + 1, '\0');
    if (H5Lget_name_by_idx(group, ".", index, H5_ITER_INC, i, name.data(), name.size(), H5P_DEFAULT) < 0)
      return h5Error(file, "cannot list '" + where + "'");
    name.resize(static_cast<std::size_t>(len));
    names.push_back(std::move(name));
  }
  return names;
}

Status validateSnapshot(const ParticleSnapshot& s) {
  const std::string where = "snapshot step " + std::to_string(s.step) + ": ";
  if (!std::isfinite(s.time)) return invalidArgument(where + "time is not finite");
  if (s.n > std::numeric_limits<std::uint32_t>::max())
    return invalidArgument(where + "n = " + std::to_string(s.n) + " exceeds the supported 4294967295 particles");
  std::set<std::string> names;
  for (std::size_t i = 0; i < s.arrays.size(); ++i) {
    const SnapshotArray& a = s.arrays[i];
    if (a.name.empty()) return invalidArgument(where + "array #" + std::to_string(i) + " has no name");
    if (a.name.find('/') != std::string::npos || a.name == "." || a.name == "..")
      return invalidArgument(where + "array name '" + a.name + "' is not a valid dataset name");
    if (!names.insert(a.name).second) return invalidArgument(where + "array '" + a.name + "' appears twice");
    if (a.components < 1)
      return invalidArgument(where + "array '" + a.name + "' has " + std::to_string(a.components) + " components");
    const std::size_t bytes = compute::scalarBytesOf(a.type);
    if (bytes == 0) return invalidArgument(where + "array '" + a.name + "' has an unknown scalar type");
    const std::size_t expected = s.n * static_cast<std::size_t>(a.components) * bytes;
    if (a.data.size() != expected)
      return invalidArgument(where + "array '" + a.name + "' has " + std::to_string(a.data.size()) +
                             " bytes, expected " + std::to_string(expected) + " (n = " + std::to_string(s.n) +
                             ", components = " + std::to_string(a.components) + ", " +
                             compute::scalarName(a.type) + ")");
  }
  const SnapshotArray* position = s.find(kPositionName);
  if (position == nullptr) return invalidArgument(where + "no 'position' array (the XDMF sidecar needs it)");
  if (position->components != 3 || (position->type != ScalarType::kF64 && position->type != ScalarType::kF32))
    return invalidArgument(where + "'position' must have 3 components of f64 or f32");
  return Status::ok();
}

Status validateGeometry(const GeometrySnapshot& g) {
  const std::string where = "geometry: ";
  if (g.triangles.size() % 3 != 0)
    return invalidArgument(where + "triangles has " + std::to_string(g.triangles.size()) +
                           " indices, not a multiple of 3");
  const std::size_t nTri = g.triangles.size() / 3;
  for (std::size_t i = 0; i < g.triangles.size(); ++i)
    if (g.triangles[i] >= g.vertices.size())
      return invalidArgument(where + "triangle " + std::to_string(i / 3) + " refers to vertex " +
                             std::to_string(g.triangles[i]) + " of " + std::to_string(g.vertices.size()));
  auto perTriangle = [&](const char* name, std::size_t size) -> Status {
    if (size != 0 && size != nTri)
      return invalidArgument(where + name + " has " + std::to_string(size) + " entries for " + std::to_string(nTri) +
                             " triangles");
    return Status::ok();
  };
  if (Status st = perTriangle("triangle_mesh", g.triangleMesh.size()); !st) return st;
  if (Status st = perTriangle("triangle_surface", g.triangleSurface.size()); !st) return st;
  if (Status st = perTriangle("triangle_material", g.triangleMaterial.size()); !st) return st;
  const std::size_t nPlanes = g.planePoints.size();
  auto perPlane = [&](const char* name, std::size_t size, bool optional) -> Status {
    if ((optional && size == 0) || size == nPlanes) return Status::ok();
    return invalidArgument(where + name + " has " + std::to_string(size) + " entries for " + std::to_string(nPlanes) +
                           " planes");
  };
  if (Status st = perPlane("plane_normal", g.planeNormals.size(), false); !st) return st;
  if (Status st = perPlane("plane_material", g.planeMaterial.size(), true); !st) return st;
  if (Status st = perPlane("plane_names", g.planeNames.size(), true); !st) return st;
  if (Status st = perPlane("plane_surface", g.planeSurface.size(), true); !st) return st;
  return Status::ok();
}

std::string shapeText(const std::vector<std::uint64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + ")";
}

bool validArrayName(const std::string& name) {
  return !name.empty() && name.find('/') == std::string::npos && name != "." && name != "..";
}

Status writeVectorAttr(hid_t obj, const char* name, hid_t fileType, hid_t memType, const void* values,
                       std::size_t count, const std::string& file, const std::string& where) {
  const hsize_t dims[1] = {count};
  Hid space = spaceHid(H5Screate_simple(1, dims, nullptr));
  Hid attr = attributeHid(H5Acreate2(obj, name, fileType, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), memType, values) < 0 || attr.reset() < 0)
    return h5Error(file, "cannot write attribute '" + std::string(name) + "' of '" + where + "'");
  return Status::ok();
}

Status readVectorAttr(hid_t obj, const char* name, hid_t memType, void* values, std::size_t count,
                      const std::string& file, const std::string& where) {
  const std::string what = "attribute '" + std::string(name) + "' of '" + where + "'";
  const htri_t exists = H5Aexists(obj, name);
  if (exists < 0) return h5Error(file, "cannot look up " + what);
  if (exists == 0) return invalidArgument(file + ": '" + where + "' has no attribute '" + name + "'");
  Hid attr = attributeHid(H5Aopen(obj, name, H5P_DEFAULT));
  if (!attr.valid()) return h5Error(file, "cannot open " + what);
  Hid space = spaceHid(H5Aget_space(attr.get()));
  if (!space.valid() || H5Sget_simple_extent_npoints(space.get()) != static_cast<hssize_t>(count))
    return invalidArgument(file + ": " + what + " does not hold " + std::to_string(count) + " values");
  if (H5Aread(attr.get(), memType, values) < 0) return h5Error(file, "cannot read " + what);
  return Status::ok();
}

Result<Hid> createNdDataset(hid_t loc, const std::string& name, hid_t fileType, const std::vector<std::uint64_t>& shape,
                            const std::string& unit, const std::string& file, const std::string& where) {
  const std::string what = "'" + where + "/" + name + "'";
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  Hid space = spaceHid(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr));
  Hid dcpl = plistHid(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !dcpl.valid() || H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER) < 0 ||
      H5Pset_obj_track_times(dcpl.get(), false) < 0)
    return h5Error(file, "cannot prepare dataset " + what);
  Hid dset = datasetHid(H5Dcreate2(loc, name.c_str(), fileType, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot create dataset " + what);
  if (Status st = writeStringAttr(dset.get(), "unit", unit, file, where + "/" + name); !st) return st;
  return dset;
}

Status selectRows(hid_t fileSpace, const std::vector<hsize_t>& dims, std::uint64_t first, std::uint64_t count,
                  Hid& memSpace) {
  std::vector<hsize_t> start(dims.size(), 0), cnt(dims);
  start[0] = first;
  cnt[0] = count;
  if (H5Sselect_hyperslab(fileSpace, H5S_SELECT_SET, start.data(), nullptr, cnt.data(), nullptr) < 0)
    return internalError("cannot select rows");
  memSpace = spaceHid(H5Screate_simple(static_cast<int>(cnt.size()), cnt.data(), nullptr));
  if (!memSpace.valid()) return internalError("cannot make a memory space");
  return Status::ok();
}

Status writeRows(hid_t dset, const std::vector<std::uint64_t>& shape, std::uint64_t first, std::uint64_t count,
                 hid_t memType, const void* data, const std::string& file, const std::string& what) {
  if (count == 0) return Status::ok();
  std::vector<hsize_t> dims(shape.begin(), shape.end());
  Hid fileSpace = spaceHid(H5Dget_space(dset));
  Hid memSpace;
  if (!fileSpace.valid() || !selectRows(fileSpace.get(), dims, first, count, memSpace) ||
      H5Dwrite(dset, memType, memSpace.get(), fileSpace.get(), H5P_DEFAULT, data) < 0)
    return h5Error(file, "cannot write rows of " + what);
  return Status::ok();
}

Status readRowsOf(hid_t dset, std::uint64_t first, std::uint64_t count, hid_t memType, void* out,
                  const std::string& file, const std::string& what) {
  auto dims = datasetDims(dset, file, what);
  if (!dims) return dims.status();
  if (dims->empty()) return invalidArgument(file + ": " + what + " is a scalar");
  if (first > (*dims)[0] || count > (*dims)[0] - first)
    return invalidArgument(file + ": rows [" + std::to_string(first) + ", " + std::to_string(first + count) +
                           ") are beyond the " + std::to_string((*dims)[0]) + " rows of " + what);
  if (count == 0) return Status::ok();
  Hid fileSpace = spaceHid(H5Dget_space(dset));
  Hid memSpace;
  if (!fileSpace.valid() || !selectRows(fileSpace.get(), dims.value(), first, count, memSpace) ||
      H5Dread(dset, memType, memSpace.get(), fileSpace.get(), H5P_DEFAULT, out) < 0)
    return h5Error(file, "cannot read rows of " + what);
  return Status::ok();
}

Result<ArrayMeta> datasetMeta(hid_t group, const std::string& name, const std::string& file, const std::string& where) {
  const std::string what = "'" + where + "/" + name + "'";
  Hid dset = datasetHid(H5Dopen2(group, name.c_str(), H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot open dataset " + what);
  Hid dtype = typeHid(H5Dget_type(dset.get()));
  if (!dtype.valid()) return h5Error(file, "cannot read the type of " + what);
  const auto type = scalarTypeOf(dtype.get());
  if (!type) return invalidArgument(file + ": dataset " + what + " has an unsupported element type");
  auto dims = datasetDims(dset.get(), file, what);
  if (!dims) return dims.status();
  ArrayMeta meta;
  meta.name = name;
  meta.type = *type;
  meta.shape.assign(dims->begin(), dims->end());
  const htri_t hasUnit = H5Aexists(dset.get(), "unit");
  if (hasUnit < 0) return h5Error(file, "cannot look up the unit of " + what);
  if (hasUnit > 0) {
    auto unit = readStringAttr(dset.get(), "unit", file, where + "/" + name);
    if (!unit) return unit.status();
    meta.unit = std::move(unit.value());
  }
  return meta;
}

Status writeGridAttrs(hid_t group, const GridSpec& spec, const std::string& file, const std::string& where) {
  const double origin[3] = {spec.origin.x, spec.origin.y, spec.origin.z};
  if (Status st = writeVectorAttr(group, "origin", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, origin, 3, file, where); !st)
    return st;
  if (Status st = writeScalarAttr(group, "cell_size", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, spec.cellSize, file, where);
      !st)
    return st;
  return writeVectorAttr(group, "cells", H5T_STD_U32LE, H5T_NATIVE_UINT32, spec.cells.data(), 3, file, where);
}

Result<GridMeta> readGridMeta(hid_t stepGroup, const std::string& file, const std::string& stepWhere) {
  const std::string where = stepWhere + "/" + kGridGroupName;
  Hid group = groupHid(H5Gopen2(stepGroup, kGridGroupName, H5P_DEFAULT));
  if (!group.valid()) return h5Error(file, "cannot open '" + where + "'");
  GridMeta meta;
  double origin[3];
  if (Status st = readVectorAttr(group.get(), "origin", H5T_NATIVE_DOUBLE, origin, 3, file, where); !st) return st;
  meta.spec.origin = {origin[0], origin[1], origin[2]};
  auto h = readScalarAttr<double>(group.get(), "cell_size", H5T_NATIVE_DOUBLE, file, where);
  if (!h) return h.status();
  meta.spec.cellSize = h.value();
  if (Status st = readVectorAttr(group.get(), "cells", H5T_NATIVE_UINT32, meta.spec.cells.data(), 3, file, where); !st)
    return st;
  auto names = linkNames(group.get(), file, where);
  if (!names) return names.status();
  for (const auto& name : names.value()) {
    auto array = datasetMeta(group.get(), name, file, where);
    if (!array) return array.status();
    meta.arrays.push_back(std::move(array.value()));
  }
  return meta;
}

Result<StepMeta> readStepMeta(hid_t file, const std::string& path, std::int64_t step) {
  const std::string where = stepGroupPath(step);
  Hid group = groupHid(H5Gopen2(file, where.c_str(), H5P_DEFAULT));
  if (!group.valid()) return h5Error(path, "cannot open '" + where + "'");
  StepMeta meta;
  meta.step = step;
  auto time = readScalarAttr<double>(group.get(), "time", H5T_NATIVE_DOUBLE, path, where);
  if (!time) return time.status();
  meta.time = time.value();
  auto n = readScalarAttr<std::uint64_t>(group.get(), "n", H5T_NATIVE_UINT64, path, where);
  if (!n) return n.status();
  meta.n = n.value();
  auto names = linkNames(group.get(), path, where);
  if (!names) return names.status();
  for (const auto& name : names.value()) {
    Hid object = objectHid(H5Oopen(group.get(), name.c_str(), H5P_DEFAULT));
    if (!object.valid()) return h5Error(path, "cannot open '" + where + "/" + name + "'");
    const H5I_type_t kind = H5Iget_type(object.get());
    object.reset();
    if (kind == H5I_GROUP && name == kGridGroupName) {
      auto grid = readGridMeta(group.get(), path, where);
      if (!grid) return grid.status();
      meta.grid = std::move(grid.value());
      continue;
    }
    if (kind != H5I_DATASET) continue;
    auto array = datasetMeta(group.get(), name, path, where);
    if (!array) return array.status();
    const auto& s = array->shape;
    if (s.empty() || s.size() > 2 || s[0] != meta.n)
      return invalidArgument(path + ": dataset '" + where + "/" + name + "' has shape " + shapeText(s) +
                             ", expected (n) or (n, components) with n = " + std::to_string(meta.n));
    meta.arrays.push_back(std::move(array.value()));
  }
  return meta;
}

Status writeGridGroup(hid_t stepGroup, const GridFields& g, const std::string& file, const std::string& stepWhere) {
  if (Status st = validateGridSpec(g.spec); !st) return {st.code(), file + ": " + st.message()};
  const std::size_t cells = g.spec.cellCount();
  if (g.solidFraction.size() != cells || g.meanVelocity.size() != 3 * cells ||
      g.granularTemperature.size() != (g.fluid ? 0 : cells) || (!g.meanPressure.empty() && g.meanPressure.size() != cells))
    return invalidArgument(file + ": grid field arrays do not match the grid's " + std::to_string(cells) + " cells");
  const std::string where = stepWhere + "/" + kGridGroupName;
  auto group = createGroup(stepGroup, kGridGroupName, true, file);
  if (!group) return group.status();
  if (Status st = writeGridAttrs(group->get(), g.spec, file, where); !st) return st;
  const std::vector<std::uint64_t> shape = {g.spec.cells[0], g.spec.cells[1], g.spec.cells[2]};
  const std::vector<std::uint64_t> shape3 = {g.spec.cells[0], g.spec.cells[1], g.spec.cells[2], 3};
  struct Field {
    const char* name;
    const std::vector<std::uint64_t>& shape;
    const char* unit;
    const std::vector<double>& data;
  };
  const Field fields[] = {{g.fluid ? kFluidFractionName : kSolidFractionName, shape, "", g.solidFraction},
                          {kMeanVelocityName, shape3, "m/s", g.meanVelocity},
                          {kGranularTemperatureName, shape, "m^2/s^2", g.granularTemperature},
                          {kMeanPressureName, shape, "Pa", g.meanPressure}};
  for (const auto& f : fields) {
    if (f.data.empty()) continue;  // a fluid has no granular temperature; a granular flow no pressure
    auto dset = createNdDataset(group->get(), f.name, H5T_IEEE_F64LE, f.shape, f.unit, file, where);
    if (!dset) return dset.status();
    if (Status st = writeRows(dset->get(), f.shape, 0, f.shape[0], H5T_NATIVE_DOUBLE, f.data.data(), file,
                              "'" + where + "/" + f.name + "'");
        !st)
      return st;
    if (dset->reset() < 0) return h5Error(file, "cannot close '" + where + "/" + f.name + "'");
  }
  return Status::ok();
}

Status checkFormat(hid_t root, const std::string& path) {
  const htri_t hasFormat = H5Aexists(root, "format");
  if (hasFormat < 0) return h5Error(path, "cannot read the root attributes");
  if (hasFormat == 0) return invalidArgument(path + ": not a pflow snapshot file (no root attribute 'format')");
  auto format = readStringAttr(root, "format", path, "/");
  if (!format) return format.status();
  if (format.value() != kSnapshotFormat)
    return invalidArgument(path + ": not a pflow snapshot file (format is '" + format.value() + "')");
  auto version = readScalarAttr<std::int64_t>(root, "format_version", H5T_NATIVE_INT64, path, "/");
  if (!version) return version.status();
  if (version.value() < 1 || version.value() > kSnapshotFormatVersion)
    return invalidArgument(path + ": unsupported format_version " + std::to_string(version.value()));
  return Status::ok();
}

}  // namespace pflow::backend::detail
