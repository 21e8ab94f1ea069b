// The cluster commands of `pflow`: submit, jobs, job, nodes, cancel, watch, fetch. They talk to the manager (jobs,
// nodes) and the back-end (fetch) over gRPC; addresses come from a flag, then PFLOW_MANAGER / PFLOW_BACKEND, then
// the config file ($PFLOW_CONFIG, else ~/.config/pflow/config.yaml: `manager: host:port`, `backend: host:port`),
// then 127.0.0.1:50051 / 127.0.0.1:50053.
#pragma once
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"

namespace pflow::cli {

// Where the services are and how to reach them. The user's token comes from PFLOW_TOKEN, else `token:` in the config
// file; the pflow CA that verifies the services from --ca, PFLOW_CA or `ca:`; plaintext only with --insecure (or
// PFLOW_INSECURE=1, `insecure: true`), for a stack started with --insecure.
struct Endpoints {
  std::string manager;  // flag value; empty = resolve
  std::string backend;
  std::string ca;
  bool insecure = false;
  std::string token;    // resolved
  // Resolves the addresses, the token and the transport, and installs them for every call of this process.
  Status resolve();
};

struct UserOptions {
  std::string action;  // add, rotate, remove, list
  std::string name;
  bool admin = false;
};

struct SubmitOptions {
  std::string scenePath;
  std::string name;
  bool wait = true;       // queue when devices are short (--wait), or refuse (--no-wait)
  int maxDevices = 0;
  bool watch = false;     // then watch it to the end
};

struct FetchOptions {
  std::string jobId;
  std::optional<std::int64_t> step;  // unset = the last
  std::string output;
  std::vector<std::string> fields;
  bool grid = true;
  bool geometry = true;
  bool probes = true;  // an SPH job's probe series: /probes in the file and <output>.probes.csv
};

// Each prints its result (a table or, with json, one JSON object) and returns the process exit code.
int submitJob(const Endpoints& e, const SubmitOptions& o, bool json);
int listJobs(const Endpoints& e, bool all, bool json);
int showJob(const Endpoints& e, const std::string& id, bool json);
int listNodes(const Endpoints& e, bool json);
int cancelJob(const Endpoints& e, const std::string& id, bool json);
// Deletes a finished job and its files on the back-end (its owner or an admin).
int deleteJob(const Endpoints& e, const std::string& id, bool json);
int watchJob(const Endpoints& e, const std::string& id, bool json);
int fetchSnapshot(const Endpoints& e, const FetchOptions& o, bool json);
// pflow admin user add|rotate|remove|list: prints a new token once (add, rotate).
int manageUsers(const Endpoints& e, const UserOptions& o, bool json);

}  // namespace pflow::cli
