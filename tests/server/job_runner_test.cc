// A fit job's progress: every stage of fit::RunFitJob maps into its own span of 0–1, later
// stages above earlier ones, ending at 1.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "server/job_runner.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

TEST(JobRunner, FitProgressGrowsThroughEveryStage) {
  const fs::path out = fs::temp_directory_path() / ("matfit-job-" + std::to_string(::getpid()));
  const std::string dataset = std::string(MATFIT_SOURCE_DIR) + "/fixtures/plaster-bonn81";
  JobSpec spec;
  spec.model = "lambert";
  spec.holdout = 3;
  std::vector<std::pair<std::string, double>> calls;
  std::set<std::string> stages;
  auto r = RunJob(spec, dataset, out.string(), [&](double f, const std::string& stage) {
    calls.emplace_back(stage, f);
    stages.insert(stage);
    return true;
  });
  fs::remove_all(out);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  for (const char* s : {"read", "fit", "reconstruction", "confidence", "heldout", "truth", "write"})
    EXPECT_TRUE(stages.count(s)) << s;
  ASSERT_FALSE(calls.empty());
  // Each new stage starts at or above everything before it (within a stage, parallel workers
  // may report slightly out of order).
  double high = 0;
  for (size_t i = 0; i < calls.size(); ++i) {
    const auto& [stage, f] = calls[i];
    EXPECT_GE(f, 0.0);
    EXPECT_LE(f, 1.0);
    if (i > 0 && stage != calls[i - 1].first) {
      EXPECT_GE(f, high) << stage << " starts below";
    }
    high = std::max(high, f);
  }
  EXPECT_DOUBLE_EQ(calls.back().second, 1.0);
}

}  // namespace
}  // namespace matfit::server
