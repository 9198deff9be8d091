// Seed method A (METHODS.md §2): the identities the seed's equations imply.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/synth/light_sets.h"
#include "core/synth/render_stack.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

LightStack Bonn(const std::string& material, int size, bool* ok) {
  LightStack s = SynthData({material, "bonn81", size}).stack;
  *ok = s.num_images() == 81;
  return s;
}

TEST(Heinrich, FastAgreesWithTheLiteralGaussJordanReference) {
  // The fast form sums in float (two-level: groups of 8 planes, then the groups), with the
  // light directions centred on their mean so nothing cancels; the reference is double.
  // 61²: strips that are not a multiple of the kernels' 8 or 16 lanes, so tails are covered.
  for (const char* material : {"wool", "plastic", "granite", "plaster", "corduroy", "wool-61"}) {
    bool ok = false;
    const bool odd = std::string(material) == "wool-61";
    const LightStack s = Bonn(odd ? "wool" : material, odd ? 61 : 64, &ok);
    ASSERT_TRUE(ok);
    FitOptions o;
    o.heinrich_specular = false;
    auto fast = FitHeinrich(s, o), ref = FitHeinrichReference(s, o);
    ASSERT_TRUE(fast.ok() && ref.ok());
    const double dn = MaxAbsDiff(fast->maps.normal, ref->maps.normal),
                 ds = MaxAbsDiff(fast->maps.normal_scale, ref->maps.normal_scale),
                 da = MaxAbsDiff(fast->maps.ambient, ref->maps.ambient),
                 dr = MaxAbsDiff(fast->maps.albedo, ref->maps.albedo);
    std::printf(
        "%s 64²: max |fast − reference| normal %.2g, normal_scale %.2g, ambient %.2g, "
        "albedo %.2g\n",
        material, dn, ds, da, dr);
    EXPECT_LT(dn, 1e-6) << material;
    EXPECT_LT(ds, 1e-6) << material;
    EXPECT_LT(da, 1e-6) << material;
    EXPECT_LT(dr, 1e-6) << material;
    EXPECT_EQ(fast->status, ref->status) << material;
  }
}

TEST(Heinrich, FlatLambertianTexelGivesTheSeedNormalAndZeroAmbient) {
  MaterialMaps m;
  m.width = m.height = 4;
  m.model = ShadingModel::kLambert;
  m.normal = Image(4, 4, 3);
  for (float& v : m.normal.Plane(2)) v = 1.0f;
  m.albedo = Image(4, 4, 3, 0.5f);
  m.height_map = Image(4, 4, 1);
  m.mask = Image(4, 4, 1, 1.0f);
  const LightStack s = synth::RenderStack(m, *synth::MakeLightSet("bonn81", 1), {});
  FitOptions o;
  o.heinrich_specular = false;
  auto fit = FitHeinrichReference(s, o);
  ASSERT_TRUE(fit.ok());
  // n ≈ (0, 0, 1/0.5695) = (0, 0, 1.756), a ≈ 0.
  EXPECT_NEAR(fit->maps.normal_scale.At(0, 1, 1), 1.756, 5e-4);
  EXPECT_NEAR(fit->maps.normal.At(2, 1, 1), 1.0, 1e-6);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(fit->maps.ambient.At(c, 1, 1), 0.0, 1e-5);
}

TEST(Heinrich, AmbientIsGreyAndEqualsOneMinusMeanLightDotN) {
  bool ok = false;
  const LightStack s = Bonn("plaster", 16, &ok);
  ASSERT_TRUE(ok);
  FitOptions o;
  o.heinrich_specular = false;
  auto fit = FitHeinrichReference(s, o);  // the literal solve: the identity is not built in
  ASSERT_TRUE(fit.ok());
  for (int64_t p = 0; p < s.plane_size(); ++p) {
    const float nz = fit->maps.normal.Plane(2)[p] * fit->maps.normal_scale.Plane(0)[p];
    const float a = fit->maps.ambient.Plane(0)[p];
    EXPECT_NEAR(a, fit->maps.ambient.Plane(1)[p], 1e-6);
    EXPECT_NEAR(a, fit->maps.ambient.Plane(2)[p], 1e-6);
    EXPECT_NEAR(a, 1.0 - 0.56948 * nz, 1e-4);  // mean light (0, 0, 0.5695): only n_z matters
  }
}

TEST(Heinrich, FlatSpecularNormalMakesTheFrontalGroupExact) {
  bool ok = false;
  const LightStack s = Bonn("granite", 32, &ok);
  ASSERT_TRUE(ok);
  FitOptions o;
  o.heinrich_flat_specular_normal = true;
  auto fit = FitHeinrich(s, o);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const ReconstructionMetrics rec = Reconstruction(s, fit->maps, fit->status);
  EXPECT_LT(rec.deviation_percent_by_theta.at(0), 1e-10);
  EXPECT_GE(fit->parameters.at("exponent"), 1.0);
  EXPECT_LE(fit->parameters.at("exponent"), 1024.0);
}

TEST(Heinrich, GrazingGroupsHaveTheLargestDeviation) {
  // Fabrics with meso-scale shadowing (resolved at 64², threads ≥ 4 texels wide); plaster is
  // Lambertian without shadows, which the model reproduces to rounding error at every θ.
  for (const char* material : {"wool", "corduroy"}) {
    bool ok = false;
    const LightStack s = Bonn(material, 64, &ok);
    ASSERT_TRUE(ok);
    auto fit = FitHeinrich(s, {});
    ASSERT_TRUE(fit.ok());
    const auto by = Reconstruction(s, fit->maps, fit->status).deviation_percent_by_theta;
    const double grazing = std::max(by.at(60), by.at(75));
    for (int t : {0, 15, 30, 45}) EXPECT_GT(grazing, by.at(t)) << material << " θ=" << t;
  }
}

TEST(Heinrich, SpecularTermLowersTheTotalDeviationOnWool) {
  bool ok = false;
  const LightStack s = Bonn("wool", 32, &ok);
  ASSERT_TRUE(ok);
  FitOptions diffuse_only;
  diffuse_only.heinrich_specular = false;
  FitOptions with_ns;
  with_ns.heinrich_flat_specular_normal = true;
  auto a = FitHeinrich(s, diffuse_only), b = FitHeinrich(s, with_ns);
  ASSERT_TRUE(a.ok() && b.ok());
  const double da = Reconstruction(s, a->maps, a->status).deviation_percent;
  const double db = Reconstruction(s, b->maps, b->status).deviation_percent;
  EXPECT_LT(db, da);
}

TEST(Heinrich, OneElevationRingIsRejected) {
  synth::SynthOptions o;
  o.lights = "ring12";
  o.size = 8;
  o.layout = Layout::kLp;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  auto fit = FitHeinrich(r->stack, {});
  ASSERT_FALSE(fit.ok());
  EXPECT_NE(fit.status().message().find("inseparable"), std::string::npos);
}

}  // namespace
}  // namespace matfit::fit
