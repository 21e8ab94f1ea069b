// Service plumbing shared by every pflow server and client: Status <-> grpc::Status, a server runner with a bound
// port and graceful shutdown, channels, and per-call deadlines. Only service code includes this (it pulls gRPC).
#pragma once
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "common/Address.h"
#include "common/Status.h"

namespace pflow::rpc {

// pflow's Status <-> gRPC status codes (kIo and kNumerical map to INTERNAL with their name in the message).
grpc::Status toGrpc(const Status& s);
Status fromGrpc(const grpc::Status& s, const std::string& what = "");

// Default deadlines: short for queries and control calls, long for bulk transfers.
inline constexpr double kControlDeadlineSeconds = 10;
inline constexpr double kBulkDeadlineSeconds = 600;

// A ClientContext with a deadline `seconds` from now (every pflow call has one).
std::unique_ptr<grpc::ClientContext> contextWithDeadline(double seconds = kControlDeadlineSeconds);

// A channel to host:port with keepalive; messages up to 64 MiB (bulk data still travels in 1 MiB chunks).
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address);

// Waits until the channel is connected or `seconds` pass.
bool waitForConnected(const std::shared_ptr<grpc::Channel>& channel, double seconds);

// Starts a gRPC server for `services` on `address` ("host:port"; port 0 picks a free one).
class ServerRunner {
 public:
  static Result<std::unique_ptr<ServerRunner>> start(const std::string& address, const std::vector<grpc::Service*>& services);
  ~ServerRunner();
  int port() const { return m_port; }
  std::string address() const { return m_address; }  // host:port actually bound
  // Stops accepting calls and waits for running ones up to `graceSeconds`, then cancels them.
  void shutdown(double graceSeconds = 5);
  void wait();  // until shutdown

 private:
  std::unique_ptr<grpc::Server> m_server;
  int m_port = 0;
  std::string m_address;
  bool m_down = false;
};

using pflow::hostOf;  // common/Address.h

}  // namespace pflow::rpc
