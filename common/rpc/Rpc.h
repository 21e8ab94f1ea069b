// Service plumbing shared by every pflow server and client: Status <-> grpc::Status, a server runner with a bound
// port and graceful shutdown, channels, and per-call deadlines. Only service code includes this (it pulls gRPC).
#pragma once
#include <grpcpp/grpcpp.h>

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "common/Address.h"
#include "common/Status.h"
#include "common/rpc/Transport.h"

namespace pflow::rpc {

// pflow's Status <-> gRPC status codes (kIo and kNumerical map to INTERNAL with their name in the message).
grpc::Status toGrpc(const Status& s);
Status fromGrpc(const grpc::Status& s, const std::string& what = "");

// Default deadlines: short for queries and control calls, long for bulk transfers.
inline constexpr double kControlDeadlineSeconds = 10;
inline constexpr double kBulkDeadlineSeconds = 600;

// A ClientContext with a deadline `seconds` from now (every pflow call has one), carrying the process's bearer token
// when it has one (setCallToken: the CLI's user).
std::unique_ptr<grpc::ClientContext> contextWithDeadline(double seconds = kControlDeadlineSeconds);

// Makes an idempotent call (`call(ClientContext*)` -> grpc::Status) again after 0.25, 0.5 and 1 s while it fails
// UNAVAILABLE (a service restarting, a connection cut while idle), each try with a fresh context of `seconds`.
template <class Call>
grpc::Status retryIdempotent(Call&& call, double seconds = kControlDeadlineSeconds, int attempts = 4) {
  grpc::Status s;
  double wait = 0.25;
  for (int i = 0; i < attempts; ++i) {
    auto ctx = contextWithDeadline(seconds);
    s = call(ctx.get());
    if (s.error_code() != grpc::StatusCode::UNAVAILABLE || i + 1 == attempts) break;
    std::this_thread::sleep_for(std::chrono::duration<double>(wait));
    wait *= 2;
  }
  return s;
}

// The user's token every call of this process carries ("authorization: Bearer <token>"); "" = none.
void setCallToken(std::string token);
// Adds `token` to one call (a service acting for a user: the back-end asking the manager whether the user may read);
// a token with bytes outside printable ASCII is left out.
void addBearer(grpc::ClientContext& ctx, const std::string& token);
// The bearer token of a server call, "" when it has none.
std::string bearerToken(const grpc::ServerContextBase& ctx);

// A channel to host:port with keepalive; messages up to 64 MiB (bulk data still travels in 1 MiB chunks). Over
// `transport`, else the default one (Transport.h).
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address);
std::shared_ptr<grpc::Channel> makeChannel(const std::string& address, const Transport& transport);

// Keep-alive, the same on both sides: clients ping every keepaliveMillis() (20 s; also without calls), servers accept
// pings twice as often (a server stricter than its clients cuts them with "Too many pings" and the client's next
// call fails). Settable for tests, before channels and servers are made.
int keepaliveMillis();
void setKeepaliveMillis(int millis);

// Waits until the channel is connected or `seconds` pass.
bool waitForConnected(const std::shared_ptr<grpc::Channel>& channel, double seconds);

// Starts a gRPC server for `services` on `address` ("host:port"; port 0 picks a free one).
class ServerRunner {
 public:
  // Over `transport` (else the default one); a plaintext server binds only to a loopback address.
  static Result<std::unique_ptr<ServerRunner>> start(const std::string& address, const std::vector<grpc::Service*>& services);
  static Result<std::unique_ptr<ServerRunner>> start(const std::string& address, const std::vector<grpc::Service*>& services,
                                                     const Transport& transport);
  ~ServerRunner();
  int port() const { return m_port; }
  std::string address() const { return m_address; }  // host:port actually bound
  // The standard health service's status of `service` (a full name such as "pflow.manager.v1.ManagerService"; ""
  // = the server as a whole). Every server starts with "" SERVING; a program declares its services SERVING once it
  // can take calls (Health.h keeps them true to their dependencies). Ignored once shutdown() began.
  void setServing(const std::string& service, bool serving);
  // Reports NOT_SERVING for every service (so health checkers stop sending calls), stops accepting calls and waits
  // for running ones up to `graceSeconds`, then cancels them.
  void shutdown(double graceSeconds = 5);
  void wait();  // until shutdown

 private:
  std::unique_ptr<grpc::Server> m_server;
  int m_port = 0;
  std::string m_address;
  bool m_down = false;
};

// A streaming reactor that only finishes with `status` (a refused call: no credentials, no right).
template <class Reactor>
Reactor* refuse(const grpc::Status& status) {
  class Refusal final : public Reactor {
   public:
    explicit Refusal(const grpc::Status& s) { this->Finish(s); }
    void OnDone() override { delete this; }
  };
  return new Refusal(status);
}

using pflow::hostOf;  // common/Address.h

}  // namespace pflow::rpc
