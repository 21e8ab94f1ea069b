// Particle generators: fill a Region with non-overlapping spheres whose radii follow a SizeDistribution.
// docs/generators.md documents parameters, defaults, bounds, guarantees, fill orders and errors.
//
// Every generator
//   - validates all of its inputs first and reports every problem at once (kInvalidArgument, key paths);
//   - is deterministic: the same inputs and seed give bit-identical particles (see Random.h for the one caveat
//     on normal and log-normal radii);
//   - guarantees no overlap beyond 1e-9 of the smaller radius between two generated particles, nor between a
//     generated particle and an existing sphere given in Avoid;
//   - places every sphere entirely inside the region and never where Avoid::reject says no.
#pragma once
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "frontend/generators/Region.h"
#include "frontend/generators/SizeDistribution.h"

namespace pflow::frontend {

struct Particles {
  std::vector<Vec3d> position;  // [m]
  std::vector<double> radius;   // [m]
  std::size_t size() const { return position.size(); }
};

// What a generator must keep clear of: spheres placed earlier (earlier particle sets) and an optional predicate
// (the scene loader passes "overlaps a wall"). The spans must stay valid during the call.
struct Avoid {
  std::span<const Vec3d> position;                                   // [m]
  std::span<const double> radius;                                    // [m], one per position
  std::function<bool(const Vec3d& centre, double radius)> reject;    // true: no sphere there; empty: accept all
};

// ---- lattice: regular packing -------------------------------------------------------------------------------------
struct LatticeOptions {
  enum class Packing { kSimpleCubic, kHexagonalClosePacked };
  Packing packing = Packing::kSimpleCubic;
  double spacing = 0;                // centre-to-centre (nearest-neighbour) distance [m]; 0: 2.1 x max radius
  double jitter = 0.005;             // random shift per axis, uniform in [-jitter, +jitter] x the particle's radius
  std::optional<std::size_t> count;  // first `count` usable sites in fill order; unset: every site
  // Most sites of the region's bounds to visit (a bound on the work of a thin region in large bounds, such as a
  // long diagonal drum); past it generation stops with kResourceExhausted.
  std::size_t maxSites = std::numeric_limits<std::size_t>::max();
};
// Simple cubic sites at bounds.min + rmax + k x spacing per axis (the scene loader's lattice); HCP sites are
// ABAB layers with nearest-neighbour distance `spacing`. Sites are visited x fastest, then y, then z. A site is
// used when the sphere of the largest radius centred there is inside the region and is clear of Avoid.
Result<Particles> generateLattice(const Region& region, const SizeDistribution& size, const LatticeOptions& options, std::uint64_t seed,
                                  const Avoid& avoid = {});
// Largest jitter for which neighbouring lattice particles cannot overlap: (spacing - 2 rmax) / (2 rmax) for simple
// cubic, (spacing - 2 rmax) / (2 sqrt(3) rmax) for HCP (neighbours there are not along the axes).
double maxLatticeJitter(LatticeOptions::Packing packing, double spacing, double maxRadius);

// ---- random: random sequential addition ---------------------------------------------------------------------------
struct RandomOptions {
  std::optional<std::size_t> count;          // exactly this many particles; or
  std::optional<double> solidFraction;       // radii are drawn until their volume reaches this fraction of |region volume|
  std::size_t maxAttemptsPerParticle = 20000;  // trial positions for one particle before giving up
};
// Radii are drawn first, then placed largest first; each particle tries uniform positions (in the region's bounds
// shrunk by its radius) until one is inside the region, clear of every sphere placed so far and of Avoid.
// Output order is placement order. Fails with kResourceExhausted when a particle finds no place.
Result<Particles> generateRandom(const Region& region, const SizeDistribution& size, const RandomOptions& options, std::uint64_t seed,
                                 const Avoid& avoid = {});

// ---- tiled: a periodic random tile, copied ------------------------------------------------------------------------
struct TiledOptions {
  std::optional<std::size_t> count;            // take the first `count` particles in fill order (lowest z first)
  std::optional<double> solidFraction;         // fill the tile to this fraction; unset: kDefaultTileSolidFraction
  double tileEdge = 0;                         // [m]; 0: 10 x the largest diameter (capped by the region's size)
  std::size_t maxAttemptsPerParticle = 20000;  // as in RandomOptions, for the tile
  static constexpr double kDefaultTileSolidFraction = 0.30;
};
// Random sequential addition in a cubic periodic tile of edge L (overlaps by minimum image), then copies of the
// tile at bounds.min + (i, j, k) L until the bounds are covered. Copies never overlap one another; particles whose
// sphere is not inside the region, that overlap Avoid's spheres or that Avoid::reject refuses are dropped.
// Output is sorted by z, then y, then x (fill order); `count` keeps the first `count`.
Result<Particles> generateTiled(const Region& region, const SizeDistribution& size, const TiledOptions& options, std::uint64_t seed,
                                const Avoid& avoid = {});

// ---- input checks -------------------------------------------------------------------------------------------------
// What each generator checks before it starts (it returns these as its kInvalidArgument status), for callers that
// want the errors one by one: paths are "<method>.<option>" ("lattice.jitter", "random.size.mean", "tiled.count").
ErrorList checkLattice(const SizeDistribution& size, const LatticeOptions& options, const Avoid& avoid = {});
ErrorList checkRandom(const SizeDistribution& size, const RandomOptions& options, const Avoid& avoid = {});
ErrorList checkTiled(const SizeDistribution& size, const TiledOptions& options, const Avoid& avoid = {});

// ---- list: explicit particles -------------------------------------------------------------------------------------
// Checks explicit particles (finite positions, radii > 0, no overlap among them or with Avoid, not rejected and,
// when `region` is given, inside it) and returns them unchanged.
Result<Particles> generateList(const Particles& particles, const Avoid& avoid = {}, const Region* region = nullptr);

// A particle CSV file: a header naming columns among x, y, z, radius, vx, vy, vz, wx, wy, wz (any order; x, y, z
// and radius required; vx, vy, vz together; wx, wy, wz together), one particle per line, `#` starts a comment.
struct ParticleCsv {
  std::vector<Vec3d> position;                        // [m]
  std::vector<double> radius;                         // [m]
  std::optional<std::vector<Vec3d>> velocity;         // [m/s], when the file has vx, vy, vz
  std::optional<std::vector<Vec3d>> angularVelocity;  // [rad/s], when the file has wx, wy, wz
  std::size_t size() const { return position.size(); }
};
Result<ParticleCsv> readParticleCsv(const std::string& path);
// The same from text; `name` stands for the file in messages ("name:line: ...").
Result<ParticleCsv> parseParticleCsv(std::string_view text, const std::string& name = "<csv>");

// ---- checks -------------------------------------------------------------------------------------------------------
struct Overlap {
  std::size_t i, j;  // j indexes `position` too, or existing[j - position.size()]
  double depth;      // r_i + r_j - distance [m]
};
// Pairs that overlap by more than `tolerance` x the smaller radius, through a cell grid (O(N)); at most maxReport.
std::vector<Overlap> findOverlaps(std::span<const Vec3d> position, std::span<const double> radius, double tolerance = 1e-9,
                                  std::size_t maxReport = 10, std::span<const Vec3d> existingPosition = {},
                                  std::span<const double> existingRadius = {});

}  // namespace pflow::frontend
