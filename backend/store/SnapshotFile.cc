// HDF5 snapshot files and their XDMF sidecar. Layout: see SnapshotFile.h.
#include "backend/store/SnapshotFile.h"

#include <hdf5.h>

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

#if H5_VERSION_GE(1, 12, 1) || (H5_VERS_MAJOR == 1 && H5_VERS_MINOR == 10 && H5_VERS_RELEASE >= 7)
#define PFLOW_HDF5_HAS_FILE_LOCKING 1
#endif

namespace pflow::backend {

// HDF5 is built without thread safety: every entry point holds this lock (ProbeSeries.cc too).
std::recursive_mutex& hdf5Mutex() {
  static std::recursive_mutex mutex;
  return mutex;
}

namespace {

namespace fs = std::filesystem;
using compute::GeometrySnapshot;
using compute::ParticleSnapshot;
using compute::ScalarType;
using compute::SnapshotArray;

constexpr const char* kSnapshotsGroup = "/snapshots";
constexpr const char* kGeometryGroup = "/geometry";
constexpr const char* kXdmfGroup = "/xdmf";
constexpr const char* kIndexDataset = "/xdmf/polyvertex_index";
constexpr const char* kPositionName = "position";
constexpr hid_t kInvalidHid = -1;
constexpr hsize_t kMinIndexChunk = 4096;
constexpr hsize_t kMaxIndexChunk = 65536;

static_assert(sizeof(Vec3d) == 3 * sizeof(double), "Vec3d must be three packed doubles");


// Errors come back as Status; HDF5 must not print its error stack to stderr.
void quietHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// The innermost message of the current HDF5 error stack ("" when empty); clears the stack.
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

// An I/O error naming the file, what failed and HDF5's own reason.
Status h5Error(const std::string& file, const std::string& what) {
  const std::string detail = hdf5Detail();
  return ioError(file + ": " + what + (detail.empty() ? "" : " (HDF5: " + detail + ")"));
}

// Owns one HDF5 identifier and closes it with the matching H5?close.
class Hid {
 public:
  using Closer = herr_t (*)(hid_t);
  Hid() = default;
  Hid(hid_t id, Closer closer) : m_id(id), m_closer(closer) {}
  Hid(Hid&& other) noexcept : m_id(std::exchange(other.m_id, kInvalidHid)), m_closer(other.m_closer) {}
  Hid& operator=(Hid&& other) noexcept {
    if (this != &other) {
      reset();
      m_id = std::exchange(other.m_id, kInvalidHid);
      m_closer = other.m_closer;
    }
    return *this;
  }
  Hid(const Hid&) = delete;
  Hid& operator=(const Hid&) = delete;
  ~Hid() { reset(); }

  hid_t get() const { return m_id; }
  bool valid() const { return m_id >= 0; }
  // Closes now; returns the close call's result (0 when nothing was open).
  herr_t reset() {
    herr_t rc = 0;
    if (m_id >= 0) rc = m_closer(m_id);
    m_id = kInvalidHid;
    return rc;
  }

