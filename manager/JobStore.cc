#include "manager/JobStore.h"

#include "manager/Sqlite.h"

#include <sqlite3.h>

#include <map>
#include <optional>
#include <utility>

namespace pflow::manager {
namespace {

constexpr int kSchemaVersion = 5;  // 2: jobs.model; 3: REQUEUED, jobs.attempts, jobs.max_attempts; 4: BUILDING, jobs.owner, max_seq;
                                   // 5: jobs.slurm_job_id, slurm_partition, slurm_account, slurm_time_limit

// The jobs table's columns and constraints (also the migration's new table).
constexpr const char* kJobColumns = R"sql((
  seq INTEGER PRIMARY KEY,
  id TEXT NOT NULL UNIQUE,
  name TEXT NOT NULL,
  state TEXT NOT NULL CHECK(state IN ('QUEUED','STARTING','RUNNING','SUCCEEDED','FAILED','CANCELLING','CANCELLED','REQUEUED','BUILDING')),
  reason TEXT NOT NULL,
  scene_name TEXT NOT NULL,
  model_id TEXT NOT NULL,
  model_uri TEXT NOT NULL,
  particles INTEGER NOT NULL,
  memory_bytes REAL NOT NULL,
  model TEXT NOT NULL DEFAULT '',
  max_devices INTEGER NOT NULL,
  wait INTEGER NOT NULL,
  submitted_at REAL NOT NULL,
  started_at REAL NOT NULL,
  finished_at REAL NOT NULL,
  exit_code INTEGER NOT NULL,
  step INTEGER NOT NULL,
  total_steps INTEGER NOT NULL,
  sim_time REAL NOT NULL,
  sim_duration REAL NOT NULL,
  particle_steps_per_second REAL NOT NULL,
  eta_seconds REAL NOT NULL,
  progress_at REAL NOT NULL,
  message TEXT NOT NULL,
  attempts INTEGER NOT NULL DEFAULT 0,
  max_attempts INTEGER NOT NULL DEFAULT 0,
  owner TEXT NOT NULL DEFAULT '',
  slurm_job_id TEXT NOT NULL DEFAULT '',
  slurm_partition TEXT NOT NULL DEFAULT '',
  slurm_account TEXT NOT NULL DEFAULT '',
  slurm_time_limit TEXT NOT NULL DEFAULT ''))sql";

constexpr const char* kOtherTables = R"sql(
CREATE TABLE IF NOT EXISTS job_devices(
  job_id TEXT NOT NULL REFERENCES jobs(id) ON DELETE CASCADE,
  rank INTEGER NOT NULL,
  node TEXT NOT NULL,
  kind TEXT NOT NULL CHECK(kind IN ('GPU','CPU')),
  device_index INTEGER NOT NULL,
  leased INTEGER NOT NULL,
  PRIMARY KEY(job_id, rank));
CREATE UNIQUE INDEX IF NOT EXISTS one_live_lease_per_device ON job_devices(node, kind, device_index) WHERE leased = 1;
)sql";

// The columns every version from 2 on has (the migration copies them).
constexpr const char* kOldColumns =
    "seq, id, name, state, reason, scene_name, model_id, model_uri, particles, memory_bytes, model, max_devices, wait, "
    "submitted_at, started_at, finished_at, exit_code, step, total_steps, sim_time, sim_duration, "
    "particle_steps_per_second, eta_seconds, progress_at, message";

DeviceKind kindFromText(const std::string& s) { return s == "CPU" ? DeviceKind::kCpu : DeviceKind::kGpu; }

}  // namespace

