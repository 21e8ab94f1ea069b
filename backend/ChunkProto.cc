#include "backend/ChunkProto.h"

#include <algorithm>
#include <cstring>

namespace pflow::backend {

namespace cv1 = pflow::common::v1;

Result<Chunk> chunkFromProto(v1::SnapshotChunk&& m) {
  Chunk c;
  c.jobId = m.job_id();
  c.step = m.step();
  c.time = m.time();
  c.particles = m.particles();
  switch (m.section()) {
    case v1::SECTION_PARTICLES: c.section = Section::kParticles; break;
    case v1::SECTION_GEOMETRY: c.section = Section::kGeometry; break;
    case v1::SECTION_GRID: c.section = Section::kGrid; break;
    case v1::SECTION_PROBES: c.section = Section::kProbes; break;
    default: return invalidArgument("chunk of array '" + m.array().name() + "' has no section");
  }
  cv1::ArrayChunk* a = m.mutable_array();
  switch (a->dtype()) {
    case cv1::DTYPE_F64: c.array.dtype = DType::kF64; break;
    case cv1::DTYPE_F32: c.array.dtype = DType::kF32; break;
    case cv1::DTYPE_I32: c.array.dtype = DType::kI32; break;
    case cv1::DTYPE_U32: c.array.dtype = DType::kU32; break;
    case cv1::DTYPE_I64: c.array.dtype = DType::kI64; break;
    case cv1::DTYPE_U64: c.array.dtype = DType::kU64; break;
    case cv1::DTYPE_STRING: c.array.dtype = DType::kString; break;
    default: return invalidArgument("chunk of array '" + a->name() + "' has no dtype");
  }
  c.array.name = a->name();
  c.array.shape.assign(a->shape().begin(), a->shape().end());
  c.array.firstRow = a->first_row();
  c.array.rows = a->rows();
  c.array.unit = a->unit();
  c.array.data = std::move(*a->mutable_data());
  if (c.section == Section::kProbes && m.has_probe_point())
    c.point = Vec3d{m.probe_point().x(), m.probe_point().y(), m.probe_point().z()};
  if (c.section == Section::kGrid) {
    const auto& g = m.grid();
    if (g.cells_size() != 3) return invalidArgument("grid chunk of '" + a->name() + "' has no grid spec with 3 cell counts");
    GridSpec spec;
    spec.origin = {g.origin().x(), g.origin().y(), g.origin().z()};
    spec.cellSize = g.cell_size();
    spec.cells = {g.cells(0), g.cells(1), g.cells(2)};
    c.grid = spec;
  }
  return c;
}

void chunkToProto(Chunk&& c, v1::SnapshotChunk* m) {
  m->Clear();
  m->set_job_id(c.jobId);
  m->set_step(c.step);
  m->set_time(c.time);
  m->set_particles(c.particles);
  switch (c.section) {
    case Section::kParticles: m->set_section(v1::SECTION_PARTICLES); break;
    case Section::kGeometry: m->set_section(v1::SECTION_GEOMETRY); break;
    case Section::kGrid: m->set_section(v1::SECTION_GRID); break;
    case Section::kProbes: m->set_section(v1::SECTION_PROBES); break;
  }
  if (c.point) {
    m->mutable_probe_point()->set_x(c.point->x);
    m->mutable_probe_point()->set_y(c.point->y);
    m->mutable_probe_point()->set_z(c.point->z);
  }
  cv1::ArrayChunk* a = m->mutable_array();
  a->set_name(c.array.name);
  switch (c.array.dtype) {
    case DType::kF64: a->set_dtype(cv1::DTYPE_F64); break;
    case DType::kF32: a->set_dtype(cv1::DTYPE_F32); break;
    case DType::kI32: a->set_dtype(cv1::DTYPE_I32); break;
    case DType::kU32: a->set_dtype(cv1::DTYPE_U32); break;
    case DType::kI64: a->set_dtype(cv1::DTYPE_I64); break;
    case DType::kU64: a->set_dtype(cv1::DTYPE_U64); break;
    case DType::kString: a->set_dtype(cv1::DTYPE_STRING); break;
  }
  for (auto d : c.array.shape) a->add_shape(d);
  a->set_first_row(c.array.firstRow);
  a->set_rows(c.array.rows);
  a->set_unit(c.array.unit);
  a->set_data(std::move(c.array.data));
  if (c.grid) {
    auto* g = m->mutable_grid();
    g->mutable_origin()->set_x(c.grid->origin.x);
    g->mutable_origin()->set_y(c.grid->origin.y);
    g->mutable_origin()->set_z(c.grid->origin.z);
    g->set_cell_size(c.grid->cellSize);
    for (auto n : c.grid->cells) g->add_cells(n);
  }
}

Result<ProbeSeries> probesFromProto(const v1::AppendProbesRequest& r) {
  ProbeSeries s;
  for (const auto& p : r.probes()) {
    s.names.push_back(p.name());
    s.units.push_back(p.unit());
    s.points.push_back({p.point().x(), p.point().y(), p.point().z()});
  }
  const std::size_t probes = s.names.size();
  if (probes == 0) return invalidArgument("AppendProbes names no probes");
  if (r.time().size() % sizeof(double) != 0) return invalidArgument("AppendProbes: time is not whole f64 values");
  const std::size_t k = r.time().size() / sizeof(double);
  if (r.values().size() != k * probes * sizeof(double))
    return invalidArgument("AppendProbes: " + std::to_string(r.values().size()) + " value bytes for " + std::to_string(k) + " samples of " +
                           std::to_string(probes) + " probes (need " + std::to_string(k * probes * sizeof(double)) + ")");
  s.time.resize(k);
  std::memcpy(s.time.data(), r.time().data(), r.time().size());
  std::vector<double> v(k * probes);
  std::memcpy(v.data(), r.values().data(), r.values().size());
  s.values.assign(probes, std::vector<double>(k));
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t p = 0; p < probes; ++p) s.values[p][i] = v[i * probes + p];
  return s;
}

