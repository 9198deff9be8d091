#include <gtest/gtest.h>

#include <atomic>
#include <thread>
#include <vector>

#include "core/parallel.h"

namespace matfit {
namespace {

class ParallelForTest : public ::testing::TestWithParam<int> {
 protected:
  void TearDown() override { SetNumThreads(0); }
};

TEST_P(ParallelForTest, CoversTheRangeExactlyOnce) {
  SetNumThreads(GetParam());
  for (int64_t grain : {1, 3, 64, 5000}) {
    std::vector<std::atomic<int>> hits(1000);
    ParallelFor(
        0, 1000,
        [&](int64_t b, int64_t e) {
          EXPECT_LT(b, e);
          for (int64_t i = b; i < e; ++i) hits[i]++;
        },
        grain);
    for (auto& h : hits) EXPECT_EQ(h.load(), 1);
  }
}

INSTANTIATE_TEST_SUITE_P(Threads, ParallelForTest, ::testing::Values(1, 2, 4));

TEST(ParallelFor, SerialFastPathRunsInline) {
  SetNumThreads(1);
  const auto me = std::this_thread::get_id();
  int calls = 0;
  ParallelFor(0, 100, [&](int64_t b, int64_t e) {
    EXPECT_EQ(std::this_thread::get_id(), me);
    EXPECT_EQ(b, 0);
    EXPECT_EQ(e, 100);
    ++calls;
  });
  EXPECT_EQ(calls, 1);
  SetNumThreads(0);
  EXPECT_GE(NumThreads(), 1);
  ParallelFor(5, 5, [&](int64_t, int64_t) { ++calls; });  // empty range: no call
  EXPECT_EQ(calls, 1);
}

}  // namespace
}  // namespace matfit
