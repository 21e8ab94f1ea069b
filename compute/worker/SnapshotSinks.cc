#include "compute/worker/SnapshotSinks.h"

#include "backend/BackendClient.h"
#include "backend/store/SnapshotFile.h"
#include "compute/worker/SpoolingSink.h"
#include "compute/worker/WorkerOptions.h"
#include "compute/worker/WorkerRun.h"

namespace pflow::worker {

namespace {

class FileSink final : public SnapshotSink {
 public:
  explicit FileSink(std::unique_ptr<backend::SnapshotWriter> w) : m_writer(std::move(w)) {}
  Status writeGeometry(compute::GeometrySnapshot g) override { return m_writer->writeGeometry(g); }
  Status write(const compute::ParticleSnapshot& s) override { return m_writer->writeSnapshot(s); }
  Status writeProbes(const backend::ProbeSeries& samples) override { return m_writer->appendProbes(samples).status(); }
  Status close() override { return m_writer->close(); }

 private:
  std::unique_ptr<backend::SnapshotWriter> m_writer;
};

// Sends each snapshot to the back-end; the geometry travels with the first one.
class BackendSink final : public SnapshotSink {
 public:
  BackendSink(std::unique_ptr<backend::BackendClient> c, std::string jobId) : m_client(std::move(c)), m_jobId(std::move(jobId)) {}
  Status writeGeometry(compute::GeometrySnapshot g) override {  // sent with the first snapshot
    m_geometry = std::move(g);
    m_geometryPending = true;
    return Status::ok();
  }
  Status write(const compute::ParticleSnapshot& s) override {
    Status st = m_client->writeSnapshot(m_jobId, s, m_geometryPending ? &m_geometry : nullptr);
    if (st.isOk()) {
      m_geometryPending = false;
      m_geometry = {};
    }
    return st;
  }
  Status writeProbes(const backend::ProbeSeries& samples) override { return m_client->appendProbes(m_jobId, samples); }
  Status close() override { return Status::ok(); }

 private:
  std::unique_ptr<backend::BackendClient> m_client;
  std::string m_jobId;
  compute::GeometrySnapshot m_geometry;
  bool m_geometryPending = false;
};

}  // namespace

Result<std::unique_ptr<SnapshotSink>> makeBackendSink(const WorkerOptions& o) {
  SpoolOptions spool;
  spool.maxBytes = o.spoolBytes >= 1.8e19 ? ~std::uint64_t(0) : std::uint64_t(std::max(1.0, o.spoolBytes));
  spool.stopRequested = [] { return g_stopSignal != 0; };
  spool.closeWait = std::chrono::milliseconds(std::int64_t(1e3 * o.spoolCloseWait));
  return std::unique_ptr<SnapshotSink>(
      new SpoolingSink(std::make_unique<BackendSink>(backend::makeGrpcBackendClient(o.backendAddress), o.jobId), std::move(spool)));
}

Result<std::unique_ptr<SnapshotSink>> makeFileSink(const std::string& h5Path) {
  auto w = backend::SnapshotWriter::create(h5Path);
  if (!w) return w.status();
  return std::unique_ptr<SnapshotSink>(new FileSink(std::move(w).value()));
}

}  // namespace pflow::worker
