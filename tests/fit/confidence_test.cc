// Per-texel error bounds (fit/confidence.h) and stack diagnostics (fit/diagnostics.h).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>

#include <filesystem>

#include <functional>
#include <memory>
#include <utility>

#include <algorithm>
#include <cmath>

#include "core/color.h"
#include "core/dataset/dataset.h"
#include "core/stack_probe.h"
#include "core/synth/light_sets.h"
#include "fit/assess.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "synth_data.h"

namespace matfit::fit {
namespace {

std::vector<Vec3> Dome() {
  std::vector<Vec3> d;
  const auto set = synth::MakeLightSet("dome:48", 1);
  for (const auto& l : *set) d.push_back(l.direction);
  return d;
}

struct Outcome {
  FitResult fit;
  FitAssessment a;
  int64_t ok = 0, silent = 0;
  double median_ratio = 0;  // median error / bound over ok texels
};

Outcome FitAndAssess(const std::string& model, const synth::SynthResult& data) {
  Outcome o;
  auto method = MakeMethod(model);
  auto fit = method->Fit(data.stack, {});
  EXPECT_TRUE(fit.ok()) << fit.status().ToString();
  o.fit = std::move(*fit);
  o.a = AssessFit(data.stack, *method, &o.fit);
  const auto err = RelightingError(o.fit.maps, data.truth, Dome(), data.stack.view_direction);
  std::vector<double> ratio;
  for (size_t p = 0; p < err.size(); ++p) {
    if (o.fit.status[p] != kTexelOk) continue;
    ++o.ok;
    o.silent += err[p] > o.a.confidence.bound[p];
    ratio.push_back(err[p] / o.a.confidence.bound[p]);
  }
  if (!ratio.empty()) {
    std::nth_element(ratio.begin(), ratio.begin() + ratio.size() / 2, ratio.end());
    o.median_ratio = ratio[ratio.size() / 2];
  }
  return o;
}

TEST(Confidence, PooledSigmaIsTheNoiseAndNoTexelExceedsItsBound) {
  const auto data = SynthData({.material = "plaster", .size = 48, .noise = 0.01});
  const Outcome o = FitAndAssess("lambert", data);
  EXPECT_NEAR(o.a.confidence.pooled_sigma, 0.01, 0.0005);
  EXPECT_DOUBLE_EQ(o.a.confidence.extrapolation, 1.0);  // bonn81 spans the dome
  EXPECT_EQ(o.ok, 48 * 48);
  EXPECT_EQ(o.silent, 0);
  // Not vacuous: the bound is within ~30× of the error actually made.
  EXPECT_GT(o.median_ratio, 1.0 / 30);
}

TEST(Confidence, BoundToActualRatioIsOverOkTexelsWithAnError) {
  // Ratios 2, 4, 1, 8, 3 on the ok texels with a finite bound and an error > 0; the rest skipped:
  // a flagged texel, an infinite bound, a zero error, a NaN error.
  const std::vector<float> bound = {2, 8, 1, 16, 6, 5, INFINITY, 4, 4};
  const std::vector<float> actual = {1, 2, 1, 2, 2, 1, 1, 0, NAN};
  std::vector<uint8_t> status(9, kTexelOk);
  status[5] = kTexelSaturated;
  const BoundRatio r = BoundToActualRatio(bound, actual, status);
  EXPECT_EQ(r.texels, 5);
  EXPECT_DOUBLE_EQ(r.median, 3);             // sorted 1 2 3 4 8: element 2
  EXPECT_DOUBLE_EQ(r.p90, 8);                // element min(4, ⌊0.9 · 5⌋) = 4
  EXPECT_DOUBLE_EQ(r.exceeded_fraction, 0);  // every ratio ≥ 1
  EXPECT_DOUBLE_EQ(BoundToActualRatio({1, 1, 3}, {2, 4, 1}, {}).exceeded_fraction, 2.0 / 3);
  EXPECT_EQ(BoundToActualRatio({}, {}, {}).texels, 0);
  EXPECT_TRUE(std::isnan(BoundToActualRatio({}, {}, {}).median));
}

TEST(Confidence, ModelMisfitWidensTheBound) {
  // Lambert on glossy plastic: highlights are misfit, the residual shows it.
  const auto data = SynthData({.material = "plastic", .size = 48});
  const Outcome lam = FitAndAssess("lambert", data);
  const Outcome bp = FitAndAssess("blinn-phong", data);
  EXPECT_EQ(lam.silent, 0);
  EXPECT_EQ(bp.silent, 0);
  EXPECT_GT(lam.a.confidence.pooled_sigma, 5 * bp.a.confidence.pooled_sigma);
}

TEST(Confidence, CoplanarLightsCannotBeVerified) {
  const auto data = SynthData({.material = "plaster", .lights = "ring:12:45", .size = 16});
  // A ring is not coplanar in 3D (the z components are equal, not zero); put the lights on one
  // great circle instead: φ = 0° or 180°.
  synth::SynthResult flat = data;
  for (size_t i = 0; i < flat.stack.lights().size(); ++i) {
    const double t = (-60.0 + 120.0 * i / 11) * M_PI / 180;
    flat.stack.lights()[i].direction = Vec3(std::sin(t), 0, std::cos(t));
  }
  EXPECT_FALSE(std::isfinite(MeanDomeLeverage(flat.stack.lights(), 1e6)));
  auto method = MakeMethod("mean");
  auto fit = method->Fit(flat.stack, {});
  ASSERT_TRUE(fit.ok());
  const FitAssessment a = AssessFit(flat.stack, *method, &*fit);
  EXPECT_EQ(a.confidence.unverifiable, 16 * 16);
  for (uint8_t s : fit->status) EXPECT_EQ(s, kTexelUnverifiable);
}

TEST(Confidence, TooFewSamplesForTheParametersAreUnverifiable) {
  // hsh2 has 12 parameters; 4 lights × 3 channels = 12 samples: an exact fit, no residual.
  const auto data = SynthData({.material = "plaster", .lights = "dome:4", .size = 16});
  auto method = MakeMethod("hsh2");
  auto fit = method->Fit(data.stack, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const FitAssessment a = AssessFit(data.stack, *method, &*fit);
  for (uint8_t s : fit->status) EXPECT_EQ(s, kTexelUnverifiable);
  EXPECT_EQ(a.confidence.unverifiable, 16 * 16);
}

TEST(Diagnostics, GammaEncodedImagesReadAsLinearAreDetected) {
  for (const char* material : {"plaster", "plastic", "wool"}) {
    auto data = SynthData({.material = material, .size = 48});
    const StackDiagnostics linear = DiagnoseStack(data.stack);
    EXPECT_FALSE(linear.looks_gamma_encoded) << material << " γ̂ " << linear.encoding_exponent;
    for (float& v : std::span<float>(data.stack.data(),
                                     size_t(data.stack.num_images()) * 3 * data.stack.plane_size()))
      v = std::round(255 * LinearToSrgb(std::clamp(v, 0.0f, 1.0f))) / 255;
    const StackDiagnostics encoded = DiagnoseStack(data.stack);
    EXPECT_TRUE(encoded.looks_gamma_encoded) << material << " γ̂ " << encoded.encoding_exponent;
    EXPECT_NEAR(encoded.encoding_exponent, 2.2, 0.5) << material;
    ASSERT_FALSE(encoded.warnings.empty());
    EXPECT_NE(encoded.warnings[0].find("--color-space srgb"), std::string::npos);
  }
}

// Radiometric self-calibration (issue 19): the exponent is recovered within 0.05 from stacks
// encoded with a known power (8-bit codes), on Lambertian, glossy and rough materials; sRGB files
// read as linear and linear files decoded as sRGB are named as such.
TEST(Diagnostics, ToneCurveIsRecoveredFromTheStack) {
  for (const char* material : {"plaster", "plastic", "wool", "granite"}) {
    auto encode = [&](const std::function<float(float)>& curve) {
      auto data = SynthData({.material = material, .size = 48});
      for (float& v : std::span<float>(
               data.stack.data(), size_t(data.stack.num_images()) * 3 * data.stack.plane_size()))
        v = std::round(255 * curve(std::clamp(v, 0.0f, 1.0f))) / 255;
      return DiagnoseStack(data.stack);
    };
    for (double g : {1.0, 1.8, 2.2}) {
      const StackDiagnostics d = encode([g](float v) { return std::pow(v, float(1 / g)); });
      EXPECT_NEAR(d.encoding_exponent, g, 0.05) << material;
      if (g == 1.0) {
        EXPECT_EQ(d.verdict, ToneVerdict::kAsRead) << material;
        EXPECT_TRUE(d.warnings.empty()) << material;
      }
    }
    const StackDiagnostics srgb = encode([](float v) { return LinearToSrgb(v); });
    EXPECT_EQ(srgb.verdict, ToneVerdict::kSrgbReadAsLinear)
        << material << " γ̂ " << srgb.encoding_exponent;
    // Linear files decoded as sRGB: the read values are the sRGB decode of linear codes.
    const StackDiagnostics wrong = encode([](float v) { return SrgbToLinear(v); });
    EXPECT_EQ(wrong.verdict, ToneVerdict::kLinearReadAsSrgb)
        << material << " γ̂ " << wrong.encoding_exponent;
    EXPECT_TRUE(wrong.looks_linear_read_as_srgb) << material;
    ASSERT_FALSE(wrong.warnings.empty()) << material;
    EXPECT_NE(wrong.warnings[0].find("--color-space linear"), std::string::npos);
    EXPECT_FALSE(wrong.looks_gamma_encoded) << material;
  }
}

// --color-space auto acts on the estimate (issue 19 item 2): 8-bit codes written with a known
// curve and read by a wrong rule are re-linearised to within the quantisation of the truth; read
// by the right rule, or by the user's choice, they are left as they are.
TEST(Diagnostics, AutoColourSpaceReadsTheCurveTheStackShows) {
  struct Case {
    const char* stored;  // the curve the codes were written with
    std::function<float(float)> encode;
    TransferFunction read;  // the rule's reading
    bool corrected;
  };
  const std::vector<Case> cases = {
      {"linear", [](float v) { return v; }, TransferFunction::kSrgb, true},
      {"linear", [](float v) { return v; }, TransferFunction::kLinear, false},
      {"sRGB", [](float v) { return LinearToSrgb(v); }, TransferFunction::kLinear, true},
      {"sRGB", [](float v) { return LinearToSrgb(v); }, TransferFunction::kSrgb, false},
      {"gamma 1.8", [](float v) { return std::pow(v, 1 / 1.8f); }, TransferFunction::kLinear, true},
      {"gamma 2.2", [](float v) { return std::pow(v, 1 / 2.2f); }, TransferFunction::kLinear, true},
  };
  for (const char* material : {"plaster", "plastic", "granite"}) {
    const auto data = SynthData({.material = material, .size = 48});
    const LightStack& truth = data.stack;
    for (const Case& k : cases) {
      for (const char* reason : {"8-bit default (sRGB)", "user override"}) {
        const ColorEncoding read{k.read, 1.0f};
        LightStack s(truth.width(), truth.height(), 3, truth.num_images(), SampleType::kUint8,
                     LinearDecodeTable(read, 8));
        s.lights() = truth.lights();
        s.encodings.assign(size_t(s.num_images()), read);
        s.encoding_reasons.assign(size_t(s.num_images()), reason);
        for (int i = 0; i < s.num_images(); ++i)
          for (int c = 0; c < 3; ++c) {
            auto codes = s.Codes<uint8_t>(i, c);
            for (int64_t p = 0; p < s.plane_size(); ++p)
              codes[size_t(p)] = uint8_t(
                  std::lround(255 * k.encode(std::clamp(truth.Sample(i, c, p), 0.0f, 1.0f))));
          }
        StackDiagnostics d = DiagnoseStack(s);
        const ToneResolution r = ResolveToneCurve(&s, &d);
        const bool user = std::string(reason) == "user override";
        const std::string what = std::string(material) + ", " + k.stored + " read as " +
                                 ColorEncoding{k.read, 1}.ToString() + " (" + reason + ")";
        EXPECT_EQ(r.corrected, k.corrected && !user) << what << ": " << DescribeToneCurve(r.before);
        if (!r.corrected) {
          EXPECT_EQ(s.encodings[0].transfer, k.read) << what;
          continue;
        }
        ASSERT_FALSE(d.warnings.empty()) << what;
        EXPECT_EQ(d.warnings[0].rfind("tone-corrected: ", 0), 0u) << d.warnings[0];
        EXPECT_NE(d.encoding_exponent, r.before.encoding_exponent) << what;
        // The re-read values against the truth: median relative error over lit samples ≤ 3 %
        // (8-bit codes and a γ̂ rounded to 0.01).
        std::vector<double> rel;
        for (int i = 0; i < s.num_images(); i += 7)
          for (int64_t p = 0; p < s.plane_size(); p += 5) {
            const float t = truth.Sample(i, 1, p);
            if (t > 0.05f && t < 0.95f) rel.push_back(std::abs(s.Sample(i, 1, p) / t - 1));
          }
        ASSERT_GT(rel.size(), 100u) << what;
        std::nth_element(rel.begin(), rel.begin() + rel.size() / 2, rel.end());
        EXPECT_LE(rel[rel.size() / 2], 0.03) << what << " → " << s.encodings[0].ToString();
        EXPECT_EQ(s.encoding_reasons[0].rfind("tone-curve estimate", 0), 0u) << what;
      }
    }
  }
}

// The loader takes the diagnosis's texels while it decodes (LightStack::probe): the probe holds
// the stack's codes at the grid DiagnoseStack samples, DiagnoseStack reads it (a stack whose
// probe codes are altered is diagnosed differently) and gives exactly the diagnosis of a gather
// from the planes: whole, cropped, as a band of rows, read as linear (the tone correction
// re-reads the codes with a new table and diagnoses again).
TEST(Diagnostics, TheLoadersProbeGivesTheGatheredDiagnosis) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("matfit_probe_" + std::to_string(getpid()));
  fs::remove_all(dir);
  synth::SynthOptions o;
  o.material = "plastic", o.lights = "dome:40", o.size = 256, o.height = 180;
  o.layout = Layout::kLp, o.bits = 8, o.format = "png";
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(synth::WriteSynthDataset(*r, o, dir.string(), true).ok());
  auto same = [](const StackDiagnostics& a, const StackDiagnostics& b, const std::string& what) {
    EXPECT_EQ(a.encoding_exponent, b.encoding_exponent) << what;
    EXPECT_EQ(a.residual_linear, b.residual_linear) << what;
    EXPECT_EQ(a.residual_best, b.residual_best) << what;
    EXPECT_EQ(a.residual_srgb_decoded, b.residual_srgb_decoded) << what;
    EXPECT_EQ(a.residual_srgb_encoded, b.residual_srgb_encoded) << what;
    EXPECT_EQ(a.evidence, b.evidence) << what;
    EXPECT_EQ(a.verdict, b.verdict) << what;
    EXPECT_EQ(a.texels_used, b.texels_used) << what;
    EXPECT_EQ(a.warnings, b.warnings) << what;
  };
  struct Case {
    const char* what;
    ReadOptions read;
  };
  std::vector<Case> cases(4);
  cases[0].what = "whole";
  cases[1].what = "cropped", cases[1].read.crop = CropRect{5, 3, 230, 161};
  cases[2].what = "band", cases[2].read.row0 = 20, cases[2].read.rows = 97;
  cases[3].what = "read as linear", cases[3].read.color_space = ColorSpaceChoice::kLinear;
  for (const Case& c : cases) {
    auto s = ReadDataset(dir.string(), c.read);
    ASSERT_TRUE(s.ok()) << c.what << ": " << s.status().message();
    ASSERT_NE(s->probe, nullptr) << c.what;
    const StackProbe& p = *s->probe;
    EXPECT_EQ(p.grid,
              MakeProbeGrid(s->width(), s->full_height(), s->band.row0, s->height(), kProbeTexels))
        << c.what;
    for (size_t y = 0; y < p.grid.ys.size(); ++y)
      for (int i = 0; i < s->num_images(); i += 3)
        for (int ch = 0; ch < 3; ++ch)
          for (size_t k = 0; k < p.grid.xs.size(); ++k)
            ASSERT_EQ(p.Code(int(y), i, ch, int(k)),
                      std::as_const(*s).Codes<uint8_t>(
                          i, ch)[size_t(p.grid.ys[y]) * s->width() + size_t(p.grid.xs[k])])
                << c.what;
    LightStack gathered = *s;
    gathered.probe.reset();
    StackDiagnostics with = DiagnoseStack(*s), without = DiagnoseStack(gathered);
    same(with, without, c.what);
    EXPECT_GT(with.texels_used, 100) << c.what;
    auto altered = std::make_shared<StackProbe>(p);
    for (uint16_t& code : altered->codes) code = uint16_t(code / 2);
    LightStack wrong = *s;
    wrong.probe = altered;
    EXPECT_NE(DiagnoseStack(wrong).residual_linear, with.residual_linear) << c.what;
    // The same codes re-read through another table (what --color-space auto does when it
    // corrects the reading): the probe holds codes, so it still gives the gathered diagnosis.
    if (c.read.color_space == ColorSpaceChoice::kLinear) {
      EXPECT_EQ(with.verdict, ToneVerdict::kSrgbReadAsLinear) << DescribeToneCurve(with);
    }
    const ColorEncoding other = c.read.color_space == ColorSpaceChoice::kLinear
                                    ? ColorEncoding{TransferFunction::kSrgb, 1.0f}
                                    : ColorEncoding{TransferFunction::kGamma, 1.6f};
    s->Relinearise(other, "test"), gathered.Relinearise(other, "test");
    ASSERT_NE(s->probe, nullptr);
    same(DiagnoseStack(*s), DiagnoseStack(gathered), std::string(c.what) + ", re-read");
  }
  // Codes that may be written drop the probe.
  auto s = ReadDataset(dir.string());
  ASSERT_TRUE(s.ok() && s->probe);
  (void)s->Codes<uint8_t>(0, 0);
  EXPECT_EQ(s->probe, nullptr);
  fs::remove_all(dir);
}

// A mistake the reader cannot have made is not reported: a glossy set under one ring of lights,
// read as linear as its files say, bends like an sRGB encode of linear values (γ̂ 0.38), but
// linear files read as they are stored were not "decoded as sRGB".
TEST(Diagnostics, AToneMistakeMustBeOneTheReaderCouldMake) {
  auto s = ReadDataset(std::string(MATFIT_SOURCE_DIR) + "/fixtures/plastic-ring12");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  ASSERT_EQ(s->encodings[0].transfer, TransferFunction::kLinear);
  const StackDiagnostics d = DiagnoseStack(*s);
  EXPECT_LT(d.encoding_exponent, 0.5);
  EXPECT_NE(d.verdict, ToneVerdict::kLinearReadAsSrgb) << DescribeToneCurve(d);
  EXPECT_FALSE(d.looks_linear_read_as_srgb);
  EXPECT_TRUE(d.warnings.empty()) << d.warnings[0];
  // The same values marked as decoded from sRGB: now the mistake is possible, and reported —
  // but one ring of lights bends the values as a curve would, so auto does not act on it.
  for (ColorEncoding& e : s->encodings) e.transfer = TransferFunction::kSrgb;
  StackDiagnostics marked = DiagnoseStack(*s);
  EXPECT_EQ(marked.verdict, ToneVerdict::kLinearReadAsSrgb);
  EXPECT_FALSE(ResolveToneCurve(&*s, &marked).corrected);
}

// The real psm sets carry no colour metadata and are read as sRGB (the 8-bit convention). The
// gray sphere says they are linear; the glossy cat (12 lights, cast shadows) gives no clear
// evidence either way. Read as linear, neither is flagged.
TEST(Diagnostics, ToneCurveVerdictsOnThePsmSets) {
  const std::string root = std::string(MATFIT_SHARED_DATA) + "/psm/";
  if (!std::filesystem::exists(root + "gray"))
    GTEST_SKIP() << "shared data 'psm' not found; skipping";
  for (const char* object : {"gray", "cat"}) {
    auto as_srgb = ReadDataset(root + object);
    ReadOptions linear;
    linear.color_space = ColorSpaceChoice::kLinear;
    auto as_linear = ReadDataset(root + object, linear);
    ASSERT_TRUE(as_srgb.ok() && as_linear.ok()) << object;
    const StackDiagnostics a = DiagnoseStack(*as_srgb), b = DiagnoseStack(*as_linear);
    std::printf("psm %s read as sRGB: %s\npsm %s read as linear: %s\n", object,
                DescribeToneCurve(a).c_str(), object, DescribeToneCurve(b).c_str());
    // --color-space auto: gray is re-read as linear (and then shows no mistake), cat stays.
    StackDiagnostics resolved = a;
    const ToneResolution t = ResolveToneCurve(&*as_srgb, &resolved);
    if (std::string(object) == "gray") {
      EXPECT_EQ(a.verdict, ToneVerdict::kLinearReadAsSrgb);
      EXPECT_GE(a.evidence, 1.4);
      EXPECT_TRUE(t.corrected);
      EXPECT_EQ(as_srgb->encodings[0].transfer, TransferFunction::kLinear);
      EXPECT_EQ(resolved.verdict, ToneVerdict::kAsRead) << DescribeToneCurve(resolved);
      for (int i = 0; i < 12; ++i)
        EXPECT_EQ(as_srgb->Sample(i, 1, 100 * 512 + 250), as_linear->Sample(i, 1, 100 * 512 + 250));
    } else {
      EXPECT_FALSE(t.corrected) << DescribeToneCurve(a);
    }
    EXPECT_FALSE(b.looks_linear_read_as_srgb) << object;
    EXPECT_FALSE(b.looks_gamma_encoded) << object;
  }
}

}  // namespace
}  // namespace matfit::fit
