// gRPC's conventions on every pflow server: the standard health service (grpc.health.v1.Health, gRPC's built-in
// implementation enabled by ServerRunner) and server reflection, so that grpcurl, load balancers and orchestrators can
// probe and list pflow's services (docs/operations.md, "Health and reflection"). Two levels:
//   ""                 the server itself: SERVING from its start until it drains (ServerRunner::shutdown)
//   each pflow service SERVING while every service it depends on is up, NOT_SERVING while one is down or draining
// A dependency is probed at "" (is it up and not draining), never at its own services, so that two servers that
// depend on each other (the manager and the back-end) cannot hold each other NOT_SERVING.
#pragma once
#include <atomic>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "common/Status.h"
#include "common/rpc/Rpc.h"

namespace pflow::rpc {

// Asks the health service at `address` for `service` ("" = the server as a whole): true when SERVING, false when
// NOT_SERVING or UNKNOWN; an error (UNAVAILABLE, DEADLINE_EXCEEDED, NOT_FOUND for a service it does not know) when
// it cannot answer. Over the default transport.
Result<bool> checkHealth(const std::string& address, const std::string& service = "", double deadlineSeconds = 2);

// Keeps `services` of `server` true to their dependencies: every `intervalSeconds` it asks each dependency's health
// (""); while every one answers SERVING they are SERVING, else NOT_SERVING. Every change is logged with the
// dependency that caused it. The first check runs in the constructor.
class HealthMonitor {
 public:
  struct Dependency {
    std::string name;     // "frontend", "back-end", ... (for logs)
    std::string address;  // host:port
  };
  HealthMonitor(ServerRunner& server, std::vector<std::string> services, std::vector<Dependency> dependencies,
                double intervalSeconds = 2);
  ~HealthMonitor();
  HealthMonitor(const HealthMonitor&) = delete;
  HealthMonitor& operator=(const HealthMonitor&) = delete;

  bool serving() const { return m_serving.load(); }
  void checkNow();  // one round (tests; the thread does the same)

 private:
  ServerRunner& m_server;
  std::vector<std::string> m_services;
  std::vector<Dependency> m_dependencies;
  double m_interval;
  std::atomic<bool> m_serving{true};
  std::string m_down;  // the dependency last found down ("" = none)
  std::mutex m_mu;
  std::condition_variable m_cv;
  bool m_stop = false;
  std::thread m_thread;
};

}  // namespace pflow::rpc
