#include "backend/BackendClient.h"

namespace pflow::backend {

Status LocalBackendClient::writeSnapshot(const std::string& jobId, const compute::ParticleSnapshot& snapshot,
                                         const compute::GeometrySnapshot* geometryOrNull) {
  auto ingest = m_store.beginSnapshot(jobId, snapshot.step, snapshot.time, snapshot.n);
  if (!ingest) return ingest.status();
  if (Status st = snapshotChunks(jobId, snapshot, geometryOrNull,
                                 [&](Chunk&& c) { return ingest.value()->appendChunk(c); });
      !st)
    return st;
  auto result = ingest.value()->commit();
  return result.status();
}

Status LocalBackendClient::appendProbes(const std::string& jobId, const ProbeSeries& samples) {
  return m_store.appendProbes(jobId, samples).status();
}

Result<std::vector<SnapshotInfo>> LocalBackendClient::list(const std::string& jobId) {
  auto listing = m_store.list(jobId);
  if (!listing) return listing.status();
  return std::move(listing->snapshots);
}

Status LocalBackendClient::fetch(const std::string& jobId, std::optional<std::int64_t> step,
                                 const std::string& outputH5, std::vector<std::string> fields, bool includeGrid,
                                 bool includeGeometry, bool includeProbes) {
  SnapshotFileSink sink(outputH5);
  ReadRequest request{step, std::move(fields), includeGrid, includeGeometry, includeProbes};
  if (Status st = m_store.readChunks(jobId, request, [&](Chunk&& c) { return sink.add(c); }); !st) return st;
  return sink.finish();
}

}  // namespace pflow::backend
