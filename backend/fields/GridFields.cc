// Grid fields: see GridFields.h for the method.
#include "backend/fields/GridFields.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

namespace pflow::backend {
namespace {

using compute::ParticleSnapshot;
using compute::ScalarType;
using compute::SnapshotArray;

double sphereVolume(double r) { return 4.0 / 3.0 * std::numbers::pi * r * r * r; }

// An array of the snapshot as f64 values, checked for n rows of `components`.
Result<std::vector<double>> asDoubles(const ParticleSnapshot& s, const char* name, int components, bool optional,
                                      bool& present) {
  present = false;
  const SnapshotArray* a = s.find(name);
  if (a == nullptr) {
    if (optional) return std::vector<double>{};
    return invalidArgument(std::string("grid fields need a '") + name + "' array");
  }
  if (a->components != components || (a->type != ScalarType::kF64 && a->type != ScalarType::kF32))
    return invalidArgument(std::string("grid fields need '") + name + "' as " + std::to_string(components) +
                           " component(s) of f64 or f32");
  const std::size_t count = s.n * static_cast<std::size_t>(components);
  if (a->data.size() != count * compute::scalarBytesOf(a->type))
    return invalidArgument(std::string("array '") + name + "' does not hold n = " + std::to_string(s.n) + " rows");
  std::vector<double> out(count);
  if (a->type == ScalarType::kF64) {
    std::copy_n(a->as<double>(), count, out.begin());
  } else {
    std::copy_n(a->as<float>(), count, out.begin());
  }
  present = true;
  return out;
}

}  // namespace

double equalVolumeCubeSide(double r) { return std::cbrt(4.0 / 3.0 * std::numbers::pi) * r; }

Status validateGridSpec(const GridSpec& spec) {
  if (!std::isfinite(spec.cellSize) || spec.cellSize <= 0)
    return invalidArgument("grid cell size must be finite and > 0 m, got " + std::to_string(spec.cellSize));
  if (!isFinite(spec.origin)) return invalidArgument("grid origin is not finite");
  for (int d = 0; d < 3; ++d)
    if (spec.cells[d] < 1) return invalidArgument("grid must have at least one cell along each axis");
  if (spec.cellCount() > kMaxGridCells)
    return invalidArgument("grid of " + std::to_string(spec.cellCount()) + " cells exceeds the limit of " +
                           std::to_string(kMaxGridCells));
  if (std::size_t(spec.cells[1]) * spec.cells[2] > kMaxGridSlabCells)
    return invalidArgument("grid slab ny * nz = " + std::to_string(std::size_t(spec.cells[1]) * spec.cells[2]) +
                           " exceeds the limit of " + std::to_string(kMaxGridSlabCells) + " cells");
  return Status::ok();
}

void ParticleBounds::add(std::size_t n, const double* position, const double* radius) {
  for (std::size_t p = 0; p < n; ++p) {
    const Vec3d x{position[3 * p], position[3 * p + 1], position[3 * p + 2]};
    const double r = radius[p];
    if (!isFinite(x) || !std::isfinite(r) || r <= 0) continue;
    const Vec3d lo{x.x - r, x.y - r, x.z - r}, hi{x.x + r, x.y + r, x.z + r};
    if (count == 0) {
      this->lo = lo;
      this->hi = hi;
    } else {
      this->lo = {std::min(this->lo.x, lo.x), std::min(this->lo.y, lo.y), std::min(this->lo.z, lo.z)};
      this->hi = {std::max(this->hi.x, hi.x), std::max(this->hi.y, hi.y), std::max(this->hi.z, hi.z)};
    }
    maxRadius = std::max(maxRadius, r);
    ++count;
  }
}

Result<GridSpec> gridCovering(const ParticleBounds& bounds, double cellSize) {
  if (bounds.count == 0) return invalidArgument("no particle with a finite position and a radius > 0");
  double h = cellSize > 0 ? cellSize : 4.0 * bounds.maxRadius;
  if (!std::isfinite(h) || h <= 0) return invalidArgument("no usable grid cell size");
  const double ext[3] = {bounds.hi.x - bounds.lo.x, bounds.hi.y - bounds.lo.y, bounds.hi.z - bounds.lo.z};
  for (int attempt = 0; attempt < 400; ++attempt, h *= 1.25) {
    GridSpec spec;
    spec.origin = bounds.lo;
    spec.cellSize = h;
    bool tooMany = false;
    for (int d = 0; d < 3; ++d) {
      const double cells = std::max(1.0, std::ceil(ext[d] / h));
      if (cells > double(kMaxGridCells)) {
        tooMany = true;
        break;
      }
      spec.cells[d] = static_cast<std::uint32_t>(cells);
    }
    if (tooMany) continue;
    if (spec.cellCount() > kMaxGridCells || std::size_t(spec.cells[1]) * spec.cells[2] > kMaxGridSlabCells) continue;
    if (Status st = validateGridSpec(spec); !st) return st;
    return spec;
  }
  return invalidArgument("particles span too large a box for a grid");
}

GridAccumulator::GridAccumulator(const GridSpec& spec, bool withPressure, bool fluid, bool planar)
    : m_spec(spec),
      m_volume(spec.cellCount(), 0.0),
      m_weight(spec.cellCount(), 0.0),
      m_momentum(3 * spec.cellCount(), 0.0),
      m_fluct(fluid ? 0 : spec.cellCount(), 0.0),
      m_pressure(withPressure ? spec.cellCount() : 0, 0.0),
      m_fluid(fluid),
      m_planar(planar) {}

bool GridAccumulator::usable(const ParticleBlock& b, std::size_t p) const {
  if (!m_pressure.empty() && (b.pressure == nullptr || !std::isfinite(b.pressure[p]))) return false;
  const double r = b.radius[p];
  if (!std::isfinite(r) || r <= 0) return false;
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(b.position[3 * p + c]) || !std::isfinite(b.velocity[3 * p + c])) return false;
  return b.mass == nullptr || (std::isfinite(b.mass[p]) && b.mass[p] >= 0);
}

