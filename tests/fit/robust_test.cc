#include <gtest/gtest.h>
#include <cstdio>

#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

synth::SynthResult Glossy(const std::string& lights, int size, double noise = 0) {
  return SynthData({"plastic", lights, size, noise, /*shadows=*/true});
}

TEST(LambertRobust, GlossyPlasticWithShadowsBeatsPlainLambert) {
  const auto data = Glossy("bonn81", 64);
  auto plain = FitLambert(data.stack, {}), robust = FitLambertRobust(data.stack, {});
  ASSERT_TRUE(plain.ok() && robust.ok());
  const TruthMetrics tp = CompareToTruth(plain->maps, data.truth, plain->status);
  const TruthMetrics tr = CompareToTruth(robust->maps, data.truth, robust->status);
  std::printf("plastic+shadows bonn81: lambert MAE %.3f°, robust MAE %.3f° (%lld flagged)\n",
              tp.normal_mae_deg, tr.normal_mae_deg, (long long)robust->flagged_texels);
  EXPECT_LT(tr.normal_mae_deg, 2.0);
  EXPECT_LE(tr.normal_mae_deg, 0.5 * tp.normal_mae_deg);
  EXPECT_LT(double(robust->flagged_texels), 0.01 * 64 * 64);
}

TEST(LambertRobust, NoisyDomeStaysAccurate) {
  const auto data = Glossy("dome:40", 48, 0.01);
  auto robust = FitLambertRobust(data.stack, {});
  ASSERT_TRUE(robust.ok());
  EXPECT_LT(CompareToTruth(robust->maps, data.truth, robust->status).normal_mae_deg, 2.0);
}

TEST(LambertRobust, TooFewLightsAreFlaggedNotGuessed) {
  // Four lights: after rejecting the highlight and shadow samples fewer than 3 may remain.
  auto data = Glossy("ring:4:40", 16);
  auto fit = FitLambertRobust(data.stack, {});
  ASSERT_TRUE(fit.ok());
  for (size_t p = 0; p < fit->status.size(); ++p) {
    const uint8_t st = fit->status[p];
    EXPECT_TRUE(st == kTexelOk || st == kTexelTooFewLights || st == kTexelIllConditioned);
    if (st != kTexelOk) {
      EXPECT_EQ(fit->maps.normal.data()[2 * fit->status.size() + p], 0.0f);
    }
  }
  LightStack two(8, 8, 3, 2);
  EXPECT_FALSE(FitLambertRobust(two, {}).ok());
}

}  // namespace
}  // namespace matfit::fit
