// Every model of the ladder on the real psm sets (skipped when ../shared/data is absent).
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "core/dataset/dataset.h"
#include "fit/assess.h"
#include "fit/confidence.h"
#include "fit/fit_types.h"
#include "fit/holdout.h"
#include "fit/method.h"

namespace matfit::fit {
namespace {

std::string SharedDir() {
  if (const char* env = std::getenv("MATFIT_SHARED_DATA")) return env;
  return MATFIT_SHARED_DATA;
}

class RealLadder : public ::testing::TestWithParam<const char*> {};

TEST_P(RealLadder, EveryModelFitsWithFewFlaggedTexels) {
  const std::string dir = SharedDir() + "/psm/" + GetParam();
  if (!std::filesystem::exists(dir))
    GTEST_SKIP() << "shared data 'psm/" << GetParam() << "' not found; skipping";
  auto s = ReadDataset(dir);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  auto robust = MakeMethod("lambert-robust")->Fit(*s, {});
  ASSERT_TRUE(robust.ok());
  for (const std::string& name : MethodNames()) {
    auto fit = MakeMethod(name)->Fit(*s, {});
    ASSERT_TRUE(fit.ok()) << name << ": " << fit.status().ToString();
    EXPECT_LT(double(fit->flagged_texels), 0.05 * s->MaskedTexels()) << name;
    // Issue 19: clipped or non-finite samples are dropped, never a reason for a hole, and no
    // model leaves a hole where lambert-robust fits the texel.
    int64_t holes = 0;
    for (size_t p = 0; p < fit->status.size(); ++p) {
      EXPECT_NE(fit->status[p], kTexelSaturated) << name << " texel " << p;
      holes += fit->status[p] != kTexelOk && fit->status[p] != kTexelMasked &&
               robust->status[p] == kTexelOk;
    }
    EXPECT_EQ(holes, 0) << name;
  }
}

INSTANTIATE_TEST_SUITE_P(Objects, RealLadder, ::testing::Values("gray", "cat"));

// The glossy cat has highlights and cast shadows: rejecting them (lambert-robust) and modelling
// the highlights (blinn-phong, cook-torrance, with their Cauchy loss) must pay off on lights the
// fit has not seen. Measured, 4 folds: lambert 0.0277, robust 0.0264, blinn-phong 0.0270,
// cook-torrance 0.0267 held-out RMSE.
TEST(RealHeldOut, RobustAndNonlinearModelsBeatPlainLambertOnTheCat) {
  const std::string dir = SharedDir() + "/psm/cat";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "shared data 'psm/cat' not found; skipping";
  auto s = ReadDataset(dir);
  ASSERT_TRUE(s.ok());
  auto plain = HeldOut(*MakeMethod("lambert"), *s, 4, {});
  ASSERT_TRUE(plain.ok());
  for (const char* name : {"lambert-robust", "blinn-phong", "cook-torrance"}) {
    auto better = HeldOut(*MakeMethod(name), *s, 4, {});
    ASSERT_TRUE(better.ok()) << name;
    EXPECT_LT(better->rmse, plain->rmse) << name;
    EXPECT_EQ(better->failed_folds, 0) << name;
  }
}

// Issue 19: the per-texel bound (the pack's confidence map) against real held-out lights, leave-
// one-out: no texel's held-out error exceeds it (no silent failure on real data), and the bound
// is a bound, not a loose ceiling of 100×. Measured 2026-12-04, read as sRGB (the 8-bit
// convention): lambert 9.4× (gray) / 7.4× (cat) median, 0 texels exceeded. Read as `matfit fit`
// reads them (--color-space auto: gray re-read as linear, cat unchanged): gray 19.4× (lambert),
// lambert-robust 0.03 % of texels exceeded. The extrapolation allowance (a − 1) μ scales with
// the texel's level, which the linear reading roughly doubles against the same errors. The
// issue's ≤ 4 is not met (docs/stability.md says why).
TEST(RealHeldOut, NoTexelExceedsItsBoundOnLeaveOneOutLights) {
  for (const char* object : {"gray", "cat"})
    for (const bool as_fit : {false, true}) {
      const std::string dir = SharedDir() + "/psm/" + object;
      if (!std::filesystem::exists(dir)) GTEST_SKIP() << "shared data 'psm' not found; skipping";
      auto s = ReadDataset(dir);
      ASSERT_TRUE(s.ok());
      if (as_fit) {
        StackDiagnostics d = DiagnoseStack(*s);
        EXPECT_EQ(ResolveToneCurve(&*s, &d).corrected, std::string(object) == "gray");
      }
      for (const char* name : {"lambert", "lambert-robust", "ptm"}) {
        auto method = MakeMethod(name);
        auto fit = method->Fit(*s, {});
        ASSERT_TRUE(fit.ok()) << name;
        const FitAssessment a = AssessFit(*s, *method, &*fit);
        auto h = HeldOut(*method, *s, kLeaveOneOut, {});
        ASSERT_TRUE(h.ok()) << name;
        const BoundRatio r = BoundToActualRatio(a.confidence.bound, h->texel_rmse, fit->status);
        SCOPED_TRACE(std::string(object) + " " + name + (as_fit ? " (auto reading)" : " (sRGB)"));
        EXPECT_GT(r.texels, s->MaskedTexels() * 9 / 10);
        EXPECT_LE(r.exceeded_fraction, 0.001);
        EXPECT_GT(r.median, 1.5);
        EXPECT_LT(r.median, as_fit ? 25.0 : 15.0);
      }
    }
}

}  // namespace
}  // namespace matfit::fit
