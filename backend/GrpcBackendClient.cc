// BackendClient over gRPC (sync stubs; flow control by the blocking Write/Read; a deadline on every call).
#include <grpcpp/grpcpp.h>

#include <cstdio>
#include <filesystem>
#include <vector>

#include "backend/BackendClient.h"
#include "backend/ChunkProto.h"
#include "common/rpc/Rpc.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"

namespace pflow::backend {
namespace {

class GrpcBackendClient final : public BackendClient {
 public:
  GrpcBackendClient(std::shared_ptr<grpc::Channel> channel, BackendClientOptions options)
      : m_channel(std::move(channel)), m_stub(v1::SnapshotService::NewStub(m_channel)), m_options(options) {}

  Status writeSnapshot(const std::string& jobId, const compute::ParticleSnapshot& snapshot,
                       const compute::GeometrySnapshot* geometryOrNull) override {
    auto context = rpc::contextWithDeadline(m_options.bulkDeadlineSeconds);
    v1::WriteSnapshotResponse response;
    auto writer = m_stub->WriteSnapshot(context.get(), &response);
    v1::SnapshotChunk message;
    bool broken = false;
    Status local = snapshotChunks(jobId, snapshot, geometryOrNull, [&](Chunk&& c) {
      chunkToProto(std::move(c), &message);
      if (!writer->Write(message)) {
        broken = true;  // the server ended the call: its status says why
        return Status(StatusCode::kCancelled, "stream closed");
      }
      return Status::ok();
    });
    if (!local && !broken) {
      context->TryCancel();  // the server aborts the ingest
      writer->Finish();
      return local;
    }
    if (!broken) writer->WritesDone();
    return rpc::fromGrpc(writer->Finish(), "WriteSnapshot job '" + jobId + "' step " + std::to_string(snapshot.step));
  }

  Status appendProbes(const std::string& jobId, const ProbeSeries& samples) override {
    auto requests = probesToProto(jobId, samples);
    if (!requests) return requests.status();
    for (const auto& request : requests.value()) {
      auto context = rpc::contextWithDeadline(m_options.controlDeadlineSeconds);
      v1::AppendProbesResponse response;
      if (Status st = rpc::fromGrpc(m_stub->AppendProbes(context.get(), request, &response), "AppendProbes job '" + jobId + "'"); !st)
        return st;
    }
    return Status::ok();
  }

  Result<std::vector<SnapshotInfo>> list(const std::string& jobId) override {
    auto context = rpc::contextWithDeadline(m_options.controlDeadlineSeconds);
    v1::ListSnapshotsRequest request;
    request.set_job_id(jobId);
    v1::ListSnapshotsResponse response;
    if (Status st = rpc::fromGrpc(m_stub->ListSnapshots(context.get(), request, &response), "ListSnapshots"); !st)
      return st;
    std::vector<SnapshotInfo> out;
    for (const auto& s : response.snapshots()) out.push_back({s.step(), s.time(), s.particles(), false});
    return out;
  }

  Status fetch(const std::string& jobId, std::optional<std::int64_t> step, const std::string& outputH5,
               std::vector<std::string> fields, bool includeGrid, bool includeGeometry, bool includeProbes) override {
    auto context = rpc::contextWithDeadline(m_options.bulkDeadlineSeconds);
    v1::ReadSnapshotRequest request;
    request.set_job_id(jobId);
    if (step) request.set_step(*step);
    else request.set_last(true);
    for (auto& f : fields) request.add_fields(std::move(f));
    request.set_include_grid(includeGrid);
    request.set_include_geometry(includeGeometry);
    request.set_include_probes(includeProbes);
    auto reader = m_stub->ReadSnapshot(context.get(), request);
    SnapshotFileSink sink(outputH5);
    v1::SnapshotChunk message;
    Status local;
    while (reader->Read(&message)) {
      auto chunk = chunkFromProto(std::move(message));
      if (chunk) local = sink.add(chunk.value());
      else local = chunk.status();
      if (!local) {
        context->TryCancel();
        break;
      }
    }
    const grpc::Status remote = reader->Finish();
    if (!local) return local;
    if (Status st = rpc::fromGrpc(remote, "ReadSnapshot job '" + jobId + "'"); !st) return st;
    return sink.finish();
  }