Result<std::unique_ptr<JobStore>> JobStore::open(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX, nullptr);
  if (rc != SQLITE_OK) {
    std::string msg = db ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
    sqlite3_close(db);
    return ioError("cannot open job database " + path + ": " + msg);
  }
  std::unique_ptr<JobStore> store(new JobStore(db, path));
  sqlite3_busy_timeout(db, 5000);
  if (path != ":memory:") {
    if (Status s = store->exec("PRAGMA journal_mode=WAL;"); !s) return s;
  }
  const std::string schema = std::string("CREATE TABLE IF NOT EXISTS schema_info(version INTEGER NOT NULL, max_seq INTEGER NOT NULL DEFAULT 0);\n") +
                             "CREATE TABLE IF NOT EXISTS jobs" + kJobColumns + ";\n" + kOtherTables;
  for (const char* sql : {"PRAGMA synchronous=NORMAL;", "PRAGMA foreign_keys=ON;", schema.c_str()})
    if (Status s = store->exec(sql); !s) return s;

  std::optional<std::int64_t> stored;  // read and finalized first: a migration may drop a table
  {
    Stmt version(db, "SELECT version FROM schema_info LIMIT 1");
    if (!version.ok()) return store->error("reading the schema version");
    if (version.step() == SQLITE_ROW) stored = version.colI64(0);
  }
  if (stored) {
    auto v = *stored;
    if (v == 1) {  // version 1 had no model column: add it (empty for the jobs it holds)
      if (Status s = store->exec("BEGIN IMMEDIATE; ALTER TABLE jobs ADD COLUMN model TEXT NOT NULL DEFAULT ''; "
                                 "UPDATE schema_info SET version = 2; COMMIT;");
          !s) {
        store->exec("ROLLBACK;");
        return s;
      }
      v = 2;
    }
    if (v == 2 || v == 3) {
      // SQLite cannot change a CHECK constraint (3: REQUEUED, 4: BUILDING), so the jobs table is rebuilt (SQLite's
      // documented procedure: foreign keys off, new table, copy, drop, rename). From 2, a job that had started counts
      // one attempt; jobs from before users existed belong to no one (admins see them). schema_info gains max_seq.
      const bool hasMaxSeq = Stmt(db, "SELECT max_seq FROM schema_info LIMIT 0").ok();
      const std::string attempts = v == 2 ? "CASE WHEN started_at > 0 THEN 1 ELSE 0 END, 0" : "attempts, max_attempts";
      const std::string sql = std::string("BEGIN IMMEDIATE; CREATE TABLE jobs_v4") + kJobColumns + "; INSERT INTO jobs_v4(" + kOldColumns +
                              ", attempts, max_attempts) SELECT " + kOldColumns + ", " + attempts + " FROM jobs; " +
                              "DROP TABLE jobs; ALTER TABLE jobs_v4 RENAME TO jobs; " +
                              (hasMaxSeq ? "" : "ALTER TABLE schema_info ADD COLUMN max_seq INTEGER NOT NULL DEFAULT 0; ") +
                              "UPDATE schema_info SET version = 5, max_seq = (SELECT IFNULL(MAX(seq), 0) FROM jobs); COMMIT;";  // the new table has every column
      if (Status s = store->exec("PRAGMA foreign_keys=OFF;"); !s) return s;
      Status migrated = store->exec(sql.c_str());
      if (!migrated) store->exec("ROLLBACK;");
      if (Status s = store->exec("PRAGMA foreign_keys=ON;"); !s) return s;
      if (!migrated) return migrated;
      v = 5;
    }
    if (v == 4) {  // 5: the Slurm job of a job's current attempt (placement through Slurm)
      if (Status s = store->exec("BEGIN IMMEDIATE; ALTER TABLE jobs ADD COLUMN slurm_job_id TEXT NOT NULL DEFAULT ''; "
                                 "ALTER TABLE jobs ADD COLUMN slurm_partition TEXT NOT NULL DEFAULT ''; "
                                 "ALTER TABLE jobs ADD COLUMN slurm_account TEXT NOT NULL DEFAULT ''; "
                                 "ALTER TABLE jobs ADD COLUMN slurm_time_limit TEXT NOT NULL DEFAULT ''; "
                                 "UPDATE schema_info SET version = 5; COMMIT;");
          !s) {
        store->exec("ROLLBACK;");
        return s;
      }
      v = 5;
    }
    if (v != kSchemaVersion)
      return failedPrecondition("job database " + path + " has schema version " + std::to_string(v) + "; this manager knows " +
                                std::to_string(kSchemaVersion));
  } else {
    Stmt ins(db, "INSERT INTO schema_info(version) VALUES(?1)");
    ins.i64(1, kSchemaVersion);
    if (!ins.ok() || ins.step() != SQLITE_DONE) return store->error("writing the schema version");
  }
  return store;
}

JobStore::~JobStore() { sqlite3_close(m_db); }

