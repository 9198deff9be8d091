#include <gtest/gtest.h>
#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

#include "fit/methods.h"
#include "fit/metrics.h"
#include "fit/select_kth.h"
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

// SelectKth (fit/select_kth.h) returns std::nth_element's element for every rank, on random
// arrays with many ties (8-bit-like codes), all-equal arrays and sorted/reversed inputs.
TEST(SelectKth, MatchesNthElementForEveryRank) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const int n = 1 + int(rng() % 300);
    const int levels = trial % 4 == 0 ? 1 : trial % 4 == 1 ? 5 : trial % 4 == 2 ? 256 : 1 << 30;
    std::vector<double> a(static_cast<size_t>(n));
    for (double& v : a) v = double(rng() % uint32_t(levels)) - levels / 3;
    if (trial % 7 == 0) std::sort(a.begin(), a.end());
    if (trial % 7 == 1) std::sort(a.rbegin(), a.rend());
    for (int k = 0; k < n; k += 1 + n / 40) {
      std::vector<double> ref = a, got = a;
      std::nth_element(ref.begin(), ref.begin() + k, ref.end());
      ASSERT_EQ(SelectKth(got.data(), n, k), ref[size_t(k)]) << "n " << n << " k " << k;
      std::sort(got.begin(), got.end());  // a permutation of the input
      std::vector<double> sorted = a;
      std::sort(sorted.begin(), sorted.end());
      ASSERT_EQ(got, sorted);
    }
  }
}

// With a strict weak order on (value, index) pairs: the rank cut-offs of lambert-robust.
TEST(SelectKth, LexicographicKeys) {
  std::mt19937 rng(11);
  struct Key {
    double y;
    int i;
  };
  auto less = [](const Key& a, const Key& b) { return a.y < b.y || (a.y == b.y && a.i < b.i); };
  for (int trial = 0; trial < 50; ++trial) {
    const int n = 3 + int(rng() % 250);
    std::vector<Key> a(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) a[size_t(i)] = {double(rng() % 7), i};
    for (int k = 0; k < n; ++k) {
      std::vector<Key> ref = a, got = a;
      std::nth_element(ref.begin(), ref.begin() + k, ref.end(), less);
      const Key s = SelectKth(got.data(), n, k, less);
      ASSERT_EQ(s.y, ref[size_t(k)].y);
      ASSERT_EQ(s.i, ref[size_t(k)].i);
    }
  }
}

}  // namespace
}  // namespace matfit::fit
