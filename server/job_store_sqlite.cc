// The single-process store: SQLite in WAL mode, one connection guarded by a mutex. One
// `matfit serve` owns the file (a flock on DATA/lock), so leases never expire here: jobs a dead
// process left running are re-queued at the next start (RequeueNode).
#include <sqlite3.h>

#include <mutex>

#include "server/job_store.h"

namespace matfit::server {
namespace {

constexpr const char* kColumns =
    "id, seq, state, spec, dataset, uploaded, created, started, finished, progress, stage, "
    "error, summary, run_seconds, attempts, cancel_requested, node";

// A prepared statement that finalises itself.
class Stmt {
 public:
  Stmt(sqlite3* db, const char* sql) { sqlite3_prepare_v2(db, sql, -1, &s_, nullptr); }
  ~Stmt() { sqlite3_finalize(s_); }
  bool ok() const { return s_ != nullptr; }
  Stmt& Bind(int i, const std::string& v) {
    sqlite3_bind_text(s_, i, v.c_str(), int(v.size()), SQLITE_TRANSIENT);
    return *this;
  }
  Stmt& Bind(int i, double v) {
    sqlite3_bind_double(s_, i, v);
    return *this;
  }
  Stmt& Bind(int i, int64_t v) {
    sqlite3_bind_int64(s_, i, v);
    return *this;
  }
  int Step() { return sqlite3_step(s_); }
  std::string Text(int c) const {
    const auto* p = sqlite3_column_text(s_, c);
    return p ? reinterpret_cast<const char*>(p) : "";
  }
  double Real(int c) const { return sqlite3_column_double(s_, c); }
  int64_t Int(int c) const { return sqlite3_column_int64(s_, c); }

 private:
  sqlite3_stmt* s_ = nullptr;
};

JobRecord FromRow(const Stmt& s) {
  JobRecord j;
  j.id = s.Text(0);
  j.seq = s.Int(1);
  ParseJobState(s.Text(2), &j.state);
  j.spec_json = s.Text(3);
  j.dataset = s.Text(4);
  j.uploaded = s.Int(5) != 0;
  j.created = s.Real(6);
  j.started = s.Real(7);
  j.finished = s.Real(8);
  j.progress = s.Real(9);
  j.stage = s.Text(10);
  j.error = s.Text(11);
  j.summary_json = s.Text(12);
  j.run_seconds = s.Real(13);
  j.attempts = int(s.Int(14));
  j.cancel_requested = s.Int(15) != 0;
  j.node = s.Text(16);
  return j;
}

Status SqlError(sqlite3* db, const std::string& what) {
  return IoError("job database: " + what + ": " + sqlite3_errmsg(db));
}

// Schema versions (PRAGMA user_version), applied in order, each in one transaction. Version 1
// is the table of the first release (IF NOT EXISTS: databases made before versioning have it).
constexpr const char* kMigrations[] = {
    "CREATE TABLE IF NOT EXISTS jobs ("
    " id TEXT PRIMARY KEY, seq INTEGER NOT NULL, state TEXT NOT NULL, spec TEXT NOT NULL,"
    " dataset TEXT NOT NULL, uploaded INTEGER NOT NULL, created REAL NOT NULL,"
    " started REAL NOT NULL DEFAULT 0, finished REAL NOT NULL DEFAULT 0,"
    " progress REAL NOT NULL DEFAULT 0, stage TEXT NOT NULL DEFAULT '',"
    " error TEXT NOT NULL DEFAULT '', summary TEXT NOT NULL DEFAULT '{}',"
    " run_seconds REAL NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0,"
    " cancel_requested INTEGER NOT NULL DEFAULT 0);"
    "CREATE INDEX IF NOT EXISTS jobs_state_seq ON jobs(state, seq);",
    // 2: leases (the node that runs a job) and the publication row of each pack.
    "ALTER TABLE jobs ADD COLUMN node TEXT NOT NULL DEFAULT '';"
    "ALTER TABLE jobs ADD COLUMN lease_until REAL NOT NULL DEFAULT 0;"
    "CREATE TABLE publications (job_id TEXT PRIMARY KEY, node TEXT NOT NULL,"
    " attempt INTEGER NOT NULL, published REAL NOT NULL);",
};

class SqliteJobStore final : public JobStore {
 public:
  explicit SqliteJobStore(sqlite3* db) : db_(db) {}
  ~SqliteJobStore() override { sqlite3_close(db_); }

