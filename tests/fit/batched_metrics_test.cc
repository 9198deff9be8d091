// The batched reconstruction, relighting error and shading cost against the literal per-sample
// definitions (EvaluateTexel over texels × lights × channels), on 1- and 3-channel stacks with
// flagged texels, for a linear, a basis and a lobe model.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <algorithm>
#include "core/parallel.h"
#include "core/shading/evaluate.h"
#include "core/stack_ops.h"
#include "core/synth/light_sets.h"
#include "fit/confidence.h"
#include "fit/fit_common.h"
#include "fit/metrics.h"
#include "fit/score.h"
#include "tests/core/model_maps.h"

namespace matfit::fit {
namespace {

LightStack NoisyStack(const MaterialMaps& m, int channels, uint32_t seed) {
  auto lights = synth::MakeLightSet("dome:30", 1);
  EXPECT_TRUE(lights.ok());
  LightStack s(m.width, m.height, channels, int(lights->size()));
  s.lights() = *lights;
  for (int i = 0; i < s.num_images(); ++i) s.lights()[size_t(i)].intensity = Vec3(0.9, 1.0, 1.1);
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0, 0.02f);
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < channels; ++c)
      for (int64_t p = 0; p < s.plane_size(); ++p)
        s.Plane(i, c)[p] =
            float(EvaluateTexel(m, p, c, Vec3f(s.lights()[size_t(i)].direction), Vec3f(0, 0, 1))) +
            noise(rng);
  return s;
}

// The definition: Σ over ok texels, lights, channels of (p − I · R)², per light in order.
ReconstructionMetrics LiteralReconstruction(const LightStack& s, const MaterialMaps& maps,
                                            const std::vector<uint8_t>& status) {
  ReconstructionMetrics m;
  std::map<int, std::pair<double, int64_t>> groups;
  double total = 0;
  const int C = s.channels();
  for (int i = 0; i < s.num_images(); ++i) {
    double acc = 0;
    int64_t k = 0;
    for (int64_t p = 0; p < s.plane_size(); ++p) {
      if (!status.empty() && status[size_t(p)] != 0) continue;
      for (int c = 0; c < C; ++c) {
        const double pred = s.lights()[size_t(i)].intensity[C == 1 ? 0 : c] *
                            EvaluateTexel(maps, p, c, Vec3f(s.lights()[size_t(i)].direction),
                                          Vec3f(s.view_direction));
        const double d = s.Plane(i, c)[p] - pred;
        acc += d * d, ++k;
      }
    }
    total += acc, m.samples += k;
    auto& g = groups[int(std::lround(s.lights()[size_t(i)].theta_deg / 15.0)) * 15];
    g.first += acc, g.second += k;
  }
  const double mse = total / double(m.samples);
  m.deviation_percent = 100 * mse, m.rmse = std::sqrt(mse);
  for (auto& [t, g] : groups) m.deviation_percent_by_theta[t] = 100 * g.first / g.second;
  return m;
}

TEST(BatchedMetrics, ReconstructionEqualsTheLiteralSum) {
  for (const char* name : {"lambert", "ptm", "blinn-phong", "heinrich"})
    for (int channels : {1, 3}) {
      // 61 × 37: runs end mid-row and the last run is short.
      const MaterialMaps m =
          testing::RandomModelMaps(ModelId(name), 61, 37, 4, /*grey=*/channels == 1);
      const LightStack s = NoisyStack(m, channels, 9);
      std::vector<uint8_t> status(size_t(s.plane_size()), 0);
      for (size_t p = 0; p < status.size(); p += 7) status[p] = 3;
      for (const auto& st : {status, std::vector<uint8_t>()}) {
        const auto want = LiteralReconstruction(s, m, st);
        for (int threads : {1, 2}) {
          SetNumThreads(threads);
          int64_t calls = 0, last = 0, total = 0;
          const auto got = Reconstruction(s, m, st, [&](int64_t d, int64_t t) {
            ++calls, last = d, total = t;
            return true;
          });
          EXPECT_EQ(got.samples, want.samples);
          EXPECT_NEAR(got.deviation_percent, want.deviation_percent, 1e-5 * want.deviation_percent)
              << name << " channels " << channels;
          ASSERT_EQ(got.deviation_percent_by_theta.size(), want.deviation_percent_by_theta.size());
          for (const auto& [theta, dev] : want.deviation_percent_by_theta)
            EXPECT_NEAR(got.deviation_percent_by_theta.at(theta), dev, 1e-5 * dev);
          EXPECT_GT(calls, 0);
          EXPECT_EQ(last, total);
        }
        SetNumThreads(0);
      }
    }
}

