#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <span>
#include <string>
#include <vector>

#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

synth::SynthResult Make(const std::string& material, int size, double noise = 0) {
  return SynthData({material, "bonn81", size, noise});
}

// Median over ok texels of |fitted/true − 1| for one plane.
double MedianRelativeError(const Image& fit, const Image& truth, const std::vector<uint8_t>& status,
                           int c = 0) {
  std::vector<double> e;
  for (size_t p = 0; p < status.size(); ++p)
    if (status[p] == 0) e.push_back(std::abs(fit.Plane(c)[p] / truth.Plane(c)[p] - 1.0));
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return e[e.size() / 2];
}

TEST(BlinnPhong, RecoversBlinnPhongData) {
  const auto data = Make("plastic", 32);
  auto fit = FitBlinnPhong(data.stack, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const TruthMetrics t = CompareToTruth(fit->maps, data.truth, fit->status);
  const double e_err = MedianRelativeError(fit->maps.exponent, data.truth.exponent, fit->status);
  double a_err = 0;
  for (int c = 0; c < 3; ++c)
    a_err =
        std::max(a_err, MedianRelativeError(fit->maps.albedo, data.truth.albedo, fit->status, c));
  std::printf(
      "blinn-phong: normal MAE %.4f°, exponent err %.4f, albedo err %.4f, %.1f LM iterations\n",
      t.normal_mae_deg, e_err, a_err, fit->parameters.at("mean_lm_iterations"));
  EXPECT_LT(t.normal_mae_deg, 0.5);
  EXPECT_LT(e_err, 0.10);
  EXPECT_LT(a_err, 0.02);
  EXPECT_LT(Reconstruction(data.stack, fit->maps, fit->status).rmse, 1e-3);
}

TEST(CookTorrance, RecoversRoughness) {
  const auto data = Make("plastic-ct", 32);
  auto fit = FitCookTorrance(data.stack, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const TruthMetrics t = CompareToTruth(fit->maps, data.truth, fit->status);
  const double r_err = MedianRelativeError(fit->maps.roughness, data.truth.roughness, fit->status);
  std::printf("cook-torrance: normal MAE %.4f°, roughness err %.4f, %.1f LM iterations\n",
              t.normal_mae_deg, r_err, fit->parameters.at("mean_lm_iterations"));
  EXPECT_LT(r_err, 0.10);
  EXPECT_LT(t.normal_mae_deg, 0.5);
}

TEST(BlinnPhong, OnePercentNoise) {
  const auto data = Make("plastic", 32, 0.01);
  auto fit = FitBlinnPhong(data.stack, {});
  ASSERT_TRUE(fit.ok());
  const TruthMetrics t = CompareToTruth(fit->maps, data.truth, fit->status);
  const double e_err = MedianRelativeError(fit->maps.exponent, data.truth.exponent, fit->status);
  std::printf("blinn-phong, 1%% noise: normal MAE %.3f°, exponent err %.3f\n", t.normal_mae_deg,
              e_err);
  EXPECT_LT(t.normal_mae_deg, 0.5);  // measured 0.108°
  EXPECT_LT(e_err, 0.10);            // measured 0.015
}

TEST(BlinnPhong, BeatsLambertOnGlossyData) {
  const auto data = Make("plastic", 24);
  auto bp = FitBlinnPhong(data.stack, {}), lam = FitLambert(data.stack, {});
  ASSERT_TRUE(bp.ok() && lam.ok());
  EXPECT_LT(Reconstruction(data.stack, bp->maps, bp->status).deviation_percent,
            0.1 * Reconstruction(data.stack, lam->maps, lam->status).deviation_percent);
}

// The material-wide exponent from per-texel fits on a grid (FitOptions::lobe_shape_texels):
// 64² texels with a target of 256 give a grid of every 4th texel of every 4th row, 256 texels.
// The shape and the maps agree with the fit whose first stage ran on every texel, and every
// texel is still fitted. A target above a quarter of the texels (grid 1) is the every-texel fit,
// bit for bit.
TEST(BlinnPhong, SharedShapeFromAGridOfTexelsAgreesWithEveryTexel) {
  const auto data = Make("plastic", 64, 0.01);
  FitOptions all, grid, quarter;
  all.lobe_shape_texels = 0, grid.lobe_shape_texels = 256, quarter.lobe_shape_texels = 1025;
  auto a = FitBlinnPhong(data.stack, all), g = FitBlinnPhong(data.stack, grid),
       q = FitBlinnPhong(data.stack, quarter);
  ASSERT_TRUE(a.ok() && g.ok() && q.ok());
  const double ea = a->parameters.at("exponent"), eg = g->parameters.at("exponent");
  const TruthMetrics ta = CompareToTruth(a->maps, data.truth, a->status),
                     tg = CompareToTruth(g->maps, data.truth, g->status);
  const double truth_e = data.truth.exponent.Plane(0)[0];
  std::printf(
      "exponent: every texel %.3f, grid %.3f (truth %.3f); normal MAE %.4f° / %.4f°; "
      "LM iterations per texel %.2f / %.2f\n",
      ea, eg, truth_e, ta.normal_mae_deg, tg.normal_mae_deg, a->parameters.at("mean_lm_iterations"),
      g->parameters.at("mean_lm_iterations"));
  EXPECT_NEAR(eg / ea, 1.0, 0.02);
  EXPECT_NEAR(eg / truth_e, 1.0, 0.05);
  EXPECT_LT(tg.normal_mae_deg, ta.normal_mae_deg * 1.05 + 0.01);
  EXPECT_EQ(tg.texels, ta.texels);
  EXPECT_EQ(g->status, a->status);
  EXPECT_LT(MaxAbsDiff(g->maps.albedo, a->maps.albedo), 0.01);
  EXPECT_EQ(g->parameters.at("lobe_shape_texels"), 256);
  EXPECT_EQ(a->parameters.at("lobe_shape_texels"), 4096);
  EXPECT_LT(g->parameters.at("mean_lm_iterations"), 0.9 * a->parameters.at("mean_lm_iterations"));
  // Grid 1: the same fit.
  EXPECT_EQ(q->parameters, a->parameters);
  EXPECT_EQ(q->parameters.at("exponent"), ea);
  EXPECT_EQ(MaxAbsDiff(q->maps.normal, a->maps.normal), 0.0);
  EXPECT_EQ(MaxAbsDiff(q->maps.albedo, a->maps.albedo), 0.0);
  EXPECT_EQ(MaxAbsDiff(q->maps.specular, a->maps.specular), 0.0);
}

// A given shape needs no first stage: every texel is fitted from lambert-robust's start with it.
TEST(BlinnPhong, GivenShapeFitsFromTheLinearStart) {
  const auto data = Make("plastic", 32, 0.01);
  FitOptions o;
  o.lobe_shape = {std::log(double(data.truth.exponent.Plane(0)[0]))};
  auto fit = FitBlinnPhong(data.stack, o);
  ASSERT_TRUE(fit.ok());
  const TruthMetrics t = CompareToTruth(fit->maps, data.truth, fit->status);
  EXPECT_EQ(fit->flagged_texels, 0);
  EXPECT_LT(t.normal_mae_deg, 0.5);
  EXPECT_NEAR(fit->parameters.at("exponent") / data.truth.exponent.Plane(0)[0], 1.0, 1e-6);
  EXPECT_EQ(fit->parameters.count("lobe_shape_texels"), 0u);  // no stage 1
}

// No texel of the grid shows a lobe (here: every grid texel is black, so lambert-robust flags it
// and none is left to estimate the shape from): the per-texel fit is kept, with a warning — and
// then every other texel needs one too, so stage 1 runs on the texels off the grid.
TEST(BlinnPhong, NoLobeOnTheGridFitsTheTexelsOffItPerTexel) {
  auto data = Make("plastic", 64);
  const int W = data.stack.width();
  auto on_grid = [&](int64_t p) { return p % W % 4 == 2 && p / W % 4 == 2; };
  for (int i = 0; i < data.stack.num_images(); ++i)
    for (int c = 0; c < data.stack.channels(); ++c) {
      std::span<float> plane = data.stack.Plane(i, c);
      for (int64_t p = 0; p < data.stack.plane_size(); ++p)
        if (on_grid(p)) plane[size_t(p)] = 0;
    }
  FitOptions o;
  o.lobe_shape_texels = 200;  // 3840 fittable texels: every 4th texel of every 4th row
  auto fit = FitBlinnPhong(data.stack, o);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  bool warned = false;
  for (const auto& w : fit->warnings)
    warned = warned || w.find("no texel shows") != std::string::npos;
  EXPECT_TRUE(warned);
  int64_t off_grid = 0;
  for (int64_t p = 0; p < data.stack.plane_size(); ++p) {
    if (on_grid(p)) {
      EXPECT_NE(fit->status[size_t(p)], kTexelOk);
      continue;
    }
    ASSERT_EQ(fit->status[size_t(p)], kTexelOk) << p;
    ++off_grid;
    const Vec3 n(fit->maps.normal.Plane(0)[p], fit->maps.normal.Plane(1)[p],
                 fit->maps.normal.Plane(2)[p]);
    const Vec3 t(data.truth.normal.Plane(0)[p], data.truth.normal.Plane(1)[p],
                 data.truth.normal.Plane(2)[p]);
    EXPECT_LT(AngleBetweenDeg(n, t), 0.5) << p;
    EXPECT_NEAR(fit->maps.exponent.Plane(0)[p] / data.truth.exponent.Plane(0)[p], 1.0, 0.1) << p;
  }
  EXPECT_EQ(off_grid, 3840);
  EXPECT_EQ(fit->parameters.at("lobe_shape_texels"), 0);
}

// A texel with too few usable samples for a free lobe shape but enough with the shape fixed
// (lafortune1: 8 parameters per texel in stage 1, 6 in stage 2; under four lights, a texel with
// one NaN sample has 9 samples, fewer than the 10 stage 1 asks for) is left by stage 1 to
// stage 2, on the grid or off it, and fitted there. Before, stage 1 flagged it.
TEST(Lafortune, ATexelStageOneCannotFitIsFittedWithTheSharedShape) {
  auto data = SynthData({"plastic", "ring:4:45", 64, 0});
  const int W = data.stack.width();
  const std::vector<int64_t> sparse = {int64_t(2) * W + 2, int64_t(2) * W + 3,
                                       int64_t(33) * W + 40};  // on the grid of 4, off it, off it
  for (int c = 0; c < data.stack.channels(); ++c)
    for (int64_t p : sparse) data.stack.Plane(0, c)[size_t(p)] = NAN;
  for (int64_t target : {int64_t(0), int64_t(256)}) {
    SCOPED_TRACE(target);
    FitOptions o;
    o.lobe_shape_texels = target;
    auto fit = FitLafortune(data.stack, o, 1);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    EXPECT_EQ(fit->parameters.at("lobe_shape_texels"), target == 0 ? 4096 - 3 : 256 - 1);
    for (int64_t p : sparse) {
      EXPECT_EQ(fit->status[size_t(p)], kTexelOk) << p;
      const Vec3 n(fit->maps.normal.Plane(0)[p], fit->maps.normal.Plane(1)[p],
                   fit->maps.normal.Plane(2)[p]);
      const Vec3 t(data.truth.normal.Plane(0)[p], data.truth.normal.Plane(1)[p],
                   data.truth.normal.Plane(2)[p]);
      EXPECT_LT(AngleBetweenDeg(n, t), 10.0) << p;
    }
  }
}

TEST(FitOptions, RejectsANegativeLobeShapeTexelCount) {
  FitOptions o;
  o.lobe_shape_texels = -1;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--lobe-shape-texels"), std::string::npos) << why;
}

}  // namespace
}  // namespace matfit::fit