// Calls f(cell, fraction) for every cell the particle's equal-volume cube overlaps (fraction of the cube's volume).
template <class F>
void GridAccumulator::forEachOverlap(const ParticleBlock& b, std::size_t p, F&& f) const {
  // Planar: the square of the disc's area in x-z, across the grid's cells in y (each a fraction 1 of it).
  const double a = m_planar ? std::sqrt(std::numbers::pi) * b.radius[p] : equalVolumeCubeSide(b.radius[p]);
  const double h = m_spec.cellSize;
  const double origin[3] = {m_spec.origin.x, m_spec.origin.y, m_spec.origin.z};
  // Per axis: the cells [first, last] touched and the fraction of the side in each (at most a few cells).
  constexpr int kMaxSpan = 64;
  std::size_t first[3];
  int span[3];
  double frac[3][kMaxSpan];
  for (int d = 0; d < 3; ++d) {
    if (m_planar && d == 1) {  // every layer in y takes the whole particle (a planar grid has one)
      first[d] = 0;
      span[d] = 1;
      frac[d][0] = 1.0;
      if (m_spec.cells[1] != 1) return;  // not a planar grid: nothing sensible to add
      continue;
    }
    const double lo = (b.position[3 * p + d] - 0.5 * a - origin[d]) / h;  // in cell units
    const double hi = (b.position[3 * p + d] + 0.5 * a - origin[d]) / h;
    const double n = m_spec.cells[d];
    const double clo = std::max(lo, 0.0), chi = std::min(hi, n);
    if (chi <= clo) return;  // entirely outside the grid along this axis
    const auto i0 = static_cast<std::size_t>(std::floor(clo));
    auto i1 = static_cast<std::size_t>(std::ceil(chi)) - 1;
    i1 = std::min<std::size_t>(i1, m_spec.cells[d] - 1);
    int count = static_cast<int>(i1 - i0 + 1);
    if (count > kMaxSpan) count = kMaxSpan;  // a particle wider than 64 cells: keep the first 64 (documented cap)
    first[d] = i0;
    span[d] = count;
    const double side = hi - lo;
    for (int k = 0; k < count; ++k) {
      const double cellLo = double(i0 + std::size_t(k)), cellHi = cellLo + 1.0;
      frac[d][k] = std::max(0.0, std::min(chi, cellHi) - std::max(clo, cellLo)) / side;
    }
  }
  for (int i = 0; i < span[0]; ++i)
    for (int j = 0; j < span[1]; ++j) {
      const double fij = frac[0][i] * frac[1][j];
      if (fij == 0) continue;
      for (int k = 0; k < span[2]; ++k) {
        const double fr = fij * frac[2][k];
        if (fr > 0) f(m_spec.index(first[0] + std::size_t(i), first[1] + std::size_t(j), first[2] + std::size_t(k)), fr);
      }
    }
}

