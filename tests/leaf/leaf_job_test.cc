// The leaf job: one pack per leaf and an index written atomically, the manifest, how the scan is
// read (colour), bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "../core/test_util.h"
#include "core/color.h"
#include "core/image_io.h"
#include "core/pack/pack_reader.h"
#include "fit/diagnostics.h"
#include "leaf/leaf_job.h"
#include "leaf/scan.h"
#include "leaf/sheet.h"
#include "leaf/synthetic_scan.h"

namespace matfit::leaf {
namespace {

namespace fs = std::filesystem;
using matfit::testing::TempDir;

SyntheticScanOptions Small() {
  SyntheticScanOptions o;
  o.leaf_size = 96, o.width = 168, o.height = 124;
  return o;
}

// Why the leaf pipeline does not act on the tone-curve estimate (fit/diagnostics.h
// ResolveToneCurve, which matfit fit uses under --color-space auto): a leaf rig's lights are
// near, so each image's brightness falls off across the sheet differently, and the per-texel
// Lambertian consistency the estimate relies on does not hold for the raw top-lit stack. Top-lit
// photos holding correct linear codes (two rings, 30° and 60°, so the elevation gate would
// pass) look like sRGB read as linear with strong evidence; acting on that would corrupt a right
// reading. The flat-fielded stack (the sheet analysis's J = I / B · cos θ) reads "as read", but
// flat-fielding a wrongly decoded stack mixes domains (B is fitted to the decoded values and
// cos θ is linear), so it cannot tell the right curve either. So the scan is read by its
// manifest and the file's metadata, and its maps do not depend on the estimate.
TEST(LeafJob, TheToneEstimateIsNotValidOnANearLightLeafRig) {
  TempDir tmp;
  SyntheticScanOptions so = Small();
  so.two_rings = true;
  const auto s = MakeSyntheticScan(so);
  ASSERT_TRUE(WriteLeafScan(s, tmp / "scan", false).ok());
  // Every photo rewritten as linear codes of the same linear values, tagged linear.
  ImageReadOptions raw;
  raw.color_space = ColorSpaceChoice::kLinear;  // the stored values, undecoded
  for (const auto& e : fs::directory_iterator(tmp / "scan")) {
    if (e.path().extension() != ".png") continue;
    auto img = ReadImage(e.path().string(), raw);
    ASSERT_TRUE(img.ok()) << img.status().ToString();
    for (float& v : img->data()) v = SrgbToLinear(v);
    ASSERT_TRUE(
        WriteImage(e.path().string(), *img, {PixelFormat::kUint8, TransferFunction::kLinear}).ok());
  }
  std::ifstream in(tmp / "scan/leaf.json");
  auto m = nlohmann::json::parse(in);
  m.erase("color_space");  // auto: the file's metadata says linear
  std::ofstream(tmp / "scan/leaf.json") << m.dump(2);
  auto scan = ReadLeafScan(tmp / "scan");
  ASSERT_TRUE(scan.ok()) << scan.status().ToString();
  ASSERT_EQ(scan->top.encodings[0].transfer, TransferFunction::kLinear);
  const fit::StackDiagnostics d = fit::DiagnoseStack(scan->top);
  std::printf("raw top-lit stack, correctly read as linear: gamma %.2f at evidence %.2f\n",
              d.encoding_exponent, d.evidence);
  EXPECT_GT(d.encoding_exponent, 1.6);  // a false "sRGB read as linear"
  EXPECT_GT(d.evidence, 2.0);
  auto sheet = AnalyzeSheet(*scan, SheetOptions{});
  ASSERT_TRUE(sheet.ok());
  const fit::StackDiagnostics f = fit::DiagnoseStack(sheet->top);
  std::printf("flat-fielded: gamma %.2f at evidence %.2f\n", f.encoding_exponent, f.evidence);
  EXPECT_EQ(f.verdict, fit::ToneVerdict::kAsRead);
  // The job keeps the reading: maps equal to those of the same scan told "linear".
  LeafJobOptions o;
  o.input = tmp / "scan", o.out = tmp / "auto";
  auto a = RunLeafJob(o);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  m["color_space"] = "linear";
  std::ofstream(tmp / "scan/leaf.json") << m.dump(2);
  o.out = tmp / "told";
  auto b = RunLeafJob(o);
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  auto pa = ReadPack(tmp / "auto/leaf_01"), pb = ReadPack(tmp / "told/leaf_01");
  ASSERT_TRUE(pa.ok() && pb.ok());
  EXPECT_EQ(pa->maps.albedo.data(), pb->maps.albedo.data());
  EXPECT_EQ(pa->maps.translucency.data(), pb->maps.translucency.data());
}

TEST(LeafJob, WritesOnePackPerLeafAndAnIndexAtomically) {
  TempDir tmp;
  const auto s = MakeSyntheticScan(Small());
  ASSERT_TRUE(WriteLeafScan(s, tmp / "scan", false).ok());
  LeafJobOptions o;
  o.input = tmp / "scan", o.out = tmp / "out";
  auto r = RunLeafJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_EQ(r->leaves, 1);
  EXPECT_EQ(r->scale_source, "markers");
  EXPECT_NEAR(r->mm_per_pixel, 0.2, 1e-9);
  std::ifstream in(tmp / "out/leaves.json");
  const auto idx = nlohmann::json::parse(in);
  ASSERT_EQ(idx["leaves"].size(), 1u);
  const auto& l0 = idx["leaves"][0];
  EXPECT_NEAR(l0["area_mm2"].get<double>(), l0["area_px"].get<double>() * 0.04, 1e-6);
  EXPECT_EQ(idx["counts"]["markers"], 4);
  auto pack = ReadPack(tmp / "out/leaf_01");
  ASSERT_TRUE(pack.ok()) << pack.status().ToString();
  EXPECT_FALSE(pack->maps.translucency.empty());
  EXPECT_FALSE(pack->maps.hl2.empty());
  EXPECT_FALSE(pack->maps.thickness.empty());
  std::ifstream g(tmp / "out/leaf_01/material.gltf");
  const auto gltf = nlohmann::json::parse(g);
  const auto& mat = gltf["materials"][0];
  EXPECT_TRUE(mat["extensions"].contains("KHR_materials_diffuse_transmission"));
  EXPECT_EQ(mat["doubleSided"], true);
  EXPECT_EQ(mat["alphaMode"], "MASK");
  for (const char* f : {"report.json", "maps/thickness_variation.png", "maps/absorption.png",
                        "maps/bump.png", "maps/gltf_diffuse_transmission.png"})
    EXPECT_TRUE(fs::exists(tmp / (std::string("out/leaf_01/") + f))) << f;
  std::ifstream rj(tmp / "out/leaf_01/report.json");
  const auto rep = nlohmann::json::parse(rj);
  EXPECT_EQ(rep["translucency"]["hl2_vs_multipole"].size(), 3u);
  // A second run without overwrite fails and leaves the first output alone.
  auto again = RunLeafJob(o);
  EXPECT_FALSE(again.ok());
  EXPECT_TRUE(fs::exists(tmp / "out/leaves.json"));
  // Without markers' size the scale falls back to the default, with a warning.
  nlohmann::json m;
  {
    std::ifstream mf(tmp / "scan/leaf.json");
    m = nlohmann::json::parse(mf);
  }
  m.erase("marker_size_mm");
  matfit::testing::WriteText(tmp / "scan/leaf.json", m.dump());
  o.out = tmp / "out2";
  auto r2 = RunLeafJob(o);
  ASSERT_TRUE(r2.ok()) << r2.status().ToString();
  EXPECT_EQ(r2->scale_source, "default");
  bool warned = false;
  for (const auto& w : r2->warnings)
    warned = warned || w.find("no physical scale") != std::string::npos;
  EXPECT_TRUE(warned);
  std::ifstream in2(tmp / "out2/leaves.json");
  EXPECT_TRUE(nlohmann::json::parse(in2)["leaves"][0]["area_mm2"].is_null());
}

// Leaves with many flagged texels are named in the job's warnings and leaves.json (issue #21).
// The real sheet has them (leaf_16: 670 of 763 texels flagged, the shadow-side ones); the clean
// synthetic scan has none above the threshold.
TEST(LeafJob, NamesLeavesWithManyFlaggedTexels) {
  MATFIT_REQUIRE_SHARED_DATA("leaf-sheet");
  TempDir tmp;
  LeafJobOptions o;
  o.input = shared_dir + "/leaf-sheet", o.out = tmp / "out";
  auto r = RunLeafJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  std::ifstream in(tmp / "out/leaves.json");
  const auto idx = nlohmann::json::parse(in);
  int named = 0, over = 0;
  for (size_t i = 0; i < r->summary.size(); ++i) {
    const auto& leaf = r->summary[i];
    EXPECT_NEAR(idx["leaves"][i]["flagged_fraction"].get<double>(), leaf.flagged_fraction, 1e-9);
    if (leaf.flagged_fraction <= kLeafFlaggedWarnFraction) continue;
    ++over;
    for (const auto& w : r->warnings)
      named += w.rfind("leaf-flagged: " + leaf.name + " has ", 0) == 0;
  }
  EXPECT_GE(over, 1);
  EXPECT_EQ(named, over);
  auto clean = RunLeafJob([&] {
    LeafJobOptions c;
    EXPECT_TRUE(WriteLeafScan(MakeSyntheticScan(Small()), tmp / "clean", false).ok());
    c.input = tmp / "clean", c.out = tmp / "out-clean";
    return c;
  }());
  ASSERT_TRUE(clean.ok()) << clean.status().ToString();
  EXPECT_LT(clean->summary[0].flagged_fraction, kLeafFlaggedWarnFraction);
  for (const auto& w : clean->warnings) EXPECT_NE(w.rfind("leaf-flagged", 0), 0u) << w;
}

TEST(LeafJob, BadInputNamesTheProblem) {
  TempDir tmp;
  const auto s = MakeSyntheticScan(Small());
  ASSERT_TRUE(WriteLeafScan(s, tmp / "scan", false).ok());
  auto expect_error = [&](const std::string& dir, const std::string& manifest,
                          const std::string& needle) {
    auto r = ReadLeafScan(dir, manifest);
    ASSERT_FALSE(r.ok()) << needle;
    EXPECT_NE(r.status().message().find(needle), std::string::npos) << r.status().message();
  };
  expect_error(tmp / "missing", "", "does not exist");
  // No back-lit images.
  fs::create_directories(tmp / "noback");
  fs::copy_file(tmp / "scan/1_TL.png", tmp / "noback/1_TL.png");
  expect_error(tmp / "noback", "", "no back-lit images");
  // Back-lit only: nothing lit from the front.
  fs::create_directories(tmp / "backonly");
  fs::copy_file(tmp / "scan/1_BL.png", tmp / "backonly/1_BL.png");
  expect_error(tmp / "backonly", "", "neither top-lit images");
  // Malformed manifest fields.
  matfit::testing::WriteText(tmp / "bad1.json", "{\"back_lit\": 3}");
  expect_error(tmp / "scan", tmp / "bad1.json", "'back_lit'");
  matfit::testing::WriteText(tmp / "bad2.json", "{\"max_thickness_mm\": -1}");
  expect_error(tmp / "scan", tmp / "bad2.json", "'max_thickness_mm'");
  matfit::testing::WriteText(tmp / "bad3.json", "[1, 2");
  expect_error(tmp / "scan", tmp / "bad3.json", "not a JSON object");
  // A back-lit image of another size.
  fs::create_directories(tmp / "mixed");
  for (const auto& e : fs::directory_iterator(tmp / "scan"))
    if (e.is_regular_file()) fs::copy_file(e.path(), tmp / "mixed" / e.path().filename());
  ASSERT_TRUE(WriteImage(tmp / "mixed/2_BL.png", Image(40, 30, 3, 0.5f),
                         {PixelFormat::kUint8, TransferFunction::kSrgb})
                  .ok());
  expect_error(tmp / "mixed", "", "one pixel grid");
  // Per-side scans: a grey albedo photo is taken as r = g = b; a grey normal map is refused.
  const Image g(s.scan.width(), s.scan.height(), 1, 0.4f);
  ASSERT_TRUE(
      WriteImage(tmp / "scan/ua.png", g, {PixelFormat::kUint8, TransferFunction::kSrgb}).ok());
  matfit::testing::WriteText(tmp / "alb.json",
                             "{\"upper_albedo\": \"ua.png\", \"lower_albedo\": \"ua.png\"}");
  auto grey = ReadLeafScan(tmp / "scan", tmp / "alb.json");
  ASSERT_TRUE(grey.ok()) << grey.status().ToString();
  EXPECT_EQ(grey->upper_albedo.channels(), 3);
  EXPECT_EQ(grey->lower_albedo.channels(), 3);
  matfit::testing::WriteText(tmp / "nrm.json", "{\"upper_normal\": \"ua.png\"}");
  expect_error(tmp / "scan", tmp / "nrm.json", "'upper_normal' (ua.png) has 1 channel");
  // An empty sheet: no leaves → a clear job error, and no output folder.
  fs::create_directories(tmp / "empty");
  const Image white(96, 64, 3, 0.8f);
  ASSERT_TRUE(
      WriteImage(tmp / "empty/1_BL.png", white, {PixelFormat::kUint8, TransferFunction::kSrgb})
          .ok());
  ASSERT_TRUE(
      WriteImage(tmp / "empty/front.png", white, {PixelFormat::kUint8, TransferFunction::kSrgb})
          .ok());
  LeafJobOptions o;
  o.input = tmp / "empty", o.out = tmp / "emptyout";
  auto r = RunLeafJob(o);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("no leaves"), std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "emptyout"));
}

}  // namespace
}  // namespace matfit::leaf