  Status writeCheckpoint(const std::string& jobId, std::int64_t step, const std::string& path) override {
    std::FILE* in = std::fopen(path.c_str(), "rb");
    if (!in) return ioError("cannot open the checkpoint '" + path + "'");
    std::error_code ec;
    const auto total = std::filesystem::file_size(path, ec);
    auto context = rpc::contextWithDeadline(m_options.bulkDeadlineSeconds);
    v1::WriteCheckpointResponse response;
    auto writer = m_stub->WriteCheckpoint(context.get(), &response);
    std::vector<char> buffer(std::size_t(1) << 20);
    v1::CheckpointChunk message;
    std::uint64_t offset = 0;
    bool broken = false;
    Status local;
    while (!ec && offset < total) {
      const std::size_t n = std::fread(buffer.data(), 1, buffer.size(), in);
      if (n == 0) {
        local = ioError("cannot read the checkpoint '" + path + "'");
        break;
      }
      message.set_job_id(jobId);
      message.set_step(step);
      message.set_total_bytes(total);
      message.set_offset(offset);
      message.set_data(buffer.data(), n);
      offset += n;
      if (!writer->Write(message)) {
        broken = true;  // the server ended the call: its status says why
        break;
      }
    }
    std::fclose(in);
    if (ec) local = ioError("cannot size the checkpoint '" + path + "': " + ec.message());
    if (!local && !broken) {
      context->TryCancel();
      writer->Finish();
      return local;
    }
    if (!broken) writer->WritesDone();
    return rpc::fromGrpc(writer->Finish(), "WriteCheckpoint job '" + jobId + "' step " + std::to_string(step));
  }

  Result<std::int64_t> readCheckpoint(const std::string& jobId, const std::string& path) override {
    auto context = rpc::contextWithDeadline(m_options.bulkDeadlineSeconds);
    v1::ReadCheckpointRequest request;
    request.set_job_id(jobId);
    auto reader = m_stub->ReadCheckpoint(context.get(), request);
    std::FILE* out = std::fopen(path.c_str(), "wb");
    if (!out) {
      context->TryCancel();
      reader->Finish();
      return ioError("cannot create '" + path + "'");
    }
    v1::CheckpointChunk message;
    Status local;
    std::int64_t step = -1;
    std::uint64_t written = 0, total = 0;
    while (reader->Read(&message)) {
      step = message.step();
      total = message.total_bytes();
      if (message.offset() != written) local = ioError("ReadCheckpoint job '" + jobId + "': chunks out of order");
      else if (std::fwrite(message.data().data(), 1, message.data().size(), out) != message.data().size())
        local = ioError("cannot write '" + path + "'");
      written += message.data().size();
      if (!local) {
        context->TryCancel();
        break;
      }
    }
    const grpc::Status remote = reader->Finish();
    if (std::fclose(out) != 0 && local) local = ioError("cannot write '" + path + "'");
    if (!local) return local;
    if (Status st = rpc::fromGrpc(remote, "ReadCheckpoint job '" + jobId + "'"); !st) return st;
    if (written != total) return ioError("ReadCheckpoint job '" + jobId + "': " + std::to_string(written) + " of " + std::to_string(total) + " bytes arrived");
    return step;
  }

 private:
  std::shared_ptr<grpc::Channel> m_channel;
  std::unique_ptr<v1::SnapshotService::Stub> m_stub;
  BackendClientOptions m_options;
};

}  // namespace

std::unique_ptr<BackendClient> makeGrpcBackendClient(std::shared_ptr<grpc::Channel> channel,
                                                     BackendClientOptions options) {
  return std::make_unique<GrpcBackendClient>(std::move(channel), options);
}

std::unique_ptr<BackendClient> makeGrpcBackendClient(const std::string& address, BackendClientOptions options) {
  return makeGrpcBackendClient(rpc::makeChannel(address), options);
}

}  // namespace pflow::backend
