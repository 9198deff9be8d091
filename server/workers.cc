// The job side of Server::Impl: workers that claim and run jobs, the final state of an
// attempt (recorded once, kept and retried when the database cannot take it, dropped when the
// lease was lost), pack publication, and the heartbeats that renew a cluster node's leases.
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "server/job_runner.h"
#include "server/job_spec.h"
#include "server/log.h"
#include "server/server_impl.h"

namespace matfit::server {

namespace fs = std::filesystem;
using json = nlohmann::json;

Status Server::Impl::PublishPack(const std::string& id, const std::string& staging) {
  std::error_code ec;
  const std::string dest = PackDir(id);
  if (!fs::exists(staging, ec)) {
    // Moved by an earlier try of this attempt whose commit failed.
    if (fs::is_directory(dest, ec)) return Status::Ok();
    return NotFound("the pack of job " + id + " is missing (" + staging + ")");
  }
  if (fs::exists(dest, ec)) {  // unpublished: its attempt died between the move and the commit
    const std::string old = staging + "-replaced";
    fs::rename(dest, old, ec);
    if (ec)
      return IoError("cannot replace the unpublished pack of job " + id + ": " + ec.message());
    fs::remove_all(old, ec);
  }
  fs::rename(staging, dest, ec);
  if (ec) return IoError("cannot move the pack of job " + id + " into place: " + ec.message());
  return Status::Ok();
}

void Server::Impl::HeartbeatLoop() {
  const auto period = std::chrono::duration<double>(options.lease_seconds / 3);
  std::unique_lock<std::mutex> lock(mutex);
  while (!heartbeat_stop) {
    // Only jobs claimed before the renewal are judged by it (a claim lands in `live` after its
    // row is written).
    std::map<std::string, std::shared_ptr<LiveJob>> before = live;
    std::vector<std::pair<std::string, int>> attempts;
    for (const auto& [id, j] : before) attempts.emplace_back(id, j->attempt);
    {
      std::lock_guard<std::mutex> p(pending_mutex);  // finished, state not written yet
      for (const auto& [id, f] : pending) attempts.emplace_back(id, f.lease.attempt);
    }
    lock.unlock();
    auto held = store->Heartbeat(node, attempts, options.lease_seconds);
    lock.lock();
    if (!held.ok()) {
      LogEvent("warn", "heartbeat_failed", {{"error", held.status().message()}});
    } else {
      // A live job this node no longer holds was taken over after its lease ran out (this node
      // was cut off from the database, or stalled): stop it, its result would be dropped.
      for (auto& [id, j] : before)
        if (!held->count(id) && !j->finishing && !j->lease_lost.exchange(true)) {
          j->cancel = true;
          LogEvent("warn", "lease_lost", {{"id", id}, {"node", node}});
        }
    }
    if (options.db_tokens) {  // a revoked token stops working within one period
      lock.unlock();
      if (Status st = RefreshTokens(); !st.ok())
        LogEvent("warn", "tokens_not_refreshed", {{"error", st.message()}});
      lock.lock();
    }
    heartbeat_cv.wait_for(lock, period, [&] { return heartbeat_stop; });
  }
}

void Server::Impl::RecordFinal(const std::string& id, PendingFinal f) {
  Status st;
  for (const int ms : {0, 50, 200, 800}) {  // a busy or briefly failing database
    std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    st = TryFinish(id, &f);
    if (st.ok()) return;
    if (IsLeaseLost(st)) return DropAttempt(id, f, st);
  }
  // The database cannot take it (disk full, I/O error): keep it, show it, write it later. A
  // single process shows the pending success itself, so its pack goes in place now (the retry
  // finds it there); a cluster's other nodes see only the database, so there it waits.
  LogEvent("error", "job_state_unsaved",
           {{"id", id}, {"state", JobStateName(f.final_state.state)}, {"error", st.message()}});
  if (!store->Shared() && f.final_state.state == JobState::kSucceeded)
    if (Status moved = PublishPack(id, f.staging); !moved.ok())
      LogEvent("error", "pack_not_published", {{"id", id}, {"error", moved.message()}});
  f.tries = 4, f.next_try = NowSeconds() + f.delay;
  std::lock_guard<std::mutex> lock(pending_mutex);
  pending[id] = std::move(f);
}

Status Server::Impl::TryFinish(const std::string& id, PendingFinal* f) {
  Status st =
      store->Finish(id, f->lease, f->final_state, [&] { return PublishPack(id, f->staging); });
  if (st.code() == StatusCode::kNotFound && f->final_state.state == JobState::kSucceeded) {
    LogEvent("error", "pack_lost", {{"id", id}, {"error", st.message()}});
    f->final_state.state = JobState::kFailed;
    f->final_state.error = "the job's pack was lost before it was published; submit it again";
    f->final_state.summary_json = "{}";
    f->staging.clear();
    st = store->Finish(id, f->lease, f->final_state, nullptr);
  }
  return st;
}

void Server::Impl::DropAttempt(const std::string& id, const PendingFinal& f, const Status& why) {
  std::error_code ec;
  if (!f.staging.empty()) fs::remove_all(f.staging, ec);
  LogEvent("warn", "attempt_dropped",
           {{"id", id}, {"attempt", f.lease.attempt}, {"reason", why.message()}});
}

Status Server::Impl::RetryPending(bool force, const std::string& only) {
  std::vector<std::pair<std::string, PendingFinal>> due;
  {
    std::lock_guard<std::mutex> lock(pending_mutex);
    const double now = NowSeconds();
    for (const auto& [id, f] : pending)
      if (only.empty() ? force || now >= f.next_try : id == only) due.emplace_back(id, f);
  }
  Status result;
  for (auto& [id, f] : due) {
    const Status st = TryFinish(id, &f);
    std::lock_guard<std::mutex> lock(pending_mutex);
    const auto it = pending.find(id);
    if (it == pending.end()) continue;  // written meanwhile by another thread
    if (st.ok() || IsLeaseLost(st)) {
      if (st.ok())
        LogEvent("info", "job_state_saved",
                 {{"id", id},
                  {"state", JobStateName(f.final_state.state)},
                  {"tries", it->second.tries + 1}});
      else
        DropAttempt(id, f, st);
      pending.erase(it);
    } else {
      PendingFinal& p = it->second;
      ++p.tries;
      p.delay = std::min(p.delay * 2, 5.0);  // back off, but land soon after space is freed
      p.next_try = NowSeconds() + p.delay;
      result = st;
    }
  }
  return result;
}

bool Server::Impl::ApplyPending(JobRecord* j) {
  // A cluster's nodes show what the database holds: another node cannot see this one's
  // pending state, and a pending success has no published pack yet.
  if (store->Shared()) return false;
  std::lock_guard<std::mutex> lock(pending_mutex);
  const auto it = pending.find(j->id);
  if (it == pending.end()) return false;
  const JobFinal& f = it->second.final_state;
  j->state = f.state, j->error = f.error, j->finished = f.finished;
  j->run_seconds = f.run_seconds;
  j->summary_json = f.summary_json.empty() ? "{}" : f.summary_json;
  if (f.state == JobState::kSucceeded) j->progress = 1;
  return true;
}

std::map<JobState, int64_t> Server::Impl::CountByState() {
  auto counts = store->CountByState();
  if (store->Shared()) return counts;  // as ApplyPending
  std::lock_guard<std::mutex> lock(pending_mutex);
  for (const auto& [id, f] : pending)  // their rows still say "running"
    if (counts[JobState::kRunning] > 0) --counts[JobState::kRunning], ++counts[f.final_state.state];
  return counts;
}

std::optional<JobRecord> Server::Impl::GetJob(const std::string& id) {
  auto j = store->Get(id);
  if (j) ApplyPending(&*j);
  return j;
}

void Server::Impl::WorkerLoop() {
  while (!draining) {
    (void)RetryPending(false);  // final states the database could not take yet
    auto job = store->ClaimNext(node, NowSeconds(), options.lease_seconds);
    if (!job) {
      std::unique_lock<std::mutex> lock(mutex);
      wake.wait_for(lock, std::chrono::seconds(1));
      continue;
    }
    RunOne(*job);
  }
}

void Server::Impl::RunOne(const JobRecord& job) {
  auto lj = std::make_shared<LiveJob>();
  lj->started = NowSeconds();
  lj->attempt = job.attempts;
  {
    std::lock_guard<std::mutex> lock(mutex);
    // An older attempt of the same job on this node (its lease ran out while the database was
    // out of reach, and this node took the job back): it is stale, stop it.
    if (auto old = live.find(job.id); old != live.end()) {
      old->second->lease_lost = true;
      old->second->cancel = true;
    }
    live[job.id] = lj;
    if (hard_stop) lj->cancel = true;  // claimed just as a shutdown gave up waiting
  }
  LogEvent("info", "job_started",
           {{"id", job.id},
            {"node", node},
            {"attempt", job.attempts},
            {"spec", json::parse(job.spec_json, nullptr, false)}});
  const JobLease lease{node, job.attempts};
  const std::string staging = StagingDir(job.id, job.attempts);
  const auto t0 = std::chrono::steady_clock::now();
  auto last_persist = t0;
  auto progress = [&](double f, const std::string& stage) {
    const auto now = std::chrono::steady_clock::now();
    {
      std::lock_guard<std::mutex> lock(lj->mutex);
      lj->fraction = f, lj->stage = stage;
    }
    if (now - last_persist > std::chrono::seconds(1)) {  // persisted about once a second
      last_persist = now;
      (void)store->UpdateProgress(job.id, lease, f, stage);  // best effort; the final must land
      if (auto r = store->Get(job.id); r && r->cancel_requested) lj->cancel = true;
      (void)RetryPending(false);  // other jobs' final states, while this one runs
    }
    return !lj->cancel.load();
  };
  StatusOr<std::string> r = DataError("the stored job options are unreadable");
  if (auto spec = JobSpecFromJson(job.spec_json); spec.ok()) {
    if (job.cancel_requested) lj->cancel = true;
    try {  // a job must never take the server down (or, re-queued, take it down again)
      r = lj->cancel ? StatusOr<std::string>(Status(StatusCode::kCancelled, "cancelled"))
                     : RunJob(*spec, job.dataset, staging, progress, SourceLabel(job),
                              options.max_stack_samples);
    } catch (const std::exception& e) {
      r = Status(StatusCode::kInternal, std::string("internal error: ") + e.what());
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string final_state;
  lj->finishing = true;
  if (lj->lease_lost) {
    final_state = "dropped";  // another node runs it now (HeartbeatLoop)
    std::error_code ec;
    fs::remove_all(staging, ec);
  } else if (r.status().code() == StatusCode::kCancelled && hard_stop) {
    final_state = "requeued";
    std::error_code ec;
    fs::remove_all(staging, ec);
    // A failed write leaves the row "running": the next start-up re-queues it the same way.
    if (Status st = store->Requeue(job.id, lease); !st.ok())
      LogEvent("error", "job_state_unsaved", {{"id", job.id}, {"error", st.message()}});
  } else {
    PendingFinal p;
    p.lease = lease;
    JobFinal& f = p.final_state;
    f.finished = NowSeconds(), f.run_seconds = seconds;
    if (r.ok()) {
      f.state = JobState::kSucceeded, f.summary_json = *r;
      p.staging = staging;
    } else if (r.status().code() == StatusCode::kCancelled) {
      f.state = JobState::kCancelled, f.error = "cancelled while running";
    } else {
      f.state = JobState::kFailed, f.error = ForClients(r.status().message(), &job);
      LogEvent("info", "job_failed", {{"id", job.id}, {"error", r.status().message()}});
      if (f.error.find(std::strerror(ENOSPC)) != std::string::npos)
        f.error = "the server's disk is full (ENOSPC); free space and submit again: " + f.error;
    }
    if (!r.ok()) {
      std::error_code ec;
      fs::remove_all(staging, ec);
    }
    final_state = JobStateName(f.state);
    RecordFinal(job.id, std::move(p));
    metrics.ObserveJob(final_state, seconds);
  }
  LogEvent(final_state == "failed" ? "warn" : "info", "job_finished",
           {{"id", job.id},
            {"state", final_state},
            {"seconds", seconds},
            {"error", r.ok() ? "" : r.status().message()}});
  {
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = live.find(job.id); it != live.end() && it->second == lj) live.erase(it);
  }
  idle.notify_all();
}

}  // namespace matfit::server
