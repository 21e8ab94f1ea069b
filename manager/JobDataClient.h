// What the manager asks of the back-end when a job is deleted: drop everything stored for it. GrpcJobDataClient is
// the real one (SnapshotService.DeleteJobData, with the manager's certificate); tests use a fake. Thread-safe, with a
// deadline per call.
#pragma once
#include <memory>
#include <string>

#include "common/Status.h"

namespace pflow::manager {

class JobDataClient {
 public:
  virtual ~JobDataClient() = default;
  // OK when nothing of the job is left on the back-end (also when nothing was there); UNAVAILABLE when it cannot be
  // reached; FAILED_PRECONDITION while it is receiving a snapshot of the job.
  virtual Status deleteJobData(const std::string& jobId) = 0;
};

// The back-end at `address` over gRPC.
std::unique_ptr<JobDataClient> makeGrpcJobDataClient(const std::string& address);

}  // namespace pflow::manager