TEST(BatchedMetrics, ReconstructionIsTheSameForAnyThreadCount) {
  const MaterialMaps m = testing::RandomModelMaps(ModelId("hsh"), 130, 70, 3);
  const LightStack s = NoisyStack(m, 3, 2);
  SetNumThreads(1);
  const auto one = Reconstruction(s, m, {});
  SetNumThreads(2);
  const auto two = Reconstruction(s, m, {});
  SetNumThreads(0);
  EXPECT_EQ(one.deviation_percent, two.deviation_percent);  // run-order sums: bit-identical
}

// Scoring images in place equals scoring a copy of them (what held-out folds did before).
TEST(BatchedMetrics, ReconstructionOfAnImageSubsetEqualsThatOfACopy) {
  const MaterialMaps m = testing::RandomModelMaps(ModelId("lambert"), 50, 20, 5);
  const LightStack s = NoisyStack(m, 3, 4);
  const std::vector<int> test = {1, 5, 9, 13, 17, 29};
  std::vector<uint8_t> status(size_t(s.plane_size()), 0);
  status[3] = status[77] = 2;
  const auto want = Reconstruction(SelectImages(s, test), m, status);
  const auto got = Reconstruction(s, test, m, status);
  EXPECT_EQ(got.samples, want.samples);
  EXPECT_EQ(got.deviation_percent, want.deviation_percent);
  EXPECT_EQ(got.deviation_percent_by_theta, want.deviation_percent_by_theta);
}

// Unlimited, and within a recorded range whose limit differs per channel (both sides taken up to
// it: min(v, limit_c)).
TEST(BatchedMetrics, RelightingErrorEqualsTheLiteralRms) {
  const MaterialMaps f = testing::RandomModelMaps(ModelId("cook-torrance"), 40, 30, 1);
  MaterialMaps t = testing::RandomModelMaps(ModelId("blinn-phong"), 40, 30, 2);
  for (int64_t p = 0; p < 40; ++p) t.mask.data()[size_t(p)] = 0;  // first row outside
  const std::vector<Vec3> lights = {Vec3(0, 0, 1), Normalize(Vec3(0.4, 0.3, 0.8)),
                                    Normalize(Vec3(-0.7, 0.1, 0.3))};
  const double inf = std::numeric_limits<double>::infinity();
  for (const Vec3& limit : {Vec3(inf, inf, inf), Vec3(0.2, inf, 0.35)}) {
    const auto err = RelightingError(f, t, lights, Vec3(0, 0, 1), limit);
    int64_t limited = 0;
    for (int64_t p = 0; p < 40 * 30; ++p) {
      if (p < 40) {
        EXPECT_TRUE(std::isnan(err[size_t(p)]));
        continue;
      }
      double acc = 0;
      for (const Vec3& l : lights)
        for (int c = 0; c < 3; ++c) {
          const double a = EvaluateTexel(f, p, c, Vec3f(l), Vec3f(0, 0, 1)),
                       b = EvaluateTexel(t, p, c, Vec3f(l), Vec3f(0, 0, 1));
          const double d = std::min(a, limit[c]) - std::min(b, limit[c]);
          acc += d * d, limited += a > limit[c] || b > limit[c];
        }
      EXPECT_NEAR(err[size_t(p)], std::sqrt(acc / 9), 1e-5);
    }
    if (std::isfinite(limit.x)) {
      EXPECT_GT(limited, 500);  // the limit is met
    }
  }
}