Result<std::vector<v1::AppendProbesRequest>> probesToProto(const std::string& jobId, const ProbeSeries& s) {
  const std::size_t probes = s.names.size(), k = s.time.size();
  if (probes == 0 || s.units.size() != probes || s.points.size() != probes || s.values.size() != probes)
    return invalidArgument("a probe series needs names, and one unit, point and value list per name");
  for (const auto& v : s.values)
    if (v.size() != k) return invalidArgument("a probe series needs one value per probe and sample time");
  const std::size_t perRequest = std::max<std::size_t>(1, kMaxChunkBytes / ((probes + 1) * sizeof(double)));
  std::vector<v1::AppendProbesRequest> out;
  for (std::size_t first = 0; first < k || out.empty(); first += perRequest) {
    const std::size_t count = std::min(perRequest, k - first);
    v1::AppendProbesRequest r;
    r.set_job_id(jobId);
    for (std::size_t p = 0; p < probes; ++p) {
      auto* info = r.add_probes();
      info->set_name(s.names[p]);
      info->set_unit(s.units[p]);
      info->mutable_point()->set_x(s.points[p].x);
      info->mutable_point()->set_y(s.points[p].y);
      info->mutable_point()->set_z(s.points[p].z);
    }
    r.set_time(std::string(reinterpret_cast<const char*>(s.time.data() + first), count * sizeof(double)));
    std::vector<double> v(count * probes);
    for (std::size_t i = 0; i < count; ++i)
      for (std::size_t p = 0; p < probes; ++p) v[i * probes + p] = s.values[p][first + i];
    r.set_values(std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double)));
    out.push_back(std::move(r));
    if (k == 0) break;
  }
  return out;
}

}  // namespace pflow::backend
