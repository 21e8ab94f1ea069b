// Domain chunks <-> pflow.backend.v1.SnapshotChunk (bulk data moved, not copied). Service code only.
#pragma once
#include "backend/SnapshotChunks.h"
#include "common/Status.h"
#include "pflow/backend/v1/snapshot_service.pb.h"

namespace pflow::backend {

// INVALID_ARGUMENT for an unspecified section or dtype, or a grid chunk without a 3-cell grid spec.
Result<Chunk> chunkFromProto(v1::SnapshotChunk&& message);
void chunkToProto(Chunk&& chunk, v1::SnapshotChunk* message);

// Probe samples <-> AppendProbesRequest. probesToProto cuts the samples into requests of at most 1 MiB of values
// (and at least one sample each; one request when there are none). INVALID_ARGUMENT for byte counts that do not
// make whole samples, or a series whose lists do not fit together.
Result<ProbeSeries> probesFromProto(const v1::AppendProbesRequest& request);
Result<std::vector<v1::AppendProbesRequest>> probesToProto(const std::string& jobId, const ProbeSeries& samples);

}  // namespace pflow::backend
