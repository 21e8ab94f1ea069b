#include "backend/store/ProbeSeries.h"

#include <hdf5.h>

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

Status vectorDataset(hid_t group, const std::string& name, const std::vector<double>& v, const std::string& unit,
                     const std::string& path) {
  const hsize_t dims[1] = {hsize_t(v.size())};
  Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
  Handle set(H5Dcreate2(group, name.c_str(), H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) return h5(path, "create /probes/" + name);
  if (!v.empty() && H5Dwrite(set.id, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    return h5(path, "write /probes/" + name);
  return stringAttr(set.id, "unit", unit, path);
}

}  // namespace

Status writeProbeSeries(const std::string& path, const ProbeSeries& s) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) return h5(path, "open the file to add its probe series");
  if (H5Lexists(file.id, "probes", H5P_DEFAULT) > 0 && H5Ldelete(file.id, "probes", H5P_DEFAULT) < 0)
    return h5(path, "replace /probes");
  Handle plist(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_link_creation_order(plist.id, H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  Handle group(H5Gcreate2(file.id, "probes", H5P_DEFAULT, plist.id, H5P_DEFAULT), H5Gclose);
  if (!group.ok()) return h5(path, "create /probes");
  if (Status st = vectorDataset(group.id, "time", s.time, "s", path); !st.isOk()) return st;
  for (std::size_t k = 0; k < s.names.size(); ++k) {
    if (Status st = vectorDataset(group.id, s.names[k], k < s.values.size() ? s.values[k] : std::vector<double>{}, s.units[k], path);
        !st.isOk())
      return st;
    Handle set(H5Dopen2(group.id, s.names[k].c_str(), H5P_DEFAULT), H5Dclose);
    const double point[3] = {s.points[k].x, s.points[k].y, s.points[k].z};
    const hsize_t three[1] = {3};
    Handle space(H5Screate_simple(1, three, nullptr), H5Sclose);
    Handle attr(H5Acreate2(set.id, "point", H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
    if (!attr.ok() || H5Awrite(attr.id, H5T_NATIVE_DOUBLE, point) < 0) return h5(path, "write the point of /probes/" + s.names[k]);
  }
  return Status::ok();
}

Result<ProbeSeries> readProbeSeries(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) return h5(path, "open");
  if (H5Lexists(file.id, "probes", H5P_DEFAULT) <= 0) return Status(StatusCode::kNotFound, path + ": no /probes (the run had no probes)");
  Handle group(H5Gopen2(file.id, "probes", H5P_DEFAULT), H5Gclose);
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
  H5G_info_t info;
  H5Gget_info(group.id, &info);
  for (hsize_t i = 0; i < info.nlinks; ++i) {
    char name[256];
    if (H5Lget_name_by_idx(group.id, ".", H5_INDEX_CRT_ORDER, H5_ITER_INC, i, name, sizeof name, H5P_DEFAULT) < 0) continue;
    if (std::string(name) == "time") continue;
    s.names.emplace_back(name);
    s.units.emplace_back();
    s.points.emplace_back();
    s.values.emplace_back();
    if (Status st = read(name, s.values.back(), &s.units.back(), &s.points.back()); !st.isOk()) return st;
  }
  return s;
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
