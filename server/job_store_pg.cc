// The cluster store: PostgreSQL shared by several `matfit serve` nodes. Workers claim jobs with
// FOR UPDATE SKIP LOCKED under a lease that heartbeats extend; a job whose lease ran out (its
// node died) is claimable again. Lease times use the database's clock, so the nodes' clocks
// need not agree. One connection per store, guarded by a mutex; a broken connection is opened
// again on the next call.
#include <pqxx/pqxx>

#include <mutex>

#include "server/job_store.h"

namespace matfit::server {
namespace {

constexpr const char* kColumns =
    "id, seq, state, spec, dataset, uploaded, created, started, finished, progress, stage, "
    "error, summary, run_seconds, attempts, cancel_requested, node";
constexpr const char* kDbNow = "EXTRACT(EPOCH FROM clock_timestamp())::float8";
constexpr int64_t kMigrationLock = 0x6d617466697431;  // "matfit1": the advisory lock key

// Schema versions (table schema_migrations), applied in order under the advisory lock.
constexpr const char* kMigrations[] = {
    "CREATE TABLE jobs ("
    " id TEXT PRIMARY KEY, seq BIGSERIAL NOT NULL, state TEXT NOT NULL, spec TEXT NOT NULL,"
    " dataset TEXT NOT NULL, uploaded BOOLEAN NOT NULL, created DOUBLE PRECISION NOT NULL,"
    " started DOUBLE PRECISION NOT NULL DEFAULT 0, finished DOUBLE PRECISION NOT NULL DEFAULT 0,"
    " progress DOUBLE PRECISION NOT NULL DEFAULT 0, stage TEXT NOT NULL DEFAULT '',"
    " error TEXT NOT NULL DEFAULT '', summary TEXT NOT NULL DEFAULT '{}',"
    " run_seconds DOUBLE PRECISION NOT NULL DEFAULT 0, attempts INTEGER NOT NULL DEFAULT 0,"
    " cancel_requested BOOLEAN NOT NULL DEFAULT false, node TEXT NOT NULL DEFAULT '',"
    " lease_until DOUBLE PRECISION NOT NULL DEFAULT 0);"
    "CREATE INDEX jobs_state_seq ON jobs(state, seq);"
    "CREATE TABLE publications (job_id TEXT PRIMARY KEY, node TEXT NOT NULL,"
    " attempt INTEGER NOT NULL, published DOUBLE PRECISION NOT NULL);"
    "CREATE TABLE counters (name TEXT PRIMARY KEY, value BIGINT NOT NULL);"
    "CREATE TABLE tokens (sha256 TEXT PRIMARY KEY, write BOOLEAN NOT NULL,"
    " label TEXT NOT NULL DEFAULT '', created DOUBLE PRECISION NOT NULL);",
};

constexpr const char* kCount =
    "INSERT INTO counters (name, value) VALUES ($1, 1) ON CONFLICT (name) DO UPDATE SET value = "
    "counters.value + 1";

JobRecord FromRow(const pqxx::row& r) {
  JobRecord j;
  j.id = r[0].as<std::string>();
  j.seq = r[1].as<int64_t>();
  ParseJobState(r[2].as<std::string>(), &j.state);
  j.spec_json = r[3].as<std::string>();
  j.dataset = r[4].as<std::string>();
  j.uploaded = r[5].as<bool>();
  j.created = r[6].as<double>();
  j.started = r[7].as<double>();
  j.finished = r[8].as<double>();
  j.progress = r[9].as<double>();
  j.stage = r[10].as<std::string>();
  j.error = r[11].as<std::string>();
  j.summary_json = r[12].as<std::string>();
  j.run_seconds = r[13].as<double>();
  j.attempts = r[14].as<int>();
  j.cancel_requested = r[15].as<bool>();
  j.node = r[16].as<std::string>();
  return j;
}

std::string Cols(const char* prefix) {
  std::string out, col;
  for (const char* p = kColumns;; ++p) {
    if (*p == ',' || *p == '\0') {
      out += (out.empty() ? "" : ", ") + std::string(prefix) + col;
      col.clear();
      if (!*p) break;
    } else if (*p != ' ') {
      col += *p;
    }
  }
  return out;
}

class PostgresJobStore final : public JobStore {
 public:
  explicit PostgresJobStore(std::string url) : url_(std::move(url)) {}

