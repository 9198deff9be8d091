// The matfit fit path end to end: dataset → fit → report.json → material pack.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "core/image_io.h"
#include "core/synth/synth.h"
#include "fit/confidence.h"
#include "fit/fit_job.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

namespace fs = std::filesystem;

class PackDir {
 public:
  PackDir() {
    path_ = (fs::temp_directory_path() /
             ("matfit-pack-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++)))
                .string();
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~PackDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& n) const { return path_ + "/" + n; }
  const std::string& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  std::string path_;
};

nlohmann::json ReadJson(const std::string& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

const std::string kFixture = std::string(MATFIT_SOURCE_DIR) + "/fixtures/plaster-bonn81";

TEST(FitJob, WritesAPackWhoseMapsEqualADirectFit) {
  PackDir tmp;
  FitJobOptions o;
  o.input = kFixture;
  o.model = "lambert";
  o.holdout = 3;
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  for (const char* f : {"material.json", "material.gltf", "quad.bin", "report.json", "preview.png",
                        "maps/albedo.png", "maps/normal.png", "maps/normal.exr", "maps/status.png",
                        "maps/mask.png"})
    EXPECT_TRUE(fs::exists(tmp / (std::string("pack/") + f))) << f;
  // The pack's exact normals equal a direct fit of the same dataset.
  auto stack = ReadDataset(kFixture);
  ASSERT_TRUE(stack.ok());
  auto direct = FitLambert(*stack, {});
  ASSERT_TRUE(direct.ok());
  auto normal = ReadImage(tmp / "pack/maps/normal.exr");
  ASSERT_TRUE(normal.ok());
  EXPECT_EQ(normal->data(), direct->maps.normal.data());

  const auto report = ReadJson(tmp / "pack/report.json");
  for (const char* key : {"method", "fit_seconds", "texels", "images", "deviation_percent",
                          "deviation_percent_by_theta", "rmse", "psnr_db", "heldout",
                          "flagged_texels", "normal_mae_deg", "normal_p95_deg", "albedo_rmse"})
    EXPECT_TRUE(report.contains(key)) << key;
  EXPECT_EQ(report["method"], "lambert");
  EXPECT_EQ(report["images"], 81);
  EXPECT_EQ(report["deviation_percent_by_theta"].size(), 6u);
  EXPECT_EQ(report["heldout"]["folds"], 3);
  EXPECT_LT(report["normal_mae_deg"].get<double>(), 0.2);  // 16-bit fixture, plaster
  const auto material = ReadJson(tmp / "pack/material.json");
  EXPECT_EQ(material["schema"], "matfit.material/1");
  EXPECT_EQ(material["model"]["name"], "lambert");
  bool has_normal = false;
  for (const auto& m : material["maps"])
    has_normal |= m["name"] == "normal" && m["encoding"] == "png16";
  EXPECT_TRUE(has_normal);
  // Nothing was dropped from this clean 16-bit set: no dropped map, zero counts.
  EXPECT_FALSE(fs::exists(tmp / "pack/maps/dropped.png"));
  EXPECT_EQ(report["refit_texels"], 0);
  EXPECT_EQ(report["dropped_samples"], 0);
}

// An 8-bit set where one texel is at the maximum code under 3 lights and another under 1: the pack
// says so per texel (maps/dropped.png) and in report.json, and both texels are fitted.
TEST(FitJob, ClippedSamplesAreCountedPerTexelInThePack) {
  PackDir tmp;
  LightStack s = SynthData({"plaster", "bonn81", 16}).stack;
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < 3; ++c)
      for (float& v : s.Plane(i, c)) v = std::min(v, 0.9f);  // nothing else at the top code
  for (int i : {3, 10, 40})
    for (int c = 0; c < 3; ++c) s.Plane(i, c)[5 * 16 + 7] = 1.0f;
  s.Plane(20, 1)[9 * 16 + 2] = 1.0f;
  fs::create_directories(tmp / "data");
  const Status written = WriteDataset(s, {Layout::kLp, 8, "x"}, tmp / "data");
  ASSERT_TRUE(written.ok()) << written.ToString();
  FitJobOptions o;
  o.input = tmp / "data";
  o.model = "ptm";
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const auto report = ReadJson(tmp / "pack/report.json");
  EXPECT_EQ(report["refit_texels"], 2);
  EXPECT_EQ(report["dropped_samples"], 4);
  EXPECT_EQ(report["flagged_texels"], 0);
  auto dropped = ReadImage(tmp / "pack/maps/dropped.png");
  ASSERT_TRUE(dropped.ok()) << dropped.status().ToString();
  for (int64_t p = 0; p < 16 * 16; ++p) {
    const int want = p == 5 * 16 + 7 ? 3 : p == 9 * 16 + 2 ? 1 : 0;
    EXPECT_EQ(int(std::lround(dropped->Plane(0)[p] * 255)), want) << p;
  }
}

TEST(FitJob, ReportsLobeParameterErrorsAgainstTruth) {
  PackDir tmp;
  FitJobOptions o;
  o.input = std::string(MATFIT_SOURCE_DIR) + "/fixtures/plastic-ring12";  // Blinn–Phong truth
  o.model = "blinn-phong";
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(r->truth.has_value());
  ASSERT_TRUE(r->truth->parameter_errors.count("exponent_median_relative_error"));
  EXPECT_LT(r->truth->parameter_errors.at("exponent_median_relative_error"), 0.10);
  const auto report = ReadJson(tmp / "pack/report.json");
  EXPECT_TRUE(report["parameter_errors"].contains("specular_median_absolute_error"));
}

TEST(FitJob, HeldOutErrorExceedsTheFittedError) {
  PackDir tmp;
  FitJobOptions o;
  o.input = std::string(MATFIT_SOURCE_DIR) + "/fixtures/wool-bonn81-8bit";
  o.model = "heinrich";
  o.holdout = 4;
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(r->heldout.has_value());
  EXPECT_EQ(r->heldout->failed_folds, 0);
  EXPECT_GT(r->heldout->rmse, r->reconstruction.rmse);
}

// Issue 19 item 3: how tight the bound is, against held-out lights (leave-one-out here) and
// against the truth maps, is in the report; the held-out one is that of a direct HeldOut.
TEST(FitJob, ReportsHowTightTheBoundIsAgainstHeldOutLightsAndTruth) {
  PackDir tmp;
  FitJobOptions o;
  o.input = kFixture;  // plaster, 81 lights, truth/
  o.model = "lambert";
  o.holdout = kLeaveOneOut;
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(r->heldout && r->bound_ratio_heldout && r->bound_ratio_truth);
  EXPECT_EQ(r->heldout->folds, 81);
  const auto report = ReadJson(tmp / "pack/report.json");
  EXPECT_EQ(report["heldout"]["folds"], 81);
  EXPECT_TRUE(report["heldout"]["psnr_srgb8_db"].is_number());
  const auto& ratio = report["confidence"]["bound_ratio"];
  for (const char* against : {"heldout", "truth"}) {
    EXPECT_GT(ratio[against]["median"].get<double>(), 1.0) << against;  // it bounds
    EXPECT_GE(ratio[against]["p90"].get<double>(), ratio[against]["median"].get<double>());
    EXPECT_GT(ratio[against]["texels"].get<int64_t>(), 0);
    EXPECT_EQ(ratio[against]["exceeded_fraction"].get<double>(), 0.0) << against;  // no silent
  }
  auto stack = ReadDataset(kFixture);
  ASSERT_TRUE(stack.ok());
  auto direct = HeldOut(*MakeMethod("lambert"), *stack, kLeaveOneOut, {});
  ASSERT_TRUE(direct.ok());
  const BoundRatio want =
      BoundToActualRatio(r->assessment.confidence.bound, direct->texel_rmse, r->fit.status);
  EXPECT_EQ(r->bound_ratio_heldout->median, want.median);
  EXPECT_EQ(r->bound_ratio_heldout->texels, want.texels);
  std::printf("bound / actual on plaster-bonn81, lambert: held-out %.2f (p90 %.2f), truth %.2f\n",
              r->bound_ratio_heldout->median, r->bound_ratio_heldout->p90,
              r->bound_ratio_truth->median);
}

// A highlight that clips: the lacquer (GGX, roughness 0.2–0.5 varying: model-family truth for
// cook-torrance, a misfit with the one shared roughness) saturates 16-bit PNGs at its peaks in
// about half of its texels. A clipped sample says only that the value reached the clip, so no
// fit can know how far above it a peak goes: the bound is on the error within the recorded
// range (report: recorded_limit, saturated_texels), and within it no texel exceeds its bound.
// Above it the error is the model's extrapolation: unclamped, the truth error exceeds the bound
// on many saturated texels (10–18 % of all texels before the bound said what it covers).
TEST(FitJob, OnClippedHighlightsTheBoundHoldsWithinTheRecordedRange) {
  PackDir tmp;
  synth::SynthOptions so;
  so.material = "lacquer", so.lights = "dome:81", so.size = 64, so.height = 48;
  so.perturb.gaussian_sigma = 0.005, so.layout = Layout::kLp, so.bits = 16;
  auto data = synth::Synthesize(so);
  ASSERT_TRUE(data.ok()) << data.status().ToString();
  ASSERT_TRUE(synth::WriteSynthDataset(*data, so, tmp / "data", true).ok());
  for (const std::string model : {"lambert", "cook-torrance"}) {
    FitJobOptions o;
    o.input = tmp / "data";
    o.model = model;
    o.out = tmp / model;
    auto r = RunFitJob(o);
    ASSERT_TRUE(r.ok()) << model << ": " << r.status().ToString();
    const Confidence& c = r->assessment.confidence;
    EXPECT_EQ(c.recorded_limit, Vec3(1, 1, 1)) << model;  // unit intensities: the clip level
    EXPECT_GT(c.saturated, 1000) << model;                // of 3072 texels
    ASSERT_TRUE(r->bound_ratio_truth) << model;
    EXPECT_GT(r->bound_ratio_truth->texels, 3000) << model;
    EXPECT_EQ(r->bound_ratio_truth->exceeded_fraction, 0.0) << model;
    const auto report = ReadJson(tmp / (model + "/report.json"));
    EXPECT_EQ(report["confidence"]["saturated_texels"].get<int64_t>(), c.saturated) << model;
    EXPECT_EQ(report["confidence"]["recorded_limit"], nlohmann::json({1.0, 1.0, 1.0})) << model;
    // The error above the clip level is not what the bound covers: unclamped it exceeds the
    // bound, and only on saturated texels' peaks.
    const std::vector<float> hdr = RelightingError(
        r->fit.maps, data->truth, DomeDirections(48, c.supported_theta_deg, c.supported_axis),
        data->stack.view_direction);
    const BoundRatio unclamped = BoundToActualRatio(c.bound, hdr, r->fit.status);
    EXPECT_GT(unclamped.exceeded_fraction, 0.02) << model;
    std::printf(
        "%s on the clipped lacquer: %lld saturated texels; bound / error %.2f (p90 %.2f), "
        "exceeded on %.2f %% within the recorded range, %.2f %% above it\n",
        model.c_str(), (long long)c.saturated, r->bound_ratio_truth->median,
        r->bound_ratio_truth->p90, 100 * r->bound_ratio_truth->exceeded_fraction,
        100 * unclamped.exceeded_fraction);
  }
}

// Round trip: a pack read back and scored against its dataset gives the fit's own deviation.
TEST(FitJob, ReportOnlyReproducesTheFitScoresForEveryModel) {
  PackDir tmp;
  for (const std::string& model : MethodNames()) {
    FitJobOptions o;
    o.input = kFixture;
    o.model = model;
    o.out = tmp / model;
    auto fit = RunFitJob(o);
    ASSERT_TRUE(fit.ok()) << model << ": " << fit.status().ToString();
    FitJobOptions score;
    score.input = kFixture;
    score.report_only = tmp / model;
    score.out = tmp / (model + ".json");
    auto rep = RunFitJob(score);
    ASSERT_TRUE(rep.ok()) << model << ": " << rep.status().ToString();
    const double a = fit->reconstruction.rmse, b = rep->reconstruction.rmse;
    EXPECT_NEAR(b, a, 1e-6 + 1e-4 * a) << model;
    EXPECT_EQ(rep->reconstruction.samples, fit->reconstruction.samples) << model;
    EXPECT_TRUE(fs::exists(tmp / (model + ".json")));
  }
  FitJobOptions bad;
  bad.input = kFixture;
  bad.report_only = tmp / "nowhere";
  auto r = RunFitJob(bad);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("material.json"), std::string::npos);
}

TEST(FitJob, ZipPackAndRefusalToOverwrite) {
  PackDir tmp;
  FitJobOptions o;
  o.input = kFixture;
  o.model = "mean";
  o.out = tmp / "pack.zip";
  o.zip = true;
  ASSERT_TRUE(RunFitJob(o).ok());
  std::ifstream zip(tmp / "pack.zip", std::ios::binary);
  char magic[2] = {};
  zip.read(magic, 2);
  EXPECT_EQ(std::string(magic, 2), "PK");
  // Only the zip remains: no staging folder, no temporaries.
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) ++entries, (void)e;
  EXPECT_EQ(entries, 1);
  auto again = RunFitJob(o);
  ASSERT_FALSE(again.ok());
  EXPECT_NE(again.status().message().find("--force"), std::string::npos);
  o.overwrite = true;
  EXPECT_TRUE(RunFitJob(o).ok());
}