  Status Migrate();
  const char* Engine() const override { return "sqlite"; }
  bool Shared() const override { return false; }
  Status Ping() override;
  Status Insert(JobRecord* job) override;
  std::optional<JobRecord> Get(const std::string& id) override;
  std::vector<JobRecord> List(std::optional<JobState> state, int limit) override;
  std::optional<JobRecord> ClaimNext(const std::string& node, double now,
                                     double lease_seconds) override;
  StatusOr<std::set<std::string>> Heartbeat(
      const std::string& node, const std::vector<std::pair<std::string, int>>& attempts,
      double lease_seconds) override;
  Status UpdateProgress(const std::string& id, const JobLease& lease, double progress,
                        const std::string& stage) override;
  Status Finish(const std::string& id, const JobLease& lease, const JobFinal& f,
                const std::function<Status()>& publish) override;
  Status Requeue(const std::string& id, const JobLease& lease) override;
  int RequeueNode(const std::string& node) override;
  bool RequestCancel(const std::string& id, double now, Status* write_error) override;
  Status Delete(const std::string& id) override;
  bool DeleteFinished(const std::string& id, Status* write_error) override;
  std::map<JobState, int64_t> CountByState() override;
  std::vector<std::string> AllIds() override;
  int64_t Publications(const std::string& id) override;

 private:
  Status Exec(const std::string& sql);
  sqlite3* db_;
  std::mutex mutex_;
};

}  // namespace

StatusOr<std::unique_ptr<JobStore>> OpenSqliteJobStore(const std::string& path) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return IoError("cannot open job database '" + path + "': " + msg);
  }
  auto store = std::make_unique<SqliteJobStore>(db);
  sqlite3_busy_timeout(db, 5000);
  // WAL + synchronous=NORMAL: a committed transition survives a process crash (kill -9).
  if (Status st = store->Migrate(); !st.ok())
    return Status(st.code(), "job database '" + path + "': " + st.message());
  return std::unique_ptr<JobStore>(std::move(store));
}

Status SqliteJobStore::Migrate() {
  MATFIT_RETURN_IF_ERROR(Exec("PRAGMA journal_mode=WAL"));
  MATFIT_RETURN_IF_ERROR(Exec("PRAGMA synchronous=NORMAL"));
  int version = 0;
  {
    Stmt v(db_, "PRAGMA user_version");
    if (v.Step() == SQLITE_ROW) version = int(v.Int(0));
  }
  const int latest = int(std::size(kMigrations));
  if (version > latest)
    return DataError("schema version " + std::to_string(version) +
                     " is newer than this matfit knows (" + std::to_string(latest) +
                     "); run the matfit that wrote it, or a newer one");
  for (int v = version; v < latest; ++v) {
    MATFIT_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
    Status st = Exec(kMigrations[v]);
    if (st.ok()) st = Exec("PRAGMA user_version = " + std::to_string(v + 1));
    if (!st.ok()) {
      (void)Exec("ROLLBACK");
      return st;
    }
    MATFIT_RETURN_IF_ERROR(Exec("COMMIT"));
  }
  return Status::Ok();
}

Status SqliteJobStore::Exec(const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    return IoError("job database: '" + sql.substr(0, 80) + "': " + msg);
  }
  return Status::Ok();
}

Status SqliteJobStore::Ping() {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "SELECT 1");
  return s.ok() && s.Step() == SQLITE_ROW ? Status::Ok() : SqlError(db_, "ping");
}
Status SqliteJobStore::Insert(JobRecord* j) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_,
         "INSERT INTO jobs (id, seq, state, spec, dataset, uploaded, created) VALUES "
         "(?, (SELECT IFNULL(MAX(seq), 0) + 1 FROM jobs), ?, ?, ?, ?, ?) RETURNING seq");
  if (!s.ok()) return SqlError(db_, "insert");
  s.Bind(1, j->id).Bind(2, std::string(JobStateName(j->state))).Bind(3, j->spec_json);
  s.Bind(4, j->dataset).Bind(5, int64_t(j->uploaded)).Bind(6, j->created);
  if (s.Step() != SQLITE_ROW) return SqlError(db_, "insert job " + j->id);
  j->seq = s.Int(0);
  s.Step();
  return Status::Ok();
}

std::optional<JobRecord> SqliteJobStore::Get(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, (std::string("SELECT ") + kColumns + " FROM jobs WHERE id = ?").c_str());
  s.Bind(1, id);
  if (s.Step() != SQLITE_ROW) return std::nullopt;
  return FromRow(s);
}