Status JobStore::exec(const char* sql) const {
  char* err = nullptr;
  if (sqlite3_exec(m_db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    std::string msg = err ? err : "unknown error";
    sqlite3_free(err);
    return ioError("job database " + m_path + ": " + msg);
  }
  return Status::ok();
}

Status JobStore::error(const std::string& what) const {
  return ioError("job database " + m_path + ": " + what + ": " + sqlite3_errmsg(m_db));
}

Status JobStore::save(const Job& job) {
  if (Status s = exec("BEGIN IMMEDIATE;"); !s) return s;
  auto fail = [&](const std::string& what) {
    Status s = error(what);
    exec("ROLLBACK;");
    return s;
  };
  {
    Stmt st(m_db, R"sql(
INSERT INTO jobs(seq, id, name, state, reason, scene_name, model_id, model_uri, particles, memory_bytes, max_devices, wait,
                 submitted_at, started_at, finished_at, exit_code, step, total_steps, sim_time, sim_duration,
                 particle_steps_per_second, eta_seconds, progress_at, message, model, attempts, max_attempts, owner, slurm_job_id,
                 slurm_partition, slurm_account, slurm_time_limit)
VALUES(?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25, ?26, ?27, ?28, ?29,
       ?30, ?31, ?32)
ON CONFLICT(id) DO UPDATE SET
  name=excluded.name, state=excluded.state, reason=excluded.reason, scene_name=excluded.scene_name,
  model_id=excluded.model_id, model_uri=excluded.model_uri, particles=excluded.particles,
  memory_bytes=excluded.memory_bytes, max_devices=excluded.max_devices, wait=excluded.wait,
  submitted_at=excluded.submitted_at, started_at=excluded.started_at, finished_at=excluded.finished_at,
  exit_code=excluded.exit_code, step=excluded.step, total_steps=excluded.total_steps, sim_time=excluded.sim_time,
  sim_duration=excluded.sim_duration, particle_steps_per_second=excluded.particle_steps_per_second,
  eta_seconds=excluded.eta_seconds, progress_at=excluded.progress_at, message=excluded.message, model=excluded.model,
  attempts=excluded.attempts, max_attempts=excluded.max_attempts, owner=excluded.owner, slurm_job_id=excluded.slurm_job_id,
  slurm_partition=excluded.slurm_partition, slurm_account=excluded.slurm_account, slurm_time_limit=excluded.slurm_time_limit
)sql");
    if (!st.ok()) return fail("preparing the job update");
    st.i64(1, job.seq);
    st.text(2, job.id);
    st.text(3, job.name);
    st.text(4, jobStateName(job.state));
    st.text(5, job.reason);
    st.text(6, job.sceneName);
    st.text(7, job.modelId);
    st.text(8, job.modelUri);
    st.i64(9, static_cast<std::int64_t>(job.particles));
    st.real(10, job.memoryBytes);
    st.i64(11, job.maxDevices);
    st.i64(12, job.wait ? 1 : 0);
    st.real(13, job.submittedAt);
    st.real(14, job.startedAt);
    st.real(15, job.finishedAt);
    st.i64(16, job.exitCode);
    st.i64(17, job.progress.step);
    st.i64(18, job.progress.totalSteps);
    st.real(19, job.progress.time);
    st.real(20, job.progress.duration);
    st.real(21, job.progress.particleStepsPerSecond);
    st.real(22, job.progress.etaSeconds);
    st.real(23, job.progressAt);
    st.text(24, job.message);
    st.text(25, job.model);
    st.i64(26, job.attempts);
    st.i64(27, job.maxAttempts);
    st.text(28, job.owner);
    st.text(29, job.slurmJobId);
    st.text(30, job.slurm.partition);
    st.text(31, job.slurm.account);
    st.text(32, job.slurm.timeLimit);
    if (st.step() != SQLITE_DONE) return fail("saving job " + job.id);
  }
  {
    Stmt seq(m_db, "UPDATE schema_info SET max_seq = MAX(max_seq, ?1)");
    if (!seq.ok()) return fail("preparing the seq update");
    seq.i64(1, job.seq);
    if (seq.step() != SQLITE_DONE) return fail("recording the seq of job " + job.id);
  }
  {
    Stmt del(m_db, "DELETE FROM job_devices WHERE job_id = ?1");
    if (!del.ok()) return fail("preparing the device update");
    del.text(1, job.id);
    if (del.step() != SQLITE_DONE) return fail("clearing the devices of job " + job.id);
  }
  for (std::size_t rank = 0; rank < job.devices.size(); ++rank) {
    const DeviceKey& d = job.devices[rank];
    Stmt ins(m_db, "INSERT INTO job_devices(job_id, rank, node, kind, device_index, leased) VALUES(?1, ?2, ?3, ?4, ?5, ?6)");
    if (!ins.ok()) return fail("preparing the device insert");
    ins.text(1, job.id);
    ins.i64(2, static_cast<std::int64_t>(rank));
    ins.text(3, d.node);
    ins.text(4, deviceKindName(d.kind));
    ins.i64(5, d.index);
    ins.i64(6, holdsDevices(job.state) ? 1 : 0);
    if (ins.step() != SQLITE_DONE) return fail("saving device " + d.toString() + " of job " + job.id);
  }
  if (Status s = exec("COMMIT;"); !s) {
    exec("ROLLBACK;");
    return s;
  }
  return Status::ok();
}

Result<std::vector<Job>> JobStore::loadAll() const {
  std::vector<Job> jobs;
  std::map<std::string, std::size_t> index;
  {
    Stmt st(m_db, R"sql(
SELECT seq, id, name, state, reason, scene_name, model_id, model_uri, particles, memory_bytes, max_devices, wait,
       submitted_at, started_at, finished_at, exit_code, step, total_steps, sim_time, sim_duration,
       particle_steps_per_second, eta_seconds, progress_at, message, model, attempts, max_attempts, owner, slurm_job_id,
       slurm_partition, slurm_account, slurm_time_limit
FROM jobs ORDER BY seq)sql");
    if (!st.ok()) return error("preparing the job query");
    int rc;
    while ((rc = st.step()) == SQLITE_ROW) {
      Job j;
      j.seq = st.colI64(0);
      j.id = st.colText(1);
      j.name = st.colText(2);
      const auto state = jobStateFromName(st.colText(3));
      if (!state) return ioError("job database " + m_path + ": job " + j.id + " has unknown state '" + st.colText(3) + "'");
      j.state = *state;
      j.reason = st.colText(4);
      j.sceneName = st.colText(5);
      j.modelId = st.colText(6);
      j.modelUri = st.colText(7);
      j.particles = static_cast<std::uint64_t>(st.colI64(8));
      j.memoryBytes = st.colReal(9);
      j.maxDevices = static_cast<int>(st.colI64(10));
      j.wait = st.colI64(11) != 0;
      j.submittedAt = st.colReal(12);
      j.startedAt = st.colReal(13);
      j.finishedAt = st.colReal(14);
      j.exitCode = static_cast<int>(st.colI64(15));
      j.progress.step = st.colI64(16);
      j.progress.totalSteps = st.colI64(17);
      j.progress.time = st.colReal(18);
      j.progress.duration = st.colReal(19);
      j.progress.particleStepsPerSecond = st.colReal(20);
      j.progress.etaSeconds = st.colReal(21);
      j.progressAt = st.colReal(22);
      j.message = st.colText(23);
      j.model = st.colText(24);
      j.attempts = static_cast<int>(st.colI64(25));
      j.maxAttempts = static_cast<int>(st.colI64(26));
      j.owner = st.colText(27);
      j.slurmJobId = st.colText(28);
      j.slurm = {st.colText(29), st.colText(30), st.colText(31)};
      index[j.id] = jobs.size();
      jobs.push_back(std::move(j));
    }
    if (rc != SQLITE_DONE) return error("reading jobs");
  }
  Stmt st(m_db, "SELECT job_id, node, kind, device_index FROM job_devices ORDER BY job_id, rank");
  if (!st.ok()) return error("preparing the device query");
  int rc;
  while ((rc = st.step()) == SQLITE_ROW) {
    auto it = index.find(st.colText(0));
    if (it == index.end()) continue;
    jobs[it->second].devices.push_back({st.colText(1), static_cast<int>(st.colI64(3)), kindFromText(st.colText(2))});
  }
  if (rc != SQLITE_DONE) return error("reading job devices");
  return jobs;
}

Status JobStore::remove(const std::string& id) {
  Stmt st(m_db, "DELETE FROM jobs WHERE id = ?1");  // its device rows go with it (ON DELETE CASCADE)
  if (!st.ok()) return error("preparing the job delete");
  st.text(1, id);
  if (st.step() != SQLITE_DONE) return error("deleting job " + id);
  return Status::ok();
}

Result<std::int64_t> JobStore::maxSeqEver() const {
  Stmt st(m_db, "SELECT max_seq FROM schema_info LIMIT 1");
  if (!st.ok()) return error("preparing the seq query");
  const int rc = st.step();
  if (rc == SQLITE_ROW) return st.colI64(0);
  if (rc == SQLITE_DONE) return std::int64_t(0);
  return error("reading the largest seq");
}

Result<std::vector<std::pair<DeviceKey, std::string>>> JobStore::leases() const {
  std::vector<std::pair<DeviceKey, std::string>> out;
  Stmt st(m_db, "SELECT node, kind, device_index, job_id FROM job_devices WHERE leased = 1 ORDER BY job_id, rank");
  if (!st.ok()) return error("preparing the lease query");
  int rc;
  while ((rc = st.step()) == SQLITE_ROW)
    out.push_back({{st.colText(0), static_cast<int>(st.colI64(2)), kindFromText(st.colText(1))}, st.colText(3)});
  if (rc != SQLITE_DONE) return error("reading leases");
  return out;
}

}  // namespace pflow::manager
