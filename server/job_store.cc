#include "server/job_store.h"

#include <sqlite3.h>

namespace matfit::server {
namespace {

constexpr const char* kStates[] = {"queued", "running", "succeeded", "failed", "cancelled"};

constexpr const char* kColumns =
    "id, seq, state, spec, dataset, uploaded, created, started, finished, progress, stage, "
    "error, summary, run_seconds, attempts, cancel_requested";

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
  return j;
}

Status SqlError(sqlite3* db, const std::string& what) {
  return IoError("job database: " + what + ": " + sqlite3_errmsg(db));
}

}  // namespace

const char* JobStateName(JobState s) { return kStates[int(s)]; }

bool ParseJobState(const std::string& s, JobState* out) {
  for (int i = 0; i < 5; ++i)
    if (s == kStates[i]) return *out = JobState(i), true;
  return false;
}

StatusOr<std::unique_ptr<JobStore>> JobStore::Open(const std::string& path) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_FULLMUTEX,
                      nullptr) != SQLITE_OK) {
    const std::string msg = db ? sqlite3_errmsg(db) : "out of memory";
    sqlite3_close(db);
    return IoError("cannot open job database '" + path + "': " + msg);
  }
  std::unique_ptr<JobStore> store(new JobStore(db));
  sqlite3_busy_timeout(db, 5000);
  // WAL + synchronous=NORMAL: a committed transition survives a process crash (kill -9).
  MATFIT_RETURN_IF_ERROR(store->Exec("PRAGMA journal_mode=WAL"));
  MATFIT_RETURN_IF_ERROR(store->Exec("PRAGMA synchronous=NORMAL"));
  MATFIT_RETURN_IF_ERROR(store->Exec(
      "CREATE TABLE IF NOT EXISTS jobs ("
      " id TEXT PRIMARY KEY, seq INTEGER NOT NULL, state TEXT NOT NULL, spec TEXT NOT NULL,"
      " dataset TEXT NOT NULL, uploaded INTEGER NOT NULL, created REAL NOT NULL,"
      " started REAL NOT NULL DEFAULT 0, finished REAL NOT NULL DEFAULT 0,"
      " progress REAL NOT NULL DEFAULT 0, stage TEXT NOT NULL DEFAULT '',"
      " error TEXT NOT NULL DEFAULT '', summary TEXT NOT NULL DEFAULT '{}',"
      " run_seconds REAL NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0,"
      " cancel_requested INTEGER NOT NULL DEFAULT 0)"));
  MATFIT_RETURN_IF_ERROR(
      store->Exec("CREATE INDEX IF NOT EXISTS jobs_state_seq ON jobs(state, seq)"));
  return store;
}

JobStore::~JobStore() { sqlite3_close(db_); }

Status JobStore::Exec(const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    return IoError(std::string("job database: '") + sql + "': " + msg);
  }
  return Status::Ok();
}

Status JobStore::Insert(JobRecord* j) {
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

std::optional<JobRecord> JobStore::Get(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, (std::string("SELECT ") + kColumns + " FROM jobs WHERE id = ?").c_str());
  s.Bind(1, id);
  if (s.Step() != SQLITE_ROW) return std::nullopt;
  return FromRow(s);
}

std::vector<JobRecord> JobStore::List(std::optional<JobState> state, int limit) {
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

std::optional<JobRecord> JobStore::ClaimNext(double now) {
  std::lock_guard<std::mutex> lock(mutex_);
  // One statement: no other worker (or process) can claim the same row.
  Stmt s(db_, (std::string("UPDATE jobs SET state = 'running', started = ?, attempts = attempts "
                           "+ 1, progress = 0, stage = '' WHERE id = (SELECT id FROM jobs WHERE "
                           "state = 'queued' ORDER BY seq LIMIT 1) RETURNING ") +
               kColumns)
                  .c_str());
  s.Bind(1, now);
  if (s.Step() != SQLITE_ROW) return std::nullopt;
  JobRecord j = FromRow(s);
  s.Step();
  return j;
}

Status JobStore::UpdateProgress(const std::string& id, double progress, const std::string& stage) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "UPDATE jobs SET progress = ?, stage = ? WHERE id = ? AND state = 'running'");
  s.Bind(1, progress).Bind(2, stage).Bind(3, id);
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "progress of " + id);
  return Status::Ok();
}

Status JobStore::Finish(const std::string& id, JobState state, const std::string& error,
                        const std::string& summary_json, double now, double run_seconds) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_,
         "UPDATE jobs SET state = ?, error = ?, summary = ?, finished = ?, run_seconds = ?, "
         "progress = CASE WHEN ? = 'succeeded' THEN 1 ELSE progress END WHERE id = ?");
  const std::string name = JobStateName(state);
  s.Bind(1, name).Bind(2, error).Bind(3, summary_json.empty() ? std::string("{}") : summary_json);
  s.Bind(4, now).Bind(5, run_seconds).Bind(6, name).Bind(7, id);
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "finish " + id);
  return Status::Ok();
}

Status JobStore::Requeue(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_,
         "UPDATE jobs SET state = 'queued', progress = 0, stage = '', started = 0 "
         "WHERE id = ? AND state = 'running'");
  s.Bind(1, id);
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "requeue " + id);
  return Status::Ok();
}

int JobStore::RequeueRunning() {
  std::lock_guard<std::mutex> lock(mutex_);
  // A cancel that was requested before the crash is honoured now.
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

bool JobStore::RequestCancel(const std::string& id, double now, Status* write_error) {
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

Status JobStore::Delete(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "DELETE FROM jobs WHERE id = ?");
  s.Bind(1, id);
  if (s.Step() != SQLITE_DONE) return SqlError(db_, "delete " + id);
  return Status::Ok();
}

bool JobStore::DeleteFinished(const std::string& id, Status* write_error) {
  std::lock_guard<std::mutex> lock(mutex_);
  Stmt s(db_, "DELETE FROM jobs WHERE id = ? AND state IN ('succeeded', 'failed', 'cancelled')");
  s.Bind(1, id);
  if (s.Step() != SQLITE_DONE) {
    if (write_error) *write_error = SqlError(db_, "delete " + id);
    return false;
  }
  return sqlite3_changes(db_) > 0;
}

std::map<JobState, int64_t> JobStore::CountByState() {
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

std::vector<std::string> JobStore::AllIds() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out;
  Stmt s(db_, "SELECT id FROM jobs");
  while (s.Step() == SQLITE_ROW) out.push_back(s.Text(0));
  return out;
}

}  // namespace matfit::server
