#include <gtest/gtest.h>

#include <cstdio>

#include "core/synth/light_sets.h"
#include "core/synth/materials.h"
#include "core/synth/render_stack.h"
#include "fit/methods.h"
#include "fit/metrics.h"

namespace matfit::fit {
namespace {

// Plaster geometry and albedo with Lafortune lobes of known shape, rendered through the shared
// forward model.
MaterialMaps LafortuneMaterial(int size, int lobes) {
  MaterialMaps m = *synth::MakeMaterial("plaster", size, 3);
  m.model = ShadingModel::kLafortune;
  for (float& a : m.albedo.data()) a *= 0.6f;
  m.specular = Image(size, size, lobes);
  m.lobe_shape = Image(size, size, 2 * lobes);
  const float amp[2] = {0.4f, 0.15f}, cxy[2] = {-1.0f, 0.6f}, e[2] = {30.0f, 5.0f};
  for (int j = 0; j < lobes; ++j) {
    for (float& v : m.specular.Plane(j)) v = amp[j];
    for (float& v : m.lobe_shape.Plane(2 * j)) v = cxy[j];
    for (float& v : m.lobe_shape.Plane(2 * j + 1)) v = e[j];
  }
  return m;
}

TEST(Lafortune, OneLobeRecoversShapeAndNormals) {
  const MaterialMaps truth = LafortuneMaterial(24, 1);
  const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet("bonn81", 1), {});
  auto fit = FitLafortune(s, {}, 1);
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const TruthMetrics t = CompareToTruth(fit->maps, truth, fit->status);
  const double e = fit->maps.lobe_shape.At(1, 5, 5), cxy = fit->maps.lobe_shape.At(0, 5, 5);
  std::printf("lafortune1: normal MAE %.4f°, C_xy %.4f (true -1), e %.3f (true 30)\n",
              t.normal_mae_deg, cxy, e);
  EXPECT_LT(t.normal_mae_deg, 0.5);
  EXPECT_NEAR(e, 30.0, 3.0);
  EXPECT_NEAR(cxy, -1.0, 0.1);
  EXPECT_LT(Reconstruction(s, fit->maps, fit->status).rmse, 1e-3);
}

TEST(Lafortune, TwoLobesFitBetterThanOneOnTwoLobeData) {
  const MaterialMaps truth = LafortuneMaterial(16, 2);
  const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet("bonn81", 1), {});
  auto one = FitLafortune(s, {}, 1), two = FitLafortune(s, {}, 2);
  ASSERT_TRUE(one.ok() && two.ok());
  const double d1 = Reconstruction(s, one->maps, one->status).deviation_percent;
  const double d2 = Reconstruction(s, two->maps, two->status).deviation_percent;
  std::printf("lafortune on 2-lobe data: 1 lobe %.3g %%, 2 lobes %.3g %%\n", d1, d2);
  EXPECT_LT(d2, 0.5 * d1);
  EXPECT_FALSE(FitLafortune(s, {}, 3).ok());
}

}  // namespace
}  // namespace matfit::fit
