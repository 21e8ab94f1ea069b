#include "common/rpc/Rpc.h"


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
    default: return internalError(msg);
  }
}

std::unique_ptr<grpc::ClientContext> contextWithDeadline(double seconds) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() +
                    std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds)));
  return ctx;
}

std::shared_ptr<grpc::Channel> makeChannel(const std::string& address) {
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(64 << 20);
  args.SetMaxSendMessageSize(64 << 20);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, 20000);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, 10000);
  args.SetInt(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  return grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
}

bool waitForConnected(const std::shared_ptr<grpc::Channel>& channel, double seconds) {
  return channel->WaitForConnected(std::chrono::system_clock::now() +
                                   std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(seconds)));
}

Result<std::unique_ptr<ServerRunner>> ServerRunner::start(const std::string& address, const std::vector<grpc::Service*>& services) {
  auto runner = std::unique_ptr<ServerRunner>(new ServerRunner());
  grpc::ServerBuilder builder;
  builder.AddListeningPort(address, grpc::InsecureServerCredentials(), &runner->m_port);
  builder.SetMaxReceiveMessageSize(64 << 20);
  builder.SetMaxSendMessageSize(64 << 20);
  for (grpc::Service* s : services) builder.RegisterService(s);
  runner->m_server = builder.BuildAndStart();
  if (!runner->m_server || runner->m_port == 0) return unavailable("cannot listen on " + address + " (address in use or not local?)");
  runner->m_address = hostOf(address) + ":" + std::to_string(runner->m_port);
  return runner;
}

ServerRunner::~ServerRunner() { shutdown(); }

void ServerRunner::shutdown(double graceSeconds) {
  if (m_down || !m_server) return;
  m_down = true;
  m_server->Shutdown(std::chrono::system_clock::now() +
                     std::chrono::duration_cast<std::chrono::system_clock::duration>(std::chrono::duration<double>(graceSeconds)));
  m_server->Wait();
}

void ServerRunner::wait() {
  if (m_server) m_server->Wait();
}


}  // namespace pflow::rpc