// Every stage that ran is announced in order and timed; report.json has the same stages.
TEST(FitJob, AnnouncesAndTimesEveryStageThatRan) {
  PackDir tmp;
  for (int holdout : {0, 3}) {
    FitJobOptions o;
    o.input = kFixture;  // has truth/
    o.model = "lambert";
    o.holdout = holdout;
    o.out = tmp / ("pack" + std::to_string(holdout));
    std::vector<std::string> seen;
    std::map<std::string, std::pair<int64_t, int64_t>> last;  // stage → (done, total)
    auto r = RunFitJob(o, [&](const std::string& stage, int64_t done, int64_t total) {
      if (seen.empty() || seen.back() != stage) {
        EXPECT_EQ(done, 0) << stage << " starts at 0";
        seen.push_back(stage);
      }
      last[stage] = {done, total};
      return true;
    });
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    std::vector<std::string> expected = {"read", "fit", "reconstruction", "confidence"};
    if (holdout) expected.push_back("heldout");
    expected.insert(expected.end(), {"truth", "write"});
    EXPECT_EQ(seen, expected);
    for (const auto& [stage, dt] : last) EXPECT_GE(dt.first, dt.second) << stage << " ends done";

    const auto report = ReadJson(o.out + "/report.json");
    ASSERT_TRUE(report.contains("timings"));
    const auto& t = report["timings"];
    EXPECT_EQ(t.size(), expected.size() + 1);
    double sum = 0;
    for (const auto& stage : expected) {
      ASSERT_TRUE(t.contains(stage)) << stage;
      EXPECT_GE(t[stage].get<double>(), 0.0) << stage;
      sum += t[stage].get<double>();
    }
    EXPECT_LE(sum, t["total"].get<double>());
    EXPECT_EQ(t.contains("heldout"), holdout > 0);
    EXPECT_FALSE(t.contains("select"));
    // The result's timings run to the end of the job: the same stages, no shorter.
    ASSERT_EQ(r->timings.stages.size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) EXPECT_EQ(r->timings.stages[i].first, expected[i]);
    EXPECT_GE(r->timings.total, t["total"].get<double>());
  }
}

