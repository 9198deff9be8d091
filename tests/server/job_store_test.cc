// The job store's contract, run on every engine: SQLite always; PostgreSQL when
// MATFIT_TEST_PG_URL names a database (tests/app/serve_cluster_test.sh starts a throw-away
// cluster and runs these tests against it). Lease takeover and concurrent claims are the shared
// store's own tests.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <thread>

#include "server/job_store.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("matfit_store_" + std::to_string(::getpid()) + name))
      .string();
}

void RemoveDb(const std::string& db) {
  fs::remove(db), fs::remove(db + "-wal"), fs::remove(db + "-shm");
}

const char* PgUrl() { return std::getenv("MATFIT_TEST_PG_URL"); }

JobRecord NewJob(const std::string& id) {
  JobRecord j;
  j.id = id;
  j.spec_json = R"({"mode":"fit"})";
  j.dataset = "/data/" + id;
  j.created = 1000;
  return j;
}

void InsertJobs(JobStore* s, std::initializer_list<const char*> ids) {
  for (const char* id : ids) {
    JobRecord j = NewJob(id);
    ASSERT_TRUE(s->Insert(&j).ok()) << id;
  }
}

JobFinal Succeeded(double at, const std::string& summary = "{}") {
  JobFinal f;
  f.state = JobState::kSucceeded, f.finished = at, f.run_seconds = 1, f.summary_json = summary;
  return f;
}

// Drops the tables through a store-independent path (psql): each test migrates from scratch.
void ResetPg() {
  const std::string cmd =
      std::string("psql -q -X '") + PgUrl() +
      "' -c 'DROP TABLE IF EXISTS jobs, publications, schema_migrations, counters, tokens' "
      ">/dev/null 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
}

// A fresh, empty store of the engine under test (PostgreSQL: its tables dropped first).
class StoreContract : public testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "postgresql") {
      if (!PgUrl()) GTEST_SKIP() << "MATFIT_TEST_PG_URL is not set (serve_cluster_test.sh sets it)";
      ResetPg();
    } else {
      db_ = TempPath("contract.db");
      RemoveDb(db_);
    }
    store_ = Open();
  }
  void TearDown() override {
    store_.reset();
    if (!db_.empty()) RemoveDb(db_);
  }
  std::unique_ptr<JobStore> Open() {
    auto s = GetParam() == "postgresql" ? OpenPostgresJobStore(PgUrl()) : OpenSqliteJobStore(db_);
    EXPECT_TRUE(s.ok()) << s.status().message();
    return s.ok() ? std::move(*s) : nullptr;
  }
  std::string db_;
  std::unique_ptr<JobStore> store_;
};

TEST_P(StoreContract, QueueOrderClaimFinishAndDurabilityAcrossReopen) {
  JobStore* s = store_.get();
  ASSERT_TRUE(s);
  InsertJobs(s, {"j1", "j2", "j3"});
  auto a = s->ClaimNext("n1", 2000, 30);
  ASSERT_TRUE(a);
  EXPECT_EQ(a->id, "j1");  // oldest first
  EXPECT_EQ(a->state, JobState::kRunning);
  EXPECT_EQ(a->attempts, 1);
  EXPECT_EQ(a->started, 2000);
  EXPECT_EQ(a->node, "n1");
  const JobLease la{"n1", 1};
  ASSERT_TRUE(s->UpdateProgress("j1", la, 0.5, "fit").ok());
  EXPECT_EQ(s->Get("j1")->stage, "fit");
  ASSERT_TRUE(s->Finish("j1", la, Succeeded(2010, R"({"rmse":0.1})"), nullptr).ok());
  auto b = s->ClaimNext("n1", 2020, 30);
  ASSERT_TRUE(b);
  EXPECT_EQ(b->id, "j2");
  EXPECT_TRUE(s->RequestCancel("j3", 2030));  // queued → cancelled at once
  EXPECT_EQ(s->Get("j3")->state, JobState::kCancelled);
  EXPECT_FALSE(s->ClaimNext("n1", 2040, 30));  // nothing queued (j2's lease is live)
  store_.reset();                              // "crash" with j2 running
  store_ = Open();
  s = store_.get();
  EXPECT_EQ(s->Get("j1")->state, JobState::kSucceeded);
  EXPECT_EQ(s->Get("j1")->summary_json, R"({"rmse":0.1})");
  EXPECT_DOUBLE_EQ(s->Get("j1")->progress, 1.0);
  EXPECT_EQ(s->Get("j2")->state, JobState::kRunning);
  EXPECT_EQ(s->RequeueNode("n1"), 1);
  auto again = s->ClaimNext("n1", 3000, 30);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, "j2");
  EXPECT_EQ(again->attempts, 2);
  const auto counts = s->CountByState();
  EXPECT_EQ(counts.at(JobState::kSucceeded), 1);
  EXPECT_EQ(counts.at(JobState::kRunning), 1);
  EXPECT_EQ(counts.at(JobState::kCancelled), 1);
  EXPECT_EQ(s->List(std::nullopt, 10).front().id, "j3");  // newest first
  EXPECT_EQ(s->List(JobState::kSucceeded, 10).size(), 1u);
  ASSERT_TRUE(s->Delete("j3").ok());
  EXPECT_FALSE(s->Get("j3"));
  EXPECT_TRUE(s->DeleteFinished("j1"));
  EXPECT_EQ(s->Publications("j1"), 0);  // the publication row goes with the job
  EXPECT_TRUE(s->Ping().ok());
}