void GridAccumulator::addMoments(const ParticleBlock& b) {
  const bool withPressure = !m_pressure.empty();
  for (std::size_t p = 0; p < b.n; ++p) {
    if (b.excluded != nullptr && b.excluded[p]) continue;
    if (!usable(b, p)) {
      ++m_skipped;
      continue;
    }
    const double r = b.radius[p];
    const double volume = m_planar ? std::numbers::pi * r * r : sphereVolume(r);  // planar: the area
    const double mass = b.mass != nullptr ? b.mass[p] : r * r * r;
    const double* v = b.velocity + 3 * p;
    forEachOverlap(b, p, [&](std::size_t c, double f) {
      m_volume[c] += f * volume;
      const double w = f * mass;
      m_weight[c] += w;
      m_momentum[3 * c] += w * v[0];
      m_momentum[3 * c + 1] += w * v[1];
      m_momentum[3 * c + 2] += w * v[2];
      if (withPressure) m_pressure[c] += w * b.pressure[p];
    });
  }
}

void GridAccumulator::endMoments() {
  for (std::size_t c = 0; c < m_weight.size(); ++c) {
    const double w = m_weight[c];
    for (int d = 0; d < 3; ++d) m_momentum[3 * c + d] = w > 0 ? m_momentum[3 * c + d] / w : 0.0;
  }
  m_meansDone = true;
}

void GridAccumulator::addFluctuations(const ParticleBlock& b) {
  if (m_fluid) return;
  for (std::size_t p = 0; p < b.n; ++p) {
    if ((b.excluded != nullptr && b.excluded[p]) || !usable(b, p)) continue;
    const double r = b.radius[p];
    const double mass = b.mass != nullptr ? b.mass[p] : r * r * r;
    const double* v = b.velocity + 3 * p;
    forEachOverlap(b, p, [&](std::size_t c, double f) {
      const double dx = v[0] - m_momentum[3 * c], dy = v[1] - m_momentum[3 * c + 1], dz = v[2] - m_momentum[3 * c + 2];
      m_fluct[c] += f * mass * (dx * dx + dy * dy + dz * dz);
    });
  }
}

GridFields GridAccumulator::finish() && {
  if (!m_meansDone) endMoments();
  GridFields out;
  out.spec = m_spec;
  // Planar: areas over the cell's x-z face.
  const double cellVolume = m_spec.cellSize * m_spec.cellSize * (m_planar ? 1.0 : m_spec.cellSize);
  out.solidFraction = std::move(m_volume);
  for (double& v : out.solidFraction) v /= cellVolume;
  out.fluid = m_fluid;
  out.granularTemperature = std::move(m_fluct);
  for (std::size_t c = 0; c < out.granularTemperature.size(); ++c)
    out.granularTemperature[c] = m_weight[c] > 0 ? out.granularTemperature[c] / (3.0 * m_weight[c]) : 0.0;
  out.meanPressure = std::move(m_pressure);
  for (std::size_t c = 0; c < out.meanPressure.size(); ++c) out.meanPressure[c] = m_weight[c] > 0 ? out.meanPressure[c] / m_weight[c] : 0.0;
  out.meanVelocity = std::move(m_momentum);
  out.skippedParticles = m_skipped;
  return out;
}

