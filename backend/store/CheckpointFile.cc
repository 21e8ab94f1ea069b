#include "backend/store/CheckpointFile.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <mutex>

#include "backend/store/Hdf5Detail.h"
#include "backend/store/ProbeSeries.h"

namespace pflow::backend {

namespace fs = std::filesystem;
using namespace detail;

namespace {

constexpr const char* kFormat = "pflow-checkpoint";
constexpr std::int64_t kVersion = 1;
constexpr const char* kParticles = "particles";

template <class T>
Status attr(hid_t obj, const char* name, T value, const std::string& file) {
  if constexpr (std::is_same_v<T, double>) return writeScalarAttr(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, value, file, "/");
  else return writeScalarAttr<std::int64_t>(obj, name, H5T_STD_I64LE, H5T_NATIVE_INT64, std::int64_t(value), file, "/");
}

Status writeFile(const std::string& file, const CheckpointData& d) {
  auto fapl = makeFileAccess(file);
  if (!fapl) return fapl.status();
  auto fcpl = makeFileCreate(file);
  if (!fcpl) return fcpl.status();
  Hid f = fileHid(H5Fcreate(file.c_str(), H5F_ACC_TRUNC, fcpl->get(), fapl->get()));
  if (!f.valid()) return h5Error(file, "cannot create the checkpoint file");
  const compute::SimulationState& s = d.state;
  hid_t root = f.get();
  for (auto [name, value] : {std::pair<const char*, const std::string*>{"format", nullptr}, {"solver", &d.solver},
                             {"precision", &d.precision}, {"scene", &d.sceneText}, {"scene_dir", &d.sceneDir},
                             {"scene_file", &d.sceneFile}})
    PFLOW_TRY(writeStringAttr(root, name, value ? *value : std::string(kFormat), file, "/"));
  PFLOW_TRY(attr(root, "version", kVersion, file));
  PFLOW_TRY(attr(root, "step", s.step, file));
  PFLOW_TRY(attr(root, "step_base", s.stepBase, file));
  PFLOW_TRY(attr(root, "rebuilds", s.rebuilds, file));
  PFLOW_TRY(attr(root, "reductions", s.reductions, file));
  PFLOW_TRY(attr(root, "contact_slots", s.contactSlots, file));
  PFLOW_TRY(attr(root, "wall_slots", s.wallSlots, file));
  PFLOW_TRY(attr(root, "particles", std::int64_t(s.particles.n), file));
  PFLOW_TRY(attr(root, "time", s.time, file));
  PFLOW_TRY(attr(root, "time_base", s.timeBase, file));
  PFLOW_TRY(attr(root, "dt", s.dt, file));
  PFLOW_TRY(attr(root, "dt_before", s.dtBefore, file));
  if (!s.wallDrive.empty())  // the driven walls' state (compute/dem/WallDrive.h), 6 values a wall
    PFLOW_TRY(writeDataset(root, "wall_drive", fileTypeOf(compute::ScalarType::kF64), memTypeOf(compute::ScalarType::kF64),
                           s.wallDrive.data(), s.wallDrive.size(), 1, "", file, "/"));
  auto group = createGroup(root, kParticles, true, file);
  if (!group) return group.status();
  for (const compute::SnapshotArray& a : s.particles.arrays)
    PFLOW_TRY(writeDataset(group->get(), a.name, fileTypeOf(a.type), memTypeOf(a.type), a.data.data(), s.particles.n,
                                       a.components, a.unit, file, "/particles"));
  group->reset();
  if (f.reset() < 0) return h5Error(file, "cannot close the checkpoint file");
  return Status::ok();
}

template <class T>
Result<T> readAttr(hid_t obj, const char* name, const std::string& file) {
  if constexpr (std::is_same_v<T, double>) return readScalarAttr<double>(obj, name, H5T_NATIVE_DOUBLE, file, "/");
  else {
    auto v = readScalarAttr<std::int64_t>(obj, name, H5T_NATIVE_INT64, file, "/");
    if (!v) return v.status();
    return T(v.value());
  }
}

}  // namespace

std::string previousCheckpointPath(const std::string& path) { return path + ".1"; }

Status syncPath(const std::string& path, bool directory) {
  const int fd = ::open(path.c_str(), directory ? O_RDONLY | O_DIRECTORY : O_RDONLY);
  if (fd < 0) return ioError("cannot open '" + path + "' to flush it to disk");
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) return ioError("cannot flush '" + path + "' to disk (fsync)");
  return Status::ok();
}

