#include <gtest/gtest.h>

#include "core/synth/light_sets.h"
#include "core/synth/render_stack.h"
#include "core/synth/synth.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/ptm_maps.h"

namespace matfit::fit {
namespace {

TEST(Ptm, ReconstructsDataFromItsOwnBasisExactly) {
  for (const char* lights : {"bonn81", "dome:30", "dome:240"}) {
    const MaterialMaps truth = RandomPtm(16);
    const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet(lights, 1), {});
    auto fit = FitPtm(s, {});
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    double worst = 0;
    for (size_t k = 0; k < truth.coefficients.data().size(); ++k)
      worst = std::max(
          worst, double(std::abs(fit->maps.coefficients.data()[k] - truth.coefficients.data()[k])));
    // Issue 19: a PTM-exact stack (240 dome lights included) gives back its coefficients to 1e-6
    // (measured worst: 2.4e-7 bonn81 and dome:30, 4.1e-7 dome:240; float samples and sums).
    EXPECT_LT(worst, 1e-6) << lights;
    const ReconstructionMetrics rec = Reconstruction(s, fit->maps, fit->status);
    EXPECT_LT(rec.rmse, 1e-5) << lights;
  }
}

TEST(Ptm, FitsAGlossyMaterialBetterThanTheMean) {
  synth::SynthOptions o;
  o.material = "plastic";
  o.lights = "bonn81";
  o.size = 32;
  auto data = synth::Synthesize(o);
  ASSERT_TRUE(data.ok());
  auto ptm = FitPtm(data->stack, {}), mean = FitMean(data->stack, {});
  ASSERT_TRUE(ptm.ok() && mean.ok());
  EXPECT_LT(Reconstruction(data->stack, ptm->maps, ptm->status).deviation_percent,
            0.5 * Reconstruction(data->stack, mean->maps, mean->status).deviation_percent);
}

// ptm-srgb: a stack whose sRGB encode is an exact PTM (values decode(Σ a_j B_j(l)) with sums in
// [0.1, 0.9]) gives back its coefficients (to the encode table's accuracy, ≤ 2e-5 per sample).
TEST(Ptm, SrgbDomainReconstructsAStackExactInCodes) {
  for (const char* lights : {"bonn81", "dome:240"}) {
    MaterialMaps truth = RandomPtm(16);
    truth.basis_srgb = true;
    for (int q = 0; q < 18; ++q)
      for (float& a : truth.coefficients.Plane(q)) a = q % 6 == 5 ? 0.5f + 0.3f * a : 0.13f * a;
    const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet(lights, 1), {});
    auto fit = FitPtm(s, {}, /*srgb=*/true);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    EXPECT_TRUE(fit->maps.basis_srgb);
    EXPECT_EQ(fit->method, "ptm-srgb");
    double worst = 0;
    for (size_t k = 0; k < truth.coefficients.data().size(); ++k)
      worst = std::max(
          worst, double(std::abs(fit->maps.coefficients.data()[k] - truth.coefficients.data()[k])));
    EXPECT_LT(worst, 1e-4) << lights;
    EXPECT_LT(Reconstruction(s, fit->maps, fit->status).rmse, 2e-5) << lights;
  }
}

// Why RTI tools' PTM/HSH predict held-out lights better than the same bases fitted to linear
// values (issue 19 item 5): they fit the stored sRGB codes, where a highlight is flatter and a
// quadratic or 4–9-term basis follows it better. On glossy plastic under 240 dome lights the
// code-space fit predicts held-out lights with a lower *linear* error; on matte plaster, whose
// linear values are exactly n·l (in the HSH span), the linear fit is the better one.
TEST(Ptm, TheFitDomainDecidesHeldOutErrorByMaterial) {
  for (const char* material : {"plastic", "plaster"}) {
    synth::SynthOptions o;
    o.material = material;
    o.lights = "dome:240";
    o.size = 24;
    o.layout = Layout::kLp;
    o.perturb.gaussian_sigma = 0.005;
    auto data = synth::Synthesize(o);
    ASSERT_TRUE(data.ok());
    for (const char* basis : {"ptm", "hsh3"}) {
      const auto lin = MakeMethod(basis), enc = MakeMethod(std::string(basis) + "-srgb");
      auto a = HeldOut(*lin, data->stack, 8, {}), b = HeldOut(*enc, data->stack, 8, {});
      ASSERT_TRUE(a.ok() && b.ok());
      std::printf("%s %s held-out RMSE: linear fit %.5f, sRGB fit %.5f\n", material, basis, a->rmse,
                  b->rmse);
      if (std::string(material) == "plastic")
        EXPECT_LT(b->rmse, 0.9 * a->rmse) << basis;
      else
        EXPECT_GT(b->rmse, 1.05 * a->rmse) << basis;
    }
  }
}

TEST(Ptm, OneElevationRingIsRejected) {
  const MaterialMaps truth = RandomPtm(4);
  const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet("ring12", 1), {});
  auto fit = FitPtm(s, {});
  ASSERT_FALSE(fit.ok());
  EXPECT_NE(fit.status().message().find("rank < 6"), std::string::npos);
}

}  // namespace
}  // namespace matfit::fit