TEST(BatchedMetrics, ShadingCostIsAMeasurement) {
  const MaterialMaps m = testing::RandomModelMaps(ModelId("ptm"), 64, 64, 1);
  const double ns = ShadingCostNs(m);
  EXPECT_TRUE(std::isfinite(ns));
  EXPECT_GT(ns, 0);
}

// The fused pass of `matfit fit` (issue 16) gives bit for bit what Reconstruction() and
// ComputeConfidence's own pass give when each runs alone (one part of ScoreStack each), on float
// and 8-bit stacks, with flagged texels, for any thread count.
TEST(BatchedMetrics, FusedScoreEqualsTheSeparatePasses) {
  for (const char* name : {"lambert", "ptm", "blinn-phong"})
    for (int channels : {1, 3}) {
      const MaterialMaps m =
          testing::RandomModelMaps(ModelId(name), 61, 37, 4, /*grey=*/channels == 1);
      const LightStack noisy = NoisyStack(m, channels, 11);
      std::vector<uint8_t> status(size_t(noisy.plane_size()), 0);
      for (size_t p = 0; p < status.size(); p += 5) status[p] = 3;
      const ModelSize size{4 * channels, 4, 3};
      for (const LightStack& s : {noisy, QuantiseStack(noisy, 8)})
        for (int threads : {1, 2}) {
          SetNumThreads(threads);
          const auto want_rec = Reconstruction(s, m, status);
          std::vector<uint8_t> want_status = status;
          const Confidence want = ComputeConfidence(s, m, size, &want_status);
          const StackScore score = ScoreStack(s, m, status);
          EXPECT_EQ(score.reconstruction.deviation_percent, want_rec.deviation_percent) << name;
          EXPECT_EQ(score.reconstruction.samples, want_rec.samples) << name;
          EXPECT_EQ(score.reconstruction.deviation_percent_by_theta,
                    want_rec.deviation_percent_by_theta)
              << name;
          std::vector<uint8_t> got_status = status;
          const Confidence got =
              ComputeConfidence(s, m, size, &got_status, {}, {}, &score.residuals);
          EXPECT_EQ(got_status, want_status) << name;
          EXPECT_EQ(got.pooled_sigma, want.pooled_sigma) << name;
          ASSERT_EQ(got.bound.size(), want.bound.size());
          for (size_t p = 0; p < got.bound.size(); ++p)
            ASSERT_TRUE(got.bound[p] == want.bound[p] ||
                        (std::isinf(got.bound[p]) && std::isinf(want.bound[p])))
                << name << " texel " << p;
          // Something was bounded and something flagged: the comparison is not vacuous.
          EXPECT_GT(std::count_if(got.bound.begin(), got.bound.end(),
                                  [](float b) { return std::isfinite(b) && b > 0; }),
                    int64_t(status.size() / 2))
              << name;
        }
      SetNumThreads(0);
    }
}