TEST_P(StoreContract, CancelOfARunningJobIsAFlagAndIsHonouredAfterACrash) {
  JobStore* s = store_.get();
  ASSERT_TRUE(s);
  InsertJobs(s, {"r"});
  ASSERT_TRUE(s->ClaimNext("n1", 1, 30));
  EXPECT_TRUE(s->RequestCancel("r", 2));
  EXPECT_EQ(s->Get("r")->state, JobState::kRunning);
  EXPECT_TRUE(s->Get("r")->cancel_requested);
  EXPECT_EQ(s->RequeueNode("n1"), 0);  // cancelled, not re-queued
  EXPECT_EQ(s->Get("r")->state, JobState::kCancelled);
  EXPECT_FALSE(s->RequestCancel("r", 3));  // finished: nothing to cancel
}

// Every write of a running job is fenced by (node, attempt); a success is published once.
TEST_P(StoreContract, FencedWritesAndExactlyOncePublication) {
  JobStore* s = store_.get();
  ASSERT_TRUE(s);
  InsertJobs(s, {"p"});
  ASSERT_TRUE(s->ClaimNext("n1", 1, 30));
  int published = 0;
  auto publish = [&] { return ++published, Status::Ok(); };
  // Another attempt's token (a stale worker): nothing is written, nothing published.
  const Status stale = s->Finish("p", {"n1", 7}, Succeeded(5), publish);
  EXPECT_TRUE(IsLeaseLost(stale)) << stale.message();
  const Status other = s->Finish("p", {"n2", 1}, Succeeded(5), publish);
  EXPECT_TRUE(IsLeaseLost(other)) << other.message();
  ASSERT_TRUE(s->UpdateProgress("p", {"n2", 1}, 0.9, "stale").ok());
  EXPECT_NE(s->Get("p")->stage, "stale");  // a fenced no-op
  EXPECT_EQ(published, 0);
  // A publish step that fails rolls the transaction back: still running, no publication row.
  const Status failed =
      s->Finish("p", {"n1", 1}, Succeeded(5), [] { return IoError("cannot move the pack"); });
  EXPECT_FALSE(failed.ok());
  EXPECT_FALSE(IsLeaseLost(failed));
  EXPECT_EQ(s->Get("p")->state, JobState::kRunning);
  EXPECT_EQ(s->Publications("p"), 0);
  // The holder publishes once. A second try with the same token (its first commit's answer
  // was lost) finds its own state recorded: Ok, nothing published again. Another token after
  // the finish is refused.
  ASSERT_TRUE(s->Finish("p", {"n1", 1}, Succeeded(6), publish).ok());
  EXPECT_EQ(published, 1);
  EXPECT_EQ(s->Publications("p"), 1);
  EXPECT_EQ(s->Get("p")->state, JobState::kSucceeded);
  EXPECT_TRUE(s->Finish("p", {"n1", 1}, Succeeded(7), publish).ok());
  EXPECT_TRUE(IsLeaseLost(s->Finish("p", {"n2", 1}, Succeeded(7), publish)));
  EXPECT_EQ(published, 1);
  EXPECT_EQ(s->Publications("p"), 1);
  EXPECT_EQ(s->Get("p")->finished, 6);
  // Requeue is fenced too.
  InsertJobs(s, {"q"});
  ASSERT_TRUE(s->ClaimNext("n1", 8, 30));
  ASSERT_TRUE(s->Requeue("q", {"n1", 2}).ok());
  EXPECT_EQ(s->Get("q")->state, JobState::kRunning);
  ASSERT_TRUE(s->Requeue("q", {"n1", 1}).ok());
  EXPECT_EQ(s->Get("q")->state, JobState::kQueued);
}

