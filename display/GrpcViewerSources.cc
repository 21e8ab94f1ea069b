#include <cstring>

#include "common/rpc/Rpc.h"
#include "display/ViewerSources.h"
#include "manager/JobJson.h"
#include "pflow/backend/v1/snapshot_service.grpc.pb.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"

namespace pflow::display {
namespace {

namespace mv1 = pflow::manager::v1;
namespace bv1 = pflow::backend::v1;
namespace cv1 = pflow::common::v1;
using nlohmann::json;

std::unique_ptr<grpc::ClientContext> callFor(const std::string& token, double seconds = rpc::kControlDeadlineSeconds) {
  auto ctx = rpc::contextWithDeadline(seconds);
  rpc::addBearer(*ctx, token);
  return ctx;
}

class GrpcJobSource final : public JobSource {
 public:
  explicit GrpcJobSource(const std::string& address) : m_stub(mv1::ManagerService::NewStub(rpc::makeChannel(address))) {}

  Result<json> listJobs(const std::string& token, bool all) override {
    mv1::ListJobsRequest req;
    req.set_active_only(!all);
    mv1::ListJobsResponse resp;
    if (auto s = m_stub->ListJobs(callFor(token).get(), req, &resp); !s.ok()) return rpc::fromGrpc(s);
    json out = json::array();
    for (const auto& j : resp.jobs()) out.push_back(manager::toJson(j));
    return out;
  }
  Result<json> getJob(const std::string& token, const std::string& id) override {
    mv1::GetJobRequest req;
    req.set_id(id);
    mv1::Job job;
    if (auto s = m_stub->GetJob(callFor(token).get(), req, &job); !s.ok()) return rpc::fromGrpc(s);
    return manager::toJson(job);
  }
  Result<json> cancelJob(const std::string& token, const std::string& id) override {
    mv1::CancelJobRequest req;
    req.set_id(id);
    mv1::Job job;
    if (auto s = m_stub->CancelJob(callFor(token).get(), req, &job); !s.ok()) return rpc::fromGrpc(s);
    return manager::toJson(job);
  }
  Result<json> listNodes(const std::string& token) override {
    mv1::ListNodesResponse resp;
    if (auto s = m_stub->ListNodes(callFor(token).get(), mv1::ListNodesRequest(), &resp); !s.ok()) return rpc::fromGrpc(s);
    json out = json::array();
    for (const auto& n : resp.nodes()) out.push_back(manager::toJson(n));
    return out;
  }
  Status watchJob(const std::string& token, const std::string& id, const std::function<bool(const json&)>& onEvent) override {
    mv1::WatchJobRequest req;
    req.set_id(id);
    // At most kWatchSeconds: an event stream holds an HTTP worker, and a closed page is only noticed at the next
    // event; the browser's EventSource reconnects by itself when the stream ends.
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(kWatchSeconds));
    rpc::addBearer(ctx, token);
    auto reader = m_stub->WatchJob(&ctx, req);
    mv1::JobEvent ev;
    while (reader->Read(&ev)) {
      if (!onEvent(manager::toJson(ev))) {
        ctx.TryCancel();
        break;
      }
    }
    const grpc::Status s = reader->Finish();
    const bool ended = s.error_code() == grpc::StatusCode::CANCELLED || s.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED;
    return ended ? Status::ok() : rpc::fromGrpc(s);
  }

 private:
  static constexpr int kWatchSeconds = 120;
  std::unique_ptr<mv1::ManagerService::Stub> m_stub;
};

// Little-endian values of one dtype as float32.
template <class T>
void widen(const std::string& data, std::vector<float>& out) {
  const std::size_t n = data.size() / sizeof(T);
  out.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    T v;
    std::memcpy(&v, data.data() + i * sizeof(T), sizeof(T));
    out[i] = static_cast<float>(v);
  }
}

const char* sectionName(bv1::Section s) {
  switch (s) {
    case bv1::SECTION_GRID: return "grid";
    case bv1::SECTION_GEOMETRY: return "geometry";
    case bv1::SECTION_PROBES: return "probes";
    default: return "particles";
  }
}

class GrpcSnapshotSource final : public SnapshotSource {
 public:
  explicit GrpcSnapshotSource(const std::string& address) : m_stub(bv1::SnapshotService::NewStub(rpc::makeChannel(address))) {}

