// The plain, validated description of one run. SI units everywhere. No proto, no YAML: the scene
// loader (frontend) and later the worker's proto conversion fill it; validate() checks it in one place.
#pragma once
#include <cmath>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"
#include "compute/sph/SphConfig.h"

namespace pflow::compute {

struct MaterialConfig {
  std::string name;
  double youngsModulus = 0;      // E [Pa]
  double poissonRatio = 0;       // nu [-], in (-1, 0.5)
  double density = 0;            // rho [kg/m^3]
  double restitution = 0.5;      // e [-], in (0, 1]
  double friction = 0.5;         // mu_s [-], >= 0
  double rollingFriction = 0.0;  // mu_r [-], >= 0 (0 disables rolling resistance)
  // Its particles do not move (beads glued into a rough floor or wall): no velocity, no spin, and a partner's
  // contact with one is damped as against a wall (the effective mass is the partner's). The first 64 materials.
  bool fixed = false;
};

// Optional per-pair overrides (symmetric). Unset members use the pair's mixing rule.
// Adhesion between two materials (pairs[].cohesion): off unless a scene asks (the least model).
enum class CohesionModel { kNone = 0, kJkr = 1, kConstant = 2 };

struct MaterialPairConfig {
  int a = 0, b = 0;  // material indices
  std::optional<double> restitution, friction, rollingFriction;
  CohesionModel cohesion = CohesionModel::kNone;  // jkr: Johnson-Kendall-Roberts; constant: DMT's 2 pi dgamma R*
  double workOfAdhesion = 0;                      // dgamma [J/m^2] (twice the surface energy for like surfaces)
};

// Explicit initial particles (the front-end's generators produce these).
struct ParticleInit {
  std::vector<Vec3d> position;         // [m]
  std::vector<Vec3d> velocity;         // [m/s]; empty = zero
  std::vector<Vec3d> angularVelocity;  // [rad/s]; empty = zero
  std::vector<double> radius;          // [m]
  std::vector<std::int32_t> material;  // index into RunConfig::materials
  std::size_t size() const { return position.size(); }
};

// An infinite plane; particles live on the side the normal points to.
struct PlaneConfig {
  std::string name;
  Vec3d point{0, 0, 0};
  Vec3d normal{0, 0, 1};
  int material = 0;
  std::int32_t surface = 0;  // scene-wide surface number (RunConfig::surfaceNames)
};

// Prescribed rigid motion of a mesh, from startTime on: translation at `velocity` and rotation
// about the axis through `axisPoint` (which moves with the translation) along `axis` at `angularSpeed`.
struct MeshMotion {
  Vec3d velocity{0, 0, 0};        // [m/s]
  Vec3d axisPoint{0, 0, 0};       // [m]
  Vec3d axis{0, 0, 1};            // unit vector
  double angularSpeed = 0;        // [rad/s], right-handed about `axis`
  double startTime = 0;           // [s]
  // Sinusoidal vibration on top (a shaker): displacement A (sin(2 pi f tau + phase) - sin(phase)) after the start,
  // so the mesh starts where it is; velocity A 2 pi f cos(2 pi f tau + phase).
  Vec3d vibration{0, 0, 0};       // amplitude A [m]
  double frequency = 0;           // f [Hz]
  double phase = 0;               // [rad]
  bool vibrates() const { return frequency > 0 && (vibration.x != 0 || vibration.y != 0 || vibration.z != 0); }
  // A piecewise-linear translation velocity instead of `velocity`: points (tau [s after startTime], v [m/s]),
  // tau increasing, at most kMaxProfilePoints; linear between them, the first value before, the last after.
  struct ProfilePoint {
    double tau;
    Vec3d velocity;
  };
  std::vector<ProfilePoint> profile;
  // A wall driven by a force or a torque (motion.drive; compute/dem/WallDrive.h): a rigid body on a guide that moves
  // by Newton's law under the particles' contact forces and its drive, instead of a prescribed motion. Translation
  // (mass > 0) along one direction: a constant force `force` (the direction is its own), or a drive that holds
  // `velocity` while that takes at most `forceLimit` [N] (the direction is the velocity's). Rotation (inertia > 0)
  // about `axis` through `axisPoint`: a constant torque `torque` [N m], or one that holds `angularSpeed` while that
  // takes at most `torqueLimit`. From startTime; held still before it.
  struct Drive {
    double mass = 0;           // [kg]; 0: no translation drive
    Vec3d force{0, 0, 0};      // [N]
    double forceLimit = 0;     // [N]
    double inertia = 0;        // [kg m^2] about the axis; 0: no rotation drive
    double torque = 0;         // [N m], right-handed about the axis
    double torqueLimit = 0;    // [N m]
    bool translates() const { return mass > 0; }
    bool rotates() const { return inertia > 0; }
  };
  std::optional<Drive> drive;
  bool moves() const {
    return velocity.x != 0 || velocity.y != 0 || velocity.z != 0 || angularSpeed != 0 || vibrates() || !profile.empty() ||
           drive.has_value();
  }
};

// A triangle mesh wall: a body of infinite mass. Triangles are numbered in order; `surface` gives each
// triangle the number of the surface it belongs to (results and forces refer to it).
struct MeshConfig {
  std::string name;
  std::vector<Vec3d> vertices;                         // [m]
  std::vector<std::array<std::uint32_t, 3>> triangles;  // vertex indices, counter-clockwise seen from the particle side
  std::vector<std::int32_t> surface;                   // per triangle; empty = all 0
  int material = 0;
  MeshMotion motion;
};

struct Aabb {
  Vec3d lo{0, 0, 0}, hi{0, 0, 0};
};

enum class Precision { kDouble, kFloat };
// How a distributed run splits space between ranks (compute/decomp): the seed patent's Morton-curve
// ranges of cells, or FDPS's multi-section cuts.
enum class DecompositionKind { kSfc, kMultiSection };
// What a run does when a detector finds it unstable (docs/physics.md, "Instability detectors"): stop with
// the error, or go back to the last checkpoint and halve the time step.
enum class OnInstability { kStop, kReduceDt };
// simulation.model: kAuto computes the least model the scene needs (compute/dem/ModelChoice.h); kFull
// computes everything (tangential history, rolling torque, wall phases, 3D) whatever the scene.
enum class ModelMode { kAuto, kFull };
// simulation.accuracy: the relative error the scene tolerates on a named reference quantity (a key of the
// accuracy study's table, compute/dem/AccuracyTable.h).
struct AccuracyTarget {
  std::string quantity;
  double tolerance = 0;  // relative, > 0
};

struct SimulationSettings {
  Vec3d gravity{0, 0, -9.81};        // [m/s^2]
  double duration = 0;               // [s]
  std::optional<double> dt;          // [s]; unset = auto: dtFraction * Rayleigh time
  double dtFraction = 0.2;           // of the Rayleigh time, used when dt is unset
  double skin = -1;                  // neighbour skin [m]; < 0 = 0.1 * largest diameter
  double snapshotInterval = 0;       // [s] between snapshots; 0 = first and last only
  std::optional<Aabb> domain;        // [m]; unset = derived from particles and walls
  Precision precision = Precision::kDouble;
  bool precisionGiven = false;       // the scene fixed simulation.precision (else an accuracy target may pick float)
  ModelMode model = ModelMode::kAuto;
  std::optional<AccuracyTarget> accuracy;
  DecompositionKind decomposition = DecompositionKind::kSfc;  // used when the run has more than one rank
  int historySlots = 8;              // initial tangential-history slots per particle (grown on demand)
  int wallHistorySlots = 1;          // initial wall-contact slots per particle (grown on demand, exactly)
  int threads = 0;                   // OpenMP threads; 0 = all
  // Overlap limit, a fraction of the smaller radius, in (0, 1]: overlaps this deep mean the integration has
  // failed (dt too large for the speeds, or a material far too soft); the run stops (excessive overlap).
  double maxOverlap = 0.5;
  int maxContacts = 64;              // simultaneous particle contacts of one particle; more is a collapse
  // false: a one-rank GPU run evaluates each contact once, by its lower index, adding the reactions by atomic adds
  // (EngineSetup::reproducible): 10-20 % less memory and faster, but the sums are added in no fixed order, so reruns and
  // resumes agree to rounding only. The CPU's pairs once is reproducible either way.
  bool reproducible = true;
  OnInstability onInstability = OnInstability::kStop;
  int checkpointSteps = 1000;        // reduce_dt: steps between checkpoints (also at every output)
  // Neighbour rebuilds: 0 = automatic (when a particle may have moved half the skin); N > 0 = exactly every
  // N steps whatever the displacement, so contacts can be missed on purpose (the accuracy study's sweep).
  int rebuildInterval = 0;
  std::uint64_t seed = 1;            // for anything random (jitter)
};

// Which solver runs the scene (the scene's `solver`): granular DEM, or weakly compressible SPH for fluids.
enum class Solver { kDem, kSph };

// A plane the DEM run's series measures the mass past (output.flow_planes): the mass of the particles whose centre
// lies on the side `normal` points to; its growth is the mass flow through the plane.
struct FlowPlane {
  std::string name;
  Vec3d point{0, 0, 0};   // m
  Vec3d normal{0, 0, 1};  // unit
};

// A DEM run's time series (backend/store/DemSeries.h): kinetic energy, contacts and the mass past each flow plane,
// sampled every `interval` s of simulated time, or at every snapshot when 0 (output.series_interval).
struct SeriesConfig {
  double interval = 0;
  std::vector<FlowPlane> flowPlanes;
};

// Whether a step from time `before` to `after` ends at a sample of a series taken every `interval` s: it reaches
// or passes the next multiple (the same test in the recorder and in the step that sums the wall loads for it).
inline bool seriesSampleDue(double before, double after, double interval) {
  return interval > 0 && std::floor(after / interval * (1 + 1e-12)) > std::floor(before / interval * (1 + 1e-12));
}

struct RunConfig {
  Solver solver = Solver::kDem;
  sph::SphConfig sph;  // solver: sph (the fluid, the method and its particles); unused by DEM
  std::vector<MaterialConfig> materials;
  std::vector<MaterialPairConfig> pairs;
  ParticleInit particles;
  std::vector<PlaneConfig> planes;
  std::vector<MeshConfig> meshes;
  // Name of each scene-wide surface number ("bin/bottom"); planes and mesh triangles refer to them.
  // Empty = unnamed (numbers still valid).
  std::vector<std::string> surfaceNames;
  SimulationSettings sim;
  SeriesConfig series;  // DEM; an SPH run has its probes (sph.probes)

  // Every problem at once, each naming the field (`particles.radius[12]`) and the bound it breaks.
  ErrorList validate() const;
};

// The most steps one run may take: step counts stay far inside int64, and `duration: 1e18` is an error, not an
// overflow to zero steps (it would end "succeeded" without moving).
inline constexpr double kMaxSteps = 1e12;
// "" when duration / dt is at most kMaxSteps; else what is wrong (the step and the count), for simulation.duration.
std::string stepCountProblem(double duration, double dt);
// The same as a Status (INVALID_ARGUMENT naming simulation.duration).
Status checkStepCount(double duration, double dt);

}  // namespace pflow::compute