// ScoreParts::common: the common texel set's figures from the same pass equal a pass with
// CommonTexelStatus (bit for bit, 8-bit sRGB codes included), and the ok set's figures and the
// residual sums are those of a pass without it; flagged texels, masked ones and a run whose
// texels are all flagged (ok set empty there, common set not), float and 8-bit, 1 and 2 threads.
TEST(BatchedMetrics, CommonSetFromTheSamePassEqualsItsOwnPass) {
  for (const char* name : {"lambert", "ptm"})
    for (int channels : {1, 3}) {
      const MaterialMaps m =
          testing::RandomModelMaps(ModelId(name), 97, 41, 6, /*grey=*/channels == 1);
      const LightStack noisy = NoisyStack(m, channels, 5);
      std::vector<uint8_t> status(size_t(noisy.plane_size()), kTexelOk);
      for (size_t p = 0; p < status.size(); p += 5) status[p] = 3;
      for (size_t p = 1; p < status.size(); p += 11) status[p] = kTexelMasked;
      for (size_t p = 1024; p < 2048; ++p) status[p] = p % 3 ? 2 : kTexelMasked;  // run 2: no ok
      const std::vector<uint8_t> common = CommonTexelStatus(status);
      const std::vector<int> images = {0, 3, 4, 9, 17, 28};
      for (const LightStack& s : {noisy, QuantiseStack(noisy, 8)})
        for (int threads : {1, 2}) {
          SetNumThreads(threads);
          const std::string what = std::string(name) + " " + std::to_string(channels) + " ch " +
                                   std::to_string(threads) + " threads" +
                                   (s.is_float() ? " float" : " 8-bit");
          const ScoreParts parts{.reconstruction = true, .residuals = true, .srgb8 = true};
          ScoreParts fused = parts;
          fused.common = true;
          const StackScore got = ScoreStack(s, images, m, status, {}, fused);
          const StackScore ok = ScoreStack(s, images, m, status, {}, parts);
          const StackScore all = ScoreStack(s, images, m, common, {}, parts);
          for (const auto& [a, b] : {std::pair(&got.reconstruction, &ok.reconstruction),
                                     std::pair(&got.reconstruction_common, &all.reconstruction)}) {
            EXPECT_EQ(a->samples, b->samples) << what;
            EXPECT_EQ(a->deviation_percent, b->deviation_percent) << what;
            EXPECT_EQ(a->rmse_srgb8, b->rmse_srgb8) << what;
            EXPECT_EQ(a->deviation_percent_by_theta, b->deviation_percent_by_theta) << what;
          }
          EXPECT_GT(got.reconstruction_common.samples, got.reconstruction.samples) << what;
          EXPECT_NE(got.reconstruction_common.deviation_percent,
                    got.reconstruction.deviation_percent)
              << what;
          EXPECT_EQ(got.residuals.rss, ok.residuals.rss) << what;
          EXPECT_EQ(got.residuals.samples, ok.residuals.samples) << what;
        }
      SetNumThreads(0);
    }
}

