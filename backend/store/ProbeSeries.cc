#include "backend/store/ProbeSeries.h"

#include <filesystem>

#include <hdf5.h>

#include <algorithm>
#include <cstdio>
#include <fstream>

#include "backend/store/Hdf5Detail.h"

namespace pflow::backend {

using namespace detail;

namespace {

constexpr const char* kProbes = "probes";

// An extendible (chunked) 1-D f64 dataset of length 0 with its unit and, for a probe, its point.
Status createSeries(hid_t group, const std::string& name, const std::string& unit, const Vec3d* point, const std::string& path) {
  const std::string where = "/probes/" + name;
  const hsize_t dims[1] = {0}, maxDims[1] = {H5S_UNLIMITED}, chunk[1] = {1024};
  Hid space = spaceHid(H5Screate_simple(1, dims, maxDims));
  Hid plist = plistHid(H5Pcreate(H5P_DATASET_CREATE));
  if (!space.valid() || !plist.valid() || H5Pset_chunk(plist.get(), 1, chunk) < 0) return h5Error(path, "cannot prepare " + where);
  Hid set = datasetHid(H5Dcreate2(group, name.c_str(), H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, plist.get(), H5P_DEFAULT));
  if (!set.valid()) return h5Error(path, "cannot create " + where);
  if (Status st = writeStringAttr(set.get(), "unit", unit, path, where); !st) return st;
  if (!point) return Status::ok();
  const double xyz[3] = {point->x, point->y, point->z};
  return writeVectorAttr(set.get(), "point", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, xyz, 3, path, where);
}

// Appends v to the extendible dataset `name`; returns its new length.
Result<std::uint64_t> appendTo(hid_t group, const std::string& name, const std::vector<double>& v, const std::string& path) {
  const std::string where = "/probes/" + name;
  Hid set = datasetHid(H5Dopen2(group, name.c_str(), H5P_DEFAULT));
  if (!set.valid()) return h5Error(path, "cannot open " + where);
  auto dims = datasetDims(set.get(), path, where);
  if (!dims) return dims.status();
  if (dims->size() != 1) return invalidArgument(path + ": " + where + " is not one-dimensional");
  const std::uint64_t size = (*dims)[0];
  if (v.empty()) return size;
  const hsize_t grown[1] = {size + v.size()};
  if (H5Dset_extent(set.get(), grown) < 0) return h5Error(path, "cannot extend " + where);
  if (Status st = writeRows(set.get(), {grown[0]}, size, v.size(), H5T_NATIVE_DOUBLE, v.data(), path, where); !st) return st;
  return std::uint64_t(grown[0]);
}

}  // namespace

Result<std::uint64_t> appendProbeSeries(std::int64_t file, const ProbeSeries& s, const std::string& path) {
  if (s.units.size() != s.names.size() || s.points.size() != s.names.size() || s.values.size() != s.names.size())
    return invalidArgument(path + ": a probe series needs one unit, point and value list per name");
  for (const auto& v : s.values)
    if (v.size() != s.time.size()) return invalidArgument(path + ": every probe needs one value per sample time");
  for (const auto& name : s.names)
    if (name.empty() || name.size() > 200 || name == "time" || name.find('/') != std::string::npos || name.find('.') == 0)
      return invalidArgument(path + ": probe name '" + name + "' is not usable in /probes");
  const htri_t exists = H5Lexists(file, kProbes, H5P_DEFAULT);
  if (exists < 0) return h5Error(path, "cannot look for /probes");
  if (exists == 0) {
    auto group = createGroup(file, kProbes, true, path);  // creation order: the probes' order
    if (!group) return group.status();
    if (Status st = createSeries(group->get(), "time", "s", nullptr, path); !st) return st;
    for (std::size_t k = 0; k < s.names.size(); ++k)
      if (Status st = createSeries(group->get(), s.names[k], s.units[k], &s.points[k], path); !st) return st;
  }
  Hid group = groupHid(H5Gopen2(file, kProbes, H5P_DEFAULT));
  if (!group.valid()) return h5Error(path, "cannot open /probes");
  auto stored = linkNames(group.get(), path, "/probes");
  if (!stored) return stored.status();
  std::vector<std::string> names;
  for (auto& n : stored.value())
    if (n != "time") names.push_back(std::move(n));
  if (names != s.names) return invalidArgument(path + ": the probes sent are not the ones in /probes (names or order differ)");
  // A resumed run (a requeued job going on from its checkpoint) samples again from the checkpoint's time: samples
  // at or before the last time storedRows are dropped, so the series keeps one sample per time.
  std::uint64_t storedRows = 0;
  double lastTime = 0;
  {
    Hid set = datasetHid(H5Dopen2(group.get(), "time", H5P_DEFAULT));
    if (!set.valid()) return h5Error(path, "cannot open /probes/time");
    auto rows = checkShape(set.get(), 1, path, "/probes/time");
    if (!rows) return rows.status();
    storedRows = rows.value();
    if (storedRows > 0)
      if (Status st = readRowsOf(set.get(), storedRows - 1, 1, H5T_NATIVE_DOUBLE, &lastTime, path, "/probes/time"); !st) return st;
  }
  std::size_t skip = 0;
  while (storedRows > 0 && skip < s.time.size() && s.time[skip] <= lastTime) ++skip;
  if (skip == s.time.size()) return storedRows;
  const ProbeSeries* sending = &s;
  ProbeSeries later;
  if (skip > 0) {
    later = s;
    later.time.erase(later.time.begin(), later.time.begin() + std::ptrdiff_t(skip));
    for (auto& v : later.values) v.erase(v.begin(), v.begin() + std::ptrdiff_t(skip));
    sending = &later;
  }
  auto samples = appendTo(group.get(), "time", sending->time, path);
  if (!samples) return samples.status();
  for (std::size_t k = 0; k < s.names.size(); ++k)
    if (auto n = appendTo(group.get(), s.names[k], sending->values[k], path); !n) return n.status();
  return samples.value();
}

Status writeProbeSeries(const std::string& path, const ProbeSeries& s) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Hid file = fileHid(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT));
  if (!file.valid()) return h5Error(path, "cannot open the file to add its probe series");
  if (H5Lexists(file.get(), kProbes, H5P_DEFAULT) > 0 && H5Ldelete(file.get(), kProbes, H5P_DEFAULT) < 0)
    return h5Error(path, "cannot replace /probes");
  return appendProbeSeries(file.get(), s, path).status();
}