 private:
  hid_t m_id = kInvalidHid;
  Closer m_closer = nullptr;
};

Hid fileHid(hid_t id) { return {id, H5Fclose}; }
Hid groupHid(hid_t id) { return {id, H5Gclose}; }
Hid datasetHid(hid_t id) { return {id, H5Dclose}; }
Hid attributeHid(hid_t id) { return {id, H5Aclose}; }
Hid spaceHid(hid_t id) { return {id, H5Sclose}; }
Hid typeHid(hid_t id) { return {id, H5Tclose}; }
Hid plistHid(hid_t id) { return {id, H5Pclose}; }
Hid objectHid(hid_t id) { return {id, H5Oclose}; }

// --- scalar types ----------------------------------------------------------------------------------------------

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

// The ScalarType a stored dataset type reads back as, if it is one of ours.
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

struct XdmfNumber {
  const char* type;
  int precision;
};

XdmfNumber xdmfNumberOf(ScalarType t) {
  switch (t) {
    case ScalarType::kF64: return {"Float", 8};
    case ScalarType::kF32: return {"Float", 4};
    case ScalarType::kI32: return {"Int", 4};
    case ScalarType::kU64: return {"UInt", 8};
    case ScalarType::kU32: return {"UInt", 4};
    case ScalarType::kI8: return {"Char", 1};
  }
  return {"Float", 8};
}

const char* xdmfAttributeType(int components) {
  switch (components) {
    case 1: return "Scalar";
    case 3: return "Vector";
    case 6: return "Tensor6";
    case 9: return "Tensor";
    default: return "Matrix";
  }
}

std::string stepGroupPath(std::int64_t step) { return std::string(kSnapshotsGroup) + "/" + std::to_string(step); }

std::optional<std::int64_t> parseStep(std::string_view s) {
  std::int64_t v = 0;
  auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || ptr != s.data() + s.size() || s.empty()) return std::nullopt;
  if (std::to_string(v) != s) return std::nullopt;  // "007" or "+7" are not ours
  return v;
}

// --- property lists ----------------------------------------------------------------------------------------------

// File access: 1.8-compatible format (readable by every current HDF5; no "file open for write" flag), objects
// closed with the file, and no file lock so ParaView or h5py can read a live run between snapshots.
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

// Group creation: remember link creation order (datasets read back in write order), no timestamps.
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

// --- attributes -------------------------------------------------------------------------------------------------

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

template <class T>
Status writeScalarAttr(hid_t obj, const char* name, hid_t fileType, hid_t memType, T value, const std::string& file,
                       const std::string& where) {
  Hid space = spaceHid(H5Screate(H5S_SCALAR));
  Hid attr = attributeHid(H5Acreate2(obj, name, fileType, space.get(), H5P_DEFAULT, H5P_DEFAULT));
  if (!attr.valid() || H5Awrite(attr.get(), memType, &value) < 0 || attr.reset() < 0)
    return h5Error(file, "cannot write attribute '" + std::string(name) + "' of '" + where + "'");
  return Status::ok();
}

// Opens a scalar (one-element) attribute; INVALID_ARGUMENT if it is missing or not scalar.
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

template <class T>
Result<T> readScalarAttr(hid_t obj, const char* name, hid_t memType, const std::string& file,
                         const std::string& where) {
  auto attr = openScalarAttr(obj, name, file, where);
  if (!attr) return attr.status();
  T value{};
  if (H5Aread(attr->get(), memType, &value) < 0)
    return h5Error(file, "cannot read attribute '" + std::string(name) + "' of '" + where + "'");
  return value;
}

// --- datasets ---------------------------------------------------------------------------------------------------

// Writes a contiguous dataset of `rows` x `cols` values (rank 1 when cols == 1) in one H5Dwrite.
Status writeDataset(hid_t loc, const std::string& name, hid_t fileType, hid_t memType, const void* data,
                    std::size_t rows, int cols, const std::string& unit, const std::string& file,
                    const std::string& where) {
  const std::string what = "'" + where + "/" + name + "'";
  const hsize_t dims[2] = {static_cast<hsize_t>(rows), static_cast<hsize_t>(cols)};
  Hid space = spaceHid(H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr));
  Hid dcpl = plistHid(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !dcpl.valid() || H5Pset_fill_time(dcpl.get(), H5D_FILL_TIME_NEVER) < 0 ||
      H5Pset_obj_track_times(dcpl.get(), false) < 0)
    return h5Error(file, "cannot prepare dataset " + what);
  Hid dset = datasetHid(H5Dcreate2(loc, name.c_str(), fileType, space.get(), H5P_DEFAULT, dcpl.get(), H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot create dataset " + what);
  if (rows > 0 && H5Dwrite(dset.get(), memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    return h5Error(file, "cannot write dataset " + what);
  if (Status st = writeStringAttr(dset.get(), "unit", unit, file, where + "/" + name); !st) return st;
  if (dset.reset() < 0) return h5Error(file, "cannot close dataset " + what);
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

// Shape of an open dataset.
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

// Rows of a dataset shaped (rows) when cols == 1 or (rows, cols) otherwise.
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

// Reads optional dataset `name` of `group` into `out` (left empty when absent). `perElement` values make one T.
template <class T>
Status readOptionalArray(hid_t group, const char* name, hid_t memType, int cols, int perElement,
                         std::vector<T>& out, const std::string& file, const std::string& where) {
  out.clear();
  const std::string what = "'" + where + "/" + name + "'";
  const htri_t exists = H5Lexists(group, name, H5P_DEFAULT);
  if (exists < 0) return h5Error(file, "cannot look up " + what);
  if (exists == 0) return Status::ok();
  Hid dset = datasetHid(H5Dopen2(group, name, H5P_DEFAULT));
  if (!dset.valid()) return h5Error(file, "cannot open dataset " + what);
  auto rows = checkShape(dset.get(), cols, file, what);
  if (!rows) return rows.status();
  out.resize(static_cast<std::size_t>(rows.value()) * static_cast<std::size_t>(cols / perElement));
  if (!out.empty() && H5Dread(dset.get(), memType, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    return h5Error(file, "cannot read dataset " + what);
  return Status::ok();
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

// Names of the links in `group`, in creation order when the group tracks it, else by name.
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

// --- validation -------------------------------------------------------------------------------------------------

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

// --- XDMF sidecar -----------------------------------------------------------------------------------------------

std::string xmlEscape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

// Shortest text that reads back as the same double.
std::string formatDouble(double v) {
  char buf[64];
  auto [ptr, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, ptr) : std::to_string(v);
}

struct ArrayInfo {
  std::string name;
  ScalarType type;
  int components;
};

struct GridInfo {
  std::int64_t step;
  double time;
  std::size_t n;
  std::vector<ArrayInfo> arrays;
};

struct GeometryInfo {
  std::size_t vertices = 0;
  std::size_t triangles = 0;
  bool mesh = false, surface = false, material = false;
  bool drawable() const { return vertices > 0 && triangles > 0; }
};

class XdmfBuilder {
 public:
  explicit XdmfBuilder(std::string h5Name) : m_h5(xmlEscape(h5Name)) {}

  std::string build(const std::map<std::int64_t, GridInfo>& grids, const std::optional<GeometryInfo>& geometry,
                    hsize_t indexSize) {
    const bool withGeometry = geometry && geometry->drawable();
    m_os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         << "<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n"
         << "<Xdmf Version=\"3.0\" xmlns:xi=\"http://www.w3.org/2001/XInclude\">\n"
         << "  <Domain>\n";
    if (!grids.empty()) {
      m_os << "    <Grid Name=\"pflow\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
      for (const auto& [step, grid] : grids) {
        if (withGeometry) {
          m_os << "      <Grid Name=\"step " << step << "\" GridType=\"Collection\" CollectionType=\"Spatial\">\n"
               << "        <Time Value=\"" << formatDouble(grid.time) << "\"/>\n";
          particles(grid, indexSize, false, 8);
          geometryGrid(*geometry, 8);
          m_os << "      </Grid>\n";
        } else {
          particles(grid, indexSize, true, 6);
        }
      }
      m_os << "    </Grid>\n";
    } else if (withGeometry) {
      geometryGrid(*geometry, 4);
    }
    m_os << "  </Domain>\n"
         << "</Xdmf>\n";
    return m_os.str();
  }

 private:
  void dataItem(int indent, const std::string& dims, XdmfNumber num, const std::string& h5Path) {
    m_os << pad(indent) << "<DataItem Dimensions=\"" << dims << "\" NumberType=\"" << num.type << "\" Precision=\""
         << num.precision << "\" Format=\"HDF\">" << m_h5 << ':' << xmlEscape(h5Path) << "</DataItem>\n";
  }

  static std::string dims(std::size_t rows, int cols) {
    return cols == 1 ? std::to_string(rows) : std::to_string(rows) + " " + std::to_string(cols);
  }

  static std::string pad(int n) { return std::string(static_cast<std::size_t>(n), ' '); }

  void particles(const GridInfo& g, hsize_t indexSize, bool withTime, int in) {
    const std::string group = stepGroupPath(g.step);
    m_os << pad(in) << "<Grid Name=\"particles\" GridType=\"Uniform\">\n";
    if (withTime) m_os << pad(in + 2) << "<Time Value=\"" << formatDouble(g.time) << "\"/>\n";
    if (g.n == 0) {
      // No vertex cells to select (and maybe no index dataset yet); the zero-length datasets are still referenced,
      // which ParaView's XDMF3 readers accept (an inline empty XML DataItem makes them abort).
      m_os << pad(in + 2) << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"0\" NodesPerElement=\"1\"/>\n";
    } else {
      // One vertex cell per particle: the first n entries of the shared 0..M-1 index dataset. Without explicit
      // connectivity the XDMF3 readers make points but no cells, and ParaView draws nothing.
      m_os << pad(in + 2) << "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"" << g.n
           << "\" NodesPerElement=\"1\">\n"
           << pad(in + 4) << "<DataItem ItemType=\"HyperSlab\" Dimensions=\"" << g.n
           << "\" NumberType=\"UInt\" Precision=\"4\" Type=\"HyperSlab\">\n"
           << pad(in + 6) << "<DataItem Dimensions=\"3 1\" NumberType=\"UInt\" Precision=\"4\" Format=\"XML\">0 1 "
           << g.n << "</DataItem>\n";
      dataItem(in + 6, std::to_string(indexSize), {"UInt", 4}, kIndexDataset);
      m_os << pad(in + 4) << "</DataItem>\n" << pad(in + 2) << "</Topology>\n";
    }
    for (const auto& a : g.arrays) {
      if (a.name != kPositionName) continue;
      m_os << pad(in + 2) << "<Geometry GeometryType=\"XYZ\">\n";
      dataItem(in + 4, dims(g.n, 3), xdmfNumberOf(a.type), group + "/" + a.name);
      m_os << pad(in + 2) << "</Geometry>\n";
    }
    for (const auto& a : g.arrays) {
      if (a.name == kPositionName) continue;
      m_os << pad(in + 2) << "<Attribute Name=\"" << xmlEscape(a.name) << "\" AttributeType=\""
           << xdmfAttributeType(a.components) << "\" Center=\"Node\">\n";
      dataItem(in + 4, dims(g.n, a.components), xdmfNumberOf(a.type), group + "/" + a.name);
      m_os << pad(in + 2) << "</Attribute>\n";
    }
    m_os << pad(in) << "</Grid>\n";
  }

  void geometryGrid(const GeometryInfo& g, int in) {
    const std::string group = kGeometryGroup;
    m_os << pad(in) << "<Grid Name=\"geometry\" GridType=\"Uniform\">\n"
         << pad(in + 2) << "<Topology TopologyType=\"Triangle\" NumberOfElements=\"" << g.triangles
         << "\" NodesPerElement=\"3\">\n";
    dataItem(in + 4, dims(g.triangles, 3), {"UInt", 4}, group + "/triangles");
    m_os << pad(in + 2) << "</Topology>\n" << pad(in + 2) << "<Geometry GeometryType=\"XYZ\">\n";
    dataItem(in + 4, dims(g.vertices, 3), {"Float", 8}, group + "/vertices");
    m_os << pad(in + 2) << "</Geometry>\n";
    auto cellAttribute = [&](bool present, const char* name) {
      if (!present) return;
      m_os << pad(in + 2) << "<Attribute Name=\"" << name << "\" AttributeType=\"Scalar\" Center=\"Cell\">\n";
      dataItem(in + 4, dims(g.triangles, 1), {"Int", 4}, group + "/" + name);
      m_os << pad(in + 2) << "</Attribute>\n";
    };
    cellAttribute(g.surface, "triangle_surface");
    cellAttribute(g.mesh, "triangle_mesh");
    cellAttribute(g.material, "triangle_material");
    m_os << pad(in) << "</Grid>\n";
  }

  std::string m_h5;
  std::ostringstream m_os;
};


// --- partial reads, N-d datasets, grids (the back-end's additions) ----------------------------------------------

constexpr const char* kGridGroupName = "grid";

std::string shapeText(const std::vector<std::uint64_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + ")";
}

bool validArrayName(const std::string& name) {
  return !name.empty() && name.find('/') == std::string::npos && name != "." && name != "..";
}

// Attribute of `count` values (a 1-D simple dataspace).
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

// An empty dataset of `shape` (contiguous, no fill, no timestamps) with its `unit`.
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

// The hyperslab of rows [first, first + count) of a dataset of `dims` (all of every other dimension).
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

// Reads rows [first, first + count) of an open dataset into `out` as `memType`.
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

// Type, shape and unit of dataset `name` of `group`.
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

// Attributes, particle arrays (rank 1 or 2, n rows) and grid of /snapshots/<step>.
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

// Writes /snapshots/<step>/grid from computed fields.
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

// Checks the root attributes of an open file: a pflow snapshot file of a version this build reads.
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

}  // namespace

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
    const std::string text = XdmfBuilder(h5Name).build(grids, geometry, indexSize);
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
  impl->file = fileHid(H5Fcreate(h5Path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl->get()));
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

Status SnapshotWriter::appendProbes(const ProbeSeries& samples) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Impl& d = *m_impl;
  if (Status st = d.checkOpen(); !st) return st;
  if (Status st = appendProbeSeries(d.file.get(), samples, d.path); !st) return st;
  return d.flushFile();
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
  impl->file = fileHid(H5Fcreate(scratchPath.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl->get()));
  if (!impl->file.valid()) return h5Error(scratchPath, "cannot create the staging file");
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