TEST_P(StoreContract, HeartbeatNamesTheJobsTheNodeHolds) {
  JobStore* s = store_.get();
  ASSERT_TRUE(s);
  InsertJobs(s, {"h1", "h2", "h3"});
  ASSERT_TRUE(s->ClaimNext("a", 1, 30));
  ASSERT_TRUE(s->ClaimNext("b", 1, 30));
  // Only the named attempts that the node holds are renewed and returned.
  auto held = s->Heartbeat("a", {{"h1", 1}, {"h2", 1}, {"h3", 1}}, 30);
  ASSERT_TRUE(held.ok()) << held.status().message();
  EXPECT_EQ(*held, std::set<std::string>{"h1"});
  EXPECT_TRUE(s->Heartbeat("a", {{"h1", 2}}, 30)->empty());  // another attempt of h1
  EXPECT_EQ(*s->Heartbeat("b", {{"h2", 1}}, 30), std::set<std::string>{"h2"});
  EXPECT_TRUE(s->Heartbeat("c", {}, 30)->empty());
}

INSTANTIATE_TEST_SUITE_P(Engines, StoreContract, testing::Values("sqlite", "postgresql"),
                         [](const auto& engine) { return engine.param; });

// A running job whose node stops renewing its lease is taken over by another node; the old
// attempt can neither publish nor move the row, and the new one publishes once.
TEST(SharedStore, AnExpiredLeaseIsTakenOverAndTheOldAttemptIsFenced) {
  if (!PgUrl()) GTEST_SKIP() << "MATFIT_TEST_PG_URL is not set (serve_cluster_test.sh sets it)";
  ResetPg();
  auto a = OpenPostgresJobStore(PgUrl()), b = OpenPostgresJobStore(PgUrl());
  ASSERT_TRUE(a.ok() && b.ok());
  JobRecord j = NewJob("t");
  ASSERT_TRUE((*a)->Insert(&j).ok());
  ASSERT_TRUE((*a)->ClaimNext("a", 1, 1.0));
  EXPECT_FALSE((*b)->ClaimNext("b", 1, 30));  // the lease is live
  // Node a's heartbeat names no worker for it (its worker died with the claim's answer lost):
  // the row is not renewed.
  EXPECT_TRUE((*a)->Heartbeat("a", {}, 30)->empty());
  std::this_thread::sleep_for(std::chrono::milliseconds(1300));
  auto taken = (*b)->ClaimNext("b", 2, 30);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->attempts, 2);
  EXPECT_EQ(taken->node, "b");
  EXPECT_TRUE((*a)->Heartbeat("a", {{"t", 1}}, 30)->empty());  // node a learns it lost the job
  int published = 0;
  auto publish = [&] { return ++published, Status::Ok(); };
  EXPECT_TRUE(IsLeaseLost((*a)->Finish("t", {"a", 1}, Succeeded(3), publish)));
  ASSERT_TRUE((*b)->Finish("t", {"b", 2}, Succeeded(4), publish).ok());
  EXPECT_EQ(published, 1);
  EXPECT_EQ((*a)->Publications("t"), 1);
  EXPECT_EQ((*a)->Get("t")->node, "b");
}