// The write stage moves while it runs: a relighting basis's glTF bake, then the files, in
// thousandths, never backwards (a 1024² ptm pack writes for seconds).
TEST(FitJob, TheWriteStageReportsProgressThroughTheBakeAndTheFiles) {
  PackDir tmp;
  for (const char* model : {"ptm", "lambert"}) {
    FitJobOptions o;
    o.input = kFixture;
    o.model = model;
    o.out = tmp / model;
    std::vector<int64_t> write;
    auto r = RunFitJob(o, [&](const std::string& stage, int64_t done, int64_t total) {
      if (stage == "write") {
        EXPECT_EQ(total, write.empty() ? total : 1000) << model;
        write.push_back(done);
      }
      return true;
    });
    ASSERT_TRUE(r.ok()) << r.status().ToString();
    ASSERT_GE(write.size(), 2u);
    EXPECT_EQ(write.front(), 0);
    EXPECT_TRUE(std::is_sorted(write.begin(), write.end())) << model;
    std::vector<int64_t> inside;
    for (int64_t d : write)
      if (d > 0 && d < 1000) inside.push_back(d);
    inside.erase(std::unique(inside.begin(), inside.end()), inside.end());
    // ptm: bake runs below 665, then one step per file; lambert: one step per file.
    EXPECT_GE(inside.size(), 5u) << model;
    if (std::string(model) == "ptm") {
      EXPECT_TRUE(std::any_of(inside.begin(), inside.end(), [](int64_t d) { return d <= 665; }));
    }
    EXPECT_EQ(write.back(), 1000) << model;
  }
}

