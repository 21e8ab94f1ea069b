// How a pflow process talks to the others: mutual TLS with the pflow CA (the default and the only mode that may face
// a network), or plaintext on loopback only (`--insecure`, logged as a warning). docs/security.md.
//
// Every service has a certificate from the pflow CA whose common name is its identity: "pflow-manager",
// "pflow-frontend", "pflow-backend", or "pflow-node:<node>" for a node's agent and the workers it starts. Servers
// verify a client certificate when one is presented; users present none and authenticate with a bearer token
// (manager/Users.h). The CLI verifies the servers with the CA alone.
#pragma once
#include <grpcpp/grpcpp.h>

#include <string>

#include "common/Status.h"

namespace CLI {
class App;
}

namespace pflow::rpc {

struct Transport {
  bool insecure = false;  // plaintext; servers then bind to loopback only
  std::string caPem;      // the pflow CA: verifies the peer
  std::string certPem;    // this process's certificate and key (empty: none, the CLI)
  std::string keyPem;

  static Transport plaintext() { return Transport{true, {}, {}, {}}; }
  // DIR/ca.crt, DIR/<name>.crt, DIR/<name>.key (name: "manager", "frontend", "backend", "node-<node>").
  static Result<Transport> fromDir(const std::string& dir, const std::string& name);
  // The CA alone: a client that authenticates by token (the CLI).
  static Result<Transport> caOnly(const std::string& caFile);

  std::shared_ptr<grpc::ChannelCredentials> channelCredentials() const;
  std::shared_ptr<grpc::ServerCredentials> serverCredentials() const;
};

// The transport makeChannel and ServerRunner::start use when not given one. Plaintext until a program sets it
// (in-process tests on loopback); every pflow program sets it from its flags before serving or calling.
void setDefaultTransport(Transport t);
const Transport& defaultTransport();

// `--tls-dir DIR` and `--insecure` on a program's command line; resolve() gives the transport (one of the two must be
// given: there is no silent plaintext).
struct TransportFlags {
  std::string tlsDir;
  bool insecure = false;
  void add(CLI::App& app);
  // `name`: the certificate this program presents (see Transport::fromDir).
  Result<Transport> resolve(const std::string& name) const;
  // The same flags for a child program (the agent's workers).
  std::vector<std::string> args() const;
};

// True for 127.0.0.0/8, ::1 and localhost.
bool isLoopbackHost(const std::string& host);

// The identity of the peer of a server call: the common name of its verified certificate, "" when it has none.
std::string peerIdentity(const grpc::ServerContextBase& ctx);
// Who a call comes from, for logs and their rate limits: the certificate's name, else the address without its port.
std::string clientKey(const grpc::ServerContextBase& ctx);

inline constexpr const char* kManagerIdentity = "pflow-manager";
inline constexpr const char* kFrontendIdentity = "pflow-frontend";
inline constexpr const char* kBackendIdentity = "pflow-backend";
inline std::string nodeIdentity(const std::string& node) { return "pflow-node:" + node; }
// The node of a "pflow-node:<node>" identity, "" for any other.
std::string nodeOfIdentity(const std::string& identity);

// Which callers a service takes: OK when the caller's certificate names `identity` (or, with anyNode, any node),
// or when this process runs without TLS (nothing can be verified there: --insecure binds to loopback only); else
// UNAUTHENTICATED (no certificate) or PERMISSION_DENIED (a certificate of another service), naming `service`.
Status requirePeer(const grpc::ServerContextBase& ctx, const char* service, const char* identity, bool anyNode = false);
// The same for a caller that is a node (its agent or workers).
inline Status requireNode(const grpc::ServerContextBase& ctx, const char* service) { return requirePeer(ctx, service, "", true); }

}  // namespace pflow::rpc