// Four connections claim 40 jobs at once: each job is claimed exactly once.
TEST(SharedStore, ConcurrentClaimsNeverShareAJob) {
  if (!PgUrl()) GTEST_SKIP() << "MATFIT_TEST_PG_URL is not set (serve_cluster_test.sh sets it)";
  ResetPg();
  auto first = OpenPostgresJobStore(PgUrl());
  ASSERT_TRUE(first.ok());
  for (int i = 0; i < 40; ++i) {
    JobRecord j = NewJob("c" + std::to_string(i));
    ASSERT_TRUE((*first)->Insert(&j).ok());
  }
  std::vector<std::vector<std::string>> got(4);
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t)
    threads.emplace_back([&, t] {
      auto s = OpenPostgresJobStore(PgUrl());
      if (!s.ok()) return;
      while (auto j = (*s)->ClaimNext("n" + std::to_string(t), 1, 30)) got[t].push_back(j->id);
    });
  for (auto& t : threads) t.join();
  std::set<std::string> all;
  size_t total = 0;
  for (const auto& g : got) total += g.size(), all.insert(g.begin(), g.end());
  EXPECT_EQ(total, 40u);
  EXPECT_EQ(all.size(), 40u);
}

// A database made before schema versions (the first release's table) is migrated in place.
TEST(SqliteStore, AnUnversionedDatabaseIsMigratedKeepingItsJobs) {
  const std::string db = TempPath("old.db");
  RemoveDb(db);
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
  ASSERT_EQ(
      sqlite3_exec(raw,
                   "CREATE TABLE jobs (id TEXT PRIMARY KEY, seq INTEGER NOT NULL, state TEXT "
                   "NOT NULL, spec TEXT NOT NULL, dataset TEXT NOT NULL, uploaded INTEGER NOT "
                   "NULL, created REAL NOT NULL, started REAL NOT NULL DEFAULT 0, finished "
                   "REAL NOT NULL DEFAULT 0, progress REAL NOT NULL DEFAULT 0, stage TEXT NOT "
                   "NULL DEFAULT '', error TEXT NOT NULL DEFAULT '', summary TEXT NOT NULL "
                   "DEFAULT '{}', run_seconds REAL NOT NULL DEFAULT 0, attempts INTEGER NOT "
                   "NULL DEFAULT 0, cancel_requested INTEGER NOT NULL DEFAULT 0);"
                   "INSERT INTO jobs (id, seq, state, spec, dataset, uploaded, created) "
                   "VALUES ('old', 1, 'queued', '{}', '/d', 0, 5);",
                   nullptr, nullptr, nullptr),
      SQLITE_OK);
  sqlite3_close(raw);
  {
    auto s = OpenSqliteJobStore(db);
    ASSERT_TRUE(s.ok()) << s.status().message();
    auto j = (*s)->ClaimNext("local", 10, 30);
    ASSERT_TRUE(j);
    EXPECT_EQ(j->id, "old");
    EXPECT_EQ(j->node, "local");
  }
  ASSERT_EQ(sqlite3_open(db.c_str(), &raw), SQLITE_OK);
  sqlite3_stmt* st = nullptr;
  sqlite3_prepare_v2(raw, "PRAGMA user_version", -1, &st, nullptr);
  ASSERT_EQ(sqlite3_step(st), SQLITE_ROW);
  EXPECT_EQ(sqlite3_column_int(st, 0), 2);
  sqlite3_finalize(st);
  sqlite3_close(raw);
  RemoveDb(db);
}

TEST(SqliteStore, UnopenableDatabaseNamesThePath) {
  auto s = OpenSqliteJobStore("/nonexistent-dir/jobs.db");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("/nonexistent-dir/jobs.db"), std::string::npos);
}

TEST(DatabaseUrl, PasswordsAreRedacted) {
  EXPECT_EQ(RedactDatabaseUrl("postgresql://u:secret@h:5432/db"), "postgresql://u:***@h:5432/db");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://u@h:5432/db"), "postgresql://u@h:5432/db");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://h:5432/db?password=pw&x=1"),
            "postgresql://h:5432/db?password=***&x=1");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://h/db?sslmode=require&pass%77ord=pw"),
            "postgresql://h/db?sslmode=require&pass%77ord=***");
  EXPECT_EQ(RedactDatabaseUrl("postgresql://h/db?PASSWORD=pw&x=pass"),
            "postgresql://h/db?PASSWORD=***&x=pass");
  EXPECT_TRUE(IsPostgresUrl("postgres://h/db"));
  EXPECT_FALSE(IsPostgresUrl("mysql://h/db"));
}

}  // namespace
}  // namespace matfit::server
