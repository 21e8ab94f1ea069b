// Thin gRPC adapters (callback API) over the Manager: ManagerService for users, NodeRegistry for agents and workers.
// Requests are converted, the Manager decides, its Status becomes a grpc::Status. Handlers that may call out to
// agents or the frontend (SubmitJob, CancelJob, Heartbeat, ReportJobExit) run on a TaskPool, never on gRPC's
// callback threads; NodeRegistry has a pool of its own, so no amount of user calls can hold up heartbeats. WatchJob
// is a ServerWriteReactor fed by a Manager subscription.
//
// Who calls (docs/security.md): ManagerService takes users, by the bearer token in each call (UserStore);
// NodeRegistry takes nodes, by the certificate of their agent or workers ("pflow-node:<node>"): a heartbeat or exit
// report only for its own node, progress only for a job on its node. Without TLS (--insecure) there are no
// certificates: NodeRegistry then trusts the node names in requests, and only loopback can reach it.
#pragma once
#include <atomic>
#include <condition_variable>
#include <deque>
#include <memory>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "manager/Manager.h"
#include "manager/Users.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"
#include "common/TaskPool.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace pflow::manager {

using pflow::TaskPool;

class ManagerServiceImpl final : public pflow::manager::v1::ManagerService::CallbackService {
 public:
  // `builds`: where submitted scenes are built, at most `maxPendingBuilds` waiting or running at once (more are
  // RESOURCE_EXHAUSTED); SubmitJob then answers at once with the job BUILDING. Null: SubmitJob builds before it
  // answers (tests of the synchronous rules).
  ManagerServiceImpl(Manager& manager, UserStore& users, TaskPool& pool, TaskPool* builds = nullptr, int maxPendingBuilds = 16)
      : m_manager(manager), m_users(users), m_pool(pool), m_builds(builds), m_maxPendingBuilds(maxPendingBuilds) {}

  grpc::ServerUnaryReactor* SubmitJob(grpc::CallbackServerContext* ctx, const v1::SubmitJobRequest* req,
                                      v1::SubmitJobResponse* resp) override;
  grpc::ServerUnaryReactor* GetJob(grpc::CallbackServerContext* ctx, const v1::GetJobRequest* req, v1::Job* resp) override;
  grpc::ServerUnaryReactor* ListJobs(grpc::CallbackServerContext* ctx, const v1::ListJobsRequest* req,
                                     v1::ListJobsResponse* resp) override;
  grpc::ServerUnaryReactor* CancelJob(grpc::CallbackServerContext* ctx, const v1::CancelJobRequest* req, v1::Job* resp) override;
  grpc::ServerWriteReactor<v1::JobEvent>* WatchJob(grpc::CallbackServerContext* ctx, const v1::WatchJobRequest* req) override;
  grpc::ServerUnaryReactor* ListNodes(grpc::CallbackServerContext* ctx, const v1::ListNodesRequest* req,
                                      v1::ListNodesResponse* resp) override;
  grpc::ServerUnaryReactor* DeleteJob(grpc::CallbackServerContext* ctx, const v1::DeleteJobRequest* req,
                                      v1::DeleteJobResponse* resp) override;
  grpc::ServerUnaryReactor* AddUser(grpc::CallbackServerContext* ctx, const v1::AddUserRequest* req,
                                    v1::UserTokenResponse* resp) override;
  grpc::ServerUnaryReactor* RotateToken(grpc::CallbackServerContext* ctx, const v1::RotateTokenRequest* req,
                                        v1::UserTokenResponse* resp) override;
  grpc::ServerUnaryReactor* RemoveUser(grpc::CallbackServerContext* ctx, const v1::RemoveUserRequest* req,
                                       v1::RemoveUserResponse* resp) override;
  grpc::ServerUnaryReactor* ListUsers(grpc::CallbackServerContext* ctx, const v1::ListUsersRequest* req,
                                      v1::ListUsersResponse* resp) override;

 private:
  // The calling user, from its token; UNAUTHENTICATED without a valid one.
  Result<Principal> caller(const grpc::CallbackServerContext* ctx) const;
  // The calling user when it is an admin; PERMISSION_DENIED for other users.
  Result<Principal> admin(const grpc::CallbackServerContext* ctx) const;
  Manager& m_manager;
  UserStore& m_users;
  TaskPool& m_pool;
  TaskPool* m_builds;
  int m_maxPendingBuilds;
  // Shared with the build tasks, which may outlive this adapter at shutdown (they hold the Manager, not the adapter).
  std::shared_ptr<std::atomic<int>> m_pendingBuilds = std::make_shared<std::atomic<int>>(0);
};

class NodeRegistryImpl final : public pflow::manager::v1::NodeRegistry::CallbackService {
 public:
  // `verifyNodes`: the server runs TLS, so every caller must present its node's certificate.
  NodeRegistryImpl(Manager& manager, TaskPool& pool, bool verifyNodes) : m_manager(manager), m_pool(pool), m_verifyNodes(verifyNodes) {}

  grpc::ServerUnaryReactor* Heartbeat(grpc::CallbackServerContext* ctx, const v1::HeartbeatRequest* req,
                                      v1::HeartbeatResponse* resp) override;
  grpc::ServerUnaryReactor* ReportProgress(grpc::CallbackServerContext* ctx, const v1::ReportProgressRequest* req,
                                           v1::ReportProgressResponse* resp) override;
  grpc::ServerUnaryReactor* ReportJobExit(grpc::CallbackServerContext* ctx, const v1::ReportJobExitRequest* req,
                                          v1::ReportJobExitResponse* resp) override;

 private:
  // OK when the caller is node `node` (or nodes are not verified); else UNAUTHENTICATED or PERMISSION_DENIED.
  Status checkNode(const grpc::CallbackServerContext* ctx, const std::string& node) const;
  // The calling node's name ("" when nodes are not verified); UNAUTHENTICATED for a caller without a node certificate.
  Result<std::string> callerNode(const grpc::CallbackServerContext* ctx) const;
  Manager& m_manager;
  TaskPool& m_pool;
  bool m_verifyNodes;
};

}  // namespace pflow::manager
