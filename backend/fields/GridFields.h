// Grid fields of a particle snapshot: solid fraction, mean velocity and granular temperature on a regular grid.
// Pure functions (no I/O); the store feeds them the staged snapshot in blocks so memory stays bounded.
//
// Method (docs/output-format.md has the same text):
//  * Each particle is replaced by the axis-aligned cube of equal volume, side a = (4 pi / 3)^(1/3) r ~ 1.612 r,
//    centred on the particle. Its volume V = 4/3 pi r^3 is split over the cells the cube overlaps in proportion
//    to the overlap volume (a product of three 1-D interval overlaps), so f_pc = overlap(p, c) / a^3 and
//    sum_c f_pc = 1 for a particle inside the grid. The split is exact for the total volume, for a sphere cut
//    by one cell face through its centre (1/2 each side) or by the cell corner at its centre (1/8 each), and
//    for a periodic lattice in cells that are whole multiples of its period. It is approximate (cube instead of
//    ball) for other cuts: the error is at most the cube's and ball's different slab volumes, which is below
//    4 % of V for any single plane cut. The part of a particle outside the grid is dropped.
//  * solid fraction phi_c = sum_p f_pc V_p / h^3 (dimensionless).
//  * mass weight w_pc = f_pc m_p with m_p from a `mass` array when the snapshot has one, otherwise
//    m_p proportional to r_p^3 (one density for every particle; the density cancels in both averages).
//  * mean velocity <v>_c = sum_p w_pc v_p / sum_p w_pc (m/s).
//  * granular temperature T_c = (1/3) sum_p w_pc |v_p - <v>_c|^2 / sum_p w_pc (m^2/s^2), computed in a
//    second pass over the particles (no cancellation between <|v|^2> and |<v>|^2).
//  * Cells without solid have phi = 0, <v> = 0 and T = 0. Particles with a non-finite position, velocity or
//    radius, or a radius <= 0, are skipped (and counted).
// Array layout: cell (i, j, k) is element (i * ny + j) * nz + k, i.e. C order of shape (nx, ny, nz[, 3]).
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::backend {

// Limits that keep a grid small enough to hold and to stream: total cells, and the cells of one x-slab
// (ny * nz): one row of mean_velocity (ny * nz * 3 f64) must fit one 1 MiB chunk of the protocol.
inline constexpr std::size_t kMaxGridCells = std::size_t(1) << 22;
inline constexpr std::size_t kMaxGridSlabCells = (std::size_t(1) << 20) / (3 * sizeof(double));

struct GridSpec {
  Vec3d origin{0, 0, 0};                  // m, lower corner of cell (0, 0, 0)
  double cellSize = 0;                    // m, cubic cells
  std::array<std::uint32_t, 3> cells{0, 0, 0};  // nx, ny, nz
  std::size_t cellCount() const { return std::size_t(cells[0]) * cells[1] * cells[2]; }
  std::size_t index(std::size_t i, std::size_t j, std::size_t k) const { return (i * cells[1] + j) * cells[2] + k; }
};

// INVALID_ARGUMENT unless the cell size is finite and > 0, the origin finite, every count >= 1 and the limits
// above hold.
Status validateGridSpec(const GridSpec& spec);

// The box around particle spheres (centre +- radius), accumulated block by block.
struct ParticleBounds {
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};
  double maxRadius = 0;
  std::size_t count = 0;  // particles that entered the box (finite position and radius > 0)
  void add(std::size_t n, const double* position, const double* radius);
  // A planar fluid's box: one cell deep in y whatever the radius (the cells stay cubic, of the x-z size).
  void flattenY() {
    const double y = 0.5 * (lo.y + hi.y);
    lo.y = hi.y = y;
  }
};

// A grid of cubic cells of `cellSize` (<= 0: 4 x the largest radius) whose lower corner is bounds.lo and which
// covers bounds.hi. When that grid would exceed kMaxGridCells or kMaxGridSlabCells, the cell size is enlarged
// (by factors of 1.25) until it fits: the spec's cellSize is the one used. INVALID_ARGUMENT when bounds are
// empty or no usable cell size results.
Result<GridSpec> gridCovering(const ParticleBounds& bounds, double cellSize);

