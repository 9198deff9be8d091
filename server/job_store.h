// Durable job records: the queue, each job's state and progress, and what it produced. Two
// engines behind one interface: SQLite (WAL) for one `matfit serve`, the embedded default, and
// PostgreSQL for several nodes sharing one database and one pack root (docs/scale-out.md).
//
// Every transition is one statement or one transaction, so a crash (kill -9) leaves each job
// either before or after it. A running job belongs to a node under a lease (JobLease): every
// write about it is fenced by (node, attempt), so a node that lost its lease — another node
// took the job over after the lease ran out — can no longer change the row or publish a pack.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/status.h"

namespace matfit::server {

enum class JobState { kQueued, kRunning, kSucceeded, kFailed, kCancelled };
const char* JobStateName(JobState s);  // "queued", "running", ...
bool ParseJobState(const std::string& s, JobState* out);
inline bool IsFinished(JobState s) {
  return s == JobState::kSucceeded || s == JobState::kFailed || s == JobState::kCancelled;
}

struct JobRecord {
  std::string id;
  int64_t seq = 0;  // insertion order (the queue order)
  JobState state = JobState::kQueued;
  std::string spec_json;  // validated job options (JobSpec as JSON)
  std::string dataset;    // absolute folder the job reads
  bool uploaded = false;  // dataset lives in the data folder (deleted with the job)
  double created = 0, started = 0, finished = 0;  // Unix seconds; 0 = not yet
  double progress = 0;                            // 0..1
  std::string stage;
  std::string error;
  std::string summary_json;  // report summary of a finished job ("{}" before)
  double run_seconds = 0;
  int attempts = 0;  // how many times a worker started it (re-queues after a crash count)
  bool cancel_requested = false;
  std::string node;  // the node that runs (or last ran) it; "" before
};

// The fencing token of a running job: which node holds it and for which attempt.
struct JobLease {
  std::string node;
  int attempt = 0;
};

// A job's final state as its worker records it.
struct JobFinal {
  JobState state = JobState::kFailed;
  std::string error, summary_json;
  double finished = 0, run_seconds = 0;
};

// Finish's outcome when the lease was lost: the row is another attempt's now; nothing was
// written and nothing was published. The caller drops its result.
inline bool IsLeaseLost(const Status& s) { return s.code() == StatusCode::kCancelled; }

// A bearer token kept in the database (a cluster's shared token set): only its SHA-256.
struct StoredToken {
  std::string sha256_hex;
  bool write = true;
  std::string label;
  double created = 0;
};

class JobStore {
 public:
  virtual ~JobStore() = default;
  virtual const char* Engine() const = 0;  // "sqlite" or "postgresql"
  // Several processes share the store: leases expire and are taken over, heartbeats are due.
  virtual bool Shared() const = 0;
  virtual Status Ping() = 0;  // the database answers

  virtual Status Insert(JobRecord* job) = 0;  // fills seq
  virtual std::optional<JobRecord> Get(const std::string& id) = 0;
  // Newest first; state filter optional; at most `limit`.
  virtual std::vector<JobRecord> List(std::optional<JobState> state, int limit) = 0;
  // Oldest claimable job → running under a lease of `node` (attempts + 1, started = now). A
  // shared store also hands out running jobs whose lease has run out (their node died).
  virtual std::optional<JobRecord> ClaimNext(const std::string& node, double now,
                                             double lease_seconds) = 0;
  // Extends the leases of the given attempts (the jobs this node's workers run, and finished
  // ones whose state is still to be written); returns the ids among them it still holds. A row
  // of this node that no worker runs is not renewed: its lease runs out and it is re-run.
  virtual StatusOr<std::set<std::string>> Heartbeat(
      const std::string& node, const std::vector<std::pair<std::string, int>>& attempts,
      double lease_seconds) = 0;
  virtual Status UpdateProgress(const std::string& id, const JobLease& lease, double progress,
                                const std::string& stage) = 0;
  // Records the final state of the lease's attempt. For a success, `publish` (which moves the
  // pack into place) runs first, inside the same transaction, and a unique publication row is
  // written with the state: the pack of a job is published exactly once. Lease lost:
  // IsLeaseLost(status), and `publish` was not called. When this attempt's final state is
  // already recorded (a commit whose answer was lost), Ok without calling `publish`.
  virtual Status Finish(const std::string& id, const JobLease& lease, const JobFinal& final_state,
                        const std::function<Status()>& publish) = 0;
  virtual Status Requeue(const std::string& id, const JobLease& lease) = 0;  // running → queued
  // At start-up: the jobs that this node (a single-process store: any node) left running are
  // re-queued, or cancelled when a cancel had been asked. Returns how many were re-queued.
  virtual int RequeueNode(const std::string& node) = 0;
  // queued → cancelled (true); running → cancel_requested = 1 (true); else false. When the
  // database cannot be written (disk full), false and *write_error says why.
  virtual bool RequestCancel(const std::string& id, double now, Status* write_error = nullptr) = 0;
  virtual Status Delete(const std::string& id) = 0;
  // True when a finished job's row was removed; false when there was none, or (with
  // *write_error set) when the database cannot be written.
  virtual bool DeleteFinished(const std::string& id, Status* write_error = nullptr) = 0;
  virtual std::map<JobState, int64_t> CountByState() = 0;
  virtual std::vector<std::string> AllIds() = 0;
  // How many publication rows the job has (0 or 1; tests check "exactly once").
  virtual int64_t Publications(const std::string& id) = 0;

  // Counters kept with the jobs, for the whole cluster (they survive a node): finished jobs by
  // state ("jobs_finished_total:succeeded", ...) and jobs taken over from a node whose lease
  // ran out ("lease_takeovers_total"). Empty for a single-process store (its /metrics counts
  // in memory).
  virtual std::map<std::string, int64_t> Counters() { return {}; }

  // The cluster's bearer tokens (`matfit tokens`, `matfit serve --db-tokens`); a single-process
  // store has only its --token-file and answers Unavailable.
  virtual StatusOr<std::vector<StoredToken>> ListTokens();
  virtual Status AddToken(const StoredToken& token);
  // Removes the tokens whose hash starts with `hash_prefix` (≥ 8 hex digits) or whose label is
  // `label` (one of the two); returns how many.
  virtual StatusOr<int> RevokeTokens(const std::string& hash_prefix, const std::string& label);
};

// SQLite at `path` (created), WAL journal, schema migrated to the current version.
StatusOr<std::unique_ptr<JobStore>> OpenSqliteJobStore(const std::string& path);
// PostgreSQL at `url` (postgresql://user@host:port/db), schema migrated under an advisory lock
// (nodes starting together migrate once). Unavailable when built without libpqxx.
StatusOr<std::unique_ptr<JobStore>> OpenPostgresJobStore(const std::string& url);
// `url` without its password (for logs and /healthz).
std::string RedactDatabaseUrl(const std::string& url);
bool IsPostgresUrl(const std::string& s);

}  // namespace matfit::server
