#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <random>
#include <vector>

#include "fit/fit_common.h"
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

// SelectKthFinite (the vector-compression path where the CPU has AVX-512) returns
// std::nth_element's value for every rank: lengths around its 8-lane blocks and its scalar
// finish (≤ 16), ties (one value, a few, many, ±0), sorted and reversed inputs (the pivot is
// then often a part's minimum), ±inf; nothing written past the array or the scratch.
TEST(SelectKth, FiniteSelectionMatchesNthElementForEveryRank) {
  std::mt19937 rng(13);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = trial < 60 ? 1 + trial : 1 + int(rng() % 400);
    const int levels = trial % 4 == 0 ? 1 : trial % 4 == 1 ? 5 : trial % 4 == 2 ? 256 : 1 << 30;
    std::vector<double> a(static_cast<size_t>(n));
    for (double& v : a) v = double(rng() % uint32_t(levels)) - levels / 3;
    if (trial % 9 == 3) a[0] = -0.0, a[size_t(n / 2)] = 0.0;
    if (trial % 9 == 4) a[0] = INFINITY, a[size_t(n - 1)] = -INFINITY;
    if (trial % 7 == 0) std::sort(a.begin(), a.end());
    if (trial % 7 == 1) std::sort(a.rbegin(), a.rend());
    // Canaries after the array and the scratch: nothing is written past either.
    constexpr double kCanary = 12345.678;
    const size_t scratch_size = size_t(SelectScratchSize(n));
    std::vector<double> scratch(scratch_size + 16, kCanary);
    for (int k = 0; k < n; k += 1 + n / 60) {
      std::vector<double> ref = a, got = a;
      got.resize(size_t(n) + 16, kCanary);
      std::nth_element(ref.begin(), ref.begin() + k, ref.end());
      ASSERT_EQ(SelectKthFinite(got.data(), n, k, scratch.data()), ref[size_t(k)])
          << "n " << n << " k " << k;
      for (size_t j = size_t(n); j < got.size(); ++j) ASSERT_EQ(got[j], kCanary) << "n " << n;
      for (size_t j = scratch_size; j < scratch.size(); ++j)
        ASSERT_EQ(scratch[j], kCanary) << "n " << n;
    }
  }
}

// Short arrays of few distinct values, every rank: parts that shrink by a few values per pass,
// where a full-width store at the end of a part reaches past it (a store into the caller's
// array would overwrite what follows it; the canaries would show it).
TEST(SelectKth, FiniteSelectionWritesNothingPastItsBuffers) {
  constexpr double kCanary = -777.5;
  {
    // 43 values: the first pivot (median of a[0] = 0, a[21], a[42] = 0.5) leaves 41 above it;
    // in those, the second pivot (median of 100, 101, 102) has 39 below it, so the part's last
    // store starts at 39 and would run 4 doubles past a 43-double buffer.
    const int n = 43;
    std::vector<double> a(size_t(n) + 16, kCanary),
        scratch(size_t(SelectScratchSize(n)) + 16, kCanary);
    for (int j = 0; j < n; ++j) a[size_t(j)] = 1 + j;
    a[0] = 0, a[42] = 0.5, a[1] = 100, a[21] = 101, a[41] = 102;
    std::vector<double> ref(a.begin(), a.begin() + n);
    std::nth_element(ref.begin(), ref.begin() + 5, ref.end());
    ASSERT_EQ(SelectKthFinite(a.data(), n, 5, scratch.data()), ref[5]);
    for (size_t j = size_t(n); j < a.size(); ++j) ASSERT_EQ(a[j], kCanary) << j;
  }
  std::mt19937 rng(17);
  for (int trial = 0; trial < 20000; ++trial) {
    const int n = 17 + int(rng() % 48), levels = 2 + int(rng() % 4);
    std::vector<double> a(size_t(n) + 16, kCanary),
        scratch(size_t(SelectScratchSize(n)) + 16, kCanary);
    for (int j = 0; j < n; ++j) a[size_t(j)] = double(rng() % uint32_t(levels));
    const int k = int(rng() % uint32_t(n));
    std::vector<double> ref(a.begin(), a.begin() + n);
    std::nth_element(ref.begin(), ref.begin() + k, ref.end());
    ASSERT_EQ(SelectKthFinite(a.data(), n, k, scratch.data()), ref[size_t(k)]);
    for (size_t j = size_t(n); j < a.size(); ++j) ASSERT_EQ(a[j], kCanary) << "n " << n;
    for (size_t j = size_t(SelectScratchSize(n)); j < scratch.size(); ++j)
      ASSERT_EQ(scratch[j], kCanary) << "n " << n;
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

// SelectTwo returns what two std::nth_element calls return, for pairs of ranks on arrays with
// ties (one value, a few, many) and sorted inputs.
TEST(SelectKth, SelectTwoMatchesTwoSelections) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 120; ++trial) {
    const int n = 2 + int(rng() % 300);
    const int levels = trial % 3 == 0 ? 1 : trial % 3 == 1 ? 6 : 1 << 30;
    std::vector<double> a(static_cast<size_t>(n));
    for (double& v : a) v = double(rng() % uint32_t(levels));
    if (trial % 5 == 0) std::sort(a.begin(), a.end());
    std::vector<double> sorted = a;
    std::sort(sorted.begin(), sorted.end());
    for (int rep = 0; rep < 20; ++rep) {
      int k1 = int(rng() % uint32_t(n)), k2 = int(rng() % uint32_t(n));
      if (k1 == k2) continue;
      if (k1 > k2) std::swap(k1, k2);
      std::vector<double> got = a;
      double v1 = -1, v2 = -1;
      SelectTwo(got.data(), n, k1, k2, std::less<double>(), &v1, &v2);
      ASSERT_EQ(v1, sorted[size_t(k1)]) << "n " << n << " k1 " << k1;
      ASSERT_EQ(v2, sorted[size_t(k2)]) << "n " << n << " k2 " << k2;
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, sorted);  // a permutation of the input
    }
  }
}

