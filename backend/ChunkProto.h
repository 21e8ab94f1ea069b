// Domain chunks <-> pflow.backend.v1.SnapshotChunk (bulk data moved, not copied). Service code only.
#pragma once
#include "backend/SnapshotChunks.h"
#include "common/Status.h"
#include "pflow/backend/v1/snapshot_service.pb.h"

namespace pflow::backend {

// INVALID_ARGUMENT for an unspecified section or dtype, or a grid chunk without a 3-cell grid spec.
Result<Chunk> chunkFromProto(v1::SnapshotChunk&& message);
void chunkToProto(Chunk&& chunk, v1::SnapshotChunk* message);

}  // namespace pflow::backend
