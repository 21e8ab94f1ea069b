#include "compute/worker/SnapshotSinks.h"

#include "backend/store/SnapshotFile.h"

namespace pflow::worker {

namespace {

class FileSink final : public SnapshotSink {
 public:
  explicit FileSink(std::unique_ptr<backend::SnapshotWriter> w) : m_writer(std::move(w)) {}
  Status writeGeometry(const compute::GeometrySnapshot& g) override { return m_writer->writeGeometry(g); }
  Status write(const compute::ParticleSnapshot& s) override { return m_writer->writeSnapshot(s); }
  Status close() override { return m_writer->close(); }

 private:
  std::unique_ptr<backend::SnapshotWriter> m_writer;
};

}  // namespace

Result<std::unique_ptr<SnapshotSink>> makeFileSink(const std::string& h5Path) {
  auto w = backend::SnapshotWriter::create(h5Path);
  if (!w) return w.status();
  return std::unique_ptr<SnapshotSink>(new FileSink(std::move(w).value()));
}

}  // namespace pflow::worker