// lambert-robust written the plain way, straight from its definition (METHODS.md §3, the file
// comment of fit/lambert_robust_fit.cc): ranks by sorting (y, i), medians by std::nth_element,
// the eigen-decomposition of every subset. The optimised fit must give the same maps exactly.
struct PlainRobust {
  std::vector<float> normal, albedo;  // [c][p]
  std::vector<uint8_t> status;
};
PlainRobust PlainLambertRobust(const LightStack& s) {
  const int n = s.num_images(), C = s.channels();
  const int64_t P = s.texels();
  const std::vector<float> inv = InverseIntensities(s);
  const bool may_clip = StackMayBeClipped(s);
  PlainRobust out{std::vector<float>(3 * P, 0.f), std::vector<float>(3 * P, 0.f),
                  std::vector<uint8_t>(P, kTexelOk)};
  auto solve = [&](const std::vector<double>& y, const std::vector<char>& keep, Vec3* g,
                   double* cond) {
    Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    int count = 0;
    for (int i = 0; i < n; ++i) {
      if (!keep[i]) continue;
      const Vec3 l = s.lights()[i].direction;
      const Eigen::Vector3d e(l.x, l.y, l.z);
      m += e * e.transpose(), b += e * y[i], ++count;
    }
    if (count < 3) return false;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(m, Eigen::EigenvaluesOnly);
    const auto ev = eig.eigenvalues();
    *cond = ev[2] > 0 ? ev[0] / ev[2] : 0;
    if (!(ev[0] > 1e-12)) return false;
    const Eigen::Vector3d x = m.ldlt().solve(b);
    *g = {x.x(), x.y(), x.z()};
    return true;
  };
  for (int64_t p = 0; p < P; ++p) {
    // No sample above the no-signal level (NaN samples aside): flagged, not fitted.
    float peak = 0;
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < C; ++c)
        if (s.Sample(i, c, p) > peak) peak = s.Sample(i, c, p);
    if (!(peak > kNoSignalLevel)) {
      out.status[p] = kTexelNoSignal;
      continue;
    }
    std::vector<double> y(n);
    std::vector<char> bad(n, 0);
    int finite = 0;
    for (int i = 0; i < n; ++i) {
      double sum = 0;
      for (int c = 0; c < C; ++c) {
        const float v = s.Sample(i, c, p);
        bad[i] |= may_clip && v >= kClipLevel;
        sum += (C == 1 ? 1.0f : kLuma[c]) * inv[i * C + c] * v;
      }
      y[i] = std::isfinite(sum) ? sum : 0.0;
      bad[i] |= !std::isfinite(sum);
      finite += std::isfinite(sum) ? 1 : 0;
    }
    if (finite < 3) {
      out.status[p] = kTexelNonFinite;
      continue;
    }
    std::vector<std::pair<double, int>> ranked(n);
    for (int i = 0; i < n; ++i) ranked[i] = {y[i], i};
    std::sort(ranked.begin(), ranked.end());
    int lo = int(std::floor(0.2 * n)), hi = int(std::ceil(0.9 * n));
    if (hi - lo < 3) lo = std::max(0, std::min(lo, n - 3)), hi = std::min(n, lo + 3);
    std::vector<char> keep(n, 0);
    for (int r = lo; r < hi; ++r) keep[ranked[r].second] = !bad[ranked[r].second];
    Vec3 g;
    double cond = 0;
    bool solved = solve(y, keep, &g, &cond);
    for (int round = 0; solved && round < 4; ++round) {
      const Vec3 nn = Normalize(g);
      std::vector<double> absr;
      for (int i = 0; i < n; ++i)
        if (keep[i])
          absr.push_back(std::abs(y[i] - std::max(0.0, Dot(g, s.lights()[i].direction))));
      std::nth_element(absr.begin(), absr.begin() + absr.size() / 2, absr.end());
      const double sigma = 1.4826 * absr[absr.size() / 2] + 1e-3 * Length(g) + 1e-6;
      std::vector<char> next(n);
      for (int i = 0; i < n; ++i) {
        const Vec3 l = s.lights()[i].direction;
        next[i] =
            !bad[i] && Dot(nn, l) > 0.05 && std::abs(y[i] - std::max(0.0, Dot(g, l))) <= 3 * sigma;
      }
      if (next == keep) break;
      Vec3 g2;
      double c2 = 0;
      if (!solve(y, next, &g2, &c2)) break;
      keep = next, g = g2, cond = c2;
    }
    const int inliers = int(std::count(keep.begin(), keep.end(), 1));
    if (!solved || inliers < 3) {
      out.status[p] = kTexelTooFewLights;
    } else if (cond < 1e-3) {
      out.status[p] = kTexelIllConditioned;
    } else if (!(Length(g) > 1e-6)) {
      out.status[p] = kTexelNoSignal;
    } else {
      const Vec3 nn = g / Length(g);
      double num[3] = {0, 0, 0}, den = 0;
      for (int i = 0; i < n; ++i) {
        if (!keep[i]) continue;
        const double si = std::max(0.0, Dot(nn, s.lights()[i].direction));
        den += si * si;
        for (int c = 0; c < C; ++c) num[c] += s.Sample(i, c, p) * inv[i * C + c] * si;
      }
      for (int c = 0; c < 3; ++c) {
        out.normal[c * P + p] = float(nn[c]);
        out.albedo[c * P + p] = float(den > 0 ? num[C == 1 ? 0 : c] / den : 0);
      }
    }
  }
  return out;
}

