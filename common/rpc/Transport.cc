#include "common/rpc/Transport.h"

#include <CLI/CLI.hpp>
#include <spdlog/spdlog.h>

#include <arpa/inet.h>

#include <fstream>
#include <mutex>
#include <sstream>

#include "common/Address.h"

namespace pflow::rpc {
namespace {

Result<std::string> readPem(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return notFound(std::string(what) + " " + path + " cannot be read (create the certificates with deploy/local/certs.sh)");
  std::ostringstream s;
  s << in.rdbuf();
  std::string pem = s.str();
  if (pem.size() > (1 << 20)) return invalidArgument(std::string(what) + " " + path + " is larger than 1 MiB");
  if (pem.find("-----BEGIN ") == std::string::npos) return invalidArgument(std::string(what) + " " + path + " is not a PEM file");
  return pem;
}

std::mutex g_mu;
Transport g_default = Transport::plaintext();

}  // namespace

Result<Transport> Transport::fromDir(const std::string& dir, const std::string& name) {
  Transport t;
  auto ca = readPem(dir + "/ca.crt", "CA certificate");
  if (!ca) return ca.status();
  auto cert = readPem(dir + "/" + name + ".crt", "certificate");
  if (!cert) return cert.status();
  auto key = readPem(dir + "/" + name + ".key", "private key");
  if (!key) return key.status();
  t.caPem = std::move(ca.value());
  t.certPem = std::move(cert.value());
  t.keyPem = std::move(key.value());
  return t;
}

Result<Transport> Transport::caOnly(const std::string& caFile) {
  auto ca = readPem(caFile, "CA certificate");
  if (!ca) return ca.status();
  Transport t;
  t.caPem = std::move(ca.value());
  return t;
}

std::shared_ptr<grpc::ChannelCredentials> Transport::channelCredentials() const {
  if (insecure) return grpc::InsecureChannelCredentials();
  grpc::SslCredentialsOptions o;
  o.pem_root_certs = caPem;
  o.pem_private_key = keyPem;
  o.pem_cert_chain = certPem;
  return grpc::SslCredentials(o);
}

std::shared_ptr<grpc::ServerCredentials> Transport::serverCredentials() const {
  if (insecure) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions o(GRPC_SSL_REQUEST_CLIENT_CERTIFICATE_AND_VERIFY);
  o.pem_root_certs = caPem;
  o.pem_key_cert_pairs.push_back({keyPem, certPem});
  return grpc::SslServerCredentials(o);
}

void setDefaultTransport(Transport t) {
  std::lock_guard lock(g_mu);
  g_default = std::move(t);
}

const Transport& defaultTransport() {
  std::lock_guard lock(g_mu);
  return g_default;  // set once at start, before any thread uses it
}

void TransportFlags::add(CLI::App& app) {
  auto* tls = app.add_option("--tls-dir", tlsDir,
                             "folder with the pflow CA (ca.crt) and this program's certificate and key (mutual TLS; "
                             "deploy/local/certs.sh makes them)");
  app.add_flag("--insecure", insecure, "plaintext, no authentication of services: binds to loopback only (tests, debugging)")
      ->excludes(tls);
}

Result<Transport> TransportFlags::resolve(const std::string& name) const {
  if (insecure) {
    spdlog::warn("--insecure: plaintext gRPC without service authentication; listening on loopback only");
    return Transport::plaintext();
  }
  if (tlsDir.empty())
    return invalidArgument("give --tls-dir DIR (mutual TLS with the pflow CA; deploy/local/certs.sh makes the files) or --insecure "
                           "(plaintext, loopback only)");
  return Transport::fromDir(tlsDir, name);
}

std::vector<std::string> TransportFlags::args() const {
  if (insecure) return {"--insecure"};
  if (!tlsDir.empty()) return {"--tls-dir", tlsDir};
  return {};
}

bool isLoopbackHost(const std::string& host) {
  if (host == "localhost" || host == "[::1]" || host == "::1") return true;
  in_addr a{};  // a numeric 127.0.0.0/8 address, not a name that starts with "127."
  return ::inet_pton(AF_INET, host.c_str(), &a) == 1 && (ntohl(a.s_addr) >> 24) == 127;
}

std::string peerIdentity(const grpc::ServerContextBase& ctx) {
  const auto auth = ctx.auth_context();
  if (!auth || !auth->IsPeerAuthenticated()) return {};
  for (const grpc::string_ref& v : auth->FindPropertyValues("x509_common_name")) return std::string(v.data(), v.size());
  return {};
}

Status requirePeer(const grpc::ServerContextBase& ctx, const char* service, const char* identity, bool anyNode) {
  if (defaultTransport().insecure) return Status::ok();
  const std::string peer = peerIdentity(ctx);
  if (peer.empty()) return unauthenticated(std::string(service) + " takes pflow services only: no client certificate");
  if ((*identity && peer == identity) || (anyNode && !nodeOfIdentity(peer).empty())) return Status::ok();
  return permissionDenied(std::string(service) + " does not take calls from " + peer);
}

std::string clientKey(const grpc::ServerContextBase& ctx) {
  if (std::string id = peerIdentity(ctx); !id.empty()) return id;
  std::string peer = ctx.peer();  // "ipv4:127.0.0.1:5432", "ipv6:[::1]:5432"
  if (const auto colon = peer.rfind(':'); colon != std::string::npos && colon > peer.find(':')) peer.resize(colon);
  return peer;
}

std::string nodeOfIdentity(const std::string& identity) {
  const std::string prefix = "pflow-node:";
  return identity.rfind(prefix, 0) == 0 ? identity.substr(prefix.size()) : std::string();
}

}  // namespace pflow::rpc
