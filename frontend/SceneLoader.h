// Scene file (YAML, SI units) -> compute::RunConfig. The format is documented in docs/scene-format.md.
// Every problem is reported at once: parse errors, unknown keys (with a did-you-mean), wrong types, missing keys,
// then RunConfig::validate()'s findings, each with its YAML key path and, where known, line and column.
// Particles are generated (frontend/generators) and shapes tessellated (frontend/geometry) while loading, so a
// LoadedScene is the complete initial state of a run. No gRPC here: the frontend service is an adapter over this.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "common/Status.h"
#include "compute/dem/AccuracyTable.h"
#include "compute/sim/RunConfig.h"

namespace pflow::frontend {

// One scene-wide surface: a plane, or the triangles of one part of a shape (a box face, a hopper's cone).
struct SurfaceInfo {
  std::int32_t id = 0;     // the number results and forces refer to (RunConfig::surfaceNames index)
  std::string name;        // "<wall>/<part>", e.g. "bin/bottom"; a plane's is its wall name
  std::string wall;        // the geometry entry's name
  std::size_t triangles = 0;  // 0 for a plane
  double area = 0;         // [m^2]; 0 for a plane (infinite)
};

// One `particles` entry after generation.
struct ParticleSetInfo {
  std::string name;
  std::string method;             // lattice, random, tiled, list
  std::size_t first = 0, count = 0;  // particle indices [first, first + count)
  double minRadius = 0, maxRadius = 0;  // [m] of the particles made
  double solidVolume = 0;         // [m^3], sum of the particles' volumes
  double regionVolume = 0;        // [m^3]; 0 when the set has no region (list)
};

// The scene's `slurm:` section: what its job asks of Slurm when the manager places jobs through Slurm
// (docs/cluster.md); empty fields take the manager's defaults. Under agents it has no effect.
struct SlurmRequest {
  std::string partition;
  std::string account;
  std::string timeLimit;  // Slurm's formats: MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS, UNLIMITED
};

struct LoadedScene {
  compute::RunConfig config;
  std::string sourcePath;  // the file read, or the sourceName given to loadSceneFromString
  std::string outputFile;  // output.file; empty = not given (the CLI's -o decides)
  double checkpointInterval = 0;  // output.checkpoint_interval [s] of simulated time; 0 = not given (docs/operations.md)
  std::vector<std::string> outputFields;  // output.fields; empty = every snapshot field
  std::vector<SurfaceInfo> surfaces;      // by surface number
  std::vector<ParticleSetInfo> sets;
  std::vector<std::string> files;         // files the scene refers to (meshes, CSV), as written, relative to it
  SlurmRequest slurm;                     // slurm: (placement through Slurm)
};

// Where relative file names point, and limits that protect a process (a service, a fuzzer) from scenes that would
// exhaust memory or time; exceeding one is an error naming the limit.
struct LoadOptions {
  std::string baseDir;                        // relative file names in the scene resolve here; "" = current dir
  std::size_t maxParticles = std::size_t(1) << 30;
  std::size_t maxTriangles = 20'000'000;
  // Most lattice sites one particle set may test against its region (the work of a thin region in large bounds).
  std::size_t maxLatticeSites = std::size_t(1) << 32;
  // Files the scene names (meshes, particle CSV): confined to baseDir (the service: the scene's own upload; no absolute
  // paths, no '..', no links out), and at most this size each. Every file is a regular file, confined or not.
  bool confineFiles = false;
  std::uintmax_t maxFileBytes = std::uintmax_t(1) << 31;
  std::size_t maxSceneBytes = std::size_t(64) << 20;  // the YAML text
  // The accuracy study's table that simulation.accuracy.quantity must name a quantity of (null: the built-in
  // one; an empty table accepts any name, and validate says it has no proposal).
  const compute::AccuracyTable* accuracyTable = nullptr;
};

// Reads and loads a scene file. I/O problems give StatusCode::kIo, scene problems kInvalidArgument with one error per
// line. Relative file names in the scene (meshes, particle CSV files) are relative to the scene file's folder.
// options.baseDir is replaced by the scene file's folder.
Result<LoadedScene> loadScene(const std::string& path, LoadOptions options = {});

// Loads a scene from YAML text; sourceName names it in messages.
Result<LoadedScene> loadSceneFromString(const std::string& yaml, const std::string& sourceName = "<string>",
                                        const LoadOptions& options = {});

}  // namespace pflow::frontend
