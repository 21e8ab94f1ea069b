// Thin gRPC adapters (callback API) over the Manager: ManagerService for users, NodeRegistry for agents and workers.
// Requests are converted, the Manager decides, its Status becomes a grpc::Status. Handlers that may call out to
// agents or the frontend (SubmitJob, CancelJob, Heartbeat, ReportJobExit) run on a TaskPool, never on gRPC's
// callback threads. WatchJob is a ServerWriteReactor fed by a Manager subscription.
#pragma once
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "manager/Manager.h"
#include "pflow/manager/v1/manager_service.grpc.pb.h"
#include "common/TaskPool.h"
#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace pflow::manager {

using pflow::TaskPool;

class ManagerServiceImpl final : public pflow::manager::v1::ManagerService::CallbackService {
 public:
  ManagerServiceImpl(Manager& manager, TaskPool& pool) : m_manager(manager), m_pool(pool) {}

  grpc::ServerUnaryReactor* SubmitJob(grpc::CallbackServerContext* ctx, const v1::SubmitJobRequest* req,
                                      v1::SubmitJobResponse* resp) override;
  grpc::ServerUnaryReactor* GetJob(grpc::CallbackServerContext* ctx, const v1::GetJobRequest* req, v1::Job* resp) override;
  grpc::ServerUnaryReactor* ListJobs(grpc::CallbackServerContext* ctx, const v1::ListJobsRequest* req,
                                     v1::ListJobsResponse* resp) override;
  grpc::ServerUnaryReactor* CancelJob(grpc::CallbackServerContext* ctx, const v1::CancelJobRequest* req, v1::Job* resp) override;
  grpc::ServerWriteReactor<v1::JobEvent>* WatchJob(grpc::CallbackServerContext* ctx, const v1::WatchJobRequest* req) override;
  grpc::ServerUnaryReactor* ListNodes(grpc::CallbackServerContext* ctx, const v1::ListNodesRequest* req,
                                      v1::ListNodesResponse* resp) override;

 private:
  Manager& m_manager;
  TaskPool& m_pool;
};

class NodeRegistryImpl final : public pflow::manager::v1::NodeRegistry::CallbackService {
 public:
  NodeRegistryImpl(Manager& manager, TaskPool& pool) : m_manager(manager), m_pool(pool) {}

  grpc::ServerUnaryReactor* Heartbeat(grpc::CallbackServerContext* ctx, const v1::HeartbeatRequest* req,
                                      v1::HeartbeatResponse* resp) override;
  grpc::ServerUnaryReactor* ReportProgress(grpc::CallbackServerContext* ctx, const v1::ReportProgressRequest* req,
                                           v1::ReportProgressResponse* resp) override;
  grpc::ServerUnaryReactor* ReportJobExit(grpc::CallbackServerContext* ctx, const v1::ReportJobExitRequest* req,
                                          v1::ReportJobExitResponse* resp) override;

 private:
  Manager& m_manager;
  TaskPool& m_pool;
};

}  // namespace pflow::manager
