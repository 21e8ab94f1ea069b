#include "manager/ManagerService.h"

#include <spdlog/spdlog.h>

#include "common/rpc/Rpc.h"
#include "manager/ProtoConvert.h"

namespace pflow::manager {

namespace {

// Runs `work` (returning a grpc::Status) on the pool and finishes the call with it.
template <class Work>
grpc::ServerUnaryReactor* onPool(grpc::CallbackServerContext* ctx, TaskPool& pool, Work work) {
  grpc::ServerUnaryReactor* reactor = ctx->DefaultReactor();
  pool.post([reactor, work = std::move(work)]() mutable { reactor->Finish(work()); });
  return reactor;
}

grpc::ServerUnaryReactor* finishNow(grpc::CallbackServerContext* ctx, const grpc::Status& s) {
  grpc::ServerUnaryReactor* reactor = ctx->DefaultReactor();
  reactor->Finish(s);
  return reactor;
}

// WatchJob: the job now, then each change; finishes OK after the final state has been written. Events are queued
// while a write is in flight; consecutive progress events of the same state waiting in the queue are coalesced to
// the newest, so a slow watcher cannot make the queue grow without bound.
class WatchReactor final : public grpc::ServerWriteReactor<v1::JobEvent> {
 public:
  WatchReactor(Manager& manager, const std::string& id) : m_manager(manager) {
    // The callback may run right here (the job now) or on any thread later; gRPC runs no reaction (OnDone
    // included) before this handler has returned the reactor.
    auto sub = manager.watch(id, [this](const JobEvent& e) { onEvent(e); });
    std::lock_guard lock(m_mu);
    if (!sub) {
      finishLocked(rpc::toGrpc(sub.status()));
      return;
    }
    m_sub = sub.value();
  }

  void OnWriteDone(bool ok) override {
    std::lock_guard lock(m_mu);
    m_writing = false;
    if (!ok) {  // the client went away or the call was cancelled
      finishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "watch cancelled"));
      return;
    }
    m_queue.pop_front();
    nextLocked();
  }

  void OnCancel() override {
    std::lock_guard lock(m_mu);
    m_cancelled = true;
    if (!m_writing) finishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "watch cancelled"));
  }

  void OnDone() override {
    m_manager.unwatch(m_sub);  // after this returns, onEvent is never called again
    delete this;
  }

 private:
  void onEvent(const JobEvent& e) {
    std::lock_guard lock(m_mu);
    if (m_finished || m_cancelled) return;
    v1::JobEvent ev;
    *ev.mutable_job() = toProto(e.job);
    ev.set_message(e.message);
    // Coalesce with a waiting (not in flight) event of the same state.
    if (m_queue.size() >= 2 && m_queue.back().job().state() == ev.job().state())
      m_queue.back() = std::move(ev);
    else
      m_queue.push_back(std::move(ev));
    if (isFinal(e.job.state)) m_sawFinal = true;
    nextLocked();
  }

  void nextLocked() {
    if (m_writing || m_finished) return;
    if (m_cancelled) {
      finishLocked(grpc::Status(grpc::StatusCode::CANCELLED, "watch cancelled"));
    } else if (!m_queue.empty()) {
      m_writing = true;
      StartWrite(&m_queue.front());
    } else if (m_sawFinal) {
      finishLocked(grpc::Status::OK);
    }
  }

  void finishLocked(const grpc::Status& s) {
    if (m_finished) return;
    m_finished = true;
    Finish(s);
  }

  Manager& m_manager;
  std::mutex m_mu;
  std::uint64_t m_sub = 0;
  std::deque<v1::JobEvent> m_queue;  // front: in flight while m_writing
  bool m_writing = false;
  bool m_sawFinal = false;
  bool m_cancelled = false;
  bool m_finished = false;
};

}  // namespace

// ---- ManagerService ----------------------------------------------------------------------------------------------

