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

// HDF5 is built without thread safety: every entry point holds this lock.
std::recursive_mutex& hdf5Mutex() {
  static std::recursive_mutex mutex;
  return mutex;
}

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

}  // namespace pflow::backend
