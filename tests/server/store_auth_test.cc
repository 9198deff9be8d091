// The job store (SQLite) and bearer-token authorisation.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "server/auth.h"
#include "server/job_store.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("matfit_store_" + std::to_string(::getpid()) + name))
      .string();
}

JobRecord NewJob(const std::string& id) {
  JobRecord j;
  j.id = id;
  j.spec_json = R"({"mode":"fit"})";
  j.dataset = "/data/" + id;
  j.created = 1000;
  return j;
}

TEST(JobStore, QueueOrderClaimFinishAndDurabilityAcrossReopen) {
  const std::string db = TempPath("a.db");
  fs::remove(db);
  {
    auto s = JobStore::Open(db);
    ASSERT_TRUE(s.ok()) << s.status().message();
    for (const char* id : {"j1", "j2", "j3"}) {
      JobRecord j = NewJob(id);
      ASSERT_TRUE((*s)->Insert(&j).ok());
    }
    auto a = (*s)->ClaimNext(2000);
    ASSERT_TRUE(a);
    EXPECT_EQ(a->id, "j1");  // oldest first
    EXPECT_EQ(a->state, JobState::kRunning);
    EXPECT_EQ(a->attempts, 1);
    EXPECT_EQ(a->started, 2000);
    ASSERT_TRUE((*s)->UpdateProgress("j1", 0.5, "fit").ok());
    ASSERT_TRUE((*s)->Finish("j1", JobState::kSucceeded, "", R"({"rmse":0.1})", 2010, 10).ok());
    auto b = (*s)->ClaimNext(2020);
    ASSERT_TRUE(b);
    EXPECT_EQ(b->id, "j2");
    EXPECT_TRUE((*s)->RequestCancel("j3", 2030));  // queued → cancelled at once
    EXPECT_EQ((*s)->Get("j3")->state, JobState::kCancelled);
    EXPECT_FALSE((*s)->ClaimNext(2040));  // nothing queued
  }                                       // "crash" with j2 running
  auto s = JobStore::Open(db);
  ASSERT_TRUE(s.ok());
  EXPECT_EQ((*s)->Get("j1")->state, JobState::kSucceeded);
  EXPECT_EQ((*s)->Get("j1")->summary_json, R"({"rmse":0.1})");
  EXPECT_DOUBLE_EQ((*s)->Get("j1")->progress, 1.0);
  EXPECT_EQ((*s)->Get("j2")->state, JobState::kRunning);
  EXPECT_EQ((*s)->RequeueRunning(), 1);
  auto again = (*s)->ClaimNext(3000);
  ASSERT_TRUE(again);
  EXPECT_EQ(again->id, "j2");
  EXPECT_EQ(again->attempts, 2);
  const auto counts = (*s)->CountByState();
  EXPECT_EQ(counts.at(JobState::kSucceeded), 1);
  EXPECT_EQ(counts.at(JobState::kRunning), 1);
  EXPECT_EQ(counts.at(JobState::kCancelled), 1);
  EXPECT_EQ((*s)->List(std::nullopt, 10).front().id, "j3");  // newest first
  ASSERT_TRUE((*s)->Delete("j3").ok());
  EXPECT_FALSE((*s)->Get("j3"));
  s->reset();  // close before removing the files
  fs::remove(db), fs::remove(db + "-wal"), fs::remove(db + "-shm");
}

TEST(JobStore, CancelOfARunningJobIsAFlagAndIsHonouredAfterACrash) {
  const std::string db = TempPath("b.db");
  fs::remove(db);
  {
    auto s = JobStore::Open(db);
    JobRecord j = NewJob("r");
    ASSERT_TRUE((*s)->Insert(&j).ok());
    ASSERT_TRUE((*s)->ClaimNext(1));
    EXPECT_TRUE((*s)->RequestCancel("r", 2));
    EXPECT_EQ((*s)->Get("r")->state, JobState::kRunning);
    EXPECT_TRUE((*s)->Get("r")->cancel_requested);
    EXPECT_EQ((*s)->RequeueRunning(), 0);  // cancelled, not re-queued
    EXPECT_EQ((*s)->Get("r")->state, JobState::kCancelled);
    EXPECT_FALSE((*s)->RequestCancel("r", 3));  // finished: nothing to cancel
  }
  fs::remove(db), fs::remove(db + "-wal"), fs::remove(db + "-shm");
}

TEST(JobStore, UnopenableDatabaseNamesThePath) {
  auto s = JobStore::Open("/nonexistent-dir/jobs.db");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("/nonexistent-dir/jobs.db"), std::string::npos);
}

TEST(Auth, ConstantTimeEqualsIsEquality) {
  EXPECT_TRUE(ConstantTimeEquals("abcdef", "abcdef"));
  EXPECT_FALSE(ConstantTimeEquals("abcdef", "abcdeg"));
  EXPECT_FALSE(ConstantTimeEquals("abcdef", "abcde"));
  EXPECT_FALSE(ConstantTimeEquals("", "a"));
  EXPECT_TRUE(ConstantTimeEquals("", ""));
  EXPECT_FALSE(ConstantTimeEquals(std::string_view("ab\0c", 4), std::string_view("ab\0d", 4)));
}

TEST(Auth, TokenFileRolesAndErrorsThatNameTheLine) {
  const std::string f = TempPath("tokens");
  std::ofstream(f) << "# lab tokens\nwritewritewritewrite1\nreadreadreadreadread read  # viewer\n";
  auto t = TokenSet::Load(f);
  ASSERT_TRUE(t.ok()) << t.status().message();
  EXPECT_EQ(t->size(), 2u);
  EXPECT_EQ(t->Check("", Access::kRead), AuthResult::kMissing);
  EXPECT_EQ(t->Check("Basic abc", Access::kRead), AuthResult::kMissing);
  EXPECT_EQ(t->Check("Bearer nottherightone123", Access::kRead), AuthResult::kInvalid);
  EXPECT_EQ(t->Check("Bearer writewritewritewrite1", Access::kWrite), AuthResult::kOk);
  EXPECT_EQ(t->Check("Bearer readreadreadreadread", Access::kRead), AuthResult::kOk);
  EXPECT_EQ(t->Check("Bearer readreadreadreadread", Access::kWrite), AuthResult::kForbidden);
  EXPECT_EQ(t->Check("Bearer writewritewritewrite", Access::kWrite), AuthResult::kInvalid);

  std::ofstream(f) << "goodgoodgoodgoodgood\nshort\n";
  auto bad = TokenSet::Load(f);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find(f + ":2"), std::string::npos) << bad.status().message();
  std::ofstream(f) << "goodgoodgoodgoodgood admin\n";
  bad = TokenSet::Load(f);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("role 'admin'"), std::string::npos);
  std::ofstream(f) << "# nothing\n";
  EXPECT_FALSE(TokenSet::Load(f).ok());
  fs::remove(f);
}

}  // namespace
}  // namespace matfit::server
