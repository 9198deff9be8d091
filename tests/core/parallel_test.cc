#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/image.h"
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

TEST(ParallelFor, KnowsWhenItIsInsideARange) {
  SetNumThreads(2);
  EXPECT_FALSE(InParallelRegion());
  std::atomic<int> inside{0}, nested{0};
  ParallelFor(
      0, 8,
      [&](int64_t b, int64_t e) {
        inside += InParallelRegion() ? int(e - b) : 0;
        ParallelFor(
            0, 4, [&](int64_t, int64_t) { nested += InParallelRegion(); }, 1);
        EXPECT_TRUE(InParallelRegion());  // still inside after the nested loop
      },
      1);
  EXPECT_EQ(inside.load(), 8);
  EXPECT_GE(nested.load(), 8);
  EXPECT_FALSE(InParallelRegion());
  // A range that throws leaves the thread outside again.
  EXPECT_THROW(ParallelFor(
                   0, 4, [](int64_t, int64_t) { throw std::runtime_error("range failed"); }, 1),
               std::runtime_error);
  EXPECT_FALSE(InParallelRegion());
  SetNumThreads(0);
}

TEST(ParallelFill, FillsEveryElementOnAnyThreadCountInsideOrOutsideALoop) {
  for (int threads : {1, 2}) {
    SetNumThreads(threads);
    for (std::size_t n : {std::size_t(0), std::size_t(7), std::size_t(1) << 19,
                          (std::size_t(5) << 18) + 3}) {  // below and above two 1 MiB blocks
      std::vector<float> v(n + 2, -1.0f);
      ParallelFill(v.data() + 1, n, 0.5f);
      EXPECT_EQ(v.front(), -1.0f);
      EXPECT_EQ(v.back(), -1.0f);
      for (std::size_t i = 1; i <= n; ++i) ASSERT_EQ(v[i], 0.5f) << i << " of " << n;
    }
    std::vector<float> w((std::size_t(3) << 18) + 1, 1.0f);
    ParallelFor(0, 1, [&](int64_t, int64_t) { ParallelFill(w.data(), w.size(), 2.0f); });
    for (float x : w) ASSERT_EQ(x, 2.0f);
  }
  SetNumThreads(0);
}

// Images of more than 2 MiB are filled by ParallelFill: every sample holds the fill value.
TEST(ParallelFill, BigImagesHoldTheirFillValue) {
  SetNumThreads(2);
  for (float fill : {0.0f, 1.0f}) {
    const Image a(1024, 700, 3, fill);  // 8.6 MB
    ASSERT_EQ(a.data().size(), size_t(1024) * 700 * 3);
    for (float x : a.data()) ASSERT_EQ(x, fill);
  }
  Image small(3, 2, 1, 4.0f);
  for (float x : small.data()) EXPECT_EQ(x, 4.0f);
  SetNumThreads(0);
}

}  // namespace
}  // namespace matfit