TEST(FitJob, DecodeOnlyReadsTheDatasetAndWritesNothing) {
  PackDir tmp;
  FitJobOptions o;
  o.input = kFixture;
  o.decode_only = true;
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->images, 81);
  EXPECT_GT(r->width, 0);
  EXPECT_EQ(r->channels, 3);
  ASSERT_EQ(r->timings.stages.size(), 1u);
  EXPECT_EQ(r->timings.stages[0].first, "read");
  EXPECT_LE(r->timings.stages[0].second, r->timings.total);
  EXPECT_TRUE(r->report_json.empty());
  o.out = tmp / "pack";
  auto bad = RunFitJob(o);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("--decode-only"), std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "pack"));
}

TEST(FitJob, BadOptionsAndDataAreReportedBeforeAnythingIsWritten) {
  PackDir tmp;
  FitJobOptions o;
  o.input = kFixture;
  o.model = "velvet";
  o.out = tmp / "pack";
  auto r = RunFitJob(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("choose one of: mean"), std::string::npos);
  o.model = "heinrich";
  o.input = std::string(MATFIT_SOURCE_DIR) + "/fixtures/plastic-ring12";  // one elevation
  r = RunFitJob(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("inseparable"), std::string::npos);
  o.holdout = 1;
  EXPECT_FALSE(RunFitJob(o).ok());
  EXPECT_FALSE(fs::exists(tmp / "pack"));
}

}  // namespace
}  // namespace matfit::fit