Result<ProbeSeries> readProbeSeries(std::int64_t file, const std::string& path) {
  if (H5Lexists(file, kProbes, H5P_DEFAULT) <= 0) return Status(StatusCode::kNotFound, path + ": no /probes (the run had no probes)");
  Hid group = groupHid(H5Gopen2(file, kProbes, H5P_DEFAULT));
  if (!group.valid()) return h5Error(path, "cannot open /probes");
  ProbeSeries s;
  auto read = [&](const std::string& name, std::vector<double>& out, std::string* unit, Vec3d* point) -> Status {
    const std::string where = "/probes/" + name;
    Hid set = datasetHid(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT));
    if (!set.valid()) return h5Error(path, "cannot open " + where);
    auto rows = checkShape(set.get(), 1, path, where);
    if (!rows) return rows.status();
    out.resize(std::size_t(rows.value()));
    if (Status st = readRowsOf(set.get(), 0, rows.value(), H5T_NATIVE_DOUBLE, out.data(), path, where); !st) return st;
    if (unit) {
      auto u = readStringAttr(set.get(), "unit", path, where);
      if (!u) return u.status();
      *unit = u.value();
    }
    if (point) {
      double xyz[3] = {0, 0, 0};
      if (Status st = readVectorAttr(set.get(), "point", H5T_NATIVE_DOUBLE, xyz, 3, path, where); !st) return st;
      *point = {xyz[0], xyz[1], xyz[2]};
    }
    return Status::ok();
  };
  if (Status st = read("time", s.time, nullptr, nullptr); !st) return st;
  auto names = linkNames(group.get(), path, "/probes");
  if (!names) return names.status();
  for (const auto& name : names.value()) {
    if (name == "time") continue;
    s.names.push_back(name);
    s.units.emplace_back();
    s.points.emplace_back();
    s.values.emplace_back();
    if (Status st = read(name, s.values.back(), &s.units.back(), &s.points.back()); !st) return st;
  }
  return s;
}

Result<ProbeSeries> readProbeSeries(const std::string& path) {
  std::lock_guard lock(hdf5Mutex());
  quietHdf5();
  Hid file = fileHid(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT));
  if (!file.valid()) return h5Error(path, "cannot open");
  return readProbeSeries(file.get(), path);
}

std::string probesCsvPathFor(const std::string& h5Path) {
  const std::string stem = h5Path.size() > 3 && h5Path.compare(h5Path.size() - 3, 3, ".h5") == 0 ? h5Path.substr(0, h5Path.size() - 3) : h5Path;
  return stem + ".probes.csv";
}

Status writeProbeFiles(const std::string& h5Path, const ProbeSeries& series) {
  if (Status st = writeProbeSeries(h5Path, series); !st) return st;
  const std::string csv = probesCsvPathFor(h5Path);
  std::ofstream f(csv);
  f << probeSeriesCsv(series);
  return f ? Status::ok() : ioError("cannot write " + csv);
}

Status writeProbesCsv(const std::string& h5Path) {
  auto series = readProbeSeries(h5Path);
  if (!series) return series.status().code() == StatusCode::kNotFound ? Status::ok() : series.status();
  const std::string csv = probesCsvPathFor(h5Path);
  std::ofstream f(csv);
  f << probeSeriesCsv(series.value());
  return f ? Status::ok() : ioError("cannot write " + csv);
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

ProbeSeries withEarlierSamples(const std::string& h5Path, const ProbeSeries& now) {
  std::error_code ec;
  if (now.time.empty() || !std::filesystem::exists(h5Path, ec)) return now;
  auto before = readProbeSeries(h5Path);
  if (!before || before->names != now.names) return now;
  ProbeSeries out = now;
  out.time.clear();
  for (auto& v : out.values) v.clear();
  for (std::size_t k = 0; k < before->time.size() && before->time[k] < now.time.front() * (1 - 1e-12); ++k) {
    out.time.push_back(before->time[k]);
    for (std::size_t p = 0; p < out.values.size(); ++p) out.values[p].push_back(before->values[p][k]);
  }
  out.time.insert(out.time.end(), now.time.begin(), now.time.end());
  for (std::size_t p = 0; p < out.values.size(); ++p) out.values[p].insert(out.values[p].end(), now.values[p].begin(), now.values[p].end());
  return out;
}

}  // namespace pflow::backend
