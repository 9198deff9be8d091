// Durable job records in SQLite (WAL journal): the queue, each job's state and progress, and
// what it produced. One connection guarded by a mutex; every transition is one statement, so a
// crash (kill -9) leaves each job either before or after it.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"

struct sqlite3;

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
};

class JobStore {
 public:
  // Opens (creating) the database; sets WAL mode and a busy timeout.
  static StatusOr<std::unique_ptr<JobStore>> Open(const std::string& path);
  ~JobStore();
  JobStore(const JobStore&) = delete;
  JobStore& operator=(const JobStore&) = delete;

  Status Insert(JobRecord* job);  // fills seq
  std::optional<JobRecord> Get(const std::string& id);
  // Newest first; state filter optional; at most `limit`.
  std::vector<JobRecord> List(std::optional<JobState> state, int limit);
  // Oldest queued job → running (attempts + 1, started = now), or nothing.
  std::optional<JobRecord> ClaimNext(double now);
  Status UpdateProgress(const std::string& id, double progress, const std::string& stage);
  Status Finish(const std::string& id, JobState state, const std::string& error,
                const std::string& summary_json, double now, double run_seconds);
  Status Requeue(const std::string& id);  // running → queued
  int RequeueRunning();                   // at start-up: jobs a dead process left running
  // queued → cancelled (true); running → cancel_requested = 1 (true); else false. When the
  // database cannot be written (disk full), false and *write_error says why.
  bool RequestCancel(const std::string& id, double now, Status* write_error = nullptr);
  Status Delete(const std::string& id);
  // True when a finished job's row was removed; false when there was none, or (with
  // *write_error set) when the database cannot be written.
  bool DeleteFinished(const std::string& id, Status* write_error = nullptr);
  std::map<JobState, int64_t> CountByState();
  std::vector<std::string> AllIds();

 private:
  explicit JobStore(sqlite3* db) : db_(db) {}
  Status Exec(const char* sql);
  sqlite3* db_;
  std::mutex mutex_;
};

}  // namespace matfit::server
