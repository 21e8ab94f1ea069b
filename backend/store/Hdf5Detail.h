// Internal to backend/store: the HDF5 helpers of the snapshot file (SnapshotFile.cc, SnapshotXdmf.cc): owned
// identifiers, type maps, attributes, datasets read and written by rows, the step and grid layout (SnapshotFile.h
// describes the layout). Every caller holds hdf5Mutex().
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "backend/store/SnapshotFile.h"
#include "common/Status.h"

#if H5_VERSION_GE(1, 12, 1) || (H5_VERS_MAJOR == 1 && H5_VERS_MINOR == 10 && H5_VERS_RELEASE >= 7)
#define PFLOW_HDF5_HAS_FILE_LOCKING 1
#endif

namespace pflow::backend::detail {

using compute::GeometrySnapshot;

using compute::ParticleSnapshot;

using compute::ScalarType;

using compute::SnapshotArray;

inline constexpr const char* kSnapshotsGroup = "/snapshots";

inline constexpr const char* kGeometryGroup = "/geometry";

inline constexpr const char* kXdmfGroup = "/xdmf";

inline constexpr const char* kIndexDataset = "/xdmf/polyvertex_index";

inline constexpr const char* kPositionName = "position";

inline constexpr hid_t kInvalidHid = -1;

inline constexpr hsize_t kMinIndexChunk = 4096;

inline constexpr hsize_t kMaxIndexChunk = 65536;

static_assert(sizeof(Vec3d) == 3 * sizeof(double), "Vec3d must be three packed doubles");

// Errors come back as Status; HDF5 must not print its error stack to stderr.
inline void quietHdf5() { H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr); }

// The innermost message of the current HDF5 error stack ("" when empty); clears the stack.
std::string hdf5Detail();

// An I/O error naming the file, what failed and HDF5's own reason.
Status h5Error(const std::string& file, const std::string& what);

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

inline Hid fileHid(hid_t id) { return {id, H5Fclose}; }

inline Hid groupHid(hid_t id) { return {id, H5Gclose}; }

inline Hid datasetHid(hid_t id) { return {id, H5Dclose}; }

inline Hid attributeHid(hid_t id) { return {id, H5Aclose}; }

inline Hid spaceHid(hid_t id) { return {id, H5Sclose}; }

inline Hid typeHid(hid_t id) { return {id, H5Tclose}; }

inline Hid plistHid(hid_t id) { return {id, H5Pclose}; }

inline Hid objectHid(hid_t id) { return {id, H5Oclose}; }

// --- scalar types ----------------------------------------------------------------------------------------------

hid_t fileTypeOf(ScalarType t);

hid_t memTypeOf(ScalarType t);

// The ScalarType a stored dataset type reads back as, if it is one of ours.
std::optional<ScalarType> scalarTypeOf(hid_t dtype);

std::optional<std::int64_t> parseStep(std::string_view s);

// --- property lists ----------------------------------------------------------------------------------------------

// File access: 1.8-compatible format (readable by every current HDF5; no "file open for write" flag), objects
// closed with the file, and no file lock so ParaView or h5py can read a live run between snapshots.
Result<Hid> makeFileAccess(const std::string& file);

// File creation: no timestamps on the root group either, so that the same content writes the same bytes.
Result<Hid> makeFileCreate(const std::string& file);

// Group creation: remember link creation order (datasets read back in write order), no timestamps.
Result<Hid> makeGroupCreate(const std::string& file, bool trackOrder);

Result<Hid> createGroup(hid_t loc, const std::string& path, bool trackOrder, const std::string& file);

// --- attributes -------------------------------------------------------------------------------------------------

Result<Hid> utf8StringType(const std::string& file);

Status writeStringAttr(hid_t obj, const char* name, const std::string& value, const std::string& file,
                       const std::string& where);

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
Result<Hid> openScalarAttr(hid_t obj, const char* name, const std::string& file, const std::string& where);

Result<std::string> readStringAttr(hid_t obj, const char* name, const std::string& file, const std::string& where);

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
                    const std::string& where);

Status writeStringDataset(hid_t loc, const std::string& name, const std::vector<std::string>& values,
                          const std::string& file, const std::string& where);

// Shape of an open dataset.
Result<std::vector<hsize_t>> datasetDims(hid_t dset, const std::string& file, const std::string& what);

// Rows of a dataset shaped (rows) when cols == 1 or (rows, cols) otherwise.
Result<hsize_t> checkShape(hid_t dset, int cols, const std::string& file, const std::string& what);

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
                           const std::string& where);

// Names of the links in `group`, in creation order when the group tracks it, else by name.
Result<std::vector<std::string>> linkNames(hid_t group, const std::string& file, const std::string& where);

// --- validation -------------------------------------------------------------------------------------------------

Status validateSnapshot(const ParticleSnapshot& s);

Status validateGeometry(const GeometrySnapshot& g);

// --- partial reads, N-d datasets, grids (the back-end's additions) ----------------------------------------------

inline constexpr const char* kGridGroupName = "grid";

std::string shapeText(const std::vector<std::uint64_t>& shape);

bool validArrayName(const std::string& name);

// Attribute of `count` values (a 1-D simple dataspace).
Status writeVectorAttr(hid_t obj, const char* name, hid_t fileType, hid_t memType, const void* values,
                       std::size_t count, const std::string& file, const std::string& where);

Status readVectorAttr(hid_t obj, const char* name, hid_t memType, void* values, std::size_t count,
                      const std::string& file, const std::string& where);

// An empty dataset of `shape` (contiguous, no fill, no timestamps) with its `unit`.
Result<Hid> createNdDataset(hid_t loc, const std::string& name, hid_t fileType, const std::vector<std::uint64_t>& shape,
                            const std::string& unit, const std::string& file, const std::string& where);

// The hyperslab of rows [first, first + count) of a dataset of `dims` (all of every other dimension).
Status selectRows(hid_t fileSpace, const std::vector<hsize_t>& dims, std::uint64_t first, std::uint64_t count,
                  Hid& memSpace);

Status writeRows(hid_t dset, const std::vector<std::uint64_t>& shape, std::uint64_t first, std::uint64_t count,
                 hid_t memType, const void* data, const std::string& file, const std::string& what);

// Reads rows [first, first + count) of an open dataset into `out` as `memType`.
Status readRowsOf(hid_t dset, std::uint64_t first, std::uint64_t count, hid_t memType, void* out,
                  const std::string& file, const std::string& what);

// Type, shape and unit of dataset `name` of `group`.
Result<ArrayMeta> datasetMeta(hid_t group, const std::string& name, const std::string& file, const std::string& where);

Status writeGridAttrs(hid_t group, const GridSpec& spec, const std::string& file, const std::string& where);

Result<GridMeta> readGridMeta(hid_t stepGroup, const std::string& file, const std::string& stepWhere);

// Attributes, particle arrays (rank 1 or 2, n rows) and grid of /snapshots/<step>.
Result<StepMeta> readStepMeta(hid_t file, const std::string& path, std::int64_t step);

// Writes /snapshots/<step>/grid from computed fields.
Status writeGridGroup(hid_t stepGroup, const GridFields& g, const std::string& file, const std::string& stepWhere);

// Checks the root attributes of an open file: a pflow snapshot file of a version this build reads.
Status checkFormat(hid_t root, const std::string& path);

// "/snapshots/<step>".
inline std::string stepGroupPath(std::int64_t step) { return std::string(kSnapshotsGroup) + "/" + std::to_string(step); }

}  // namespace pflow::backend::detail
