// Nodes and their devices as agents report them in heartbeats, the device leases of running jobs, and lost-node
// detection through an injectable Clock. Not thread-safe: the Manager serialises access.
//
// Device state is derived, never stored: LOST when its node is lost, BUSY when a job holds a lease on it, else FREE.
// Leases are kept by device key independently of the nodes, so after a manager restart the leases loaded from the
// job store hold their devices before (and whether or not) the node heartbeats again.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "common/Clock.h"
#include "common/Status.h"
#include "manager/Types.h"

namespace pflow::manager {

class Inventory {
 public:
  // A node lost for `forgetAfterSeconds` more (and holding no lease) leaves the inventory: `pflow nodes` stops listing
  // it; it comes back with its next heartbeat.
  Inventory(const Clock& clock, double heartbeatTimeoutSeconds, double forgetAfterSeconds = 600);

  // Checks a heartbeat's contents: a node name, an agent address, devices with distinct keys on that node and
  // non-negative indices. INVALID_ARGUMENT naming what is wrong.
  static Status validateHeartbeat(const HeartbeatInfo& hb);

  // Records a (validated) heartbeat: the node is created or updated and is no longer lost. Returns true when the
  // node was lost (or unknown) before.
  bool heartbeat(const HeartbeatInfo& hb);

  // Marks nodes whose last heartbeat is older than the timeout as lost; returns the names of the newly lost ones.
  // Forgets lost nodes past forgetAfterSeconds whose devices hold no lease (their names go to `forgotten`).
  std::vector<std::string> expireLost(std::vector<std::string>* forgotten = nullptr);

  bool isKnown(const std::string& node) const { return m_nodes.count(node) > 0; }
  bool isLost(const std::string& node) const;
  std::string agentAddress(const std::string& node) const;  // "" when unknown
  double heartbeatTimeout() const { return m_timeout; }

  // Leases: every device in `devices` becomes BUSY with `jobId`. FAILED_PRECONDITION (and nothing changes) when a
  // device is already leased to another job.
  Status lease(const std::vector<DeviceKey>& devices, const std::string& jobId);
  void release(const std::string& jobId);
  std::string leaseHolder(const DeviceKey& device) const;  // "" when free

  // Every known node with its devices and their states, sorted by node name.
  std::vector<NodeView> snapshot() const;

 private:
  struct Node {
    std::string agentAddress;
    bool lost = false;
    double lastHeartbeat = 0;
    std::vector<DeviceInfo> devices;
  };
  const Clock& m_clock;
  double m_timeout;
  double m_forgetAfter;
  std::map<std::string, Node> m_nodes;
  std::map<DeviceKey, std::string> m_leases;  // device -> job id
};

}  // namespace pflow::manager
