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

#include "core/synth/synth.h"
#include "server/job_runner.h"
#include "server/job_spec.h"

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

// Issue 17: a multi-view BTF upload (view=all) fitted by svbrdf, its images counted against the
// stack limit before any pixel is decoded.
TEST(JobRunner, AMultiViewUploadIsFittedOverEveryView) {
  auto spec = ParseJobSpecFields({{"view", "all"}, {"model", "svbrdf"}});
  ASSERT_TRUE(spec.ok()) << spec.status().ToString();
  EXPECT_TRUE(JobReadOptions(*spec).all_views);
  EXPECT_FALSE(JobReadOptions(*spec).view.has_value());
  const fs::path root = fs::temp_directory_path() / ("matfit-mv-job-" + std::to_string(::getpid()));
  fs::remove_all(root);
  synth::SynthOptions o;
  o.material = "lacquer", o.lights = "bonn81", o.views = "dome:4", o.size = 12, o.bits = 16;
  auto data = synth::Synthesize(o);
  ASSERT_TRUE(data.ok());
  ASSERT_TRUE(synth::WriteSynthDataset(*data, o, (root / "btf").string(), false).ok());
  // 4 views × 81 lights × 12² × 3 samples: over a limit of 100 k, under 200 k.
  std::string field;
  const Status over = ValidateDataset(*spec, (root / "btf").string(), 100000, &field);
  EXPECT_FALSE(over.ok());
  EXPECT_TRUE(ValidateDataset(*spec, (root / "btf").string(), 200000, &field).ok());
  // The multi-view job's stages map in order: the job's fraction never goes back.
  std::vector<std::pair<std::string, double>> calls;
  auto r = RunJob(*spec, (root / "btf").string(), (root / "pack").string(),
                  [&](double f, const std::string& stage) {
                    calls.emplace_back(stage, f);
                    return true;
                  });
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  double high = 0;
  for (size_t i = 0; i < calls.size(); ++i)
    if (i > 0 && calls[i].first != calls[i - 1].first) {
      EXPECT_GE(calls[i].second, high) << calls[i].first << " starts below";
      high = std::max(high, calls[i].second);
    } else {
      high = std::max(high, calls[i].second);
    }
  EXPECT_NE(r->find("svbrdf"), std::string::npos) << *r;
  // per-view:<model>: one pack per view under the job's pack.
  auto per_view = ParseJobSpecFields({{"view", "all"}, {"model", "per-view:lambert"}});
  ASSERT_TRUE(per_view.ok()) << per_view.status().ToString();
  auto pv = RunJob(*per_view, (root / "btf").string(), (root / "pv").string(),
                   [](double, const std::string&) { return true; });
  ASSERT_TRUE(pv.ok()) << pv.status().ToString();
  for (const char* v : {"v000", "v003"})
    EXPECT_TRUE(fs::exists(root / "pv" / "views" / v / "material.json")) << v;
  auto unknown = ParseJobSpecFields({{"view", "all"}, {"model", "per-view:svbrdf"}});
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.status().message().find("per-view:<one of"), std::string::npos)
      << unknown.status().message();
  fs::remove_all(root);
}

}  // namespace
}  // namespace matfit::server