grpc::ServerUnaryReactor* ManagerServiceImpl::SubmitJob(grpc::CallbackServerContext* ctx, const v1::SubmitJobRequest* req,
                                                        v1::SubmitJobResponse* resp) {
  return onPool(ctx, m_pool, [this, req, resp] {
    auto job = m_manager.submit(fromProto(*req));
    if (!job) return rpc::toGrpc(job.status());
    *resp->mutable_job() = toProto(job.value());
    return grpc::Status::OK;
  });
}

grpc::ServerUnaryReactor* ManagerServiceImpl::GetJob(grpc::CallbackServerContext* ctx, const v1::GetJobRequest* req, v1::Job* resp) {
  auto job = m_manager.get(req->id());
  if (job) *resp = toProto(job.value());
  return finishNow(ctx, rpc::toGrpc(job.status()));
}

grpc::ServerUnaryReactor* ManagerServiceImpl::ListJobs(grpc::CallbackServerContext* ctx, const v1::ListJobsRequest* req,
                                                       v1::ListJobsResponse* resp) {
  for (const Job& j : m_manager.list(req->active_only())) *resp->add_jobs() = toProto(j);
  return finishNow(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* ManagerServiceImpl::CancelJob(grpc::CallbackServerContext* ctx, const v1::CancelJobRequest* req, v1::Job* resp) {
  return onPool(ctx, m_pool, [this, req, resp] {
    auto job = m_manager.cancel(req->id());
    if (job) *resp = toProto(job.value());
    return rpc::toGrpc(job.status());
  });
}

grpc::ServerWriteReactor<v1::JobEvent>* ManagerServiceImpl::WatchJob(grpc::CallbackServerContext*, const v1::WatchJobRequest* req) {
  return new WatchReactor(m_manager, req->id());
}

grpc::ServerUnaryReactor* ManagerServiceImpl::ListNodes(grpc::CallbackServerContext* ctx, const v1::ListNodesRequest*,
                                                        v1::ListNodesResponse* resp) {
  for (const NodeView& n : m_manager.nodes()) *resp->add_nodes() = toProto(n);
  return finishNow(ctx, grpc::Status::OK);
}

// ---- NodeRegistry ------------------------------------------------------------------------------------------------

grpc::ServerUnaryReactor* NodeRegistryImpl::Heartbeat(grpc::CallbackServerContext* ctx, const v1::HeartbeatRequest* req,
                                                      v1::HeartbeatResponse* resp) {
  return onPool(ctx, m_pool, [this, req, resp] {
    auto hb = fromProto(*req);
    if (!hb) return rpc::toGrpc(hb.status());
    auto reply = m_manager.heartbeat(hb.value());
    if (!reply) return rpc::toGrpc(reply.status());
    resp->set_heartbeat_interval_seconds(reply->heartbeatIntervalSeconds);
    for (const std::string& id : reply->stopJobs) resp->add_stop_jobs(id);
    return grpc::Status::OK;
  });
}

grpc::ServerUnaryReactor* NodeRegistryImpl::ReportProgress(grpc::CallbackServerContext* ctx, const v1::ReportProgressRequest* req,
                                                           v1::ReportProgressResponse* resp) {
  auto cancel = m_manager.reportProgress(req->job_id(), fromProto(req->progress()), req->message(), req->attempt());
  if (cancel) resp->set_cancel(cancel.value());
  return finishNow(ctx, rpc::toGrpc(cancel.status()));
}

grpc::ServerUnaryReactor* NodeRegistryImpl::ReportJobExit(grpc::CallbackServerContext* ctx, const v1::ReportJobExitRequest* req,
                                                          v1::ReportJobExitResponse*) {
  return onPool(ctx, m_pool, [this, req] {
    return rpc::toGrpc(m_manager.reportExit(req->job_id(), req->node(), req->exit_code(), req->reason()));
  });
}

}  // namespace pflow::manager
