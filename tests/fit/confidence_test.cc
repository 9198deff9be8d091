// Per-texel error bounds (fit/confidence.h) and stack diagnostics (fit/diagnostics.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/color.h"
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

}  // namespace
}  // namespace matfit::fit