  Status Migrate();
  const char* Engine() const override { return "postgresql"; }
  bool Shared() const override { return true; }
  Status Ping() override {
    return Run(
        "ping", true, [](pqxx::connection& c) { pqxx::nontransaction(c).exec("SELECT 1"); },
        kControl);
  }
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
  std::map<std::string, int64_t> Counters() override;
  StatusOr<std::vector<StoredToken>> ListTokens() override;
  Status AddToken(const StoredToken& token) override;
  StatusOr<int> RevokeTokens(const std::string& hash_prefix, const std::string& label) override;

 private:
  // Runs `fn` on the connection (opened first when there is none). A broken connection is
  // dropped and, when `retry` (the call is idempotent), opened again for one more try.
  // Two connections: the workers' and HTTP handlers' (kMain), and the heartbeats', health
  // checks' and token refreshes' (kControl), so that a slow job transaction never delays a
  // lease renewal or /healthz.
  enum Slot { kMain = 0, kControl = 1 };
  Status Run(const std::string& what, bool retry, const std::function<void(pqxx::connection&)>& fn,
             Slot slot = kMain);

  std::string url_;
  struct Conn {
    std::unique_ptr<pqxx::connection> c;
    std::mutex m;
  };
  Conn conns_[2];
};

// A status that Finish returns from inside its transaction (the fence or the publish step).
struct Abort {
  Status status;
};

// `url` with bounded waits, unless it sets them itself: connecting (10 s), a dead peer (TCP
// keepalives, 30 s unacknowledged data) and a statement (60 s). Without them a half-open
// connection would hold the store for the kernel's ~15-minute retransmission timeout.
std::string WithTimeouts(std::string url) {
  const char* defaults[][2] = {{"connect_timeout", "10"},
                               {"keepalives", "1"},
                               {"keepalives_idle", "15"},
                               {"keepalives_interval", "5"},
                               {"keepalives_count", "3"},
                               {"tcp_user_timeout", "30000"},
                               {"options", "-c%20statement_timeout%3D60000"}};
  for (const auto& [key, value] : defaults) {
    if (url.find(std::string(key) + "=") != std::string::npos) continue;
    url += (url.find('?') == std::string::npos ? "?" : "&") + std::string(key) + "=" + value;
  }
  return url;
}

Status PostgresJobStore::Run(const std::string& what, bool retry,
                             const std::function<void(pqxx::connection&)>& fn, Slot slot) {
  Conn& conn = conns_[slot];
  std::lock_guard<std::mutex> lock(conn.m);
  for (int attempt = 0;; ++attempt) {
    try {
      if (!conn.c || !conn.c->is_open())
        conn.c = std::make_unique<pqxx::connection>(WithTimeouts(url_));
      fn(*conn.c);
      return Status::Ok();
    } catch (const Abort& a) {
      return a.status;
    } catch (const pqxx::in_doubt_error& e) {  // the commit's outcome is unknown
      conn.c.reset();
      return Status(
          StatusCode::kUnavailable,
          "job database: " + what + ": the connection broke during the commit (" + e.what() + ")");
    } catch (const pqxx::broken_connection& e) {
      conn.c.reset();
      if (!retry || attempt > 0)
        return Status(StatusCode::kUnavailable, "job database (" + RedactDatabaseUrl(url_) +
                                                    ") unreachable: " + what + ": " + e.what());
    } catch (const std::exception& e) {
      return IoError("job database: " + what + ": " + e.what());
    }
  }
}

Status PostgresJobStore::Migrate() {
  return Run("migrate", true, [](pqxx::connection& c) {
    pqxx::work w(c);
    // Nodes that start together: one migrates, the others wait here and find it done.
    w.exec_params("SELECT pg_advisory_xact_lock($1)", kMigrationLock);
    w.exec(
        "CREATE TABLE IF NOT EXISTS schema_migrations (version INTEGER PRIMARY KEY,"
        " applied DOUBLE PRECISION NOT NULL)");
    const int version =
        w.exec1("SELECT COALESCE(MAX(version), 0) FROM schema_migrations")[0].as<int>();
    const int latest = int(std::size(kMigrations));
    if (version > latest)
      throw Abort{DataError("schema version " + std::to_string(version) +
                            " is newer than this matfit knows (" + std::to_string(latest) +
                            "); upgrade this node")};
    for (int v = version; v < latest; ++v) {
      w.exec(kMigrations[v]);
      w.exec_params(std::string("INSERT INTO schema_migrations VALUES ($1, ") + kDbNow + ")",
                    v + 1);
    }
    w.commit();
  });
}

Status PostgresJobStore::Insert(JobRecord* j) {
  return Run("insert job " + j->id, false, [&](pqxx::connection& c) {
    pqxx::work w(c);
    const auto r = w.exec_params1(
        "INSERT INTO jobs (id, state, spec, dataset, uploaded, created) VALUES "
        "($1, $2, $3, $4, $5, $6) RETURNING seq",
        j->id, std::string(JobStateName(j->state)), j->spec_json, j->dataset, j->uploaded,
        j->created);
    w.commit();
    j->seq = r[0].as<int64_t>();
  });
}

std::optional<JobRecord> PostgresJobStore::Get(const std::string& id) {
  std::optional<JobRecord> out;
  (void)Run("get " + id, true, [&](pqxx::connection& c) {
    pqxx::nontransaction w(c);
    const auto r =
        w.exec_params(std::string("SELECT ") + kColumns + " FROM jobs WHERE id = $1", id);
    if (!r.empty()) out = FromRow(r[0]);
  });
  return out;
}

std::vector<JobRecord> PostgresJobStore::List(std::optional<JobState> state, int limit) {
  std::vector<JobRecord> out;
  (void)Run("list", true, [&](pqxx::connection& c) {
    out.clear();
    pqxx::nontransaction w(c);
    const std::string sql = std::string("SELECT ") + kColumns + " FROM jobs" +
                            (state ? " WHERE state = $2" : "") + " ORDER BY seq DESC LIMIT $1";
    const auto r = state ? w.exec_params(sql, limit, std::string(JobStateName(*state)))
                         : w.exec_params(sql, limit);
    for (const auto& row : r) out.push_back(FromRow(row));
  });
  return out;
}

std::optional<JobRecord> PostgresJobStore::ClaimNext(const std::string& node, double now,
                                                     double lease_seconds) {
  std::optional<JobRecord> out;
  (void)Run("claim", false, [&](pqxx::connection& c) {
    pqxx::work w(c);
    // SKIP LOCKED: workers of other nodes pass over a row being claimed (or published).
    const auto r = w.exec_params(
        std::string("WITH c AS (SELECT id, state AS was FROM jobs WHERE state = 'queued' OR "
                    "(state = 'running' AND lease_until < ") +
            kDbNow +
            ") ORDER BY seq LIMIT 1 FOR UPDATE SKIP LOCKED) "
            "UPDATE jobs j SET state = 'running', started = $1, attempts = j.attempts + 1, "
            "progress = 0, stage = '', node = $2, lease_until = " +
            kDbNow + " + $3 FROM c WHERE j.id = c.id RETURNING " + Cols("j.") + ", c.was",
        now, node, lease_seconds);
    if (!r.empty() && r[0][17].as<std::string>() == "running")
      w.exec_params(kCount, std::string("lease_takeovers_total"));
    w.commit();
    if (!r.empty()) out = FromRow(r[0]);
  });
  return out;
}

StatusOr<std::set<std::string>> PostgresJobStore::Heartbeat(
    const std::string& node, const std::vector<std::pair<std::string, int>>& attempts,
    double lease_seconds) {
  std::set<std::string> held;
  MATFIT_RETURN_IF_ERROR(Run(
      "heartbeat", true,
      [&](pqxx::connection& c) {
        held.clear();
        pqxx::work w(c);
        for (const auto& [id, attempt] : attempts) {
          const auto r = w.exec_params(std::string("UPDATE jobs SET lease_until = ") + kDbNow +
                                           " + $4 WHERE id = $1 AND state = 'running' AND node "
                                           "= $2 AND attempts = $3",
                                       id, node, attempt, lease_seconds);
          if (r.affected_rows() > 0) held.insert(id);
        }
        w.commit();
      },
      kControl));
  return held;
}

Status PostgresJobStore::UpdateProgress(const std::string& id, const JobLease& lease,
                                        double progress, const std::string& stage) {
  return Run("progress of " + id, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    w.exec_params(
        "UPDATE jobs SET progress = $1, stage = $2 WHERE id = $3 AND state = 'running' AND "
        "node = $4 AND attempts = $5",
        progress, stage, id, lease.node, lease.attempt);
    w.commit();
  });
}

Status PostgresJobStore::Finish(const std::string& id, const JobLease& lease, const JobFinal& f,
                                const std::function<Status()>& publish) {
  // Not retried on a broken connection: the pack may have moved. The caller tries again later;
  // the fence and the unique publication row keep that exact-once.
  return Run("finish " + id, false, [&](pqxx::connection& c) {
    pqxx::work w(c);
    // The fence: the row is locked until commit, so no other node claims it meanwhile.
    const auto row =
        w.exec_params("SELECT state, node, attempts FROM jobs WHERE id = $1 FOR UPDATE", id);
    JobState now = JobState::kQueued;
    const bool mine = !row.empty() && row[0][1].as<std::string>() == lease.node &&
                      row[0][2].as<int>() == lease.attempt;
    if (!row.empty()) ParseJobState(row[0][0].as<std::string>(), &now);
    if (mine && IsFinished(now)) throw Abort{Status::Ok()};  // recorded by an earlier try
    if (!mine || now != JobState::kRunning)
      throw Abort{Status(StatusCode::kCancelled, "job " + id + ": the lease of attempt " +
                                                     std::to_string(lease.attempt) + " on node " +
                                                     lease.node + " is no longer held")};
    const std::string name = JobStateName(f.state);
    if (f.state == JobState::kSucceeded) {
      w.exec_params(
          "INSERT INTO publications (job_id, node, attempt, published) VALUES "
          "($1, $2, $3, $4)",
          id, lease.node, lease.attempt, f.finished);
      if (publish)
        if (Status st = publish(); !st.ok()) throw Abort{st};
    }
    w.exec_params(
        "UPDATE jobs SET state = $1, error = $2, summary = $3, finished = $4, run_seconds = $5, "
        "progress = CASE WHEN $1 = 'succeeded' THEN 1 ELSE progress END WHERE id = $6",
        name, f.error, f.summary_json.empty() ? std::string("{}") : f.summary_json, f.finished,
        f.run_seconds, id);
    w.exec_params(kCount, "jobs_finished_total:" + name);
    w.commit();
  });
}

Status PostgresJobStore::Requeue(const std::string& id, const JobLease& lease) {
  return Run("requeue " + id, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    w.exec_params(
        "UPDATE jobs SET state = 'queued', progress = 0, stage = '', started = 0, "
        "lease_until = 0 WHERE id = $1 AND state = 'running' AND node = $2 AND attempts = $3",
        id, lease.node, lease.attempt);
    w.commit();
  });
}

