#include "backend/BackendClient.h"

#include <filesystem>
#include <fstream>
#include <vector>

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

Status LocalBackendClient::writeCheckpoint(const std::string& jobId, std::int64_t step, const std::string& path) {
  std::error_code ec;
  const auto total = std::filesystem::file_size(path, ec);
  if (ec) return ioError("cannot size the checkpoint '" + path + "': " + ec.message());
  auto upload = m_store.checkpoints().begin(jobId, step, total);
  if (!upload) return upload.status();
  std::ifstream in(path, std::ios::binary);
  std::vector<char> buffer(std::size_t(1) << 20);
  std::uint64_t offset = 0;
  while (offset < total) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    const auto n = std::size_t(in.gcount());
    if (n == 0) return ioError("cannot read the checkpoint '" + path + "'");
    PFLOW_TRY(upload.value()->append(offset, buffer.data(), n));
    offset += n;
  }
  return upload.value()->commit().status();
}

Result<std::int64_t> LocalBackendClient::readCheckpoint(const std::string& jobId, const std::string& path) {
  auto latest = m_store.checkpoints().latest(jobId);
  if (!latest) return latest.status();
  std::error_code ec;
  std::filesystem::copy_file(latest->path, path, std::filesystem::copy_options::overwrite_existing, ec);
  if (ec) return ioError("cannot copy '" + latest->path + "' to '" + path + "': " + ec.message());
  return latest->step;
}

}  // namespace pflow::backend
