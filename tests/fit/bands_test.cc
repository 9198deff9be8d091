// A fit distributed over ranks (docs/scale-out.md), in process: each rank a thread with an
// in-memory Comm, so that the band reductions run under the sanitizers without an MPI launcher
// (tests/app/mpi_fit_test.sh runs the same on real MPI). Rank 0's result equals a single
// process's: maps, status, bound and report.json (timings aside) bit for bit.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/comm.h"
#include "core/image_io.h"
#include "core/material_maps.h"
#include "core/model/model.h"
#include "fit/bands.h"
#include "fit/fit_job.h"

namespace matfit::fit {
namespace {

namespace fs = std::filesystem;

// Ranks as threads: a collective completes when every rank has called it.
class ThreadRanks {
 public:
  explicit ThreadRanks(int n) : size_(n), slots_(size_t(n)) {}

  class Rank : public Comm {
   public:
    Rank(ThreadRanks* all, int rank) : all_(all), rank_(rank) {}
    int rank() const override { return rank_; }
    int size() const override { return all_->size_; }
    std::vector<std::string> AllGather(const std::string& mine) const override {
      return all_->Exchange(rank_, mine);
    }
    std::vector<std::string> Gather(const std::string& mine, int root) const override {
      auto all = all_->Exchange(rank_, mine);
      return rank_ == root ? all : std::vector<std::string>();
    }

   private:
    ThreadRanks* all_;
    int rank_;
  };

 private:
  std::vector<std::string> Exchange(int rank, const std::string& mine) {
    std::unique_lock<std::mutex> lock(mu_);
    slots_[size_t(rank)] = mine;
    const int64_t round = round_;
    if (++arrived_ == size_) {
      result_ = slots_, arrived_ = 0, ++round_;
      cv_.notify_all();
    } else if (!cv_.wait_for(lock, std::chrono::seconds(120), [&] { return round_ != round; })) {
      // The ranks called different collectives (a step taken on some bands only): say so rather
      // than hang.
      std::fprintf(stderr, "rank %d waited 120 s in collective %lld: the ranks are out of step\n",
                   rank, (long long)round);
      std::abort();
    }
    return result_;  // stays until every rank has called the next collective
  }

  const int size_;
  std::mutex mu_;
  std::condition_variable cv_;
  int arrived_ = 0;
  int64_t round_ = 0;
  std::vector<std::string> slots_, result_;
};

TEST(Bands, SplitRowsTilesTheRowsOnRunBoundaries) {
  for (auto [w, h, n] : std::vector<std::array<int, 3>>{
           {2048, 2048, 4}, {96, 80, 3}, {64, 50, 3}, {45, 37, 3}, {7, 5, 5}, {512, 344, 2}}) {
    SCOPED_TRACE(std::to_string(w) + "x" + std::to_string(h) + " / " + std::to_string(n));
    int next = 0;
    const int g = kEvalRun / std::gcd(w, kEvalRun);
    const bool aligned = h / g >= n;
    for (int r = 0; r < n; ++r) {
      auto b = SplitRows(w, h, r, n);
      ASSERT_TRUE(b.ok()) << b.status().ToString();
      EXPECT_EQ(b->row0, next);
      EXPECT_GE(b->rows, 1);
      if (aligned) {
        EXPECT_EQ(int64_t(b->row0) * w % kEvalRun, 0) << "band " << r;
      }
      next = b->row0 + b->rows;
    }
    EXPECT_EQ(next, h);
  }
  auto few = SplitRows(8, 4, 0, 5);
  ASSERT_FALSE(few.ok());
  EXPECT_NE(few.status().message().find("4 rows but 5 ranks"), std::string::npos);
  // Model selection's blocks: every band but the last a multiple of them.
  for (int r = 0, next = 0; r < 3; ++r) {
    auto b = SplitRows(96, 83, r, 3, 8);
    ASSERT_TRUE(b.ok());
    EXPECT_EQ(b->row0, next);
    if (r < 2) {
      EXPECT_EQ(b->rows % 8, 0);
    }
    next = b->row0 + b->rows;
  }
  auto coarse = SplitRows(96, 20, 0, 3, 8);
  ASSERT_FALSE(coarse.ok());
  EXPECT_NE(coarse.status().message().find("at most 2 ranks"), std::string::npos)
      << coarse.status().ToString();
}

TEST(Bands, CollectivesReduceInRankOrder) {
  ThreadRanks all(3);
  std::vector<std::thread> threads;
  std::vector<double> sums(3);
  std::vector<std::vector<int>> concat(3);
  std::vector<std::string> why(3);
  std::vector<bool> ok(3);
  for (int r = 0; r < 3; ++r)
    threads.emplace_back([&, r] {
      ThreadRanks::Rank comm(&all, r);
      double v = r + 0.5;
      SumAcross(comm, &v, 1);
      sums[size_t(r)] = v;
      concat[size_t(r)] = ConcatAcross(comm, std::vector<int>(size_t(r), r), 0);
      ok[size_t(r)] = AllOk(comm, r != 1, "rank 1 failed", &why[size_t(r)]);
    });
  for (auto& t : threads) t.join();
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(sums[size_t(r)], 4.5);
    EXPECT_FALSE(ok[size_t(r)]);
    EXPECT_EQ(why[size_t(r)], "rank 1 failed");
  }
  EXPECT_EQ(concat[0], (std::vector<int>{1, 2, 2}));
  EXPECT_TRUE(concat[1].empty() && concat[2].empty());
}

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("matfit-bands-" + std::to_string(::getpid()) + "-" + name))
      .string();
}

