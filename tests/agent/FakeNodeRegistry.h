// A tiny in-test manager: the NodeRegistry service (callback API) that records heartbeats and exit reports, and can
// ask an agent to stop jobs through the heartbeat answer.
#pragma once
#include <chrono>
#include <condition_variable>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "pflow/manager/v1/node_registry.grpc.pb.h"

namespace pflow::agent::testing {

class FakeNodeRegistry final : public pflow::manager::v1::NodeRegistry::CallbackService {
 public:
  using HeartbeatRequest = pflow::manager::v1::HeartbeatRequest;
  using ExitRequest = pflow::manager::v1::ReportJobExitRequest;

  grpc::ServerUnaryReactor* Heartbeat(grpc::CallbackServerContext* ctx, const HeartbeatRequest* req,
                                      pflow::manager::v1::HeartbeatResponse* resp) override {
    {
      std::lock_guard lock(m_mutex);
      latest[req->node()] = *req;
      ++heartbeatCount[req->node()];
      resp->set_heartbeat_interval_seconds(interval);
      for (const std::string& id : stopJobs[req->node()]) resp->add_stop_jobs(id);
      stopJobs[req->node()].clear();
    }
    m_cv.notify_all();
    auto* r = ctx->DefaultReactor();
    r->Finish(grpc::Status::OK);
    return r;
  }

  grpc::ServerUnaryReactor* ReportProgress(grpc::CallbackServerContext* ctx, const pflow::manager::v1::ReportProgressRequest*,
                                           pflow::manager::v1::ReportProgressResponse*) override {
    auto* r = ctx->DefaultReactor();
    r->Finish(grpc::Status::OK);
    return r;
  }

  grpc::ServerUnaryReactor* ReportJobExit(grpc::CallbackServerContext* ctx, const ExitRequest* req,
                                          pflow::manager::v1::ReportJobExitResponse*) override {
    {
      std::lock_guard lock(m_mutex);
      exits.push_back(*req);
    }
    m_cv.notify_all();
    auto* r = ctx->DefaultReactor();
    r->Finish(grpc::Status::OK);
    return r;
  }

  // Waits until `pred()` (called under the lock) holds.
  template <class Pred>
  bool waitFor(Pred pred, double seconds) {
    std::unique_lock lock(m_mutex);
    return m_cv.wait_for(lock, std::chrono::duration<double>(seconds), pred);
  }
  void stop(const std::string& node, const std::string& jobId) {
    std::lock_guard lock(m_mutex);
    stopJobs[node].push_back(jobId);
  }
  std::vector<ExitRequest> exitsCopy() {
    std::lock_guard lock(m_mutex);
    return exits;
  }
  HeartbeatRequest latestOf(const std::string& node) {
    std::lock_guard lock(m_mutex);
    return latest[node];
  }

  // Read and written under the lock (waitFor predicates run under it).
  std::map<std::string, HeartbeatRequest> latest;
  std::map<std::string, int> heartbeatCount;
  std::map<std::string, std::vector<std::string>> stopJobs;
  std::vector<ExitRequest> exits;
  double interval = 0.1;

 private:
  std::mutex m_mutex;
  std::condition_variable m_cv;
};

}  // namespace pflow::agent::testing