namespace {

// The arrays of a snapshot in f64, a fluid's radii derived from its volumes and its boundary rows excluded.
struct Prepared {
  std::vector<double> position, velocity, radius, mass, pressure;
  std::vector<std::uint8_t> excluded;
  bool fluid = false, planar = false;
  ParticleBlock block(std::size_t n) const {
    return {n,
            position.data(),
            velocity.data(),
            radius.data(),
            mass.empty() ? nullptr : mass.data(),
            pressure.empty() ? nullptr : pressure.data(),
            excluded.empty() ? nullptr : excluded.data()};
  }
};

Result<Prepared> prepare(const ParticleSnapshot& snapshot, bool needVelocity) {
  Prepared p;
  bool present = false, hasMass = false;
  p.fluid = snapshot.find("radius") == nullptr && snapshot.find("density") != nullptr && snapshot.find("mass") != nullptr;
  auto position = asDoubles(snapshot, "position", 3, false, present);
  if (!position) return position.status();
  p.position = std::move(position).value();
  if (needVelocity) {
    auto velocity = asDoubles(snapshot, "velocity", 3, false, present);
    if (!velocity) return velocity.status();
    p.velocity = std::move(velocity).value();
  }
  auto mass = asDoubles(snapshot, "mass", 1, true, hasMass);
  if (!mass) return mass.status();
  p.mass = std::move(mass).value();
  if (!p.fluid) {
    auto radius = asDoubles(snapshot, "radius", 1, false, present);
    if (!radius) return radius.status();
    p.radius = std::move(radius).value();
    return p;
  }
  auto density = asDoubles(snapshot, "density", 1, false, present);
  if (!density) return density.status();
  bool hasPressure = false;
  auto pressure = asDoubles(snapshot, "pressure", 1, true, hasPressure);
  if (!pressure) return pressure.status();
  p.pressure = std::move(pressure).value();
  p.radius.resize(snapshot.n);
  p.excluded.assign(snapshot.n, 0);
  const SnapshotArray* kind = snapshot.find("kind");
  if (kind != nullptr && (kind->type != ScalarType::kI32 || kind->components != 1 || kind->data.size() != 4 * snapshot.n))
    return invalidArgument("grid fields need 'kind' as one i32 per particle");
  for (std::size_t i = 0; i < snapshot.n; ++i) p.excluded[i] = kind != nullptr && kind->as<std::int32_t>()[i] != 0;
  PlaneCheck plane;
  plane.add(snapshot.n, p.position.data(), p.excluded.data());
  p.planar = plane.planar();
  for (std::size_t i = 0; i < snapshot.n; ++i) p.radius[i] = p.excluded[i] ? 0.0 : fluidRadius(p.mass[i], density.value()[i], p.planar);
  return p;
}

}  // namespace

void PlaneCheck::add(std::size_t n, const double* position, const std::uint8_t* excluded) {
  for (std::size_t i = 0; i < n && same; ++i) {
    if (excluded != nullptr && excluded[i]) continue;
    const double yi = position[3 * i + 1];
    if (!std::isfinite(yi)) continue;
    if (any && yi != y) same = false;
    y = yi;
    any = true;
  }
}

double fluidRadius(double mass, double density, bool planar) {
  if (!(mass > 0) || !(density > 0) || !std::isfinite(mass / density)) return 0;
  if (planar) return std::sqrt(mass / (std::numbers::pi * density));
  return std::cbrt(3.0 * mass / (4.0 * std::numbers::pi * density));
}

Result<GridFields> computeGridFields(const ParticleSnapshot& snapshot, const GridSpec& spec) {
  if (Status st = validateGridSpec(spec); !st) return st;
  auto p = prepare(snapshot, true);
  if (!p) return p.status();
  const ParticleBlock block = p->block(snapshot.n);
  GridAccumulator acc(spec, block.pressure != nullptr, p->fluid, p->planar);
  acc.addMoments(block);
  acc.endMoments();
  acc.addFluctuations(block);
  return std::move(acc).finish();
}

Result<GridFields> computeGridFields(const ParticleSnapshot& snapshot, double cellSize) {
  auto p = prepare(snapshot, false);
  if (!p) return p.status();
  ParticleBounds bounds;
  bounds.add(snapshot.n, p->position.data(), p->radius.data());
  const double y = 0.5 * (bounds.lo.y + bounds.hi.y);
  if (p->planar) bounds.flattenY();
  auto spec = gridCovering(bounds, cellSize);
  if (!spec) return spec.status();
  if (p->planar) spec->origin.y = y - 0.5 * spec->cellSize;  // the one layer of cells centred on the plane
  return computeGridFields(snapshot, spec.value());
}

}  // namespace pflow::backend
