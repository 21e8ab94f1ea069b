// SQLite persistence of jobs and their device leases, so a manager restart loses neither. WAL journal; every save
// is one transaction (the job row and its device rows together). Schema in manager/README.md.
//
// A device row is `leased` while its job holds devices (starting, running, cancelling); a partial unique index makes
// the database itself refuse two live leases on one device.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "common/Status.h"
#include "manager/Types.h"

struct sqlite3;

namespace pflow::manager {

class JobStore {
 public:
  // Opens (creating if needed) the database at `path` (":memory:" for a private in-memory one).
  static Result<std::unique_ptr<JobStore>> open(const std::string& path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  // Inserts or updates the job and replaces its device rows, in one transaction. On error nothing changes.
  Status save(const Job& job);
  // Every job, in submission order, with its devices in rank order.
  Result<std::vector<Job>> loadAll() const;
  // Deletes a job and its device rows (`pflow delete`). The largest seq stays recorded (maxSeqEver).
  Status remove(const std::string& id);
  // The largest seq any job ever had, deleted ones included: new ids continue after it.
  Result<std::int64_t> maxSeqEver() const;
  // Live leases: device -> job id (devices of jobs that hold them).
  Result<std::vector<std::pair<DeviceKey, std::string>>> leases() const;

  const std::string& path() const { return m_path; }

 private:
  JobStore(sqlite3* db, std::string path) : m_db(db), m_path(std::move(path)) {}
  Status exec(const char* sql) const;
  Status error(const std::string& what) const;
  sqlite3* m_db;
  std::string m_path;
};

}  // namespace pflow::manager
