#include "backend/ChunkProto.h"

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

}  // namespace pflow::backend