std::vector<JobRecord> SqliteJobStore::List(std::optional<JobState> state, int limit) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string sql = std::string("SELECT ") + kColumns + " FROM jobs";
  if (state) sql += " WHERE state = ?";
  sql += " ORDER BY seq DESC LIMIT ?";
  Stmt s(db_, sql.c_str());
  int i = 1;
  if (state) s.Bind(i++, std::string(JobStateName(*state)));
  s.Bind(i, int64_t(limit));
  std::vector<JobRecord> out;
  while (s.Step() == SQLITE_ROW) out.push_back(FromRow(s));
  return out;
}

std::optional<JobRecord> SqliteJobStore::ClaimNext(const std::string& node, double now,
                                                   double lease_seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  // One statement: no other worker can claim the same row. Only queued jobs: no other process
  // shares this file, so a running job's worker is alive (or re-queued at the next start).
  Stmt s(db_, (std::string("UPDATE jobs SET state = 'running', started = ?, attempts = attempts "
                           "+ 1, progress = 0, stage = '', node = ?, lease_until = ? WHERE id = "
                           "(SELECT id FROM jobs WHERE state = 'queued' ORDER BY seq LIMIT 1) "
                           "RETURNING ") +
               kColumns)
                  .c_str());
  s.Bind(1, now).Bind(2, node).Bind(3, now + lease_seconds);
  if (s.Step() != SQLITE_ROW) return std::nullopt;
  JobRecord j = FromRow(s);
  s.Step();
  return j;
}

StatusOr<std::set<std::string>> SqliteJobStore::Heartbeat(
    const std::string& node, const std::vector<std::pair<std::string, int>>& attempts, double) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::set<std::string> out;
  for (const auto& [id, attempt] : attempts) {
    Stmt s(db_,
           "SELECT 1 FROM jobs WHERE id = ? AND state = 'running' AND node = ? AND attempts = ?");
    s.Bind(1, id).Bind(2, node).Bind(3, int64_t(attempt));
    const int rc = s.Step();
    if (rc == SQLITE_ROW)
      out.insert(id);
    else if (rc != SQLITE_DONE)
      return SqlError(db_, "heartbeat");
  }
  return out;
}

Status SqliteJobStore::UpdateProgress(const std::string& id, const JobLease& lease, double progress,
                                      const std::string& stage) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_,
         "UPDATE jobs SET progress = ?, stage = ? WHERE id = ? AND state = 'running' AND node = ? "
         "AND attempts = ?");
  s.Bind(1, progress).Bind(2, stage).Bind(3, id).Bind(4, lease.node);
  s.Bind(5, int64_t(lease.attempt));
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "progress of " + id);
  return Status::Ok();
}

Status SqliteJobStore::Finish(const std::string& id, const JobLease& lease, const JobFinal& f,
                              const std::function<Status()>& publish) {
  std::lock_guard<std::mutex> lock(mutex_);
  MATFIT_RETURN_IF_ERROR(Exec("BEGIN IMMEDIATE"));
  auto rollback = [&](Status st) {
    (void)Exec("ROLLBACK");
    return st;
  };
  {
    Stmt q(db_, "SELECT state, node, attempts FROM jobs WHERE id = ?");
    q.Bind(1, id);
    const int rc = q.Step();
    if (rc != SQLITE_ROW && rc != SQLITE_DONE) return rollback(SqlError(db_, "finish " + id));
    const bool mine = rc == SQLITE_ROW && q.Text(1) == lease.node && q.Int(2) == lease.attempt;
    JobState now = JobState::kQueued;
    if (rc == SQLITE_ROW) ParseJobState(q.Text(0), &now);
    if (mine && IsFinished(now)) return rollback(Status::Ok());  // recorded by an earlier try
    if (!mine || now != JobState::kRunning)
      return rollback(Status(StatusCode::kCancelled, "job " + id + ": the lease of attempt " +
                                                         std::to_string(lease.attempt) +
                                                         " is no longer held"));
  }
  const std::string name = JobStateName(f.state);
  if (f.state == JobState::kSucceeded) {
    Stmt p(db_, "INSERT INTO publications (job_id, node, attempt, published) VALUES (?, ?, ?, ?)");
    p.Bind(1, id).Bind(2, lease.node).Bind(3, int64_t(lease.attempt)).Bind(4, f.finished);
    if (p.Step() != SQLITE_DONE) return rollback(SqlError(db_, "publish " + id));
    if (publish)
      if (Status st = publish(); !st.ok()) return rollback(st);
  }
  Stmt s(db_,
         "UPDATE jobs SET state = ?, error = ?, summary = ?, finished = ?, run_seconds = ?, "
         "progress = CASE WHEN ? = 'succeeded' THEN 1 ELSE progress END WHERE id = ?");
  s.Bind(1, name).Bind(2, f.error);
  s.Bind(3, f.summary_json.empty() ? std::string("{}") : f.summary_json);
  s.Bind(4, f.finished).Bind(5, f.run_seconds).Bind(6, name).Bind(7, id);
  if (s.Step() != SQLITE_DONE) return rollback(SqlError(db_, "finish " + id));
  // A failed commit after the pack was moved leaves an unpublished pack in place; the job is
  // still "running" and its next attempt replaces it.
  if (Status st = Exec("COMMIT"); !st.ok()) return rollback(st);
  return Status::Ok();
}