int PostgresJobStore::RequeueNode(const std::string& node) {
  int n = 0;
  (void)Run("requeue node " + node, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    const auto cancelled = w.exec_params(
        "UPDATE jobs SET state = 'cancelled', error = 'cancelled' WHERE state = 'running' AND "
        "node = $1 AND cancel_requested",
        node);
    for (size_t i = 0; i < cancelled.affected_rows(); ++i)
      w.exec_params(kCount, std::string("jobs_finished_total:cancelled"));
    const auto r = w.exec_params(
        "UPDATE jobs SET state = 'queued', progress = 0, stage = '', started = 0, "
        "lease_until = 0 WHERE state = 'running' AND node = $1",
        node);
    w.commit();
    n = int(r.affected_rows());
  });
  return n;
}

bool PostgresJobStore::RequestCancel(const std::string& id, double now, Status* write_error) {
  bool asked = false;
  const Status st = Run("cancel " + id, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    auto r = w.exec_params(
        "UPDATE jobs SET state = 'cancelled', error = 'cancelled before it started', "
        "finished = $1 WHERE id = $2 AND state = 'queued'",
        now, id);
    if (r.affected_rows() > 0)
      w.exec_params(kCount, std::string("jobs_finished_total:cancelled"));
    else
      r = w.exec_params(
          "UPDATE jobs SET cancel_requested = true WHERE id = $1 AND state = 'running'", id);
    w.commit();
    asked = r.affected_rows() > 0;
  });
  if (!st.ok() && write_error) *write_error = st;
  return st.ok() && asked;
}