nlohmann::json WithoutTimings(const std::string& report) {
  auto j = nlohmann::json::parse(report);
  j.erase("timings"), j.erase("fit_seconds");
  return j;
}

const std::string kFixture = std::string(MATFIT_SOURCE_DIR) + "/fixtures/plaster-bonn81";

void ExpectSameImage(const Image& a, const Image& b, const char* what) {
  ASSERT_EQ(a.width(), b.width()) << what;
  ASSERT_EQ(a.height(), b.height()) << what;
  ASSERT_EQ(a.channels(), b.channels()) << what;
  for (int c = 0; c < a.channels(); ++c)
    for (size_t p = 0; p < size_t(a.plane_size()); ++p)
      ASSERT_EQ(a.Plane(c)[p], b.Plane(c)[p]) << what << " plane " << c << " texel " << p;
}

// Fits `input` with `model` in one process and over three thread ranks; rank 0's result must
// equal the single process's.
// *parameters (when given): the one-process fit's model-wide values.
void ExpectRanksFitWhatOneProcessFits(const std::string& input, const std::string& model,
                                      int64_t lobe_shape_texels = FitOptions{}.lobe_shape_texels,
                                      std::map<std::string, double>* parameters = nullptr) {
  SCOPED_TRACE(model);
  FitJobOptions o;
  o.input = input;
  o.model = model;
  o.fit.lobe_shape_texels = lobe_shape_texels;
  o.holdout = 3;
  o.out = TempPath(model + "-one");
  auto one = RunFitJob(o);
  ASSERT_TRUE(one.ok()) << one.status().ToString();
  if (parameters) *parameters = one->fit.parameters;
  fs::remove_all(o.out);

  constexpr int kRanks = 3;
  ThreadRanks all(kRanks);
  std::vector<std::optional<StatusOr<FitJobResult>>> results(kRanks);
  std::vector<std::thread> threads;
  o.out = TempPath(model + "-ranks");
  for (int r = 0; r < kRanks; ++r)
    threads.emplace_back([&, r] {
      ThreadRanks::Rank comm(&all, r);
      FitJobOptions ro = o;
      ro.comm = &comm;
      results[size_t(r)] = RunFitJob(ro);
    });
  for (auto& t : threads) t.join();
  for (auto& res : results) ASSERT_TRUE(res->ok()) << res->status().ToString();
  const FitJobResult& d = **results[0];
  EXPECT_TRUE(fs::exists(fs::path(o.out) / "report.json"));
  fs::remove_all(o.out);
  EXPECT_EQ(d.fit.status, one->fit.status);
  ExpectSameImage(d.fit.maps.normal, one->fit.maps.normal, "normal");
  ExpectSameImage(d.fit.maps.albedo, one->fit.maps.albedo, "albedo");
  ExpectSameImage(d.fit.maps.specular, one->fit.maps.specular, "specular");
  ExpectSameImage(d.fit.maps.coefficients, one->fit.maps.coefficients, "coefficients");
  EXPECT_EQ(d.assessment.confidence.bound, one->assessment.confidence.bound);
  EXPECT_EQ(d.fit.parameters, one->fit.parameters);
  EXPECT_EQ(d.fit.warnings, one->fit.warnings);
  EXPECT_EQ(d.fit.flagged_texels, one->fit.flagged_texels);
  // The fixture's 32 columns put every band off the 1024-texel run boundaries: sums over the
  // stack then add in another order, equal to rounding (bit-equal bands: mpi_fit_test.sh).
  for (const auto& op :
       nlohmann::json::diff(WithoutTimings(one->report_json), WithoutTimings(d.report_json))) {
    const std::string path = op["path"];
    // The selection's timings of each candidate (fit seconds, rendering cost) are measured.
    if (path.ends_with("/fit_seconds") || path.ends_with("/render_ns_per_pixel")) continue;
    const auto at = nlohmann::json::json_pointer(path);
    const auto before = WithoutTimings(one->report_json)[at];
    ASSERT_TRUE(op["op"] == "replace" && before.is_number() && op["value"].is_number())
        << "report.json differs: " << op.dump();
    const double x = before.get<double>(), y = op["value"].get<double>();
    EXPECT_LE(std::abs(x - y), 1e-12 * std::abs(x)) << op.dump();
  }
  EXPECT_EQ(d.height, one->height);
}

