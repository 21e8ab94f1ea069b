#include "common/rpc/Health.h"

#include <spdlog/spdlog.h>

#include "grpc_std/health/v1/health.grpc.pb.h"

namespace pflow::rpc {

Result<bool> checkHealth(const std::string& address, const std::string& service, double deadlineSeconds) {
  auto stub = grpc::health::v1::Health::NewStub(makeChannel(address));
  grpc::health::v1::HealthCheckRequest req;
  req.set_service(service);
  grpc::health::v1::HealthCheckResponse resp;
  auto ctx = contextWithDeadline(deadlineSeconds);
  const grpc::Status s = stub->Check(ctx.get(), req, &resp);
  if (!s.ok()) return fromGrpc(s, "health of " + address);
  return resp.status() == grpc::health::v1::HealthCheckResponse::SERVING;
}

HealthMonitor::HealthMonitor(ServerRunner& server, std::vector<std::string> services, std::vector<Dependency> dependencies,
                             double intervalSeconds)
    : m_server(server), m_services(std::move(services)), m_dependencies(std::move(dependencies)), m_interval(intervalSeconds) {
  checkNow();
  if (m_dependencies.empty()) return;
  m_thread = std::thread([this] {
    std::unique_lock lock(m_mu);
    while (!m_cv.wait_for(lock, std::chrono::duration<double>(m_interval), [this] { return m_stop; })) {
      lock.unlock();
      checkNow();
      lock.lock();
    }
  });
}

HealthMonitor::~HealthMonitor() {
  {
    std::lock_guard lock(m_mu);
    m_stop = true;
  }
  m_cv.notify_all();
  if (m_thread.joinable()) m_thread.join();
}

void HealthMonitor::checkNow() {
  std::string down, why;
  for (const Dependency& d : m_dependencies) {
    auto h = checkHealth(d.address);
    if (!h || !h.value()) {
      down = d.name;
      why = h ? "NOT_SERVING" : h.status().message();
      break;
    }
  }
  const bool serving = down.empty();
  if (serving != m_serving.load() || down != m_down) {
    if (serving) spdlog::info("health: SERVING ({} up)", m_down.empty() ? "every dependency" : "the " + m_down + " is");
    else spdlog::warn("health: NOT_SERVING: the {} is down ({})", down, why);
  }
  m_down = down;
  m_serving = serving;
  for (const std::string& s : m_services) m_server.setServing(s, serving);
}

}  // namespace pflow::rpc
