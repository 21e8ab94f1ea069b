// Reading Slurm's command output: `scontrol -o` records (Key=Value pairs, one record a line, values that may hold
// spaces), host lists ("gpu[01-03,07]"), id lists ("0-3,8"), exit codes ("code:signal"). Pure functions.
#pragma once
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "common/Status.h"
#include "manager/slurm/SlurmTypes.h"

namespace pflow::manager::slurm {

// One `scontrol -o` line as an ordered list of (key, value). A word without '=' continues the previous value (an OS
// string, a node's Reason). The detailed job record repeats Nodes=/CPU_IDs=/GRES= once per node: every pair is kept.
using Record = std::vector<std::pair<std::string, std::string>>;
Record parseRecord(const std::string& line);
std::vector<Record> parseRecords(const std::string& text);
// The first value of `key` ("" when absent).
std::string field(const Record& record, const std::string& key);

// "pflow-node[1-3,5],gpu07" -> pflow-node1, pflow-node2, pflow-node3, pflow-node5, gpu07. Zero-padded ranges keep
// their width. INVALID_ARGUMENT for an unbalanced bracket or a bad range.
Result<std::vector<std::string>> expandHostList(const std::string& list);
// "0-3,8" -> 0 1 2 3 8.
Result<std::vector<int>> expandIdList(const std::string& list);

JobInfo jobFromRecord(const Record& record);
NodeInfo nodeFromRecord(const Record& record);

// The number of GPUs in a Gres= or AllocTRES= value: "gpu:4", "gpu:h100:4(S:0-1)", "gpu:a100:2,gpu:h100:2" (6), or
// "cpu=8,gres/gpu=2" (2).
int gpuCount(const std::string& value);

}  // namespace pflow::manager::slurm
