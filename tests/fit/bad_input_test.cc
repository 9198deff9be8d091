// Bad input never yields a silent garbage map: a clear error, or flagged texels + a warning.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "core/dataset/dataset.h"
#include "core/dataset/writer.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

namespace fs = std::filesystem;

synth::SynthResult Plastic(int size) { return SynthData({"plastic", "bonn81", size}); }

TEST(BadInput, AllBlackStackIsFlaggedByEveryMethod) {
  LightStack black = Plastic(8).stack;
  std::fill(black.data(), black.data() + black.plane_size() * 3 * black.num_images(), 0.0f);
  for (const std::string& name : MethodNames()) {
    auto fit = MakeMethod(name)->Fit(black, {});
    if (!fit.ok()) {
      EXPECT_FALSE(fit.status().message().empty()) << name;
      continue;
    }
    EXPECT_EQ(fit->flagged_texels, black.plane_size()) << name;
    ASSERT_FALSE(fit->warnings.empty()) << name;
    EXPECT_NE(fit->warnings.back().find("no signal"), std::string::npos)
        << name << ": " << fit->warnings.back();
  }
}

double NormalErrorDeg(const MaterialMaps& m, const MaterialMaps& truth, int64_t p) {
  const Vec3 a(m.normal.Plane(0)[p], m.normal.Plane(1)[p], m.normal.Plane(2)[p]);
  const Vec3 b(truth.normal.Plane(0)[p], truth.normal.Plane(1)[p], truth.normal.Plane(2)[p]);
  return AngleBetweenDeg(a, b);
}