Status writeCheckpoint(const std::string& path, const CheckpointData& data, bool scratch) {
  std::lock_guard<std::recursive_mutex> lock(hdf5Mutex());
  quietHdf5();
  if (scratch) return writeFile(path, data);
  const std::string tmp = path + ".tmp";
  if (const fs::path parent = fs::path(path).parent_path(); !parent.empty()) {
    std::error_code ec;
    fs::create_directories(parent, ec);
    if (ec) return ioError("cannot create the checkpoint folder '" + parent.string() + "': " + ec.message());
  }
  if (Status s = writeFile(tmp, data); !s.isOk()) {
    std::error_code ec;
    fs::remove(tmp, ec);
    return s;
  }
  PFLOW_TRY(syncPath(tmp, false));
  std::error_code ec;
  if (fs::exists(path, ec)) {
    fs::rename(path, previousCheckpointPath(path), ec);
    if (ec) return ioError("cannot keep the previous checkpoint as '" + previousCheckpointPath(path) + "': " + ec.message());
  }
  fs::rename(tmp, path, ec);
  if (ec) return ioError("cannot move the checkpoint into place at '" + path + "': " + ec.message());
  const fs::path dir = fs::path(path).parent_path();
  return syncPath(dir.empty() ? "." : dir.string(), true);
}

namespace {

// Opens a checkpoint and checks its format and version (under the HDF5 lock, held by the caller).
Result<Hid> openCheckpoint(const std::string& path) {
  quietHdf5();
  std::error_code ec;
  if (!fs::exists(path, ec)) return Status(StatusCode::kNotFound, "no checkpoint at '" + path + "'");
  auto fapl = makeFileAccess(path);
  if (!fapl) return fapl.status();
  Hid f = fileHid(H5Fopen(path.c_str(), H5F_ACC_RDONLY, fapl->get()));
  if (!f.valid()) return h5Error(path, "cannot open the checkpoint (cut off or not an HDF5 file)");
  hid_t root = f.get();
  auto format = readStringAttr(root, "format", path, "/");
  if (!format || format.value() != kFormat) return invalidArgument("'" + path + "' is not a pflow checkpoint (no format attribute \"pflow-checkpoint\")");
  auto version = readAttr<std::int64_t>(root, "version", path);
  if (!version) return version.status();
  if (version.value() != kVersion)
    return invalidArgument("'" + path + "' is a checkpoint of format version " + std::to_string(version.value()) + "; this pflow reads version " +
                           std::to_string(kVersion));
  return f;
}

}  // namespace

Result<CheckpointHeader> readCheckpointHeader(const std::string& path) {
  std::lock_guard<std::recursive_mutex> lock(hdf5Mutex());
  auto f = openCheckpoint(path);
  if (!f) return f.status();
  hid_t root = f->get();
  CheckpointHeader h;
  for (auto [name, out] : {std::pair<const char*, std::string*>{"solver", &h.solver}, {"precision", &h.precision}}) {
    auto v = readStringAttr(root, name, path, "/");
    if (!v) return v.status();
    *out = v.value();
  }
  auto step = readAttr<std::int64_t>(root, "step", path);
  auto time = readAttr<double>(root, "time", path);
  auto particles = readAttr<std::int64_t>(root, "particles", path);
  if (!step) return step.status();
  if (!time) return time.status();
  if (!particles) return particles.status();
  h.step = step.value();
  h.time = time.value();
  h.particles = particles.value();
  return h;
}

