#include "backend/store/ProbeSeries.h"

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <memory>

namespace pflow::backend {
namespace {

// An hid_t closed by `close` when it goes out of scope.
struct Handle {
  hid_t id = -1;
  herr_t (*close)(hid_t) = nullptr;
  Handle(hid_t i, herr_t (*c)(hid_t)) : id(i), close(c) {}
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() {
    if (id >= 0 && close) close(id);
  }
  bool ok() const { return id >= 0; }
};

Status h5(const std::string& path, const std::string& what) { return ioError(path + ": cannot " + what + " (HDF5)"); }

Status stringAttr(hid_t obj, const char* name, const std::string& value, const std::string& path) {
  Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  if (!type.ok() || H5Tset_size(type.id, value.size() ? value.size() : 1) < 0) return h5(path, "make a string type");
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle attr(H5Acreate2(obj, name, type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  const char* data = value.size() ? value.c_str() : "";
  if (!attr.ok() || H5Awrite(attr.id, type.id, data) < 0) return h5(path, std::string("write the attribute ") + name);
  return Status::ok();
}

// An extendible 1-D f64 dataset of length 0 with its unit (and point).
Status createSeries(hid_t group, const std::string& name, const std::string& unit, const Vec3d* point, const std::string& path) {
  const hsize_t dims[1] = {0}, maxDims[1] = {H5S_UNLIMITED}, chunk[1] = {1024};
  Handle space(H5Screate_simple(1, dims, maxDims), H5Sclose);
  Handle plist(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  if (!space.ok() || !plist.ok() || H5Pset_chunk(plist.id, 1, chunk) < 0) return h5(path, "prepare /probes/" + name);
  Handle set(H5Dcreate2(group, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, plist.id, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return h5(path, "create /probes/" + name);
  if (Status st = stringAttr(set.id, "unit", unit, path); !st.isOk()) return st;
  if (point) {
    const double xyz[3] = {point->x, point->y, point->z};
    const hsize_t three[1] = {3};
    Handle s3(H5Screate_simple(1, three, nullptr), H5Sclose);
    Handle attr(H5Acreate2(set.id, "point", H5T_IEEE_F64LE, s3.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.ok() || H5Awrite(attr.id, H5T_NATIVE_DOUBLE, xyz) < 0) return h5(path, "write the point of /probes/" + name);
  }
  return Status::ok();
}

// Appends v to the extendible dataset `name`.
Status appendTo(hid_t group, const std::string& name, const std::vector<double>& v, const std::string& path) {
  Handle set(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return h5(path, "open /probes/" + name);
  Handle old(H5Dget_space(set.id), H5Sclose);
  hsize_t size[1] = {0};
  if (!old.ok() || H5Sget_simple_extent_dims(old.id, size, nullptr) != 1) return h5(path, "read the length of /probes/" + name);
  if (v.empty()) return Status::ok();
  const hsize_t grown[1] = {size[0] + v.size()};
  if (H5Dset_extent(set.id, grown) < 0) return h5(path, "extend /probes/" + name);
  Handle space(H5Dget_space(set.id), H5Sclose);
  const hsize_t start[1] = {size[0]}, count[1] = {v.size()};
  Handle memory(H5Screate_simple(1, count, nullptr), H5Sclose);
  if (!space.ok() || H5Sselect_hyperslab(space.id, H5S_SELECT_SET, start, nullptr, count, nullptr) < 0 ||
      H5Dwrite(set.id, H5T_NATIVE_DOUBLE, memory.id, space.id, H5P_DEFAULT, v.data()) < 0)
    return h5(path, "write /probes/" + name);
  return Status::ok();
}

// The probes' names in /probes, in creation order, without "time".
std::vector<std::string> storedNames(hid_t group) {
  std::vector<std::string> names;
  H5G_info_t info;
  if (H5Gget_info(group, &info) < 0) return names;
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[256];
    if (H5Lget_name_by_idx(group, ".", H5_INDEX_CRT_ORDER, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT) < 0) continue;
    if (std::string(name) != "time") names.emplace_back(name);
  }
  return names;
}

}  // namespace

Status appendProbeSeries(std::int64_t file, const ProbeSeries& s, const std::string& path) {
  if (s.units.size() != s.names.size() || s.points.size() != s.names.size() || s.values.size() != s.names.size())
    return invalidArgument(path + ": a probe series needs one unit, point and value list per name");
  for (const auto& v : s.values)
    if (v.size() != s.time.size()) return invalidArgument(path + ": every probe needs one value per sample time");
  for (const auto& name : s.names)
    if (name.empty() || name.size() > 200 || name == "time" || name.find('/') != std::string::npos || name.find('.') == 0)
      return invalidArgument(path + ": probe name '" + name + "' is not usable in /probes");
  const htri_t exists = H5Lexists(file, "probes", H5P_DEFAULT);
  if (exists < 0) return h5(path, "look for /probes");
  if (exists == 0) {
    Handle plist(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
    H5Pset_link_creation_order(plist.id, H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
    Handle group(H5Gcreate2(file, "probes", H5P_DEFAULT, plist.id, H5P_DEFAULT), H5Gclose);
    if (!group.ok()) return h5(path, "create /probes");
    if (Status st = createSeries(group.id, "time", "s", nullptr, path); !st.isOk()) return st;
    for (std::size_t k = 0; k < s.names.size(); ++k)
      if (Status st = createSeries(group.id, s.names[k], s.units[k], &s.points[k], path); !st.isOk()) return st;
  }
  Handle group(H5Gopen2(file, "probes", H5P_DEFAULT), H5Gclose);
  if (!group.ok()) return h5(path, "open /probes");
  if (storedNames(group.id) != s.names) return invalidArgument(path + ": the probes sent are not the ones in /probes (names or order differ)");
  if (Status st = appendTo(group.id, "time", s.time, path); !st.isOk()) return st;
  for (std::size_t k = 0; k < s.names.size(); ++k)
    if (Status st = appendTo(group.id, s.names[k], s.values[k], path); !st.isOk()) return st;
  return Status::ok();
}

Status writeProbeSeries(const std::string& path, const ProbeSeries& s) {
  std::lock_guard lock(hdf5Mutex());
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) return h5(path, "open the file to add its probe series");
  if (H5Lexists(file.id, "probes", H5P_DEFAULT) > 0 && H5Ldelete(file.id, "probes", H5P_DEFAULT) < 0)
    return h5(path, "replace /probes");
  return appendProbeSeries(file.id, s, path);
}

Result<ProbeSeries> readProbeSeries(std::int64_t file, const std::string& path) {
  if (H5Lexists(file, "probes", H5P_DEFAULT) <= 0) return Status(StatusCode::kNotFound, path + ": no /probes (the run had no probes)");
  Handle group(H5Gopen2(file, "probes", H5P_DEFAULT), H5Gclose);
  ProbeSeries s;
  auto read = [&](const std::string& name, std::vector<double>& out, std::string* unit, Vec3d* point) -> Status {
    Handle set(H5Dopen2(group.id, name.c_str(), H5P_DEFAULT), H5Dclose);
    if (!set.ok()) return h5(path, "open /probes/" + name);
    Handle space(H5Dget_space(set.id), H5Sclose);
    out.resize(std::size_t(H5Sget_simple_extent_npoints(space.id)));
    if (!out.empty() && H5Dread(set.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
      return h5(path, "read /probes/" + name);
    if (unit) {
      Handle attr(H5Aopen(set.id, "unit", H5P_DEFAULT), H5Aclose);
      Handle type(H5Aget_type(attr.id), H5Tclose);
      std::string u(H5Tget_size(type.id), '\0');
      if (attr.ok() && H5Aread(attr.id, type.id, u.data()) >= 0) *unit = u.c_str();
    }
    if (point) {
      Handle attr(H5Aopen(set.id, "point", H5P_DEFAULT), H5Aclose);
      double p[3] = {0, 0, 0};
      if (attr.ok()) H5Aread(attr.id, H5T_NATIVE_DOUBLE, p);
      *point = {p[0], p[1], p[2]};
    }
    return Status::ok();
  };
  if (Status st = read("time", s.time, nullptr, nullptr); !st.isOk()) return st;
  for (const auto& name : storedNames(group.id)) {
    s.names.push_back(name);
    s.units.emplace_back();
    s.points.emplace_back();
    s.values.emplace_back();
    if (Status st = read(name, s.values.back(), &s.units.back(), &s.points.back()); !st.isOk()) return st;
  }
  return s;
}

Result<ProbeSeries> readProbeSeries(const std::string& path) {
  std::lock_guard lock(hdf5Mutex());
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) return h5(path, "open");
  return readProbeSeries(file.id, path);
}

ProbeSeries probeSamples(const ProbeSeries& series, std::size_t first) {
  ProbeSeries out;
  out.names = series.names;
  out.units = series.units;
  out.points = series.points;
  first = std::min(first, series.time.size());
  out.time.assign(series.time.begin() + std::ptrdiff_t(first), series.time.end());
  out.values.resize(series.values.size());
  for (std::size_t k = 0; k < series.values.size(); ++k)
    out.values[k].assign(series.values[k].begin() + std::ptrdiff_t(std::min(first, series.values[k].size())), series.values[k].end());
  return out;
}

std::string probeSeriesCsv(const ProbeSeries& s) {
  std::string out = "time [s]";
  for (std::size_t k = 0; k < s.names.size(); ++k) out += "," + s.names[k] + " [" + s.units[k] + "]";
  out += "\n";
  char buf[32];
  for (std::size_t i = 0; i < s.time.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%.9g", s.time[i]);
    out += buf;
    for (const auto& v : s.values) {
      std::snprintf(buf, sizeof buf, ",%.9g", i < v.size() ? v[i] : 0.0);
      out += buf;
    }
    out += "\n";
  }
  return out;
}

}  // namespace pflow::backend