// Shadows, noise, highlights clipped at 1 (the stack says it is clipped), NaN samples, texels
// without signal (black, at the row ends too; four of them one whole block of lanes; a NaN texel
// with two zeros; one whose samples are all negative, which a fit alone would not flag), and a
// 12-light set where the robust fit runs out of inliers: every texel the same as the plain
// form. 42 texels a row: the last block of each row is partial; the default work units and
// one row per unit.
TEST(LambertRobust, EqualsItsPlainDefinitionExactly) {
  for (const char* lights : {"bonn81", "ring:12:35"}) {
    auto data = Glossy(lights, 42, 0.01);
    LightStack& s = data.stack;
    std::mt19937 rng(3);
    const int W = s.width();
    const int64_t nan_texel = 20 * W + 3, negative = 30 * W + 9;
    const std::vector<int64_t> black = {0,          5 * W + 7,     5 * W + 8,
                                        6 * W + 7,  9 * W + W - 1, 12 * W + 4,
                                        12 * W + 5, 12 * W + 6,    12 * W + 7};
    for (int i = 0; i < s.num_images(); ++i)
      for (int c = 0; c < s.channels(); ++c) {
        for (float& v : s.Plane(i, c)) {
          v = std::min(v * 1.6f, 1.0f);  // bright enough to clip the highlights
          if (rng() % 500 == 0) v = std::nanf("");
        }
        for (int64_t p : black) s.Plane(i, c)[p] = 0.0f;
        s.Plane(i, c)[nan_texel] = i < 2 ? 0.0f : std::nanf("");
        s.Plane(i, c)[negative] = -0.3f;
      }
    s.saturated_pixels.assign(size_t(s.num_images()), 1);
    const PlainRobust ref = PlainLambertRobust(s);
    for (int tile : {64, 8}) {
      FitOptions o;
      o.tile = tile;
      auto fit = FitLambertRobust(s, o);
      ASSERT_TRUE(fit.ok());
      const int64_t P = s.texels();
      int64_t ok = 0;
      for (int64_t p = 0; p < P; ++p) {
        ASSERT_EQ(int(fit->status[p]), int(ref.status[p])) << lights << " texel " << p;
        ok += fit->status[p] == kTexelOk;
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(fit->maps.normal.Plane(c)[p], ref.normal[c * P + p]) << lights << " " << p;
          ASSERT_EQ(fit->maps.albedo.Plane(c)[p], ref.albedo[c * P + p]) << lights << " " << p;
        }
      }
      EXPECT_GT(ok, P / 2) << lights;  // the comparison covers fitted texels, not only flags
      for (int64_t p : black) EXPECT_EQ(int(fit->status[p]), int(kTexelNoSignal)) << lights << p;
      EXPECT_EQ(int(fit->status[nan_texel]), int(kTexelNoSignal)) << lights;
      EXPECT_EQ(int(fit->status[negative]), int(kTexelNoSignal)) << lights;
    }
  }
}

}  // namespace
}  // namespace matfit::fit
