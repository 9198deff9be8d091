// The fast one-pass linear fits against their literal per-texel references, and the row
// kernels against plain loops. CTest also runs this file with MATFIT_KERNELS=generic, so both
// kernel builds are held to the same bounds.
#include <gtest/gtest.h>

#include <cstdlib>

#include <cmath>
#include <limits>
#include <vector>

#include "core/synth/random.h"
#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

TEST(Reference, FastLambertAgreesWithThePerTexelGaussJordanSolve) {
  for (const char* material : {"plaster", "wool", "granite"}) {
    const LightStack s = SynthData({material, "bonn81", 32}).stack;
    auto fast = FitLambert(s, {}), ref = FitLambertReference(s, {});
    ASSERT_TRUE(fast.ok() && ref.ok());
    EXPECT_LT(MaxAbsDiff(fast->maps.normal, ref->maps.normal), 2e-6) << material;
    EXPECT_LT(MaxAbsDiff(fast->maps.albedo, ref->maps.albedo), 2e-6) << material;
    EXPECT_EQ(fast->status, ref->status) << material;
  }
}

TEST(Reference, FastPtmAndHshAgreeWithThePerTexelGaussJordanSolve) {
  const LightStack s = SynthData({"wool", "bonn81", 32}).stack;
  auto ptm = FitPtm(s, {}), ptm_ref = FitPtmReference(s, {});
  ASSERT_TRUE(ptm.ok() && ptm_ref.ok());
  EXPECT_LT(MaxAbsDiff(ptm->maps.coefficients, ptm_ref->maps.coefficients), 1e-5);
  EXPECT_LT(MaxAbsDiff(ptm->maps.albedo, ptm_ref->maps.albedo), 1e-5);
  for (int order : {2, 3}) {
    auto hsh = FitHsh(s, {}, order), hsh_ref = FitHshReference(s, {}, order);
    ASSERT_TRUE(hsh.ok() && hsh_ref.ok());
    EXPECT_LT(MaxAbsDiff(hsh->maps.coefficients, hsh_ref->maps.coefficients), 1e-5) << order;
  }
}

// The seed's literal per-texel forms flag a texel with a NaN sample; the fast forms refit it from
// its other lights (fit/valid_refit.h), which must give what the reference gives for that texel
// when the light is absent from the stack altogether. Every other texel's status agrees.
TEST(Reference, FastFormsRefitANanTexelAsIfItsLightWereAbsent) {
  LightStack s = SynthData({"plaster", "bonn81", 16}).stack;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < s.channels(); ++c) {
      s.Plane(i, c)[5] = 0.0f;             // black everywhere: no signal
      if (i == 7) s.Plane(i, c)[9] = nan;  // one NaN sample
    }
  std::vector<int> others;
  for (int i = 0; i < s.num_images(); ++i)
    if (i != 7) others.push_back(i);
  const LightStack without = SelectImages(s, others);
  auto same_except_9 = [](const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
    for (size_t p = 0; p < a.size(); ++p)
      if (p != 9 && a[p] != b[p]) return false;
    return true;
  };
  auto fast = FitLambert(s, {}), ref = FitLambertReference(s, {});
  auto ref_without = FitLambertReference(without, {});
  ASSERT_TRUE(fast.ok() && ref.ok() && ref_without.ok());
  EXPECT_EQ(fast->status[5], kTexelNoSignal);
  EXPECT_EQ(ref->status[9], kTexelNonFinite);
  EXPECT_EQ(fast->status[9], kTexelOk);
  EXPECT_TRUE(same_except_9(fast->status, ref->status));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(fast->maps.normal.Plane(c)[9], ref_without->maps.normal.Plane(c)[9], 1e-6);
    EXPECT_NEAR(fast->maps.albedo.Plane(c)[9], ref_without->maps.albedo.Plane(c)[9], 1e-6);
  }
  auto ptm = FitPtm(s, {}), ptm_ref = FitPtmReference(s, {});
  auto ptm_without = FitPtmReference(without, {});
  ASSERT_TRUE(ptm.ok() && ptm_ref.ok() && ptm_without.ok());
  EXPECT_EQ(ptm->status[9], kTexelOk);
  EXPECT_TRUE(same_except_9(ptm->status, ptm_ref->status));
  for (int q = 0; q < ptm->maps.coefficients.channels(); ++q)
    EXPECT_NEAR(ptm->maps.coefficients.Plane(q)[9], ptm_without->maps.coefficients.Plane(q)[9],
                1e-5);
  FitOptions diffuse;
  diffuse.heinrich_specular = false;
  auto hr = FitHeinrich(s, diffuse), hr_ref = FitHeinrichReference(s, diffuse);
  auto hr_without = FitHeinrichReference(without, diffuse);
  ASSERT_TRUE(hr.ok() && hr_ref.ok() && hr_without.ok());
  EXPECT_EQ(hr->status[9], kTexelOk);
  EXPECT_TRUE(same_except_9(hr->status, hr_ref->status));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(hr->maps.normal.Plane(c)[9], hr_without->maps.normal.Plane(c)[9], 1e-6);
    EXPECT_NEAR(hr->maps.albedo.Plane(c)[9], hr_without->maps.albedo.Plane(c)[9], 1e-6);
    EXPECT_NEAR(hr->maps.ambient.Plane(c)[9], hr_without->maps.ambient.Plane(c)[9], 1e-6);
  }
  EXPECT_NEAR(hr->maps.normal_scale.Plane(0)[9], hr_without->maps.normal_scale.Plane(0)[9], 1e-6);
}