// The residual sums of the error bound against their definition, sample by sample: q = raw / I,
// r = q − pred over samples that are finite, below the clip level, with a finite q and r, and
// over the clipped ones (finite, at or above the clip level, which counts when the stack may be
// clipped) whose prediction is below q: in the recorded range their error is q − pred, else 0
// and they are left out. The stack holds NaN and ±∞ samples and a light of zero intensity
// (1 / I = ∞: none of its samples count), on 1 and 3 channels; the clipped variant saturates
// samples of a light of unit-ish intensity (predictions below q) and of a bright one (I = 4,
// q = 0.25: predictions mostly above).
TEST(BatchedMetrics, ResidualSumsEqualTheLiteralDefinition) {
  for (bool clipped : {false, true})
    for (int channels : {1, 3}) {
      const std::string what = std::string(clipped ? "clipped, " : "") + std::to_string(channels);
      const MaterialMaps m = testing::RandomModelMaps(ModelId("lambert"), 29, 23, 6, channels == 1);
      LightStack s = NoisyStack(m, channels, 5);
      s.lights()[3].intensity = Vec3(0, 0, 0);
      const float nan = std::numeric_limits<float>::quiet_NaN(),
                  inf = std::numeric_limits<float>::infinity();
      s.Plane(1, 0)[7] = nan, s.Plane(2, 0)[8] = inf, s.Plane(4, channels - 1)[9] = -inf;
      if (clipped) {
        s.lights()[8].intensity = Vec3(4, 4, 4);
        s.saturated_pixels.assign(size_t(s.num_images()), 0);
        for (int i : {6, 8})
          for (int64_t p = 0; p < s.plane_size(); p += 3) {
            for (int c = 0; c < channels; ++c) s.Plane(i, c)[p] = 1.0f;
            ++s.saturated_pixels[size_t(i)];
          }
      }
      ASSERT_EQ(StackMayBeClipped(s), clipped);
      // Alone and fused with the reconstruction (the pass `matfit fit` makes): the same sums.
      const StackScore score =
          ScoreStack(s, m, {}, {}, {.reconstruction = false, .residuals = true});
      const StackScore fused =
          ScoreStack(s, m, {}, {}, {.reconstruction = true, .residuals = true});
      EXPECT_EQ(fused.residuals.rss, score.residuals.rss) << what;
      EXPECT_EQ(fused.residuals.level, score.residuals.level) << what;
      EXPECT_EQ(fused.residuals.samples, score.residuals.samples) << what;
      EXPECT_EQ(fused.residuals.clipped_lights, score.residuals.clipped_lights) << what;
      const std::vector<float> inv = InverseIntensities(s);
      const float clip = StackMayBeClipped(s) ? kClipLevel : inf;
      int64_t counted = 0, under = 0, over = 0;
      for (int64_t p = 0; p < s.plane_size(); ++p) {
        double rss = 0, level = 0;
        int samples = 0, used = 0, saturated = 0;
        for (int i = 0; i < s.num_images(); ++i) {
          bool any = false, sat = false;
          for (int c = 0; c < channels; ++c) {
            const float raw = s.Plane(i, c)[p];
            const double q = double(raw) * double(inv[size_t(i) * channels + c]);
            const double r = q - EvaluateTexel(m, p, c, Vec3f(s.lights()[size_t(i)].direction),
                                               Vec3f(s.view_direction));
            if (!(std::isfinite(raw) && std::isfinite(r))) continue;
            if (raw >= clip) {
              sat = true;
              (r > 0 ? under : over)++;
              if (r <= 0) continue;
            } else {
              any = true;
            }
            rss += r * r, level += std::abs(q), ++samples;
          }
          used += any, saturated += sat;
        }
        EXPECT_EQ(score.residuals.samples[size_t(p)], samples) << what << ", texel " << p;
        EXPECT_EQ(score.residuals.used_lights[size_t(p)], used) << what << ", texel " << p;
        EXPECT_EQ(score.residuals.clipped_lights[size_t(p)], saturated) << what << ", texel " << p;
        EXPECT_NEAR(score.residuals.rss[size_t(p)], rss, 1e-5 * rss + 1e-9)
            << what << ", texel " << p;
        if (samples > 0) {
          EXPECT_NEAR(score.residuals.level[size_t(p)], level / samples, 1e-6)
              << what << ", texel " << p;
        }
        counted += samples;
      }
      if (!clipped) {
        // The zero-intensity light and the three non-finite samples are out, the rest in.
        EXPECT_EQ(counted, s.plane_size() * channels * (s.num_images() - 1) - 3) << what;
      } else {  // both kinds of clipped sample occur
        EXPECT_GT(under, 100) << what;
        EXPECT_GT(over, 100) << what;
        // The recorded range per channel: 1 / I of the weakest light in that channel (light 0's
        // I = 0.9, 1, 1.1 — every light's but light 8's 4 and light 3's 0); a grey stack's one
        // channel for all three.
        const Confidence conf = ComputeConfidence(s, m, {5, 1, 3}, nullptr);
        const auto lim = [&](int c) { return double(inv[size_t(channels == 3 ? c : 0)]); };
        const Vec3 want(lim(0), lim(1), lim(2));
        if (channels == 3) {
          EXPECT_GT(want.x, want.z) << what;
        }
        EXPECT_EQ(conf.recorded_limit, want) << what;
        EXPECT_GT(conf.saturated, 0) << what;
      }
    }
}

}  // namespace
}  // namespace matfit::fit