TEST(Bands, ThreeRanksFitWhatOneProcessFits) {
  for (const char* model : {"lambert", "heinrich", "ptm", "blinn-phong", "rbf", "auto"})
    ExpectRanksFitWhatOneProcessFits(kFixture, model);
}

// The lobe shape from per-texel fits on a grid of every 4th texel of every 4th row (32² texels,
// a target of 64: 8 × 8 texels): the bands start at rows 10 and 21, and sample the rows the
// whole stack's grid has (counted from their own first row, they would sample others).
TEST(Bands, ThreeRanksSampleTheLobeShapeOnOneProcessGrid) {
  std::map<std::string, double> parameters;
  ExpectRanksFitWhatOneProcessFits(kFixture, "blinn-phong", 64, &parameters);
  EXPECT_EQ(parameters["lobe_shape_texels"], 64);
}

// Flagged texels in the first band only (the top rows black: no signal): every rank must still
// take the same steps (the common-texel scoring runs when any band has flagged texels).
TEST(Bands, FlaggedTexelsInOneBandOnly) {
  const fs::path dir = TempPath("flagged");
  fs::remove_all(dir);
  fs::copy(kFixture, dir, fs::copy_options::recursive);
  for (const auto& e : fs::directory_iterator(dir / "tv000_pv000")) {
    ImageFileInfo info;
    auto img = ReadImage(e.path().string(), {}, &info);
    ASSERT_TRUE(img.ok()) << img.status().ToString();
    for (int c = 0; c < img->channels(); ++c)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < img->width(); ++x) img->At(c, y, x) = 0;
    const bool eight = info.pixel_format == "uint8";
    ASSERT_TRUE(WriteImage(e.path().string(), *img,
                           {eight ? PixelFormat::kUint8 : PixelFormat::kUint16,
                            eight ? TransferFunction::kSrgb : TransferFunction::kLinear})
                    .ok());
  }
  for (const char* model : {"lambert", "blinn-phong"})
    ExpectRanksFitWhatOneProcessFits(dir.string(), model);
  fs::remove_all(dir);
}

TEST(Bands, DistributedOptionsAreCheckedOnEveryRank) {
  ThreadRanks all(2);
  ThreadRanks::Rank comm(&all, 0);
  FitJobOptions o;
  o.input = kFixture;
  o.out = TempPath("refused");
  o.comm = &comm;
  std::string why;
  for (const char* model : {"auto", "rbf", "lambert"}) {
    o.model = model;
    EXPECT_TRUE(o.Check(&why)) << why;
  }
  o.model = "lambert";
  o.report_only = TempPath("a-pack");
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--report-only is not run across MPI ranks"), std::string::npos) << why;
}

}  // namespace
}  // namespace matfit::fit
