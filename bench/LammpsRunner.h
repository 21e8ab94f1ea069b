// Runs LAMMPS on the same DEM bed that pflow's benchmark times, to compare throughput fairly.
//
// The runner writes a LAMMPS data file and input script (units si, atom_style sphere, pair_style granular with
// hertz/material + tsuji damping + mindlin tangential, fix wall/gran planes, fix nve/sphere, fix gravity), runs
// `lmp` (under mpirun when ranks > 1) and parses the "Loop time" line of the log (the timed loop only: setup, the
// first neighbour build and force evaluation, is excluded). The domain is split in x and y only (`processors * * 1`):
// gravity makes a bed non-uniform in z, and a z split unbalances the ranks.
//
// Two quirks of the LAMMPS 29 Sep 2021 / 2022-01-06 Debian build are corrected here so that LAMMPS computes the same
// physics as pflow (both found by measurement, see tests/bench/lammps_runner_test.cc):
//  - `damping tsuji` realises a larger restitution than requested (input 0.367 gives 0.5): LAMMPS applies
//    alpha(e)*sqrt(m* k_n delta^(1/2))*v_n with k_n = (4/3)E*sqrt(R*), but its polynomial alpha(e) only yields e
//    when the damping is sqrt(2) times that. LammpsBed::restitution is the restitution to realise;
//    lammpsTsujiInputFor() gives the input that realises it (from the Hertz equation of motion, checked in LAMMPS).
//  - `fix wall/gran ... hertz/material E e nu` uses E* = E/(2(1-nu)) instead of E/(2(1-nu^2)), and its derived
//    Mindlin stiffness (tangential mindlin NULL) is E(2-nu)(1+nu)/4 instead of 8G*. The runner passes
//    E/(1+nu) and an explicit k_t = 8G* to the walls so they act as a wall of the bed's own material.
#pragma once
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/Status.h"
#include "compute/core/VectorMath.h"

namespace pflow::bench {

// One monodisperse-or-polydisperse bed of spheres of one material, in SI units.
struct LammpsBed {
  std::vector<Vec3d> position;         // m
  std::vector<Vec3d> velocity;         // m/s (empty = all zero)
  std::vector<Vec3d> angularVelocity;  // rad/s (empty = all zero)
  std::vector<double> radius;          // m
  double density = 2500.0;             // kg/m^3
  double youngsModulus = 1e7;          // Pa
  double poissonRatio = 0.3;
  double restitution = 0.5;            // the restitution to realise (converted to LAMMPS's tsuji input)
  double friction = 0.5;               // sliding (Coulomb) coefficient, particles and walls
  double rollingFriction = 0.0;        // > 0 adds `rolling sds` with this mu_roll
  double tangentialDampingRatio = 1.0; // LAMMPS x_gamma_t: tangential / normal damping coefficient
  bool clipNormalForce = true;         // LAMMPS `limit_damping`: damping never makes the normal force attractive
  Vec3d boxLo{0, 0, 0};                // walls at x = lo.x, hi.x; y = lo.y, hi.y; z = lo.z (the top is open)
  Vec3d boxHi{0, 0, 0};                // boxHi.z is only the least height of the LAMMPS box (it grows with the bed)
  Vec3d gravity{0, 0, -9.81};          // m/s^2
  double dt = 5e-6;                    // s
  double skin = 1e-4;                  // m, neighbour skin; contact list checked every step
  long steps = 1000;
};

struct LammpsOptions {
  int ranks = 1;                      // MPI ranks (1 runs lmp directly)
  std::string lmp = "lmp";            // executable name or path
  std::string mpirun = "mpirun";      // Open MPI launcher
  std::string mpirunArgs = "--oversubscribe";  // extra launcher flags, e.g. "--bind-to none" on a busy machine
  std::string workDir;                // empty: a fresh temporary directory, removed afterwards unless keepFiles
  bool keepFiles = false;             // keep the temporary directory (data, input, log)
  bool newtonPair = true;             // LAMMPS `newton on` (the default; fastest with several ranks)
};

struct LammpsResult {
  double loopSeconds = 0;             // "Loop time of X" (wall seconds of the timed loop, setup excluded)
  double particleStepsPerSecond = 0;  // atoms * steps / loopSeconds
  long steps = 0;
  long atoms = 0;
  int ranks = 0;
  long neighborBuilds = -1;           // "Neighbor list builds = N" (-1 when absent)
  long dangerousBuilds = -1;          // "Dangerous builds = N" (-1 when absent)
  double tsujiInput = 0;              // the restitution passed to `damping tsuji`
  std::string lammpsVersion;          // e.g. "29 Sep 2021 - Update 2"
  // "MPI task timing breakdown": each section's average seconds over ranks (Pair, Neigh, Comm, Output,
  // Modify, Other), in the log's order; empty when the log has none.
  std::vector<std::pair<std::string, double>> sections;
  std::string command;                // the shell command that ran LAMMPS
  std::string logPath;                // LAMMPS log; empty when the work directory was removed
};

// Runs LAMMPS on the bed and returns its throughput. Fails with a message naming the command, its exit status and
// the log when LAMMPS fails.
Result<LammpsResult> runLammps(const LammpsBed& bed, const LammpsOptions& options);

// The LAMMPS input script for the bed, reading the data file `dataFile` (a path LAMMPS can open).
std::string lammpsInputScript(const LammpsBed& bed, const std::string& dataFile, bool newtonPair = true);

// Writes the bed as a LAMMPS data file (atom_style sphere, with a Velocities section).
Status writeLammpsData(const LammpsBed& bed, const std::string& path);

// Checks the bed: sizes, positive properties, every centre inside the walls.
Status validateBed(const LammpsBed& bed);

// Runs an arbitrary LAMMPS input script (it may read files from the work directory) and returns the log text.
Result<std::string> runLammpsInput(const std::string& script, const LammpsOptions& options);

// "lmp" (or $PFLOW_LAMMPS) resolved on PATH, or nullopt when LAMMPS is not installed.
std::optional<std::string> findLammps();

// --- restitution mapping for `damping tsuji` ----------------------------------------------------------------

// LAMMPS's Tsuji polynomial alpha(e) (Tsuji et al. 1992 fit) applied to the tsuji damping input e.
double tsujiAlpha(double tsujiInput);

// Restitution of a Hertz contact with damping force alpha*sqrt(m* k_n)*delta^(1/4)*v_n, k_n = (4/3)E*sqrt(R*),
// from the continuous equation of motion (it depends on alpha only); clipped: total normal force kept >= 0.
double hertzTsujiRestitution(double alpha, bool clipped);

// The `damping tsuji` input that realises `restitution` in this LAMMPS version (0.367 for 0.5 unclipped).
// NaN when no input in [0, 1] reaches it: below 0.114 unclipped, below 0.263 clipped.
double lammpsTsujiInputFor(double restitution, bool clipped = false);

// One head-on impact, to measure what LAMMPS realises.
struct ImpactSpec {
  double radius = 0.5e-3, density = 2500.0, youngsModulus = 1e7, poissonRatio = 0.3;
  double speed = 0.5;     // approach speed (relative speed for two spheres)
  double dt = 5e-7;
  bool onWall = true;     // sphere onto the floor wall; false: two equal spheres
  bool clipNormalForce = false;
};

// Runs the impact in LAMMPS with `damping tsuji tsujiInput` (walls corrected as in runLammps) and returns the
// measured restitution (outgoing over incoming normal speed), with no gravity.
Result<double> measureLammpsRestitution(double tsujiInput, const ImpactSpec& spec, const LammpsOptions& options);

}  // namespace pflow::bench
