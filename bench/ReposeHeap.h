// The angle of repose of a heap of glass beads (docs/accuracy.md, "Angle of repose"): beads settle in a cylinder
// standing on a plate and the cylinder is lifted, or they pour from a funnel onto the plate; the heap they leave is
// measured: its surface height against the distance from the axis, fitted by a line between the apex and the foot,
// over all azimuths and in four quadrants. The reference pair is
// Sunday et al. (2020, MNRAS 498, 1062): 1 mm glass beads, measured 25.2 +- 0.8 degrees, and their DEM (Chrono)
// 25.3 degrees at mu_r = 0.09, whose rolling torque's lever is the bead's radius, not pflow's R* (docs/accuracy.md).
// Used by pflow-repose (bench/repose.cc); the measurement and the checkpoint by repose_measure_test (label unit).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "compute/core/ExecutorKind.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::bench {

struct ReposeOptions {
  // Beads: Sunday et al.'s glass (their Table 2 as quoted in docs/accuracy.md): diameters 0.8-1.2 mm (uniform),
  // 2500 kg/m^3, E 70 MPa, nu 0.24; bead-bead e 0.97, mu 0.16, mu_r 0.09; bead-wall e 0.82, mu 0.45.
  double rMin = 0.0004, rMax = 0.0006, spacing = 0.0013;
  double youngs = 7e7, poisson = 0.24, density = 2500;
  double restitution = 0.97, friction = 0.16, rolling = 0.09;
  double wallRestitution = 0.82, wallFriction = 0.45, wallRolling = 0.09;
  std::size_t particles = 58040;  // as in Sunday et al.'s pile
  double cylinderRadius = 0.02;   // [m]
  // The plate: flat (0), or rough as Sunday et al.'s (roughened with fixed beads): a triangulated height field on a
  // grid of 1.5 mean diameters with heights uniform in [0, roughness] [m].
  double roughness = 0.0005;
  // The plate's roughness: "field" (the height field above) or "beads" (a flat plate under a layer of glued beads,
  // as Sunday et al. roughened theirs: beads of the pile's sizes, fixed (MaterialConfig::fixed), on a hexagonal grid
  // of one largest diameter over the disc inscribed in the plate; the glued beads' contacts with the pile's are
  // bead-bead contacts).
  std::string floor = "field";
  // The plate's half-width [m]; 0: 4 cylinder radii for a poured pile (58,040 beads heap to a radius of about
  // 48 mm at 25 degrees), 6 for the lifted cylinder (its collapse spreads to about 3).
  double plateHalfWidth = 0;
  // How the heap is made: "lift" (the beads settle in a cylinder standing on the plate, which is then lifted) or
  // "pour" (they settle in a funnel whose orifice, `pourHeight` above the plate, a gate opens; the pile builds
  // under it, bead by bead, as a pile poured in the laboratory does).
  std::string method = "lift";
  double orifice = 0.012;     // the funnel's orifice diameter [m]
  double pourHeight = 0.04;   // the orifice above the plate [m]
  double pour = 3.0;          // [s] from the gate's opening to the end of the pouring
  double settle = 0.4;            // [s] in the cylinder (or the funnel)
  double liftSpeed = 0.05;        // [m/s]
  double lift = 0.06;             // how far the cylinder rises [m] (above the settled bed)
  double rest = 0.5;              // [s] after the lift, for the heap to come to rest
  std::string precision = "double";
  std::uint64_t seed = 1;
  // A run longer than one sitting (a device call's limit): after `wallLimit` s of stepping (0: none) the run stops
  // at its next neighbour rebuild and writes its state to `checkpoint` (a pflow checkpoint file,
  // backend/store/CheckpointFile.h); a run started with the same options and an existing `checkpoint` goes on from it.
  std::string checkpoint;
  double wallLimit = 0;
  // Called every 0.1 s of simulated time (pflow-repose prints it, so that a run cut short says how far it got).
  std::function<void(double time, std::int64_t steps, double wallSeconds)> onProgress;
};

// The plate's half-width a run uses [m]: ReposeOptions::plateHalfWidth, or its default for the method (0 there).
inline double plateHalfWidth(const ReposeOptions& o) {
  return o.plateHalfWidth > 0 ? o.plateHalfWidth : (o.method == "pour" ? 4 : 6) * o.cylinderRadius;
}

// The surface of the heap: the highest bead top (z + r) in rings of width `bin` about the axis.
struct ReposeProfile {
  double bin = 0;
  std::vector<double> radius, height;  // ring middles [m], tops [m] (rings with no bead: NaN)
};

struct ReposeResult {
  double angle = 0;                    // [deg], the fit over all azimuths
  std::array<double, 4> quadrant{};    // [deg], the same in the four quadrants (+x, +y, -x, -y)
  double spread = 0;                   // largest minus smallest quadrant [deg]
  double heapRadius = 0, heapHeight = 0, fitFrom = 0, fitTo = 0;  // [m]
  double kineticEnergy = 0;            // at the end [J]
  ReposeProfile profile;
  std::size_t particles = 0;
  std::size_t floorBeads = 0;          // glued beads of a bead floor (ReposeOptions::floor)
  std::size_t onPlate = 0;             // beads at the end above the plate's underside (the rest fell off its edge)
  double plateHalfWidth = 0;           // the plate's half-width the run used [m] (plateHalfWidth(options))
  double lowest = 0;                   // the lowest bead centre at the end [m] (a poured pile's tray: 20 mm under the plate)
  double wall = 0;                     // [s]
  std::string error;
  bool unfinished = false;             // stopped at wallLimit, its state in the checkpoint
  double time = 0;                     // simulated [s] at the end
  std::string phases;                  // the step loop's phase timers (PhaseTimers::report)
  std::int64_t steps = 0;              // taken in this sitting
  std::int64_t rebuilds = 0;           // neighbour rebuilds of the run so far
  std::size_t triangles = 0;           // the walls'
  double cellSize = 0;                 // the cell grid's [m]
  int contactSlots = 0, wallSlots = 0; // history slots a particle at the end
};

// The heap's surface from a snapshot (position, radius), all azimuths or one quadrant (0..3; -1: all).
ReposeProfile reposeProfile(const compute::ParticleSnapshot& s, double bin, int quadrant = -1);
// The slope angle of a profile [deg]: a least-squares line through the rings between 25 % and 75 % of the heap's
// radius (where the surface first falls below 1.5 mean diameters above `floorLevel`, the top of the floor's roughness:
// 0 on the plate, the glued beads' mean top on a bead floor), away from the rounded apex and the foot's tail.
// Sets from/to (the fitted range) and radius/height (the heap's).
double reposeAngle(const ReposeProfile& p, double meanDiameter, double* from = nullptr, double* to = nullptr,
                   double* heapRadius = nullptr, double* heapHeight = nullptr, double floorLevel = 0);

ReposeResult runRepose(const ReposeOptions& o, compute::ExecutorKind kind);

}  // namespace pflow::bench
