#include "common/rpc/Rpc.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>

#include <atomic>
#include <mutex>


namespace pflow::rpc {

grpc::Status toGrpc(const Status& s) {
  using C = grpc::StatusCode;
  switch (s.code()) {
    case StatusCode::kOk: return grpc::Status::OK;
    case StatusCode::kInvalidArgument: return {C::INVALID_ARGUMENT, s.message()};
    case StatusCode::kNotFound: return {C::NOT_FOUND, s.message()};
    case StatusCode::kFailedPrecondition: return {C::FAILED_PRECONDITION, s.message()};
    case StatusCode::kResourceExhausted: return {C::RESOURCE_EXHAUSTED, s.message()};
    case StatusCode::kUnavailable: return {C::UNAVAILABLE, s.message()};
    case StatusCode::kAlreadyExists: return {C::ALREADY_EXISTS, s.message()};
    case StatusCode::kCancelled: return {C::CANCELLED, s.message()};
    case StatusCode::kDeadlineExceeded: return {C::DEADLINE_EXCEEDED, s.message()};
    case StatusCode::kUnauthenticated: return {C::UNAUTHENTICATED, s.message()};
    case StatusCode::kPermissionDenied: return {C::PERMISSION_DENIED, s.message()};
    case StatusCode::kIo:
    case StatusCode::kNumerical:
    case StatusCode::kInternal: return {C::INTERNAL, s.toString()};
  }
  return {C::UNKNOWN, s.message()};
}

Status fromGrpc(const grpc::Status& s, const std::string& what) {
  using C = grpc::StatusCode;
  if (s.ok()) return Status::ok();
  const std::string msg = what.empty() ? s.error_message() : what + ": " + s.error_message();
  switch (s.error_code()) {
    case C::INVALID_ARGUMENT: return invalidArgument(msg);
    case C::NOT_FOUND: return notFound(msg);
    case C::FAILED_PRECONDITION: return failedPrecondition(msg);
    case C::RESOURCE_EXHAUSTED: return resourceExhausted(msg);
    case C::UNAVAILABLE: return unavailable(msg.empty() ? "service unavailable" : msg);
    case C::ALREADY_EXISTS: return alreadyExists(msg);
    case C::CANCELLED: return {StatusCode::kCancelled, msg};
    case C::DEADLINE_EXCEEDED: return {StatusCode::kDeadlineExceeded, msg};
    case C::UNAUTHENTICATED: return unauthenticated(msg);
    case C::PERMISSION_DENIED: return permissionDenied(msg);
    default: return internalError(msg);
  }
}

namespace {
std::mutex g_tokenMu;
std::string g_token;
std::atomic<int> g_keepaliveMillis{20000};
}  // namespace

int keepaliveMillis() { return g_keepaliveMillis.load(); }
void setKeepaliveMillis(int millis) { g_keepaliveMillis = millis; }

void setCallToken(std::string token) {
  std::lock_guard lock(g_tokenMu);
  g_token = std::move(token);
}

void addBearer(grpc::ClientContext& ctx, const std::string& token) {
  // gRPC aborts the process on a header value outside printable ASCII: such a token is no token (the call is then
  // UNAUTHENTICATED), never a crash.
  for (char c : token)
    if (c < 0x20 || c > 0x7e) return;
  if (!token.empty()) ctx.AddMetadata("authorization", "Bearer " + token);
}

std::string bearerToken(const grpc::ServerContextBase& ctx) {
  const auto& md = ctx.client_metadata();
  const auto it = md.find("authorization");
  if (it == md.end()) return {};
  const std::string v(it->second.data(), it->second.size());
  const std::string prefix = "Bearer ";
  return v.rfind(prefix, 0) == 0 ? v.substr(prefix.size()) : std::string();
}

std::unique_ptr<grpc::ClientContext> contextWithDeadline(double seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  {
    std::lock_guard lock(g_tokenMu);
    addBearer(*ctx, g_token);
  }
  ctx->set_deadline(std::chrono::system_clock::now() +
                    std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds)));
  return ctx;
}

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address) { return makeChannel(address, defaultTransport()); }

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address, const Transport& transport) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, keepaliveMillis());
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);  // keep pinging an idle connection
  return grpc::CreateCustomChannel(address, transport.channelCredentials(), args);
}

bool waitForConnected(const std::shared_ptr<grpc::Channel>& channel, double seconds) {
  return channel->WaitForConnected(std::chrono::system_clock::now() +
                                   std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds)));
}

Result<std::unique_ptr<ServerRunner>> ServerRunner::start(const std::string& address, const std::vector<grpc::Service*>& services) {
  return start(address, services, defaultTransport());
}

Result<std::unique_ptr<ServerRunner>> ServerRunner::start(const std::string& address, const std::vector<grpc::Service*>& services,
                                                          const Transport& transport) {
  if (transport.insecure && !isLoopbackHost(hostOf(address)))
    return invalidArgument("--listen " + address + ": a plaintext (--insecure) server listens on loopback only (127.0.0.1, ::1); "
                           "use --tls-dir to serve other addresses");
  auto runner = std::unique_ptr<ServerRunner>(new ServerRunner());
  // gRPC's conventions (Health.h): the standard health service and server reflection on every pflow server.
  static std::once_flag conventions;
  std::call_once(conventions, [] {
    grpc::EnableDefaultHealthCheckService(true);
    grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  });
  grpc::ServerBuilder builder;
  builder.AddListeningPort(address, transport.serverCredentials(), &runner->m_port);
  builder.SetMaxReceiveMessageSize(64 << 20);
  builder.SetMaxSendMessageSize(64 << 20);
  // Accept the clients' keep-alive pings (makeChannel), also between calls.
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS, keepaliveMillis() / 2);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MAX_PING_STRIKES, 0);
  for (grpc::Service* s : services) builder.RegisterService(s);
  runner->m_server = builder.BuildAndStart();
  if (!runner->m_server || runner->m_port == 0) return unavailable("cannot listen on " + address + " (address in use or not local?)");
  runner->m_address = hostOf(address) + ":" + std::to_string(runner->m_port);
  return runner;
}

ServerRunner::~ServerRunner() { shutdown(); }

void ServerRunner::setServing(const std::string& service, bool serving) {
  if (m_server && m_server->GetHealthCheckService()) m_server->GetHealthCheckService()->SetServingStatus(service, serving);
}

void ServerRunner::shutdown(double graceSeconds) {
  if (m_down || !m_server) return;
  m_down = true;
  if (m_server->GetHealthCheckService()) m_server->GetHealthCheckService()->Shutdown();  // NOT_SERVING while draining
  m_server->Shutdown(std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(graceSeconds)));
  m_server->Wait();
}

void ServerRunner::wait() {
  if (m_server) m_server->Wait();
}


}  // namespace pflow::rpc
