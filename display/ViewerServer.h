// pflow-web's HTTP side (cpp-httplib): JSON for jobs and nodes, snapshot arrays in a compact binary form, a job's
// changes as server-sent events, and the page's static files. Each request acts for the user whose token it carries
// (`Authorization: Bearer <token>`, or `?token=` for event streams, which browsers open without headers); the
// manager and the back-end decide what that user may see. No simulation logic here. docs/viewer.md.
//
//   GET  /api/jobs[?all=1]                 the user's jobs (an admin's: everyone's), JSON (manager/JobJson.h)
//   GET  /api/jobs/ID                      one job
//   POST /api/jobs/ID/cancel               cancel it
//   GET  /api/jobs/ID/events               text/event-stream: the job now, then each change, until it ends (or for
//                                          at most 2 minutes: EventSource reconnects)
//   GET  /api/jobs/ID/snapshots            {"job", "snapshots": [{"step", "time", "particles"}]}
//   GET  /api/jobs/ID/snapshots/STEP|last  ?fields=position,velocity&grid=1&geometry=1: application/x-pflow-arrays
//   GET  /api/nodes                        nodes and devices
//   GET  /...                              files of --static (the page)
//
// application/x-pflow-arrays: frames, each a little-endian u32 n, n bytes of JSON, then the frame's values as
// little-endian float32. The first frame is {"step", "time"} with no values; each other is one piece of an array,
// {"section", "name", "first_row", "rows", "total_rows", "components", "unit"} followed by rows x components
// values (at most 1 MiB a piece). The answer streams as the back-end sends it; an error after the first byte ends it
// with a frame {"error", "code"}.
#pragma once
#include <memory>
#include <string>

#include "common/Status.h"
#include "display/ViewerSources.h"

namespace pflow::display {

struct ViewerOptions {
  std::string listen = "127.0.0.1:8080";  // host:port (port 0: any free one)
  std::string staticDir;                  // the page's files ("" = none)
  std::string certFile, keyFile;          // HTTPS; required unless listening on loopback
  int threads = 32;                       // HTTP workers (event streams hold one each while open)
};

class ViewerServer {
 public:
  static Result<std::unique_ptr<ViewerServer>> start(const ViewerOptions& options, JobSource& jobs, SnapshotSource& snapshots);
  ~ViewerServer();
  int port() const;
  void stop();

 private:
  struct Impl;
  explicit ViewerServer(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> m_impl;
};

// The HTTP status for a pflow Status (401 UNAUTHENTICATED, 403 PERMISSION_DENIED, 404, 400, 409, 429, 503, 500).
int httpStatusFor(const Status& s);

}  // namespace pflow::display
