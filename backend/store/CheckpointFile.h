// A run's checkpoint file: everything `pflow run --resume` needs to go on from a step bit for bit (issue 18;
// docs/operations.md, "Checkpoints"). HDF5, SI units, readable with h5py:
//   /            attributes format = "pflow-checkpoint", version = 1, solver ("dem" | "sph"), precision ("float" |
//                "double"), step, time [s], dt [s], dt_before [s], step_base, time_base [s], rebuilds, reductions,
//                contact_slots, wall_slots, particles, scene (the scene's YAML text), scene_dir (the folder its
//                relative paths start from), scene_file (its path when written)
//   /particles/<field>   one dataset per field of the state (n x components, the table's own type; a slot field
//                        holds slots x components per row), with its unit
// Written to PATH.tmp, flushed to disk (fsync), then renamed over PATH after the previous PATH became PATH.1: the
// last two are kept, and a file cut off mid-write is never under either name.
#pragma once
#include <cstdint>
#include <string>

#include "common/Status.h"
#include "compute/sim/SimulationState.h"

namespace pflow::backend {

struct CheckpointData {
  std::string solver = "dem";
  std::string precision;  // "float" | "double": a checkpoint resumes at its own precision
  std::string sceneText, sceneDir, sceneFile;
  compute::SimulationState state;  // compute/sim/SimulationState.h
};

// What a checkpoint's root attributes say, without reading its particles (the back-end's check of an upload).
struct CheckpointHeader {
  std::string solver, precision;
  std::int64_t step = 0;
  double time = 0;  // s
  std::int64_t particles = 0;
};

// `scratch`: a copy only on its way elsewhere (the worker's, sent to the back-end, which makes it durable): written
// in place, neither flushed to disk nor rotated.
Status writeCheckpoint(const std::string& path, const CheckpointData& data, bool scratch = false);
// A file's bytes (or a folder's entries) flushed to the disk (fsync): before a rename puts it in place, and after.
Status syncPath(const std::string& path, bool directory);
// INVALID_ARGUMENT for a file that is not a pflow checkpoint of this format version; NOT_FOUND for no file.
Result<CheckpointHeader> readCheckpointHeader(const std::string& path);
Result<CheckpointData> readCheckpoint(const std::string& path);
// PATH, else (unreadable: cut off, corrupted, missing) PATH.1, saying why PATH was passed over in `skipped`.
Result<CheckpointData> readLatestCheckpoint(const std::string& path, std::string* skipped = nullptr);
// PATH.1: the checkpoint before the last.
std::string previousCheckpointPath(const std::string& path);

}  // namespace pflow::backend
