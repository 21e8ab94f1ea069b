// Where a worker's snapshots go: the back-end service (normal) or a local HDF5 file (standalone runs, tests).
#pragma once
#include <memory>
#include <string>

#include "common/Status.h"
#include "backend/store/ProbeSeries.h"
#include "compute/particles/ParticleSnapshot.h"

namespace pflow::worker {

class SnapshotSink {
 public:
  virtual ~SnapshotSink() = default;
  virtual Status writeGeometry(compute::GeometrySnapshot geometry) = 0;
  virtual Status write(const compute::ParticleSnapshot& snapshot) = 0;
  // Appends probe samples (an SPH run's, since the last call) to the job's /probes.
  virtual Status writeProbes(const backend::ProbeSeries& samples) = 0;
  virtual Status close() = 0;
  // Whether every output written so far has reached its destination (a sink that spools tries its spool first).
  // A checkpoint is sent only when this holds: a run resumed from it does not write its step's snapshot again.
  virtual bool delivered() { return true; }
};

Result<std::unique_ptr<SnapshotSink>> makeFileSink(const std::string& h5Path);
// Snapshots to the back-end at `address`, through a SpoolingSink (SpoolingSink.h) of the worker's spool options.
struct WorkerOptions;
Result<std::unique_ptr<SnapshotSink>> makeBackendSink(const WorkerOptions& o);

}  // namespace pflow::worker