// Rows [0, n) of the arrays a pass needs, in f64: position and velocity n x 3, radius n, mass n or null.
struct ParticleBlock {
  std::size_t n = 0;
  const double* position = nullptr;
  const double* velocity = nullptr;
  const double* radius = nullptr;
  const double* mass = nullptr;      // optional
  const double* pressure = nullptr;  // optional (fluids): averaged like the velocity
  const std::uint8_t* excluded = nullptr;  // optional: rows left out without being counted as skipped
};

// A fluid's grid (an SPH snapshot: `mass`, `density` and `pressure`, no `radius`) is the same computation with
// each fluid particle's volume V = m / rho as its sphere (r = (3V / 4 pi)^(1/3)) and the boundary particles
// (kind != 0) left out: fluid_fraction, mean_velocity and mean_pressure (the mass-weighted mean, Pa); no
// granular temperature. A planar (2D) fluid, every fluid particle at one y, has m / rho = A, its area in the x-z
// plane per metre of depth: each particle is the square of side sqrt(A) in x-z across the grid's one layer of
// cells in y, and the fluid fraction is sum f A / h^2 (the `radius` such a block carries is sqrt(A / pi)).
struct GridFields {
  GridSpec spec;
  bool fluid = false;                       // solidFraction is the fluid fraction; no granular temperature
  std::vector<double> solidFraction;        // cellCount(), dimensionless
  std::vector<double> meanVelocity;         // cellCount() x 3, m/s
  std::vector<double> granularTemperature;  // cellCount(), m^2/s^2; empty for a fluid
  std::vector<double> meanPressure;         // cellCount(), Pa; empty unless the particles carry a pressure
  std::size_t skippedParticles = 0;         // non-finite or radius <= 0
};

// Two passes over every particle, in blocks of any size:
//   GridAccumulator acc(spec); for blocks: acc.addMoments(b); acc.endMoments(); for blocks: acc.addFluctuations(b);
//   GridFields f = std::move(acc).finish();
class GridAccumulator {
 public:
  // withPressure: the blocks carry pressure, and mean_pressure is computed; fluid: the fraction is a fluid's and
  // the fluctuation pass is not needed (finish() leaves granularTemperature empty); planar: a 2D fluid (above).
  explicit GridAccumulator(const GridSpec& spec, bool withPressure = false, bool fluid = false, bool planar = false);
  void addMoments(const ParticleBlock& block);
  void endMoments();  // mean velocities from the first pass
  void addFluctuations(const ParticleBlock& block);
  GridFields finish() &&;

 private:
  template <class F>
  void forEachOverlap(const ParticleBlock& b, std::size_t p, F&& f) const;
  bool usable(const ParticleBlock& b, std::size_t p) const;

  GridSpec m_spec;
  std::vector<double> m_volume;  // sum f V
  std::vector<double> m_weight;  // sum w
  std::vector<double> m_momentum;  // sum w v (3 per cell), then <v>
  std::vector<double> m_fluct;   // sum w |v - <v>|^2
  std::vector<double> m_pressure;  // sum w p (with pressure)
  bool m_fluid = false, m_planar = false;
  std::size_t m_skipped = 0;
  bool m_meansDone = false;
};

// The radius of the sphere of a fluid particle's volume m / rho (planar: of the disc of area m / rho); 0 (left
// out) when either is not > 0.
double fluidRadius(double mass, double density, bool planar = false);
// Whether every row not excluded (with a finite y) has the same y, a planar (2D) fluid; accumulated block by block.
struct PlaneCheck {
  bool any = false, same = true;
  double y = 0;
  void add(std::size_t n, const double* position, const std::uint8_t* excluded);
  bool planar() const { return any && same; }
};

// Side of the cube with the volume of a sphere of radius r: (4 pi / 3)^(1/3) r.
double equalVolumeCubeSide(double r);

// The whole computation for a snapshot held in memory. Needs `position` (n x 3), `velocity` (n x 3) and `radius`
// (n) of f64 or f32, and uses `mass` (n) when present; a fluid's snapshot (no radius; mass, density, pressure
// and kind) gives the fluid's fields. INVALID_ARGUMENT otherwise.
Result<GridFields> computeGridFields(const compute::ParticleSnapshot& snapshot, const GridSpec& spec);
// The grid covering the snapshot's particles (gridCovering) and its fields.
Result<GridFields> computeGridFields(const compute::ParticleSnapshot& snapshot, double cellSize);

}  // namespace pflow::backend
