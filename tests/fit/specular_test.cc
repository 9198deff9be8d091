#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

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

}  // namespace
}  // namespace matfit::fit