// RowAccumulate against scalar loops, on lengths with a ragged tail,
// every term count, partial plane groups and NaN samples (which must not raise peak).
TEST(RowKernels, MatchPlainLoopsIncludingTailsAndNaN) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int64_t m : {1, 7, 8, 15, 16, 17, 37, 256}) {  // tails of the 8- and 16-lane builds
    for (int planes : {1, 3, kMaxRowPlanes}) {
      std::vector<std::vector<float>> data(planes, std::vector<float>(m));
      std::vector<const float*> src(planes);
      for (int p = 0; p < planes; ++p) {
        for (int64_t x = 0; x < m; ++x) data[p][x] = float(synth::HashUniform(3, p, x));
        if (m > 5) data[p][5] = nan;
        src[p] = data[p].data();
      }
      for (int k : {1, 2, 3, 4, 6, 9, 16}) {  // 2 and 16: the run-time-k kernel
        std::vector<float> w(size_t(planes) * k);
        for (size_t q = 0; q < w.size(); ++q) w[q] = float(synth::HashUniform(4, k, q) - 0.5);
        std::vector<std::vector<float>> acc(k, std::vector<float>(m, 0.5f)), want = acc;
        std::vector<float*> ap(k);
        for (int j = 0; j < k; ++j) ap[j] = acc[j].data();
        std::vector<float> peak(m, 0.25f), want_peak(m, 0.25f);
        // Three calls: three groups of planes summed into the same accumulators.
        for (int call = 0; call < 3; ++call)
          RowAccumulate(src.data(), planes, m, k, w.data(), ap.data(), peak.data());
        for (int call = 0; call < 3; ++call)
          for (int64_t x = 0; x < m; ++x)
            for (int p = 0; p < planes; ++p) {
              for (int j = 0; j < k; ++j) want[j][x] += w[p * k + j] * data[p][x];
              if (data[p][x] > want_peak[x]) want_peak[x] = data[p][x];
            }
        for (int64_t x = 0; x < m; ++x) {
          ASSERT_EQ(peak[x], want_peak[x]) << m << " " << planes << " " << k << " x=" << x;
          for (int j = 0; j < k; ++j) {
            if (x == 5) {
              EXPECT_TRUE(std::isnan(acc[j][x]));  // NaN reaches the sums, so fitters see it
              continue;
            }
            EXPECT_NEAR(acc[j][x], want[j][x], 1e-5) << m << " " << planes << " " << k;
          }
        }
      }
    }
  }
  const std::string isa = RowKernelIsa();
  const char* force = std::getenv("MATFIT_KERNELS");
  if (force && std::string(force) == "generic")
    EXPECT_EQ(isa, "generic");
  else if (force && std::string(force) == "avx2")
    EXPECT_TRUE(isa == "avx2+fma" || isa == "generic") << isa;
  else
    EXPECT_TRUE(isa == "avx512f" || isa == "avx2+fma" || isa == "generic") << isa;
}

}  // namespace
}  // namespace matfit::fit