  Result<json> listSnapshots(const std::string& token, const std::string& job) override {
    bv1::ListSnapshotsRequest req;
    req.set_job_id(job);
    bv1::ListSnapshotsResponse resp;
    if (auto s = m_stub->ListSnapshots(callFor(token).get(), req, &resp); !s.ok()) return rpc::fromGrpc(s);
    json snaps = json::array();
    for (const auto& s : resp.snapshots()) snaps.push_back({{"step", s.step()}, {"time", s.time()}, {"particles", s.particles()}});
    return json{{"job", job}, {"snapshots", snaps}};
  }

  Status readSnapshot(const std::string& token, const SnapshotRequest& r, const std::function<void(std::int64_t, double)>& onHeader,
                      const std::function<bool(const ArrayPiece&)>& onPiece) override {
    bv1::ReadSnapshotRequest req;
    req.set_job_id(r.job);
    if (r.step) req.set_step(*r.step);
    else req.set_last(true);
    for (const auto& f : r.fields) req.add_fields(f);
    req.set_include_grid(r.grid);
    req.set_include_geometry(r.geometry);
    req.set_include_probes(r.probes);
    req.set_skip_particles(!r.particles);
    auto ctx = callFor(token, rpc::kBulkDeadlineSeconds);
    auto reader = m_stub->ReadSnapshot(ctx.get(), req);
    bv1::SnapshotChunk chunk;
    bool first = true;
    ArrayPiece piece;
    while (reader->Read(&chunk)) {
      if (first) onHeader(chunk.step(), chunk.time()), first = false;
      const cv1::ArrayChunk& a = chunk.array();
      piece.section = sectionName(chunk.section());
      piece.grid.reset();
      piece.strings.clear();
      piece.values.clear();
      if (a.dtype() == cv1::DTYPE_STRING) {  // names (geometry's surface names): each a u32 length and its bytes
        piece.name = a.name();
        const std::string& d = a.data();
        for (std::size_t at = 0; at + 4 <= d.size();) {
          std::uint32_t n = 0;
          std::memcpy(&n, d.data() + at, 4);
          at += 4;
          if (n > d.size() - at) break;
          piece.strings.push_back(d.substr(at, n));
          at += n;
        }
        if (!piece.strings.empty() && !onPiece(piece)) {
          ctx->TryCancel();
          break;
        }
        continue;
      }
      if (chunk.has_grid() && chunk.grid().cells_size() == 3) {
        const auto& g = chunk.grid();
        GridInfo info;
        info.origin[0] = g.origin().x(), info.origin[1] = g.origin().y(), info.origin[2] = g.origin().z();
        info.cellSize = g.cell_size();
        for (int k = 0; k < 3; ++k) info.cells[k] = g.cells(k);
        piece.grid = info;
      }
      piece.name = a.name();
      piece.unit = a.unit();
      piece.firstRow = a.first_row();
      piece.rows = a.rows();
      piece.totalRows = a.shape_size() > 0 ? a.shape(0) : 0;
      piece.components = 1;
      for (int k = 1; k < a.shape_size(); ++k) piece.components *= a.shape(k);
      switch (a.dtype()) {
        case cv1::DTYPE_F64: widen<double>(a.data(), piece.values); break;
        case cv1::DTYPE_F32: widen<float>(a.data(), piece.values); break;
        case cv1::DTYPE_I32: widen<std::int32_t>(a.data(), piece.values); break;
        case cv1::DTYPE_U32: widen<std::uint32_t>(a.data(), piece.values); break;
        case cv1::DTYPE_I64: widen<std::int64_t>(a.data(), piece.values); break;
        case cv1::DTYPE_U64: widen<std::uint64_t>(a.data(), piece.values); break;
        default: continue;
      }
      if (!onPiece(piece)) {
        ctx->TryCancel();
        break;
      }
    }
    const grpc::Status s = reader->Finish();
    return s.error_code() == grpc::StatusCode::CANCELLED ? Status::ok() : rpc::fromGrpc(s);
  }

 private:
  std::unique_ptr<bv1::SnapshotService::Stub> m_stub;
};

}  // namespace

std::unique_ptr<JobSource> makeGrpcJobSource(const std::string& managerAddress) { return std::make_unique<GrpcJobSource>(managerAddress); }
std::unique_ptr<SnapshotSource> makeGrpcSnapshotSource(const std::string& backendAddress) {
  return std::make_unique<GrpcSnapshotSource>(backendAddress);
}

}  // namespace pflow::display