Result<CheckpointData> readCheckpoint(const std::string& path) {
  std::lock_guard<std::recursive_mutex> lock(hdf5Mutex());
  auto opened = openCheckpoint(path);
  if (!opened) return opened.status();
  Hid f = std::move(opened).value();
  hid_t root = f.get();
  CheckpointData d;
  for (auto [name, out] : {std::pair<const char*, std::string*>{"solver", &d.solver}, {"precision", &d.precision}, {"scene", &d.sceneText},
                           {"scene_dir", &d.sceneDir}, {"scene_file", &d.sceneFile}}) {
    auto v = readStringAttr(root, name, path, "/");
    if (!v) return v.status();
    *out = v.value();
  }
  compute::SimulationState& s = d.state;
#define PFLOW_READ(field, name, T)                 \
  {                                                \
    auto v = readAttr<T>(root, name, path);        \
    if (!v) return v.status();                     \
    s.field = v.value();                           \
  }
  PFLOW_READ(step, "step", std::int64_t)
  PFLOW_READ(stepBase, "step_base", std::int64_t)
  PFLOW_READ(rebuilds, "rebuilds", std::int64_t)
  PFLOW_READ(reductions, "reductions", int)
  PFLOW_READ(contactSlots, "contact_slots", int)
  PFLOW_READ(wallSlots, "wall_slots", int)
  PFLOW_READ(time, "time", double)
  PFLOW_READ(timeBase, "time_base", double)
  PFLOW_READ(dt, "dt", double)
  PFLOW_READ(dtBefore, "dt_before", double)
#undef PFLOW_READ
  if (H5Lexists(root, "wall_drive", H5P_DEFAULT) > 0) {
    auto meta = datasetMeta(root, "wall_drive", path, "/");
    if (!meta) return meta.status();
    if (meta->shape.size() != 1) return invalidArgument("checkpoint '" + path + "': '/wall_drive' is not a list of values");
    s.wallDrive.resize(std::size_t(meta->shape[0]));
    Hid dset = datasetHid(H5Dopen2(root, "wall_drive", H5P_DEFAULT));
    if (!dset.valid()) return h5Error(path, "cannot open '/wall_drive'");
    PFLOW_TRY(readRowsOf(dset.get(), 0, s.wallDrive.size(), H5T_NATIVE_DOUBLE, s.wallDrive.data(), path, "'/wall_drive'"));
  }
  auto count = readAttr<std::int64_t>(root, "particles", path);
  if (!count) return count.status();
  s.particles.step = s.step;
  s.particles.time = s.time;
  s.particles.n = std::size_t(count.value());
  Hid group = groupHid(H5Gopen2(root, kParticles, H5P_DEFAULT));
  if (!group.valid()) return h5Error(path, "cannot open '/particles'");
  auto names = linkNames(group.get(), path, "/particles");
  if (!names) return names.status();
  for (const std::string& name : names.value()) {
    auto meta = datasetMeta(group.get(), name, path, "/particles");
    if (!meta) return meta.status();
    const std::string what = "'/particles/" + name + "'";
    if (meta->shape.empty() || meta->shape[0] != s.particles.n)
      return invalidArgument("checkpoint '" + path + "': " + what + " does not hold one row per particle");
    compute::SnapshotArray a{name, meta->type, meta->shape.size() > 1 ? int(meta->shape[1]) : 1, meta->unit, {}};
    a.data.resize(s.particles.n * std::size_t(a.components) * compute::scalarBytesOf(a.type));
    Hid dset = datasetHid(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT));
    if (!dset.valid()) return h5Error(path, "cannot open " + what);
    PFLOW_TRY(readRowsOf(dset.get(), 0, s.particles.n, memTypeOf(a.type), a.data.data(), path, what));
    s.particles.arrays.push_back(std::move(a));
  }
  return d;
}

Result<CheckpointData> readLatestCheckpoint(const std::string& path, std::string* skipped) {
  auto last = readCheckpoint(path);
  if (last) return last;
  auto before = readCheckpoint(previousCheckpointPath(path));
  if (!before) return last.status();  // the newer one's reason
  if (skipped) *skipped = last.status().message();
  return before;
}

}  // namespace pflow::backend
