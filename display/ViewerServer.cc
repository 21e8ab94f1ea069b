#include "display/ViewerServer.h"

#include <httplib.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstring>
#include <sstream>
#include <thread>

#include "common/Address.h"
#include "common/Log.h"
#include "common/rpc/Transport.h"
#include "display/ArrayFrames.h"

namespace pflow::display {
namespace {

using nlohmann::json;

std::string tokenOf(const httplib::Request& req, bool queryToo) {
  const std::string auth = req.get_header_value("Authorization");
  const std::string prefix = "Bearer ";
  if (auth.rfind(prefix, 0) == 0) return auth.substr(prefix.size());
  if (queryToo && req.has_param("token")) return req.get_param_value("token");
  return {};
}

void sendError(httplib::Response& res, const Status& s) {
  res.status = httpStatusFor(s);
  res.set_content(json{{"error", log::escaped(s.message(), 2000)}, {"code", statusCodeName(s.code())}}.dump(), "application/json");
}

void sendJson(httplib::Response& res, const Result<json>& r) {
  if (!r) return sendError(res, r.status());
  res.set_content(r.value().dump(), "application/json");
}

// Streams a snapshot request as application/x-pflow-arrays, piece by piece as the back-end sends it; an error after
// the first byte ends the stream with an error frame.
void streamArrays(httplib::Response& res, SnapshotSource& snapshots, const std::string& token, const SnapshotRequest& r) {
  res.set_chunked_content_provider("application/x-pflow-arrays", [&snapshots, token, r](std::size_t, httplib::DataSink& sink) {
    std::string frame;
    auto send = [&] {
      const bool ok = sink.is_writable() && sink.write(frame.data(), frame.size());
      frame.clear();
      return ok;
    };
    const Status st = snapshots.readSnapshot(
        token, r, [&](std::int64_t step, double time) { appendHeaderFrame(frame, step, time), send(); },
        [&](const ArrayPiece& p) {
          appendPieceFrame(frame, p);
          return send();
        });
    if (!st) {
      appendErrorFrame(frame, st);
      send();
    }
    sink.done();
    return true;
  });
}

std::vector<std::string> splitCommas(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int httpStatusFor(const Status& s) {
  switch (s.code()) {
    case StatusCode::kOk: return 200;
    case StatusCode::kUnauthenticated: return 401;
    case StatusCode::kPermissionDenied: return 403;
    case StatusCode::kNotFound: return 404;
    case StatusCode::kInvalidArgument: return 400;
    case StatusCode::kFailedPrecondition:
    case StatusCode::kAlreadyExists: return 409;
    case StatusCode::kResourceExhausted: return 429;
    case StatusCode::kUnavailable:
    case StatusCode::kDeadlineExceeded: return 503;
    default: return 500;
  }
}

struct ViewerServer::Impl {
  std::unique_ptr<httplib::Server> server;
  std::thread thread;
  int port = 0;
};

ViewerServer::ViewerServer(std::unique_ptr<Impl> impl) : m_impl(std::move(impl)) {}
ViewerServer::~ViewerServer() { stop(); }
int ViewerServer::port() const { return m_impl->port; }

void ViewerServer::stop() {
  if (!m_impl || !m_impl->server) return;
  m_impl->server->stop();
  if (m_impl->thread.joinable()) m_impl->thread.join();
  m_impl->server.reset();
}

Result<std::unique_ptr<ViewerServer>> ViewerServer::start(const ViewerOptions& o, JobSource& jobs, SnapshotSource& snapshots) {
  const std::string host = hostOf(o.listen);
  const bool tls = !o.certFile.empty();
  if (!tls && !rpc::isLoopbackHost(host))
    return invalidArgument("--listen " + o.listen + ": plain HTTP serves loopback only (tokens would cross the network in the clear); "
                           "give --tls-dir for HTTPS");
  auto impl = std::make_unique<Impl>();
  if (tls) impl->server = std::make_unique<httplib::SSLServer>(o.certFile.c_str(), o.keyFile.c_str());
  else impl->server = std::make_unique<httplib::Server>();
  httplib::Server& svr = *impl->server;
  if (!svr.is_valid()) return invalidArgument("cannot serve HTTPS with " + o.certFile + " and " + o.keyFile);
  const int threads = o.threads;
  svr.new_task_queue = [threads] { return new httplib::ThreadPool(std::size_t(threads)); };
  svr.set_payload_max_length(1 << 20);
  svr.set_read_timeout(30, 0);
  svr.set_write_timeout(60, 0);
  // The page loads nothing from elsewhere (three.js is bundled), runs no inline script and is not framed.
  svr.set_default_headers({{"X-Content-Type-Options", "nosniff"},
                           {"Cache-Control", "no-store"},
                           {"Referrer-Policy", "no-referrer"},
                           {"Content-Security-Policy",
                            "default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' blob: data:; "
                            "connect-src 'self'; frame-ancestors 'none'; base-uri 'none'; form-action 'self'"}});

  svr.Get("/api/jobs", [&jobs](const httplib::Request& req, httplib::Response& res) {
    sendJson(res, jobs.listJobs(tokenOf(req, false), req.get_param_value("all") == "1"));
  });
  svr.Get(R"(/api/jobs/([A-Za-z0-9._-]{1,64}))", [&jobs](const httplib::Request& req, httplib::Response& res) {
    sendJson(res, jobs.getJob(tokenOf(req, false), req.matches[1]));
  });
  svr.Post(R"(/api/jobs/([A-Za-z0-9._-]{1,64})/cancel)", [&jobs](const httplib::Request& req, httplib::Response& res) {
    sendJson(res, jobs.cancelJob(tokenOf(req, false), req.matches[1]));
  });
  svr.Get("/api/nodes", [&jobs](const httplib::Request& req, httplib::Response& res) { sendJson(res, jobs.listNodes(tokenOf(req, false))); });
  // Snapshots: the manager says first whether the job is the user's (the back-end asks it too when it runs TLS;
  // this holds whatever the back-end's mode).
  svr.Get(R"(/api/jobs/([A-Za-z0-9._-]{1,64})/snapshots)", [&jobs, &snapshots](const httplib::Request& req, httplib::Response& res) {
    const std::string token = tokenOf(req, false);
    if (auto job = jobs.getJob(token, req.matches[1]); !job) return sendError(res, job.status());
    sendJson(res, snapshots.listSnapshots(token, req.matches[1]));
  });
  svr.Get(R"(/api/jobs/([A-Za-z0-9._-]{1,64})/snapshots/(last|[0-9]{1,18}))", [&jobs, &snapshots](const httplib::Request& req,
                                                                                               httplib::Response& res) {
    SnapshotRequest r;
    r.job = req.matches[1];
    if (req.matches[2] != "last") r.step = std::stoll(req.matches[2]);
    r.fields = splitCommas(req.get_param_value("fields"));
    r.grid = req.get_param_value("grid") == "1";
    r.geometry = req.get_param_value("geometry") == "1";
    // Checked first (the user's right to the job, the step's existence), so that such errors are an error status,
    // not a cut stream; then streamed piece by piece as the back-end sends them. An error after that ends the
    // stream with a frame {"error", "code"}.
    const std::string token = tokenOf(req, false);
    if (auto job = jobs.getJob(token, r.job); !job) return sendError(res, job.status());
    auto listing = snapshots.listSnapshots(token, r.job);
    if (!listing) return sendError(res, listing.status());
    bool found = !r.step && !listing.value()["snapshots"].empty();
    for (const auto& snap : listing.value()["snapshots"]) found = found || (r.step && snap["step"].get<std::int64_t>() == *r.step);
    if (!found) return sendError(res, notFound("job " + r.job + " has no snapshot " + (r.step ? "at step " + std::to_string(*r.step) : "yet")));
    streamArrays(res, snapshots, token, r);
  });
  // The run's time series (DEM series, SPH probes), with the last snapshot's step and time.
  svr.Get(R"(/api/jobs/([A-Za-z0-9._-]{1,64})/series)", [&jobs, &snapshots](const httplib::Request& req, httplib::Response& res) {
    SnapshotRequest r;
    r.job = req.matches[1];
    r.probes = true;
    r.particles = false;
    const std::string token = tokenOf(req, false);
    if (auto job = jobs.getJob(token, r.job); !job) return sendError(res, job.status());
    auto listing = snapshots.listSnapshots(token, r.job);
    if (!listing) return sendError(res, listing.status());
    if (listing.value()["snapshots"].empty()) return sendError(res, notFound("job " + r.job + " has no snapshot yet"));
    streamArrays(res, snapshots, token, r);
  });
  svr.Get(R"(/api/jobs/([A-Za-z0-9._-]{1,64})/events)", [&jobs](const httplib::Request& req, httplib::Response& res) {
    const std::string token = tokenOf(req, true), id = req.matches[1];
    res.set_header("X-Accel-Buffering", "no");
    res.set_chunked_content_provider("text/event-stream", [&jobs, token, id](std::size_t, httplib::DataSink& sink) {
      const Status s = jobs.watchJob(token, id, [&sink](const json& event) {
        const std::string line = "data: " + event.dump() + "\n\n";
        return sink.is_writable() && sink.write(line.data(), line.size());
      });
      if (!s) {
        const std::string line =
            "event: error\ndata: " + json{{"error", log::escaped(s.message(), 2000)}, {"code", statusCodeName(s.code())}}.dump() + "\n\n";
        if (sink.is_writable()) sink.write(line.data(), line.size());
      }
      sink.done();
      return true;
    });
  });
  if (!o.staticDir.empty() && !svr.set_mount_point("/", o.staticDir))
    return invalidArgument("--static " + o.staticDir + ": not a folder");

  const std::string bindHost = host.size() > 2 && host.front() == '[' ? host.substr(1, host.size() - 2) : host;
  const int wanted = std::atoi(o.listen.substr(o.listen.rfind(':') + 1).c_str());
  impl->port = wanted == 0 ? svr.bind_to_any_port(bindHost) : (svr.bind_to_port(bindHost, wanted) ? wanted : -1);
  if (impl->port <= 0) return unavailable("cannot listen on " + o.listen + " (address in use?)");
  impl->thread = std::thread([&svr] { svr.listen_after_bind(); });
  return std::unique_ptr<ViewerServer>(new ViewerServer(std::move(impl)));
}

}  // namespace pflow::display
