// Bad input never yields a silent garbage map: a clear error, or flagged texels + a warning.
#include <gtest/gtest.h>

#include <unistd.h>

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

TEST(BadInput, ClippedSamplesAreFlaggedOrDroppedNeverUsed) {
  // An over-exposed 8-bit capture: highlights and bright texels hit code 255.
  synth::SynthResult data = Plastic(32);
  for (int64_t k = 0; k < data.stack.plane_size() * 3 * data.stack.num_images(); ++k)
    data.stack.data()[k] *= 1.8f;
  const std::string dir =
      (fs::temp_directory_path() / ("matfit-clip-" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  fs::create_directories(dir);
  ASSERT_TRUE(WriteDataset(data.stack, {Layout::kLp, 8, "x"}, dir).ok());
  auto stack = ReadDataset(dir);
  fs::remove_all(dir);
  ASSERT_TRUE(stack.ok());
  ASSERT_GT(stack->saturated_pixels[0] + stack->saturated_pixels[1], 0);

  auto plain = MakeMethod("lambert")->Fit(*stack, {});
  ASSERT_TRUE(plain.ok());
  int64_t saturated = 0;
  for (uint8_t s : plain->status) saturated += s == kTexelSaturated;
  EXPECT_GT(saturated, 0);
  EXPECT_FALSE(plain->warnings.empty());

  auto robust = MakeMethod("lambert-robust")->Fit(*stack, {});
  ASSERT_TRUE(robust.ok());
  EXPECT_LT(robust->flagged_texels, saturated);  // it keeps texels with enough unclipped samples
  // Albedo was scaled by 1.8 in the images: compare normals only.
  EXPECT_LT(CompareToTruth(robust->maps, data.truth, robust->status).normal_mae_deg, 2.0);
}

TEST(BadInput, NanPixelsAreFlaggedByTheLinearMethodsAndDroppedByTheRobustOne) {
  LightStack s = Plastic(8).stack;
  s.Plane(7, 0)[3 * s.width() + 3] = std::nanf("");
  for (const char* name : {"lambert", "heinrich", "ptm", "hsh3", "mean"}) {
    auto fit = MakeMethod(name)->Fit(s, {});
    ASSERT_TRUE(fit.ok()) << name;
    EXPECT_EQ(fit->status[3 * 8 + 3], kTexelNonFinite) << name;
    EXPECT_EQ(fit->flagged_texels, 1) << name;
  }
  // lambert-robust drops the lost sample and fits the texel from the others.
  const auto data = Plastic(8);
  auto robust = MakeMethod("lambert-robust")->Fit(s, {});
  ASSERT_TRUE(robust.ok());
  EXPECT_EQ(robust->status[3 * 8 + 3], kTexelOk);
  auto clean = MakeMethod("lambert-robust")->Fit(data.stack, {});
  ASSERT_TRUE(clean.ok());
  const Vec3 a(robust->maps.normal.Plane(0)[27], robust->maps.normal.Plane(1)[27],
               robust->maps.normal.Plane(2)[27]);
  const Vec3 b(clean->maps.normal.Plane(0)[27], clean->maps.normal.Plane(1)[27],
               clean->maps.normal.Plane(2)[27]);
  EXPECT_LT(AngleBetweenDeg(a, b), 1.0);
  // So do the nonlinear fits (they start from lambert-robust).
  for (const char* name : {"blinn-phong", "cook-torrance", "lafortune1"}) {
    auto nl = MakeMethod(name)->Fit(s, {});
    auto nl_clean = MakeMethod(name)->Fit(data.stack, {});
    ASSERT_TRUE(nl.ok() && nl_clean.ok()) << name;
    EXPECT_EQ(nl->status[27], kTexelOk) << name;
    const Vec3 c(nl->maps.normal.Plane(0)[27], nl->maps.normal.Plane(1)[27],
                 nl->maps.normal.Plane(2)[27]);
    const Vec3 d(nl_clean->maps.normal.Plane(0)[27], nl_clean->maps.normal.Plane(1)[27],
                 nl_clean->maps.normal.Plane(2)[27]);
    EXPECT_LT(AngleBetweenDeg(c, d), 1.0) << name;
    EXPECT_TRUE(std::isfinite(nl->maps.specular.Plane(0)[27])) << name;
  }
  // A texel left with fewer than 3 finite samples is flagged.
  LightStack holes = data.stack;
  for (int i = 0; i < holes.num_images() - 2; ++i)
    holes.Plane(i, 1)[3 * holes.width() + 3] = std::nanf("");
  auto sparse = MakeMethod("lambert-robust")->Fit(holes, {});
  ASSERT_TRUE(sparse.ok());
  EXPECT_EQ(sparse->status[27], kTexelNonFinite);
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