// Issue 19: an over-exposed 8-bit capture (highlights and bright texels hit code 255). Every
// model drops the clipped samples of a texel and fits it from the rest; a texel is flagged only
// when the rest cannot determine the model, and lambert is about as accurate on the texels that
// lost samples as elsewhere.
TEST(BadInput, ClippedSamplesAreDroppedAndTheTexelFittedFromTheRest) {
  synth::SynthResult data = Plastic(32);
  for (int64_t k = 0; k < data.stack.plane_size() * 3 * data.stack.num_images(); ++k)
    data.stack.data()[k] *= 1.25f;
  const std::string dir =
      (fs::temp_directory_path() / ("matfit-clip-" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  fs::create_directories(dir);
  ASSERT_TRUE(WriteDataset(data.stack, {Layout::kLp, 8, "x"}, dir).ok());
  auto stack = ReadDataset(dir);
  fs::remove_all(dir);
  ASSERT_TRUE(stack.ok());
  ASSERT_GT(stack->saturated_pixels[0] + stack->saturated_pixels[1], 0);
  const int64_t P = stack->plane_size();

  for (const char* name :
       {"lambert", "ptm", "hsh2", "hsh3", "heinrich", "lambert-robust", "blinn-phong"}) {
    auto fit = MakeMethod(name)->Fit(*stack, {});
    ASSERT_TRUE(fit.ok()) << name;
    int64_t saturated = 0;
    for (uint8_t st : fit->status) saturated += st == kTexelSaturated;
    EXPECT_EQ(saturated, 0) << name;
    EXPECT_LT(double(fit->flagged_texels), 0.01 * P) << name;
  }

  auto plain = MakeMethod("lambert")->Fit(*stack, {});
  ASSERT_TRUE(plain.ok());
  ASSERT_EQ(plain->dropped_lights.size(), size_t(P));
  EXPECT_GT(plain->refit_texels, P / 20);  // the test covers many clipped texels
  EXPECT_GT(plain->dropped_samples, plain->refit_texels);
  // Normal error (vs. truth) on the texels that lost samples vs. on the others. Albedo was scaled
  // by 1.25 in the images: normals only.
  double clipped = 0, other = 0;
  int64_t nc = 0, no = 0;
  for (int64_t p = 0; p < P; ++p) {
    if (plain->status[size_t(p)] != kTexelOk) continue;
    const double e = NormalErrorDeg(plain->maps, data.truth, p);
    if (plain->dropped_lights[size_t(p)] > 0)
      clipped += e, ++nc;
    else
      other += e, ++no;
  }
  ASSERT_GT(nc, 0);
  ASSERT_GT(no, 0);
  std::printf(
      "lambert, clipped 8-bit plastic: %lld texels refitted, normal MAE %.2f° on them, "
      "%.2f° elsewhere\n",
      (long long)nc, clipped / nc, other / no);
  EXPECT_LE(clipped / nc, 1.5 * (other / no));
}

// A NaN sample (dead pixel, decode hole) is dropped by every model and the texel fitted from its
// other lights; with fewer than 3 finite lights left it is flagged.
TEST(BadInput, NanSamplesAreDroppedAndTheTexelFittedFromTheRest) {
  const auto data = Plastic(8);
  LightStack s = data.stack;
  s.Plane(7, 0)[3 * s.width() + 3] = std::nanf("");
  const int64_t p = 3 * 8 + 3;
  for (const char* name : {"lambert", "heinrich", "ptm", "hsh3", "mean", "lambert-robust",
                           "blinn-phong", "cook-torrance", "lafortune1"}) {
    auto fit = MakeMethod(name)->Fit(s, {});
    auto clean = MakeMethod(name)->Fit(data.stack, {});
    ASSERT_TRUE(fit.ok() && clean.ok()) << name;
    EXPECT_EQ(fit->status[p], kTexelOk) << name;
    EXPECT_EQ(fit->flagged_texels, 0) << name;
    const Vec3 a(fit->maps.normal.Plane(0)[p], fit->maps.normal.Plane(1)[p],
                 fit->maps.normal.Plane(2)[p]);
    const Vec3 b(clean->maps.normal.Plane(0)[p], clean->maps.normal.Plane(1)[p],
                 clean->maps.normal.Plane(2)[p]);
    EXPECT_LT(AngleBetweenDeg(a, b), 1.0) << name;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(fit->maps.albedo.Plane(c)[p], clean->maps.albedo.Plane(c)[p],
                  0.05 * clean->maps.albedo.Plane(c)[p])
          << name;
    if (!fit->maps.specular.empty()) {
      EXPECT_TRUE(std::isfinite(fit->maps.specular.Plane(0)[p])) << name;
    }
  }
  for (const char* name : {"lambert", "heinrich", "ptm", "hsh3", "mean"}) {
    auto fit = MakeMethod(name)->Fit(s, {});
    ASSERT_TRUE(fit.ok()) << name;
    ASSERT_EQ(fit->dropped_lights.size(), size_t(s.plane_size())) << name;
    EXPECT_EQ(fit->dropped_lights[p], 1) << name;
    EXPECT_EQ(fit->refit_texels, 1) << name;
    EXPECT_EQ(fit->dropped_samples, 1) << name;
  }
  // A texel left with 2 finite lights is flagged, never guessed.
  LightStack holes = data.stack;
  for (int i = 0; i < holes.num_images() - 2; ++i)
    holes.Plane(i, 1)[3 * holes.width() + 3] = std::nanf("");
  auto sparse = MakeMethod("lambert-robust")->Fit(holes, {});
  ASSERT_TRUE(sparse.ok());
  EXPECT_EQ(sparse->status[p], kTexelNonFinite);
  for (const char* name : {"lambert", "heinrich", "ptm", "hsh3"}) {
    auto fit = MakeMethod(name)->Fit(holes, {});
    ASSERT_TRUE(fit.ok()) << name;
    EXPECT_EQ(fit->status[p], kTexelTooFewLights) << name;
    EXPECT_EQ(fit->maps.normal.Plane(0)[p], 0.0f) << name;
  }
}

TEST(BadInput, TooFewAndCoplanarLightsAreClearErrors) {
  LightStack s = Plastic(8).stack;
  LightStack two = SelectImages(s, {0, 1});
  for (const std::string& name : MethodNames()) {
    if (name == "mean") continue;  // the mean needs no geometry
    auto fit = MakeMethod(name)->Fit(two, {});
    ASSERT_FALSE(fit.ok()) << name;
    EXPECT_FALSE(fit.status().message().empty());
  }
}

}  // namespace
}  // namespace matfit::fit