Status PostgresJobStore::Delete(const std::string& id) {
  return Run("delete " + id, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    w.exec_params("DELETE FROM publications WHERE job_id = $1", id);
    w.exec_params("DELETE FROM jobs WHERE id = $1", id);
    w.commit();
  });
}

bool PostgresJobStore::DeleteFinished(const std::string& id, Status* write_error) {
  bool gone = false;
  const Status st = Run("delete " + id, true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    const auto r = w.exec_params(
        "DELETE FROM jobs WHERE id = $1 AND state IN ('succeeded', 'failed', 'cancelled')", id);
    if (r.affected_rows() > 0) w.exec_params("DELETE FROM publications WHERE job_id = $1", id);
    w.commit();
    gone = r.affected_rows() > 0;
  });
  if (!st.ok() && write_error) *write_error = st;
  return st.ok() && gone;
}

std::map<JobState, int64_t> PostgresJobStore::CountByState() {
  std::map<JobState, int64_t> out;
  for (int i = 0; i < 5; ++i) out[JobState(i)] = 0;
  (void)Run("count", true, [&](pqxx::connection& c) {
    pqxx::nontransaction w(c);
    for (const auto& row : w.exec("SELECT state, COUNT(*) FROM jobs GROUP BY state")) {
      JobState st;
      if (ParseJobState(row[0].as<std::string>(), &st)) out[st] = row[1].as<int64_t>();
    }
  });
  return out;
}

