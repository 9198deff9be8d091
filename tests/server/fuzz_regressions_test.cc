// Inputs the fuzz targets (fuzz/, docs/fuzzing.md) found crashing, pinned: each must now give an
// error Status naming the problem, never a crash or an uncaught exception.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "capture/session.h"
#include "fit/select.h"
#include "server/archive.h"
#include "server/job_spec.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;

const std::string kDir = std::string(MATFIT_SOURCE_DIR) + "/tests/server/fuzz_regressions";

// archive_fuzzer: truncated/garbled zips for which libarchive gives a NULL error string; the
// server appended it to a std::string and crashed (SIGSEGV) on such an upload.
TEST(FuzzRegressions, ArchivesWithoutALibarchiveMessageAreRefusedNotACrash) {
  for (const char* name : {"archive-null-error-1.bin", "archive-null-error-2.bin"}) {
    const fs::path dest = fs::temp_directory_path() / ("matfit-fuzzreg-" + std::string(name));
    fs::remove_all(dest);
    ArchiveProblem problem = ArchiveProblem::kNone;
    auto r = ExtractArchive(kDir + "/" + name, dest.string(), ArchiveLimits{}, &problem);
    ASSERT_FALSE(r.ok()) << name;
    EXPECT_EQ(problem, ArchiveProblem::kMalformed) << name;
    EXPECT_FALSE(r.status().message().empty());
    EXPECT_FALSE(fs::exists(dest)) << name << ": a refused archive leaves nothing";
  }
}

// scene/capture_plan/job_spec fuzzers: a number out of double range (1e999) makes nlohmann's
// parser throw out_of_range, not parse_error; only parse_error was caught.
TEST(FuzzRegressions, OutOfRangeJsonNumbersAreSyntaxErrorsNotExceptions) {
  auto scene = fit::ParseScene("-1e999", "scene.json");
  ASSERT_FALSE(scene.ok());
  EXPECT_NE(scene.status().message().find("scene.json: not JSON"), std::string::npos);
  std::string dataset;
  auto spec = ParseJobSpecJson(R"({"dataset": "/data/a", "model": 1e999})", &dataset);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.status().message().find("not valid JSON"), std::string::npos);
  const fs::path plan = fs::temp_directory_path() / "matfit-fuzzreg-plan.json";
  std::ofstream(plan) << R"({"schema": "matfit.captureplan/1", "exposures_s": [1e999]})";
  auto p = capture::ReadPlan(plan.string());
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.status().message().find("is not valid JSON"), std::string::npos);
  fs::remove(plan);
}

}  // namespace
}  // namespace matfit::server
