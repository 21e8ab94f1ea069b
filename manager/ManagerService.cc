#include "manager/ManagerService.h"

#include <spdlog/spdlog.h>

#include "common/Log.h"
#include "common/rpc/Rpc.h"
#include "manager/ProtoConvert.h"

namespace pflow::manager {

namespace {

// Runs `work` (returning a grpc::Status) on the pool and finishes the call with it; a call whose deadline passed
// (or that its caller cancelled) while it waited for a thread is answered DEADLINE_EXCEEDED without being done.
template <class Work>
grpc::ServerUnaryReactor* onPool(grpc::CallbackServerContext* ctx, TaskPool& pool, Work work) {
  grpc::ServerUnaryReactor* reactor = ctx->DefaultReactor();
  pool.post([ctx, reactor, work = std::move(work)]() mutable {
    if (ctx->IsCancelled()) reactor->Finish(grpc::Status(grpc::StatusCode::DEADLINE_EXCEEDED, "the call waited past its deadline"));
    else reactor->Finish(work());
  });
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
  WatchReactor(Manager& manager, const Result<Principal>& who, const std::string& id) : m_manager(manager) {
    if (!who) {
      std::lock_guard lock(m_mu);
      finishLocked(rpc::toGrpc(who.status()));
      return;
    }
    // The callback may run right here (the job now) or on any thread later; gRPC runs no reaction (OnDone
    // included) before this handler has returned the reactor.
    auto sub = manager.watch(who.value(), id, [this](const JobEvent& e) { onEvent(e); });
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
    if (m_sub) m_manager.unwatch(m_sub);  // after this returns, onEvent is never called again
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

Result<Principal> ManagerServiceImpl::caller(const grpc::CallbackServerContext* ctx) const {
  auto user = m_users.authenticate(rpc::bearerToken(*ctx));
  if (!user) return user.status();
  return Principal::user(user->name, user->admin);
}

Result<Principal> ManagerServiceImpl::admin(const grpc::CallbackServerContext* ctx) const {
  auto who = caller(ctx);
  if (who && !who->admin) return permissionDenied("managing users needs an admin's token");
  return who;
}

grpc::ServerUnaryReactor* ManagerServiceImpl::SubmitJob(grpc::CallbackServerContext* ctx, const v1::SubmitJobRequest* req,
                                                        v1::SubmitJobResponse* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  return onPool(ctx, m_pool, [this, req, resp, owner = who->name] {
    if (m_builds && m_pendingBuilds->fetch_add(1) >= m_maxPendingBuilds) {  // counted here: a call skipped is not
      --*m_pendingBuilds;
      return rpc::toGrpc(resourceExhausted(std::to_string(m_maxPendingBuilds) + " submitted scenes are being built; submit again shortly"));
    }
    SubmitRequest r = fromProto(*req);
    r.owner = owner;
    if (!m_builds) {
      auto job = m_manager.submit(r);
      if (!job) return rpc::toGrpc(job.status());
      *resp->mutable_job() = toProto(job.value());
      return grpc::Status::OK;
    }
    auto job = m_manager.beginSubmit(r);
    if (!job) {
      --*m_pendingBuilds;
      return rpc::toGrpc(job.status());
    }
    *resp->mutable_job() = toProto(job.value());
    m_builds->post([&manager = m_manager, pending = m_pendingBuilds, id = job->id, r = std::move(r)] {
      manager.buildSubmitted(id, r);
      --*pending;
    });
    return grpc::Status::OK;
  });
}

grpc::ServerUnaryReactor* ManagerServiceImpl::GetJob(grpc::CallbackServerContext* ctx, const v1::GetJobRequest* req, v1::Job* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  auto job = m_manager.get(who.value(), req->id());
  if (job) *resp = toProto(job.value());
  return finishNow(ctx, rpc::toGrpc(job.status()));
}

grpc::ServerUnaryReactor* ManagerServiceImpl::ListJobs(grpc::CallbackServerContext* ctx, const v1::ListJobsRequest* req,
                                                       v1::ListJobsResponse* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  for (const Job& j : m_manager.list(who.value(), req->active_only())) *resp->add_jobs() = toProto(j);
  return finishNow(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* ManagerServiceImpl::CancelJob(grpc::CallbackServerContext* ctx, const v1::CancelJobRequest* req, v1::Job* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  return onPool(ctx, m_pool, [this, req, resp, who = who.value()] {
    auto job = m_manager.cancel(who, req->id());
    if (job) *resp = toProto(job.value());
    return rpc::toGrpc(job.status());
  });
}

grpc::ServerWriteReactor<v1::JobEvent>* ManagerServiceImpl::WatchJob(grpc::CallbackServerContext* ctx, const v1::WatchJobRequest* req) {
  return new WatchReactor(m_manager, caller(ctx), req->id());
}

grpc::ServerUnaryReactor* ManagerServiceImpl::ListNodes(grpc::CallbackServerContext* ctx, const v1::ListNodesRequest*,
                                                        v1::ListNodesResponse* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  for (const NodeView& n : m_manager.nodes()) *resp->add_nodes() = toProto(n);
  return finishNow(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* ManagerServiceImpl::DeleteJob(grpc::CallbackServerContext* ctx, const v1::DeleteJobRequest* req,
                                                        v1::DeleteJobResponse*) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  return onPool(ctx, m_pool, [this, req, who = who.value()] { return rpc::toGrpc(m_manager.remove(who, req->id())); });
}

grpc::ServerUnaryReactor* ManagerServiceImpl::AddUser(grpc::CallbackServerContext* ctx, const v1::AddUserRequest* req,
                                                      v1::UserTokenResponse* resp) {
  auto who = admin(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  auto token = m_users.add(req->name(), req->admin(), m_manager.now());
  if (!token) return finishNow(ctx, rpc::toGrpc(token.status()));
  spdlog::info("manager: {} added user {}{}", who->name, req->name(), req->admin() ? " (admin)" : "");
  resp->set_name(req->name());
  resp->set_token(token.value());
  return finishNow(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* ManagerServiceImpl::RotateToken(grpc::CallbackServerContext* ctx, const v1::RotateTokenRequest* req,
                                                          v1::UserTokenResponse* resp) {
  auto who = caller(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  if (!who->admin && who->name != req->name()) return finishNow(ctx, rpc::toGrpc(permissionDenied("a user may rotate only its own token")));
  auto token = m_users.rotate(req->name());
  if (!token) return finishNow(ctx, rpc::toGrpc(token.status()));
  spdlog::info("manager: {} rotated the token of {}", who->name, req->name());
  resp->set_name(req->name());
  resp->set_token(token.value());
  return finishNow(ctx, grpc::Status::OK);
}

grpc::ServerUnaryReactor* ManagerServiceImpl::RemoveUser(grpc::CallbackServerContext* ctx, const v1::RemoveUserRequest* req,
                                                         v1::RemoveUserResponse*) {
  auto who = admin(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  if (req->name() == who->name) return finishNow(ctx, rpc::toGrpc(failedPrecondition("an admin cannot remove itself")));
  const Status s = m_users.remove(req->name());
  if (s) spdlog::info("manager: {} removed user {}", who->name, req->name());
  return finishNow(ctx, rpc::toGrpc(s));
}

grpc::ServerUnaryReactor* ManagerServiceImpl::ListUsers(grpc::CallbackServerContext* ctx, const v1::ListUsersRequest*,
                                                        v1::ListUsersResponse* resp) {
  auto who = admin(ctx);
  if (!who) return finishNow(ctx, rpc::toGrpc(who.status()));
  auto users = m_users.list();
  if (!users) return finishNow(ctx, rpc::toGrpc(users.status()));
  for (const User& u : users.value()) {
    v1::User* p = resp->add_users();
    p->set_name(u.name);
    p->set_admin(u.admin);
    p->set_created_at(u.createdAt);
  }
  return finishNow(ctx, grpc::Status::OK);
}

// ---- NodeRegistry ------------------------------------------------------------------------------------------------

Result<std::string> NodeRegistryImpl::callerNode(const grpc::CallbackServerContext* ctx) const {
  if (!m_verifyNodes) return std::string();
  const std::string identity = rpc::peerIdentity(*ctx);
  const std::string node = rpc::nodeOfIdentity(identity);
  if (node.empty())
    return identity.empty() ? unauthenticated("NodeRegistry takes nodes only: no client certificate")
                            : permissionDenied("NodeRegistry takes nodes only, not " + identity);
  return node;
}

Status NodeRegistryImpl::checkNode(const grpc::CallbackServerContext* ctx, const std::string& node) const {
  auto caller = callerNode(ctx);
  if (!caller) return caller.status();
  if (!caller->empty() && caller.value() != node)
    return permissionDenied("node " + caller.value() + " cannot speak for node '" + log::escaped(node, 64) + "'");
  return Status::ok();
}

grpc::ServerUnaryReactor* NodeRegistryImpl::Heartbeat(grpc::CallbackServerContext* ctx, const v1::HeartbeatRequest* req,
                                                      v1::HeartbeatResponse* resp) {
  if (Status s = checkNode(ctx, req->node()); !s) return finishNow(ctx, rpc::toGrpc(s));
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
  auto node = callerNode(ctx);
  if (!node) return finishNow(ctx, rpc::toGrpc(node.status()));
  if (!node->empty())
    if (Status s = m_manager.checkJobOnNode(req->job_id(), node.value()); !s) {
      // A worker of an earlier attempt on a node the job has left: told to stop, as any stray worker is.
      if (s.code() == StatusCode::kPermissionDenied) {
        resp->set_cancel(true);
        return finishNow(ctx, grpc::Status::OK);
      }
      return finishNow(ctx, rpc::toGrpc(s));
    }
  auto cancel = m_manager.reportProgress(req->job_id(), fromProto(req->progress()), req->message(), req->attempt());
  if (cancel) resp->set_cancel(cancel.value());
  return finishNow(ctx, rpc::toGrpc(cancel.status()));
}

grpc::ServerUnaryReactor* NodeRegistryImpl::ReportJobExit(grpc::CallbackServerContext* ctx, const v1::ReportJobExitRequest* req,
                                                          v1::ReportJobExitResponse*) {
  if (Status s = checkNode(ctx, req->node()); !s) return finishNow(ctx, rpc::toGrpc(s));
  return onPool(ctx, m_pool, [this, req] {
    return rpc::toGrpc(m_manager.reportExit(req->job_id(), req->node(), req->exit_code(), req->reason()));
  });
}

}  // namespace pflow::manager