Status SqliteJobStore::Requeue(const std::string& id, const JobLease& lease) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_,
         "UPDATE jobs SET state = 'queued', progress = 0, stage = '', started = 0 "
         "WHERE id = ? AND state = 'running' AND node = ? AND attempts = ?");
  s.Bind(1, id).Bind(2, lease.node).Bind(3, int64_t(lease.attempt));
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "requeue " + id);
  return Status::Ok();
}

int SqliteJobStore::RequeueNode(const std::string&) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Every running job: this process owns the file. A cancel that was requested before the crash
  // is honoured now.
  Stmt c(db_,
         "UPDATE jobs SET state = 'cancelled', error = 'cancelled' WHERE state = 'running' AND "
         "cancel_requested = 1");
  c.Step();
  Stmt s(db_,
         "UPDATE jobs SET state = 'queued', progress = 0, stage = '', started = 0 "
         "WHERE state = 'running'");
  s.Step();
  return sqlite3_changes(db_);
}

bool SqliteJobStore::RequestCancel(const std::string& id, double now, Status* write_error) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt q(db_,
         "UPDATE jobs SET state = 'cancelled', error = 'cancelled before it started', "
         "finished = ? WHERE id = ? AND state = 'queued'");
  q.Bind(1, now).Bind(2, id);
  if (q.Step() != SQLITE_DONE) {
    if (write_error) *write_error = SqlError(db_, "cancel " + id);
    return false;
  }
  if (sqlite3_changes(db_) > 0) return true;
  Stmt r(db_, "UPDATE jobs SET cancel_requested = 1 WHERE id = ? AND state = 'running'");
  r.Bind(1, id);
  if (r.Step() != SQLITE_DONE) {
    if (write_error) *write_error = SqlError(db_, "cancel " + id);
    return false;
  }
  return sqlite3_changes(db_) > 0;
}

Status SqliteJobStore::Delete(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt p(db_, "DELETE FROM publications WHERE job_id = ?");
  p.Bind(1, id);
  if (p.Step() != SQLITE_DONE) return SqlError(db_, "delete " + id);
  Stmt s(db_, "DELETE FROM jobs WHERE id = ?");
  s.Bind(1, id);
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "delete " + id);
  return Status::Ok();
}

bool SqliteJobStore::DeleteFinished(const std::string& id, Status* write_error) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "DELETE FROM jobs WHERE id = ? AND state IN ('succeeded', 'failed', 'cancelled')");
  s.Bind(1, id);
  if (s.Step() != SQLITE_DONE) {
    if (write_error) *write_error = SqlError(db_, "delete " + id);
    return false;
  }
  if (sqlite3_changes(db_) == 0) return false;
  Stmt p(db_, "DELETE FROM publications WHERE job_id = ?");  // the job is gone: no pack either
  p.Bind(1, id);
  p.Step();
  return true;
}

std::map<JobState, int64_t> SqliteJobStore::CountByState() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<JobState, int64_t> out;
  for (int i = 0; i < 5; ++i) out[JobState(i)] = 0;
  Stmt s(db_, "SELECT state, COUNT(*) FROM jobs GROUP BY state");
  while (s.Step() == SQLITE_ROW) {
    JobState st;
    if (ParseJobState(s.Text(0), &st)) out[st] = s.Int(1);
  }
  return out;
}

std::vector<std::string> SqliteJobStore::AllIds() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out;
  Stmt s(db_, "SELECT id FROM jobs");
  while (s.Step() == SQLITE_ROW) out.push_back(s.Text(0));
  return out;
}

int64_t SqliteJobStore::Publications(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "SELECT COUNT(*) FROM publications WHERE job_id = ?");
  s.Bind(1, id);
  return s.Step() == SQLITE_ROW ? s.Int(0) : -1;
}

}  // namespace matfit::server
