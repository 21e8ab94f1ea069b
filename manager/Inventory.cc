#include "manager/Inventory.h"

#include "common/Log.h"

#include <set>

namespace pflow::manager {

Inventory::Inventory(const Clock& clock, double heartbeatTimeoutSeconds, double forgetAfterSeconds)
    : m_clock(clock), m_timeout(heartbeatTimeoutSeconds), m_forgetAfter(forgetAfterSeconds) {}

Status Inventory::validateHeartbeat(const HeartbeatInfo& hb) {
  ErrorList errors;
  if (hb.node.empty()) errors.add("node", "is empty: a heartbeat must name its node");
  else if (hb.node.size() > 64 || hb.node.find_first_not_of("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789._-") != std::string::npos)
    errors.add("node", "'" + log::escaped(hb.node, 64) + "': at most 64 letters, digits, '.', '_' and '-'");
  if (hb.agentAddress.empty()) errors.add("agent_address", "is empty: the manager needs host:port of the agent");
  else if (hb.agentAddress.size() > 256 || !log::isPrintable(hb.agentAddress))
    errors.add("agent_address", "'" + log::escaped(hb.agentAddress, 64) + "': at most 256 printable characters");
  if (hb.devices.size() > 1024) errors.add("devices", std::to_string(hb.devices.size()) + " devices; the limit is 1024");
  if (hb.runningJobs.size() > 4096) errors.add("running_jobs", std::to_string(hb.runningJobs.size()) + " jobs; the limit is 4096");
  if (!errors.empty()) return errors.toStatus("heartbeat");
  std::set<DeviceKey> seen;
  for (std::size_t i = 0; i < hb.devices.size(); ++i) {
    const DeviceKey& k = hb.devices[i].key;
    const std::string path = "devices[" + std::to_string(i) + "]";
    if (k.node != hb.node) errors.add(path + ".ref.node", "is '" + log::escaped(k.node, 64) + "', not the heartbeat's node '" + hb.node + "'");
    if (hb.devices[i].name.size() > 256 || !log::isPrintable(hb.devices[i].name)) errors.add(path + ".name", "at most 256 printable characters");
    if (k.index < 0) errors.add(path + ".ref.index", "is negative (" + std::to_string(k.index) + ")");
    if (!seen.insert(k).second) errors.add(path + ".ref", "repeats device " + k.toString());
  }
  for (std::size_t i = 0; i < hb.runningJobs.size(); ++i)
    if (hb.runningJobs[i].empty()) errors.add("running_jobs[" + std::to_string(i) + "]", "is empty");
  return errors.empty() ? Status::ok() : errors.toStatus("heartbeat");
}

bool Inventory::heartbeat(const HeartbeatInfo& hb) {
  auto [it, inserted] = m_nodes.try_emplace(hb.node);
  Node& n = it->second;
  const bool wasLost = inserted || n.lost;
  n.agentAddress = hb.agentAddress;
  n.lost = false;
  n.lastHeartbeat = m_clock.now();
  n.devices = hb.devices;
  return wasLost;
}

std::vector<std::string> Inventory::expireLost(std::vector<std::string>* forgotten) {
  std::vector<std::string> lost;
  const double now = m_clock.now();
  for (auto it = m_nodes.begin(); it != m_nodes.end();) {
    auto& [name, n] = *it;
    if (!n.lost && now - n.lastHeartbeat > m_timeout) {
      n.lost = true;
      lost.push_back(name);
    }
    bool leased = false;
    for (const DeviceInfo& d : n.devices) leased = leased || m_leases.count(d.key) > 0;
    if (n.lost && now - n.lastHeartbeat > m_timeout + m_forgetAfter && !leased) {
      if (forgotten) forgotten->push_back(name);
      it = m_nodes.erase(it);
    } else {
      ++it;
    }
  }
  return lost;
}

bool Inventory::isLost(const std::string& node) const {
  auto it = m_nodes.find(node);
  return it != m_nodes.end() && it->second.lost;
}

std::string Inventory::agentAddress(const std::string& node) const {
  auto it = m_nodes.find(node);
  return it == m_nodes.end() ? std::string() : it->second.agentAddress;
}

Status Inventory::lease(const std::vector<DeviceKey>& devices, const std::string& jobId) {
  for (const DeviceKey& d : devices) {
    auto it = m_leases.find(d);
    if (it != m_leases.end() && it->second != jobId)
      return failedPrecondition("device " + d.toString() + " is already leased to job " + it->second);
  }
  for (const DeviceKey& d : devices) m_leases[d] = jobId;
  return Status::ok();
}

void Inventory::release(const std::string& jobId) {
  for (auto it = m_leases.begin(); it != m_leases.end();) {
    if (it->second == jobId)
      it = m_leases.erase(it);
    else
      ++it;
  }
}

std::string Inventory::leaseHolder(const DeviceKey& device) const {
  auto it = m_leases.find(device);
  return it == m_leases.end() ? std::string() : it->second;
}

std::vector<NodeView> Inventory::snapshot() const {
  std::vector<NodeView> out;
  out.reserve(m_nodes.size());
  for (const auto& [name, n] : m_nodes) {
    NodeView v;
    v.name = name;
    v.agentAddress = n.agentAddress;
    v.lost = n.lost;
    v.lastHeartbeat = n.lastHeartbeat;
    for (const DeviceInfo& d : n.devices) {
      DeviceView dv;
      dv.info = d;
      dv.jobId = leaseHolder(d.key);
      dv.state = n.lost ? DeviceState::kLost : dv.jobId.empty() ? DeviceState::kFree : DeviceState::kBusy;
      v.devices.push_back(std::move(dv));
    }
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace pflow::manager