std::vector<std::string> PostgresJobStore::AllIds() {
  std::vector<std::string> out;
  (void)Run("ids", true, [&](pqxx::connection& c) {
    out.clear();
    pqxx::nontransaction w(c);
    for (const auto& row : w.exec("SELECT id FROM jobs")) out.push_back(row[0].as<std::string>());
  });
  return out;
}

int64_t PostgresJobStore::Publications(const std::string& id) {
  int64_t n = -1;
  (void)Run("publications", true, [&](pqxx::connection& c) {
    pqxx::nontransaction w(c);
    n = w.exec_params1("SELECT COUNT(*) FROM publications WHERE job_id = $1", id)[0].as<int64_t>();
  });
  return n;
}

std::map<std::string, int64_t> PostgresJobStore::Counters() {
  std::map<std::string, int64_t> out;
  (void)Run(
      "counters", true,
      [&](pqxx::connection& c) {
        pqxx::nontransaction w(c);
        for (const auto& row : w.exec("SELECT name, value FROM counters"))
          out[row[0].as<std::string>()] = row[1].as<int64_t>();
      },
      kControl);
  return out;
}

StatusOr<std::vector<StoredToken>> PostgresJobStore::ListTokens() {
  std::vector<StoredToken> out;
  MATFIT_RETURN_IF_ERROR(Run(
      "tokens", true,
      [&](pqxx::connection& c) {
        out.clear();
        pqxx::nontransaction w(c);
        for (const auto& row : w.exec("SELECT sha256, write, label, created FROM tokens ORDER BY "
                                      "created"))
          out.push_back({row[0].as<std::string>(), row[1].as<bool>(), row[2].as<std::string>(),
                         row[3].as<double>()});
      },
      kControl));
  return out;
}

Status PostgresJobStore::AddToken(const StoredToken& t) {
  return Run("add token", false, [&](pqxx::connection& c) {
    pqxx::work w(c);
    w.exec_params("INSERT INTO tokens (sha256, write, label, created) VALUES ($1, $2, $3, $4)",
                  t.sha256_hex, t.write, t.label, t.created);
    w.commit();
  });
}

StatusOr<int> PostgresJobStore::RevokeTokens(const std::string& hash_prefix,
                                             const std::string& label) {
  int n = 0;
  MATFIT_RETURN_IF_ERROR(Run("revoke tokens", true, [&](pqxx::connection& c) {
    pqxx::work w(c);
    const auto r =
        hash_prefix.empty()
            ? w.exec_params("DELETE FROM tokens WHERE label = $1", label)
            : w.exec_params("DELETE FROM tokens WHERE starts_with(sha256, $1)", hash_prefix);
    w.commit();
    n = int(r.affected_rows());
  }));
  return n;
}

}  // namespace

StatusOr<std::unique_ptr<JobStore>> OpenPostgresJobStore(const std::string& url) {
  auto store = std::make_unique<PostgresJobStore>(url);
  if (Status st = store->Migrate(); !st.ok())
    return Status(st.code(),
                  "cannot use job database " + RedactDatabaseUrl(url) + ": " + st.message());
  return std::unique_ptr<JobStore>(std::move(store));
}

}  // namespace matfit::server
