#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "core/progress.h"

namespace matfit {
namespace {

TEST(Progress, FormatsBarAndEta) {
  EXPECT_EQ(ProgressReporter::FormatBar(5, 10, 10.0, 10), "[#####-----]  50% 5/10 ETA 10s");
  EXPECT_EQ(ProgressReporter::FormatBar(10, 10, 65.0, 4), "[####] 100% 10/10 in 1m05s");
  EXPECT_EQ(ProgressReporter::FormatBar(0, 10, 1.0, 2), "[--]   0% 0/10");
  EXPECT_EQ(ProgressReporter::FormatDuration(3725), "1h02m");
}

TEST(Progress, LinesStyleEndsWithTheCompleteLine) {
  char buf[4096] = {};
  FILE* f = fmemopen(buf, sizeof buf, "w");
  ASSERT_NE(f, nullptr);
  {
    ProgressReporter p("fit", f, ProgressReporter::Style::kLines);
    for (int i = 0; i <= 200; ++i) p.Update(i, 200);
  }
  std::fclose(f);
  const std::string out(buf);
  // Fast jobs print only the final line in line mode.
  EXPECT_NE(out.find("fit [####################] 100% 200/200 in 0s"), std::string::npos) << out;
  EXPECT_EQ(out.find('\r'), std::string::npos);
}

TEST(Progress, BarStyleRedrawsInPlace) {
  char buf[4096] = {};
  FILE* f = fmemopen(buf, sizeof buf, "w");
  ASSERT_NE(f, nullptr);
  {
    ProgressReporter p("read", f, ProgressReporter::Style::kBar);
    p.Update(1, 4);
    p.Update(4, 4);
  }
  std::fclose(f);
  const std::string out(buf);
  EXPECT_EQ(out.front(), '\r');
  EXPECT_EQ(out.back(), '\n');
  EXPECT_NE(out.find("100% 4/4"), std::string::npos) << out;
}

}  // namespace
}  // namespace matfit
